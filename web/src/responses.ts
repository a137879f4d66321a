/**
 * The cells' responses from responses.bin: fetched one cell's block at a time, only for the
 * cells around the listener (an HTTP range request; a server that answers with the whole file
 * is fine too: the file is then fetched once and kept), checked against the block's CRC-32,
 * inflated when the bundle is compressed, then decoded (/1, /2: the responses themselves) or
 * synthesised from the cell's compact fields in a Web Worker (/3, synth/), and kept in a
 * cache of bounded size (least recently used cells go first). With several source fields
 * (/3), a cell's responses are the sources' responses mixed with the gains of setGains.
 */
import { BundleError, type BundleIndex, type Cell, type ResponseRef } from './bundle';
import { crc32 } from './crc32';
import { readParts, Synthesiser } from './synth/client';

/** A response: `delay` zeros, then `samples` (already × scale). */
export interface ImpulseResponse {
  delay: number;
  samples: Float32Array;
}

export interface PartImpulses {
  full: ImpulseResponse[];
  direct: ImpulseResponse[];
}

export interface CellResponses {
  cell: number;
  full: ImpulseResponse[];
  direct: ImpulseResponse[];
  /** /3: each source field's own responses (full and direct are their mix). */
  parts?: PartImpulses[];
}

/** Σ_k gains[k] × responses[k], per direction (delays kept: the sum starts at the earliest). */
export function mixResponses(parts: ImpulseResponse[][], gains: number[]): ImpulseResponse[] {
  const used = parts.map((_, k) => k).filter((k) => (gains[k] ?? 1) !== 0);
  if (used.length === 1 && (gains[used[0]] ?? 1) === 1) return parts[used[0]];
  return parts[0].map((_, d) => {
    const rs = used.map((k) => ({ g: gains[k] ?? 1, r: parts[k][d] })).filter((e) => e.r.samples.length > 0);
    if (rs.length === 0) return { delay: 0, samples: new Float32Array(0) };
    const delay = Math.min(...rs.map((e) => e.r.delay));
    const end = Math.max(...rs.map((e) => e.r.delay + e.r.samples.length));
    const out = new Float32Array(end - delay);
    for (const { g, r } of rs) {
      const at = r.delay - delay;
      for (let i = 0; i < r.samples.length; i++) out[at + i] += g * r.samples[i];
    }
    return { delay, samples: out };
  });
}

/** Leading zeros cut off (the convolvers need not run over them). */
function trimmed(x: Float32Array): ImpulseResponse {
  let k = 0;
  while (k < x.length && x[k] === 0) k++;
  return { delay: k, samples: k === x.length ? new Float32Array(0) : x.subarray(k) };
}

export type Mode = 'full' | 'direct';

const RETRY_AFTER_MS = 5000;

export function responsesOf(c: CellResponses, mode: Mode): ImpulseResponse[] {
  return mode === 'full' ? c.full : c.direct;
}

/** Inflates a zlib stream (RFC 1950) with the browser's own DecompressionStream. */
async function inflate(stored: ArrayBuffer): Promise<ArrayBuffer> {
  const stream = new Blob([stored]).stream().pipeThrough(new DecompressionStream('deflate'));
  return new Response(stream).arrayBuffer();
}

/** One cell's block as stored (exactly its byte_length bytes), checked and inflated when the
 * bundle is compressed. */
export async function inflateCell(index: BundleIndex, cell: Cell, stored: ArrayBuffer): Promise<ArrayBuffer> {
  const file = index.responsesFile;
  if (stored.byteLength !== cell.byteLength) {
    throw new BundleError(file, `cell ${cell.index}: got ${stored.byteLength} bytes, expected ${cell.byteLength}`);
  }
  if (crc32(new Uint8Array(stored)) !== cell.crc32) {
    throw new BundleError(file, `cell ${cell.index}: the data is corrupt (CRC-32 does not match field.json)`);
  }
  let block = stored;
  if (index.encoding === 'deflate') {
    try {
      block = await inflate(stored);
    } catch (e) {
      throw new BundleError(file, `cell ${cell.index}: could not be inflated (${(e as Error).message})`);
    }
    if (block.byteLength !== cell.rawLength) {
      throw new BundleError(file, `cell ${cell.index}: inflates to ${block.byteLength} bytes, field.json says ${cell.rawLength}`);
    }
  }
  return block;
}

/** Decodes one cell's block as stored (/1, /2): checked, inflated, split into its responses. */
export async function decodeCell(index: BundleIndex, cell: Cell, stored: ArrayBuffer): Promise<CellResponses> {
  const file = index.responsesFile;
  const block = await inflateCell(index, cell, stored);
  const words = index.sampleFormat === 'int16' ? new Int16Array(block, 0, block.byteLength >> 1) : new Float32Array(block, 0, block.byteLength >> 2);
  const decode = (ref: ResponseRef): ImpulseResponse => {
    const out = new Float32Array(ref.length);
    const src = words.subarray(ref.offset, ref.offset + ref.length);
    for (let i = 0; i < out.length; i++) out[i] = src[i] * ref.scale;
    if (index.sampleFormat === 'float32' && out.some((v) => !Number.isFinite(v))) {
      throw new BundleError(file, `cell ${cell.index}: a response holds a value that is not a number`);
    }
    return { delay: ref.delay, samples: out };
  };
  return { cell: cell.index, full: cell.full.map(decode), direct: cell.direct.map(decode) };
}

export class ResponseStore {
  private readonly cache = new Map<number, Promise<CellResponses>>();
  private readonly done = new Map<number, CellResponses>();
  /** The whole file, once a server has sent it instead of a range (fetched once, then kept). */
  private whole: Promise<ArrayBuffer> | null = null;
  /** Every range this store asked for, [first, last] bytes, in order (the tests read it). */
  readonly requested: [number, number][] = [];
  private readonly url: string;
  /** Bytes of decoded responses kept; the least recently used cells go first. */
  budgetBytes = 256e6;
  /** Called with the first error of a fetch (the page shows it). */
  onError: (e: unknown) => void = () => {};
  /** /3: the synthesis workers, and each source field's gain in the mix. */
  readonly synth: Synthesiser | null;
  private readonly urgent = new Set<number>();
  gains: number[];

  constructor(
    readonly baseUrl: string,
    readonly index: BundleIndex,
    private readonly fetchFn: typeof fetch = (...a) => fetch(...a),
  ) {
    this.url = new URL(index.responsesFile, baseUrl).href;
    this.synth = index.synthesis ? new Synthesiser(index) : null;
    this.gains = index.sourceFields.map(() => 1);
  }

  /** New gains of the source fields: every cell here is mixed again (the engine's voices
   * must then be made again: SoundEngine.refresh). */
  setGains(gains: number[]): void {
    this.gains = this.index.sourceFields.map((_, k) => gains[k] ?? 1);
    for (const c of this.done.values()) this.mix(c);
  }

  private mix(c: CellResponses): void {
    if (!c.parts) return;
    c.full = mixResponses(c.parts.map((p) => p.full), this.gains);
    c.direct = mixResponses(c.parts.map((p) => p.direct), this.gains);
  }

  /** A cell's responses from its block as stored: decoded (/1, /2) or synthesised (/3). */
  async decode(cell: Cell, stored: ArrayBuffer): Promise<CellResponses> {
    if (!this.synth) return decodeCell(this.index, cell, stored);
    const block = await inflateCell(this.index, cell, stored);
    let parts;
    try {
      parts = await this.synth.cell(cell, readParts(this.index, cell, block), undefined, this.urgent.has(cell.index));
    } catch (e) {
      throw new BundleError(this.index.responsesFile, `cell ${cell.index}: ${(e as Error).message}`);
    }
    const c: CellResponses = {
      cell: cell.index,
      full: [],
      direct: [],
      parts: parts.map((p) => ({ full: p.full.map(trimmed), direct: p.direct.map(trimmed) })),
    };
    this.mix(c);
    return c;
  }

  /** The cell's responses if they are here already. */
  get(cell: number): CellResponses | undefined {
    const c = this.done.get(cell);
    if (c) {
      this.done.delete(cell); // re-insert: most recently used last
      this.done.set(cell, c);
    }
    return c;
  }

  /** Whether the cell's responses are here (without touching the cache's order). */
  has(cell: number): boolean {
    return this.done.has(cell);
  }

  /** Fetches (once) and decodes the cell; `urgent`: the listener needs it now, so its
   * synthesis goes before the other cells waiting. */
  load(cell: number, urgent = false): Promise<CellResponses> {
    let p = this.cache.get(cell);
    if (p && urgent) this.urgent.add(cell);
    if (p && urgent) this.synth?.hurry(cell);
    if (!p) {
      if (urgent) this.urgent.add(cell);
      p = this.fetchBlock(this.index.cells[cell]).then(async (block) => {
        const c = await this.decode(this.index.cells[cell], block);
        this.done.set(cell, c);
        this.trim();
        return c;
      });
      p.catch((e) => {
        this.onError(e);
        // Not again at once (the frame loop asks every frame): after a pause, in case the
        // network only hiccuped.
        setTimeout(() => this.cache.delete(cell), RETRY_AFTER_MS);
      });
      this.cache.set(cell, p);
    }
    return p;
  }

  private async fetchBlock(cell: Cell): Promise<ArrayBuffer> {
    const file = this.index.responsesFile;
    const first = cell.byteOffset;
    const last = cell.byteOffset + cell.byteLength - 1;
    if (cell.byteLength === 0) return new ArrayBuffer(0);
    if (this.whole) return (await this.whole).slice(first, last + 1);
    let res: Response;
    try {
      this.requested.push([first, last]);
      res = await this.fetchFn(this.url, { headers: { Range: `bytes=${first}-${last}` } });
    } catch (e) {
      throw new BundleError(file, `could not be fetched (${(e as Error).message})`);
    }
    if (res.status === 206) return res.arrayBuffer();
    if (res.status === 200) {
      // No ranges here: keep this answer as the whole file, and let every other cell's
      // request (those already under way too) take its slice of it.
      this.whole ??= res.arrayBuffer().then((all) => {
        if (all.byteLength !== this.index.responsesBytes) {
          this.whole = null; // asked again after the pause, in case the file was being replaced
          throw new BundleError(file, `is ${all.byteLength} bytes long, field.json says ${this.index.responsesBytes}: re-export the bundle`);
        }
        return all;
      });
      return (await this.whole).slice(first, last + 1);
    }
    if (res.status === 416) throw new BundleError(file, 'is shorter than field.json says: re-export the bundle');
    throw new BundleError(file, `could not be fetched (HTTP ${res.status})`);
  }

  private trim(): void {
    let bytes = 0;
    for (const c of this.done.values()) bytes += cellBytes(c);
    for (const [k, c] of this.done) {
      if (bytes <= this.budgetBytes || this.done.size <= 4) break;
      bytes -= cellBytes(c);
      this.done.delete(k);
      this.cache.delete(k);
    }
  }
}

function cellBytes(c: CellResponses): number {
  // A mix of one source at gain 1 is that source's own arrays: count each buffer once.
  const seen = new Set<ArrayBufferLike>();
  let n = 0;
  for (const r of [...c.full, ...c.direct, ...(c.parts ?? []).flatMap((p) => [...p.full, ...p.direct])]) {
    if (seen.has(r.samples.buffer)) continue;
    seen.add(r.samples.buffer);
    n += r.samples.buffer.byteLength;
  }
  return n;
}
