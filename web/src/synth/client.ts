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
    };
  });
}

export class Synthesiser {
  private worker: Worker | null = null;
  private next = 1;
  private readonly waiting = new Map<number, (r: SynthReply) => void>();
  /** Milliseconds the worker took per cell, in order (the page and the tests read it). */
  readonly times: number[] = [];

  constructor(readonly index: BundleIndex) {
    if (typeof Worker !== 'undefined') {
      this.worker = new Worker(new URL('./worker.ts', import.meta.url), { type: 'module' });
      this.worker.onmessage = (e: MessageEvent<SynthReply>) => {
        const done = this.waiting.get(e.data.id);
        this.waiting.delete(e.data.id);
        done?.(e.data);
      };
    }
  }

  /** The responses of every source field of the cell (seeds per source, cell and direction). */
  async cell(cell: Cell, parts: CompactPart[], impulses?: (Float64Array[] | undefined)[]): Promise<PartResponses[]> {
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
    const reply = this.worker ? await this.post(req) : run(req);
    if (reply.error) throw new Error(`synthesising cell ${cell.index}: ${reply.error}`);
    this.times.push(reply.ms ?? 0);
    return reply.parts!;
  }

  private post(req: SynthRequest): Promise<SynthReply> {
    return new Promise((ok) => {
      this.waiting.set(req.id, ok);
      this.worker!.postMessage(req);
    });
  }
}
