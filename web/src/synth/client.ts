/**
 * The main thread's side of the synthesis: a cell's block (inflated, checked) is cut into its
 * source fields' compact parts and handed to the Web Worker (worker.ts); the answer is that
 * cell's responses per source field. Where there is no Worker (Node.js unit tests) the same
 * code runs in the calling thread.
 */
import type { BundleIndex, Cell } from '../bundle';
import type { CompactPart, PartResponses } from './synthesis';
import { run, type SynthReply, type SynthRequest } from './worker';

/** A cell's parts, one per source field, read from its inflated block (little-endian). */
export function readParts(index: BundleIndex, cell: Cell, block: ArrayBuffer): CompactPart[] {
  const spec = index.synthesis!;
  const db = spec.directions * spec.bandsHz.length;
  return cell.fields.map((f) => {
    let at = f.byteOffset;
    const take = <T>(make: (b: ArrayBuffer, o: number, n: number) => T, n: number): T => {
      const v = make(block, at, n);
      at += 4 * n;
      return v;
    };
    return {
      onset: f.onset,
      cell: take((b, o, n) => new Uint32Array(b, o, n), f.arrivals),
      value: take((b, o, n) => new Float32Array(b, o, n), f.arrivals),
      envelope: take((b, o, n) => new Float32Array(b, o, n), db * f.envelopeBins),
      envelopeBins: f.envelopeBins,
      late: take((b, o, n) => new Float32Array(b, o, n), db * f.lateBins),
      lateBins: f.lateBins,
      exactSample: take((b, o, n) => new Uint32Array(b, o, n), 2 * f.exactArrivals),
      exactDirection: take((b, o, n) => new Float32Array(b, o, n), 2 * f.exactArrivals),
      exactEnergy: take((b, o, n) => new Float32Array(b, o, n), spec.bandsHz.length * f.exactArrivals),
    };
  });
}

interface Job {
  req: SynthRequest;
  cell: number;
  urgent: boolean;
  done: (r: SynthReply) => void;
}

/** Workers in the pool: one per core but one (for the page), from 1 to 4. */
export function poolSize(cores: number | undefined): number {
  return Math.max(1, Math.min(4, (cores ?? 2) - 1));
}

export class Synthesiser {
  private readonly workers: Worker[] = [];
  private readonly busy = new Set<Worker>();
  private readonly queue: Job[] = [];
  private next = 1;
  private readonly waiting = new Map<number, (r: SynthReply) => void>();
  /** Milliseconds a worker took per cell, in order of completion (the page and tests read it). */
  readonly times: number[] = [];

  constructor(readonly index: BundleIndex) {
    if (typeof Worker === 'undefined') return;
    const n = poolSize(typeof navigator === 'undefined' ? undefined : navigator.hardwareConcurrency);
    for (let k = 0; k < n; k++) {
      const w = new Worker(new URL('./worker.ts', import.meta.url), { type: 'module' });
      w.onmessage = (e: MessageEvent<SynthReply>) => {
        this.busy.delete(w);
        const done = this.waiting.get(e.data.id);
        this.waiting.delete(e.data.id);
        done?.(e.data);
        this.pump();
      };
      this.workers.push(w);
    }
  }

  /** The responses of every source field of the cell (seeds per source, cell and direction).
   * Urgent cells (the one the listener is in) are synthesised before the others waiting. */
  async cell(cell: Cell, parts: CompactPart[], impulses?: (Float64Array[] | undefined)[], urgent = false): Promise<PartResponses[]> {
    const ix = this.index;
    const spec = ix.synthesis!;
    const nCells = ix.cells.length;
    const req: SynthRequest = {
      id: this.next++,
      spec,
      parts: parts.map((part, j) => ({ part, seed: ix.seed + (j * nCells + cell.index) * spec.directions, sources: ix.sourceFields[j].positions })),
      length: cell.lengthSamples,
      receiver: cell.position,
      impulses,
    };
    const reply = this.workers.length ? await this.post(req, cell.index, urgent) : run(req);
    if (reply.error) throw new Error(`synthesising cell ${cell.index}: ${reply.error}`);
    this.times.push(reply.ms ?? 0);
    return reply.parts!;
  }

  /** A cell waiting in the queue goes first (the listener got there before it was made). */
  hurry(cell: number): void {
    const k = this.queue.findIndex((j) => j.cell === cell);
    if (k > 0) this.queue.unshift(...this.queue.splice(k, 1));
  }

  /** Cells waiting for a worker. */
  get pending(): number {
    return this.queue.length;
  }

  private post(req: SynthRequest, cell: number, urgent: boolean): Promise<SynthReply> {
    return new Promise((done) => {
      const job = { req, cell, urgent, done };
      if (urgent) this.queue.unshift(job);
      else this.queue.push(job);
      this.pump();
    });
  }

  private pump(): void {
    for (const w of this.workers) {
      if (this.busy.has(w) || this.queue.length === 0) continue;
      const job = this.queue.shift()!;
      this.busy.add(w);
      this.waiting.set(job.req.id, job.done);
      w.postMessage(job.req);
    }
  }
}
