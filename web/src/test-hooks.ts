/**
 * window.sonolux: what the browser tests (tests/web/browser) read and drive, and a console
 * handle for the curious. renderOffline builds the same audio graph as the page (SoundEngine)
 * in an OfflineAudioContext and renders it.
 */
import type { WalkThrough } from './app';
import { SoundEngine } from './audio/engine';
import { makeSignal, type SignalName } from './audio/signals';
import type { Rendering } from './audio/spatializer';
import type { BundleIndex } from './bundle';
import { FULL } from './crossfade';
import { inflateCell, type Mode } from './responses';
import { readParts } from './synth/client';
import type { Listener } from './walker';

export interface OfflineRequest {
  /** The cells in order; cells[k + 1] fades in at switchAtS[k]. */
  cells: number[];
  switchAtS?: number[];
  fadeS?: number;
  headingDeg?: number;
  mode?: Mode;
  rendering?: Rendering;
  /** A built-in signal, or a sine of sineHz. */
  signal?: SignalName | 'sine';
  sineHz?: number;
  seconds: number;
}

export interface Hooks {
  ready: boolean;
  error: string | null;
  index?: BundleIndex;
  app?: WalkThrough;
  state?: () => unknown;
  teleport?: (p: Partial<Listener>) => void;
  startSound?: () => Promise<void>;
  renderOffline?: (r: OfflineRequest) => Promise<AudioBuffer>;
  project?: (x: number, y: number, z: number) => [number, number] | null;
  /** /3: a cell's responses per source field and direction from the worker, optionally with
   * given impulses (per source field, per direction), as plain arrays. */
  synthesise?: (cell: number, impulses?: number[][][]) => Promise<{ full: number[][]; direct: number[][] }[]>;
  setGains?: (gains: number[]) => void;
}

declare global {
  interface Window {
    sonolux: Hooks;
  }
}

export function installHooks(app: WalkThrough): void {
  const h = window.sonolux;
  h.app = app;
  h.index = app.index;
  h.state = () => ({
    listener: { ...app.listener },
    cell: app.cell,
    predicted: app.predicted,
    frameCount: app.frameCount,
    pendingTasks: app.tasks.pending,
    synthMs: app.store.synth?.times.slice() ?? [],
    audio: app.audio ? { state: app.audio.ctx.state, voices: app.audio.engine.describe(), changes: app.audio.engine.changes.slice() } : null,
  });
  h.teleport = (p) => app.teleport(p);
  h.startSound = () => app.startSound();
  h.project = (x, y, z) => app.view.project([x, y, z]);
  h.renderOffline = (r) => renderOffline(app, r);
  h.setGains = (g) => app.setGains(g);
  h.synthesise = async (cell, impulses) => {
    const store = app.store;
    const c = app.index.cells[cell];
    const url = new URL(app.index.responsesFile, store.baseUrl).href;
    const res = await fetch(url, { headers: { Range: `bytes=${c.byteOffset}-${c.byteOffset + c.byteLength - 1}` } });
    const block = await inflateCell(app.index, c, await res.arrayBuffer());
    const parts = await store.synth!.cell(c, readParts(app.index, c, block), impulses?.map((p) => p.map((x) => Float64Array.from(x))));
    return parts.map((p) => ({ full: p.full.map((x) => Array.from(x)), direct: p.direct.map((x) => Array.from(x)) }));
  };
}

async function renderOffline(app: WalkThrough, r: OfflineRequest): Promise<AudioBuffer> {
  const fs = app.index.sampleRateHz;
  const ctx = new OfflineAudioContext({ numberOfChannels: 2, length: Math.round(r.seconds * fs), sampleRate: fs });
  await Promise.all(r.cells.map((c) => app.store.load(c)));
  const engine = new SoundEngine(ctx, app.index, app.store, null, { limiter: false, lookaheadS: 0 });
  const mode = r.mode ?? 'full';
  engine.setMode(mode);
  engine.spatializer.setRendering(r.rendering ?? 'hrtf', null);
  engine.spatializer.setHeading(r.headingDeg ?? 0, null);
  // Every voice is connected from the start, as the page prepares the next cell ahead.
  const voices = r.cells.map((c) => engine.voiceFor(c, mode, true)!);
  voices[0].fadeTo(0, FULL, 0);
  voices.slice(1).forEach((v, k) => engine.crossfadeTo(v, r.switchAtS?.[k] ?? 0, r.fadeS));
  const samples =
    r.signal === 'sine' || r.signal === undefined
      ? Float32Array.from({ length: Math.round(r.seconds * fs) }, (_, i) => 0.5 * Math.sin((2 * Math.PI * (r.sineHz ?? 200) * i) / fs))
      : makeSignal(r.signal, fs);
  const buffer = new AudioBuffer({ length: samples.length, sampleRate: fs, numberOfChannels: 1 });
  buffer.copyToChannel(samples as Float32Array<ArrayBuffer>, 0);
  const src = new AudioBufferSourceNode(ctx, { buffer, loop: true });
  src.connect(engine.input);
  src.start(0);
  return ctx.startRendering();
}
