/**
 * The sound of the walk-through (the paper's playback, section 2.3): the dry signal goes
 * through the responses of the listener's cell, one convolver per direction band, into the
 * spatializer (virtual sources turned by the heading), then the master gain. When the
 * listener changes cell, the new cell's voice fades in as the old one fades out (equal power).
 * The cell the listener is heading for is prepared ahead, one convolver a frame, so the
 * change needs no slow work at that moment. Works on any BaseAudioContext: the page's
 * AudioContext, or an OfflineAudioContext in the tests.
 */
import type { BundleIndex } from '../bundle';
import { FULL, SILENT } from '../crossfade';
import type { FrameTasks } from '../frame-tasks';
import { responsesOf, type Mode, type ResponseStore } from '../responses';
import { Spatializer, type Rendering } from './spatializer';
import { CellVoice, SEGMENT_S } from './voice';

export interface EngineOptions {
  /** A limiter before the output, so that a loud file cannot clip (off in measurements). */
  limiter: boolean;
  /** How long after "now" scheduled changes start: the audio thread is a little ahead. */
  lookaheadS: number;
}

export class SoundEngine {
  readonly input: GainNode;
  readonly master: GainNode;
  readonly spatializer: Spatializer;
  private voices: CellVoice[] = [];
  private readonly delays: AudioNode[] = [];
  current: CellVoice | null = null;
  wantedCell = -1;
  anticipatedCell = -1;
  mode: Mode = 'full';
  private volume = 1;
  /** Cell changes so far, with the time each fade started (for the page and the tests). */
  readonly changes: { cell: number; mode: Mode; at: number }[] = [];

  constructor(
    readonly ctx: BaseAudioContext,
    readonly index: BundleIndex,
    readonly store: ResponseStore,
    readonly tasks: FrameTasks | null,
    readonly options: EngineOptions = { limiter: true, lookaheadS: 0.02 },
  ) {
    this.input = new GainNode(ctx, { gain: 1 });
    this.master = new GainNode(ctx, { gain: index.playbackGain });
    this.spatializer = new Spatializer(ctx, index.directions, this.master);
    if (options.limiter) {
      const limiter = new DynamicsCompressorNode(ctx, { threshold: -3, knee: 0, ratio: 20, attack: 0.002, release: 0.15 });
      this.master.connect(limiter).connect(ctx.destination);
    } else {
      this.master.connect(ctx.destination);
    }
  }

  private get now(): number {
    return this.ctx.currentTime + this.options.lookaheadS;
  }

  /** The voice of (cell, mode): the one there is, or a new one whose convolvers are filled
   * by the frame tasks (at once without them). Null until the cell's responses are here
   * (their fetch is started). */
  voiceFor(cell: number, mode: Mode, urgent: boolean): CellVoice | null {
    const had = this.voices.find((v) => v.cell === cell && v.mode === mode);
    if (had) {
      if (urgent && !had.ready) this.tasks?.hurry(had);
      return had;
    }
    const data = this.store.get(cell);
    if (!data) {
      void this.store.load(cell, urgent).catch(() => {}); // the store reports errors to the page
      return null;
    }
    const v = new CellVoice(this.ctx, cell, mode, responsesOf(data, mode), (k) => this.delayed(k), this.spatializer.buses);
    this.voices.push(v);
    for (const step of v.steps()) {
      if (this.tasks) this.tasks.push(step.run, v, urgent, step.first);
      else step.run();
    }
    return v;
  }

  /** The dry signal delayed by k response segments (voice.ts), made once and shared. */
  private delayed(k: number): AudioNode {
    if (k === 0) return this.input;
    if (!this.delays[k]) {
      const s = k * SEGMENT_S;
      const exact = Math.round(SEGMENT_S * this.ctx.sampleRate) * k / this.ctx.sampleRate;
      this.delays[k] = new DelayNode(this.ctx, { delayTime: exact, maxDelayTime: Math.max(1, s + 1) });
      this.input.connect(this.delays[k]);
    }
    return this.delays[k];
  }

  /** The listener is in this cell: its voice fades in as soon as it is ready. */
  want(cell: number): void {
    this.wantedCell = cell;
  }

  /** Keep this cell's voice prepared, for when the listener gets there. */
  anticipate(cell: number): void {
    this.anticipatedCell = cell;
  }

  setMode(mode: Mode): void {
    this.mode = mode;
  }

  setRendering(r: Rendering): void {
    this.spatializer.setRendering(r, this.ctx.currentTime);
  }

  setHeading(headingDeg: number, immediate = false): void {
    if (headingDeg === this.spatializer.headingDeg) return;
    this.spatializer.setHeading(headingDeg, immediate ? null : this.ctx.currentTime);
  }

  setVolume(v: number): void {
    this.volume = v;
    this.master.gain.setTargetAtTime(this.index.playbackGain * v, this.ctx.currentTime, 0.02);
  }

  getVolume(): number {
    return this.volume;
  }

  /** Fades to `v` from time t (default: now): every other audible voice fades out. */
  crossfadeTo(v: CellVoice, t = this.now, fadeS?: number): void {
    for (const o of this.voices) if (o !== v && o.fade.theta1 !== SILENT) o.fadeTo(t, SILENT, fadeS);
    v.fadeTo(t, FULL, fadeS);
    this.current = v;
    this.changes.push({ cell: v.cell, mode: v.mode, at: t });
  }

  /** Once a frame: fade to the wanted voice when it is ready, keep the anticipated one
   * prepared, and drop voices that are silent and not needed. */
  update(): void {
    const wanted = this.wantedCell >= 0 ? this.voiceFor(this.wantedCell, this.mode, true) : null;
    if (wanted && wanted.audible && wanted !== this.current) this.crossfadeTo(wanted);
    const ahead =
      this.anticipatedCell >= 0 && this.anticipatedCell !== this.wantedCell
        ? this.voiceFor(this.anticipatedCell, this.mode, false)
        : null;
    const t = this.ctx.currentTime;
    this.voices = this.voices.filter((v) => {
      const keep = v === this.current || v === wanted || v === ahead || !v.silentAfter(t);
      if (!keep) {
        this.tasks?.drop(v);
        v.dispose();
      }
      return keep;
    });
  }

  /** Voices alive now: (cell, mode, ready, level). */
  describe(): { cell: number; mode: Mode; ready: boolean; current: boolean }[] {
    return this.voices.map((v) => ({ cell: v.cell, mode: v.mode, ready: v.ready, current: v === this.current }));
  }

  /** Drops every voice, so that they are made again from the store's responses (after the
   * source fields' gains changed); the wanted cell's new voice fades in when it is ready. */
  refresh(): void {
    this.dispose();
  }

  dispose(): void {
    for (const v of this.voices) {
      this.tasks?.drop(v);
      v.dispose();
    }
    this.voices = [];
    this.current = null;
  }
}
