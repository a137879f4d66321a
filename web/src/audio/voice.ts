/**
 * One cell's sound in one mode (full field or direct sound only): per direction band, that
 * cell's response convolved with the dry signal, scaled by the voice's level (a
 * ConstantSourceNode driving every gain of the voice, so one automation fades it all) into
 * the direction's bus of the spatializer.
 *
 * A response is cut into segments of SEGMENT_S, each its own ConvolverNode fed by the dry
 * signal delayed by the segment's start: the sum is the whole convolution, and the slow step
 * (setting a convolver's buffer, about 0.25 ms per 1000 samples on the main thread) is
 * bounded per segment whatever the room's reverberation time, so that each frame-sized task
 * stays small. The segments are fed as soon as their buffers are set, so a voice prepared
 * ahead is already "warm" (its reverberation built up) when it is faded in. Steps go in time
 * order (every direction's first segment, then every second one, ...): a voice can be heard
 * once its first segments are in (`audible`), its later reverberation joining a few frames
 * later, so a listener who outruns the preparation still hears the new cell at once.
 */
import { fadeCurve, fadeTo, still, type Fade } from '../crossfade';
import type { ImpulseResponse, Mode } from '../responses';

export const SEGMENT_S = 0.34;

/** The dry signal delayed by k segments (k = 0: not delayed), shared by all voices. */
export type DelayedInput = (k: number) => AudioNode;

interface Segment {
  direction: number;
  k: number;
  conv: ConvolverNode;
  first: boolean; // the first segment of its direction holding anything
}

export class CellVoice {
  readonly level: ConstantSourceNode;
  private readonly segments: Segment[] = [];
  private readonly outs: GainNode[] = [];
  private readonly fed: [AudioNode, ConvolverNode][] = [];
  private readonly segmentSamples: number;
  private firstCount = 0;
  fade: Fade = still(0);
  disposed = false;

  constructor(
    private readonly ctx: BaseAudioContext,
    readonly cell: number,
    readonly mode: Mode,
    private readonly responses: ImpulseResponse[],
    private readonly input: DelayedInput,
    buses: AudioNode[],
  ) {
    this.segmentSamples = Math.max(128, Math.round(SEGMENT_S * ctx.sampleRate));
    this.level = new ConstantSourceNode(ctx, { offset: 0 });
    responses.forEach((r, d) => {
      if (r.samples.length === 0) return;
      const out = new GainNode(ctx, { gain: 0 });
      this.level.connect(out.gain);
      out.connect(buses[d]);
      this.outs.push(out);
      const end = r.delay + r.samples.length;
      // Segments wholly inside the leading zeros hold nothing: skip them.
      let first = true;
      for (let k = Math.floor(r.delay / this.segmentSamples); k * this.segmentSamples < end; k++) {
        const conv = new ConvolverNode(ctx, { disableNormalization: true });
        conv.connect(out);
        this.segments.push({ direction: d, k, conv, first });
        first = false;
      }
    });
    // Time order: all the first segments, then the next ones, ...
    const rank = (s: Segment) => (s.first ? -1 : s.k);
    this.segments.sort((a, b) => rank(a) - rank(b) || a.direction - b.direction);
    this.firstCount = this.segments.filter((s) => s.first).length;
    this.level.start();
  }

  /** The slow work, one step a segment (in time order; `first`: one of the segments that
   * make the voice audible): build its buffer, give it to its convolver, feed it. */
  steps(): { run: () => void; first: boolean }[] {
    return this.segments.map((s) => ({
      first: s.first,
      run: () => {
        if (this.disposed) return;
        s.conv.buffer = this.segmentBuffer(this.responses[s.direction], s.k);
        const src = this.input(s.k);
        src.connect(s.conv);
        this.fed.push([src, s.conv]);
      },
    }));
  }

  /** Samples [kS, (k+1)S) of the response (its leading zeros included), as an AudioBuffer. */
  private segmentBuffer(r: ImpulseResponse, k: number): AudioBuffer {
    const S = this.segmentSamples;
    const start = k * S;
    const end = Math.min((k + 1) * S, r.delay + r.samples.length);
    const buffer = new AudioBuffer({ length: end - start, sampleRate: this.ctx.sampleRate, numberOfChannels: 1 });
    const from = Math.max(0, start - r.delay); // first sample of r.samples in this segment
    const to = end - r.delay;
    const at = Math.max(0, r.delay - start); // where it lands in the segment
    buffer.copyToChannel(r.samples.subarray(from, to) as Float32Array<ArrayBuffer>, 0, at);
    return buffer;
  }

  /** Every segment is in. */
  get ready(): boolean {
    return this.fed.length === this.segments.length;
  }

  /** Every direction's first segment is in: the direct sound and early reflections play. */
  get audible(): boolean {
    return this.fed.length >= this.firstCount;
  }

  get progress(): number {
    return this.segments.length ? this.fed.length / this.segments.length : 1;
  }

  get segmentCount(): number {
    return this.segments.length;
  }

  /** Fades from where the level is at time t to `theta` (see crossfade.ts). */
  fadeTo(t: number, theta: number, fadeS?: number): void {
    this.fade = fadeTo(this.fade, t, theta, fadeS);
    applyFade(this.level.offset, this.fade);
  }

  /** Silent from time t on, and staying so. */
  silentAfter(t: number): boolean {
    return this.fade.theta1 === 0 && this.fade.t1 <= t;
  }

  dispose(): void {
    if (this.disposed) return;
    this.disposed = true;
    this.level.stop();
    this.level.disconnect();
    for (const [src, conv] of this.fed) src.disconnect(conv);
    for (const s of this.segments) s.conv.disconnect();
    for (const o of this.outs) o.disconnect();
  }
}

/** Schedules a fade on an AudioParam: hold the value at t0, then the curve to t1. */
export function applyFade(param: AudioParam, f: Fade): void {
  if (typeof param.cancelAndHoldAtTime === 'function') param.cancelAndHoldAtTime(f.t0);
  else param.cancelScheduledValues(f.t0);
  const duration = f.t1 - f.t0;
  if (duration < 1e-4) {
    param.setValueAtTime(Math.sin(f.theta1), f.t0);
    return;
  }
  // About one point a millisecond: the curve is linearly interpolated between its points.
  param.setValueCurveAtTime(fadeCurve(f, Math.ceil(duration * 1000) + 2), f.t0, duration);
}
