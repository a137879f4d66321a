/**
 * The walk-through: one frame loop that moves the listener (controls, collisions), finds
 * their cell, keeps the sound engine on it (and the next cell prepared), runs one slow task,
 * and draws the view and the plan. Everything else is in the modules it wires together.
 */
import { SoundEngine } from './audio/engine';
import { DryPlayer } from './audio/player';
import { SIGNALS, makeSignal, mono, type SignalName } from './audio/signals';
import type { Rendering } from './audio/spatializer';
import { type BundleIndex, bandsLabel } from './bundle';
import { CellGrid } from './cells';
import { sectionAt, sectionCaster, slide, type CastRay, type Room } from './collide';
import { headingOf } from './coords';
import { KeyboardMouse } from './controls';
import { showError } from './error-view';
import { FrameTasks } from './frame-tasks';
import { Panel } from './panel';
import { PlanView } from './plan-view';
import type { Mode, ResponseStore } from './responses';
import type { SceneView } from './scene-view';
import { TouchControls } from './touch';
import { look, step, type Listener } from './walker';

/** Main-thread time a frame may give to preparing convolvers (one segment at least). */
export const TASK_BUDGET_MS = 10;

export interface FrameRecord {
  t: number; // performance.now() at the frame's start, ms
  dtMs: number; // since the previous frame
  workMs: number; // this frame's own work (movement, audio, task, drawing)
  moveMs: number; // of which moving (controls, collisions)
  audioMs: number; // of which the sound engine's bookkeeping
  taskMs: number; // of which the slow task
  drawMs: number; // of which drawing the view and the plan
  cell: number;
}

export interface Audio {
  ctx: AudioContext;
  engine: SoundEngine;
  player: DryPlayer;
}

export class WalkThrough {
  listener: Listener;
  cell = -1;
  predicted = -1;
  audio: Audio | null = null;
  readonly grid: CellGrid;
  readonly tasks = new FrameTasks();
  readonly frames: FrameRecord[] = [];
  private readonly keys: KeyboardMouse;
  private readonly touch: TouchControls;
  private readonly plan: PlanView;
  readonly panel: Panel;
  private readonly room: Room;
  private readonly castRay: CastRay;
  private lastT = -1;
  private lastStatus = 0;
  private signal: { name: string; samples: Float32Array | null } = { name: 'talker', samples: null };
  private mode: Mode = 'full';
  private rendering: Rendering = 'hrtf';
  /** Frames the loop has drawn (the tests wait on it). */
  frameCount = 0;

  constructor(
    readonly index: BundleIndex,
    readonly view: SceneView,
    readonly store: ResponseStore,
    start: Partial<Listener>,
  ) {
    this.grid = new CellGrid(
      index.cells.map((c) => c.position),
      index.gridSpacingM,
      index.radiusM,
    );
    const z0 = index.boundsMin[2];
    this.room = {
      min: [index.boundsMin[0], index.boundsMin[1]],
      max: [index.boundsMax[0], index.boundsMax[1]],
      heights: [z0 + 0.3, z0 + 1.0, index.headHeightM],
    };
    const triangles = view.solidTriangles();
    this.castRay = sectionCaster(this.room.heights.map((z) => ({ z, segments: sectionAt(triangles, z) })));
    this.listener = { ...this.startingPoint(), ...start, vx: 0, vy: 0 };
    this.keys = new KeyboardMouse(view.canvas);
    this.touch = new TouchControls(view.container);
    this.plan = new PlanView(document.getElementById('plan') as HTMLCanvasElement, index);
    const bands = bandsLabel(index.bands);
    this.panel = new Panel(document.getElementById('panel')!, `sonolux · ${index.sceneName || 'scene'}${bands ? ` · ${bands}` : ''}`, {
      toggleSound: () => void (this.audio?.player.playing ? this.stopSound() : this.startSound()),
      signal: (name) => this.playSignal(name),
      file: (f) => void this.playFile(f),
      mode: (m) => this.setMode(m),
      rendering: (r) => this.setRendering(r),
      volume: (v) => this.audio?.engine.setVolume(v),
    });
    this.panel.setSources(
      index.sourceFields.map((f) => f.name),
      (g) => this.setGains(g),
    );
    store.onError = (e) => showError(e);
  }

  /** The source fields' gains (a bundle with a field per source): the cells are mixed again
   * and the sound engine's voices made anew. */
  setGains(gains: number[]): void {
    this.store.setGains(gains);
    this.audio?.engine.refresh();
  }

  /** A quarter of the way along the room, mid-width, facing the first source. */
  private startingPoint(): Pick<Listener, 'x' | 'y' | 'headingDeg' | 'pitchDeg'> {
    const ix = this.index;
    const c = this.grid.nearest(ix.boundsMin[0] + 0.25 * (ix.boundsMax[0] - ix.boundsMin[0]), (ix.boundsMin[1] + ix.boundsMax[1]) / 2);
    const [x, y] = ix.cells[c].position;
    const s = ix.sources[0]?.position;
    const headingDeg = s && Math.hypot(s[0] - x, s[1] - y) > 1e-6 ? headingOf(s[0] - x, s[1] - y) : 0;
    return { x, y, headingDeg: ((headingDeg % 360) + 360) % 360, pitchDeg: 0 };
  }

  run(): void {
    const loop = (t: number) => {
      try {
        this.frame(t);
      } catch (e) {
        showError(e);
        return;
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  frame(t: number): void {
    const start = performance.now();
    const dtMs = this.lastT < 0 ? 0 : t - this.lastT;
    this.lastT = t;
    // Move: look first, then walk where the walls let us.
    const [kh, kp] = this.keys.takeLook();
    const [th, tp] = this.touch.takeLook();
    let l = look(this.listener, kh + th, kp + tp);
    const intent = this.touch.intent() ?? this.keys.intent();
    l = step(l, intent, Math.min(dtMs, 100) / 1000, (x0, y0, x1, y1) => slide(this.room, this.castRay, x0, y0, x1, y1));
    this.listener = l;
    const t1 = performance.now();
    this.follow();
    const t2 = performance.now();
    const taskMs = this.tasks.runFor(TASK_BUDGET_MS);
    const t3 = performance.now();
    this.view.setListener(l, this.index.headHeightM);
    this.view.render();
    this.plan.draw({ listener: l, cell: this.cell, preparedCell: this.predicted, loaded: (i) => this.store.has(i) });
    const drawMs = performance.now() - t3;
    if (start - this.lastStatus > 250) {
      this.lastStatus = start;
      this.panel.setStatus(this.statusText());
    }
    this.frameCount++;
    this.frames.push({ t: start, dtMs, workMs: performance.now() - start, moveMs: t1 - start, audioMs: t2 - t1, taskMs, drawMs, cell: this.cell });
    if (this.frames.length > 1200) this.frames.splice(0, this.frames.length - 1200);
  }

  /** Cell bookkeeping and the sound engine, after the listener moved. */
  private follow(): void {
    const l = this.listener;
    const cell = this.grid.choose(this.cell, l.x, l.y);
    if (cell !== this.cell) {
      this.cell = cell;
      // Fetch this cell's and its neighbours' responses (cheap when they are here already).
      for (const c of [cell, ...this.grid.neighbours(cell)]) void this.store.load(c).catch(() => {});
    }
    this.predicted = this.grid.predict(l.x, l.y, l.vx, l.vy, cell);
    const a = this.audio;
    if (!a) return;
    a.engine.setHeading(l.headingDeg);
    a.engine.want(cell);
    a.engine.anticipate(this.predicted);
    a.engine.update();
  }

  private statusText(): string {
    const l = this.listener;
    const c = this.index.cells[this.cell];
    const grid = c?.gridIndex ? ` (grid ${c.gridIndex[0]}, ${c.gridIndex[1]})` : '';
    const where = `x ${l.x.toFixed(2)} m, y ${l.y.toFixed(2)} m, facing ${Math.round(l.headingDeg)}° · cell ${this.cell}${grid}`;
    if (!this.audio) return `${where} · sound off`;
    const engine = this.audio.engine;
    const cur = engine.current;
    const hearing = cur ? `hearing cell ${cur.cell}, ${cur.mode === 'full' ? 'full field' : 'direct sound only'}` : 'preparing the sound…';
    const next = engine.describe().find((v) => v.cell === this.predicted && v.mode === engine.mode);
    const ahead = this.predicted >= 0 && this.predicted !== this.cell ? ` · next: cell ${this.predicted}, ${next?.ready ? 'ready' : 'preparing'}` : '';
    return `${where} · ${hearing}${ahead}`;
  }

  async startSound(): Promise<void> {
    if (!this.audio) {
      const ctx = new AudioContext({ sampleRate: this.index.sampleRateHz, latencyHint: 'interactive' });
      const engine = new SoundEngine(ctx, this.index, this.store, this.tasks);
      engine.setMode(this.mode);
      engine.spatializer.setRendering(this.rendering, null);
      engine.setHeading(this.listener.headingDeg, true);
      this.audio = { ctx, engine, player: new DryPlayer(ctx, engine.input) };
    }
    await this.audio.ctx.resume();
    this.play();
    this.panel.setPlaying(true);
  }

  stopSound(): void {
    this.audio?.player.stop();
    this.panel.setPlaying(false);
  }

  private play(): void {
    const a = this.audio;
    if (!a) return;
    const name = this.signal.name;
    const samples = this.signal.samples ?? makeSignal(name as SignalName, a.ctx.sampleRate);
    a.player.play(samples, name);
  }

  playSignal(name: string): void {
    if (SIGNALS.some((s) => s.name === name)) this.signal = { name, samples: null };
    else if (name !== this.signal.name) return; // a file chosen earlier and replaced since
    if (this.audio?.player.playing) this.play();
  }

  async playFile(f: File): Promise<void> {
    if (!this.audio) await this.startSound();
    const a = this.audio!;
    let decoded: AudioBuffer;
    try {
      decoded = await a.ctx.decodeAudioData(await f.arrayBuffer());
    } catch (e) {
      this.panel.setStatus(`${f.name}: not an audio file this browser can decode (${(e as Error).message ?? e})`);
      return;
    }
    this.signal = { name: f.name, samples: mono(decoded) };
    this.panel.setSignalLabel(f.name);
    this.play();
    this.panel.setPlaying(true);
  }

  setMode(m: Mode): void {
    this.mode = m;
    this.audio?.engine.setMode(m);
  }

  setRendering(r: Rendering): void {
    this.rendering = r;
    this.audio?.engine.setRendering(r);
  }

  teleport(p: Partial<Listener>): void {
    this.listener = { ...this.listener, ...p, vx: 0, vy: 0 };
  }
}
