/**
 * The cells' responses from responses.bin: fetched one cell's block at a time, only for the
 * cells around the listener (an HTTP range request; a server that answers with the whole file
 * is fine too: the file is then fetched once and kept), checked against the block's CRC-32,
 * inflated when the bundle is compressed, decoded to float32 and kept in a cache of bounded
 * size (least recently used cells go first).
 */
import { BundleError, type BundleIndex, type Cell, type ResponseRef } from './bundle';
import { crc32 } from './crc32';

/** A response: `delay` zeros, then `samples` (already × scale). */
export interface ImpulseResponse {
  delay: number;
  samples: Float32Array;
}

export interface CellResponses {
  cell: number;
  full: ImpulseResponse[];
  direct: ImpulseResponse[];
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

/** Decodes one cell's block as stored (exactly its byte_length bytes): checked, inflated when
 * the bundle is compressed, then split into its responses. */
export async function decodeCell(index: BundleIndex, cell: Cell, stored: ArrayBuffer): Promise<CellResponses> {
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

  constructor(
    base: string,
    readonly index: BundleIndex,
    private readonly fetchFn: typeof fetch = (...a) => fetch(...a),
  ) {
    this.url = new URL(index.responsesFile, base).href;
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

  load(cell: number): Promise<CellResponses> {
    let p = this.cache.get(cell);
    if (!p) {
      p = this.fetchBlock(this.index.cells[cell]).then(async (block) => {
        const c = await decodeCell(this.index, this.index.cells[cell], block);
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
  let n = 0;
  for (const r of [...c.full, ...c.direct]) n += r.samples.byteLength;
  return n;
}
