import { describe, expect, test } from 'vitest';
import { parseIndex } from '../src/bundle';
import { crc32 } from '../src/crc32';
import { ResponseStore } from '../src/responses';

/** A bundle of `n` cells, one direction, each cell's block four int16 words [k, 0, 0, 0]. */
function bundle(n: number) {
  const words = new Int16Array(4 * n);
  const cells = [];
  for (let k = 0; k < n; k++) {
    words[4 * k] = k + 1;
    const block = new Uint8Array(words.buffer, 8 * k, 8);
    cells.push({ position_m: [k, 0, 1.5], grid_index: [k, 0], byte_offset: 8 * k, byte_length: 8, crc32: crc32(block), full: [[0, 1, 0, 1]], direct: [[0, 1, 0, 1]] });
  }
  const index = parseIndex({
    format: 'sonolux-web/2', encoding: 'none', scene: { file: 'scene.glb', lit: true }, sample_rate_hz: 48000, response_length_samples: 1,
    sample_format: 'int16', responses_file: 'responses.bin', responses_bytes: 8 * n, playback_gain: 1, head_height_m: 1.5,
    directions: [{ name: 'front', azimuth_deg: 0, elevation_deg: 0 }], grid: { spacing_m: 1, radius_m: 0.25 }, sources: [],
    bounds_m: { min: [0, 0, 0], max: [n, 1, 2] }, plan_segments_m: [], cells,
  });
  return { index, bytes: new Uint8Array(words.buffer) };
}

/** A server: answers ranges with 206 (or, without range support, the whole file with 200). */
function server(bytes: Uint8Array, ranges: boolean) {
  const seen: string[] = [];
  const fetchFn = (async (_url: string, init?: RequestInit) => {
    const range = new Headers(init?.headers).get('Range');
    seen.push(range ?? 'whole');
    const m = /^bytes=(\d+)-(\d+)$/.exec(range ?? '');
    if (ranges && m) return new Response(bytes.slice(Number(m[1]), Number(m[2]) + 1), { status: 206 });
    return new Response(bytes.slice(), { status: 200 });
  }) as typeof fetch;
  return { fetchFn, seen };
}

describe('ResponseStore', () => {
  test('fetches exactly the cells asked for, one range each, once', async () => {
    const { index, bytes } = bundle(10);
    const srv = server(bytes, true);
    const store = new ResponseStore('http://h/bundle/', index, srv.fetchFn);
    const got = await Promise.all([store.load(3), store.load(4), store.load(3)]);
    expect(got.map((c) => c.full[0].samples[0])).toEqual([4, 5, 4]);
    expect(srv.seen).toEqual(['bytes=24-31', 'bytes=32-39']);
    expect(store.requested).toEqual([[24, 31], [32, 39]]);
    expect([...Array(10).keys()].filter((k) => store.has(k))).toEqual([3, 4]);
  });

  test('a server without ranges sends the file once, however many cells are asked for at once', async () => {
    const { index, bytes } = bundle(10);
    const srv = server(bytes, false);
    const store = new ResponseStore('http://h/bundle/', index, srv.fetchFn);
    const got = await Promise.all([0, 5, 9].map((k) => store.load(k)));
    expect(got.map((c) => c.full[0].samples[0])).toEqual([1, 6, 10]);
    await store.load(7);
    // The three first asked at once (before any answer came); the fourth took its slice.
    expect(srv.seen.length).toBe(3);
  });

  test('the cache keeps within its budget, least recently used first', async () => {
    const { index, bytes } = bundle(10);
    const store = new ResponseStore('http://h/bundle/', index, server(bytes, true).fetchFn);
    store.budgetBytes = 5 * 8; // five cells of 2 float32 samples each
    for (let k = 0; k < 8; k++) await store.load(k);
    expect([...Array(10).keys()].filter((k) => store.has(k))).toEqual([3, 4, 5, 6, 7]);
  });
});
