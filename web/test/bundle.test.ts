import { describe, expect, test } from 'vitest';
import { BundleError, bandsLabel, bundleBase, parseIndex } from '../src/bundle';
import { crc32 } from '../src/crc32';
import { decodeCell } from '../src/responses';

/** A zlib stream (RFC 1950, the format of Python's zlib.compress) of the words, in a buffer of its own. */
async function deflated(words: Int16Array): Promise<ArrayBuffer> {
  const stream = new Blob([words.slice().buffer]).stream().pipeThrough(new CompressionStream('deflate'));
  return new Response(stream).arrayBuffer();
}

function index(): Record<string, unknown> {
  return {
    format: 'sonolux-web/2',
    scene: { file: 'scene.glb', lit: true, name: 't', source: 'scene' },
    sample_rate_hz: 48000,
    response_length_samples: 4,
    sample_format: 'int16',
    responses_file: 'responses.bin',
    responses_bytes: 8,
    playback_gain: 0.5,
    head_height_m: 1.5,
    directions: [{ name: 'front', azimuth_deg: 0, elevation_deg: 0 }],
    grid: { spacing_m: 1, radius_m: 0.25 },
    sources: [{ position_m: [3, 1, 1.5], power_w: 1 }],
    bounds_m: { min: [0, 0, 0], max: [6, 2.5, 2] },
    plan_segments_m: [[0, 0, 6, 0]],
    cells: [{ position_m: [1, 1, 1.5], grid_index: [0, 0], byte_offset: 0, byte_length: 8, crc32: 0, full: [[2, 3, 0, 0.5]], direct: [[2, 1, 0, 0.5]] }],
  };
}

describe('field.json', () => {
  test('a good index reads back in the viewer terms', () => {
    const ix = parseIndex(index());
    expect(ix.cells[0].full[0]).toEqual({ delay: 2, length: 3, offset: 0, scale: 0.5 });
    expect(ix.sampleRateHz).toBe(48000);
  });

  test('every problem names its field', () => {
    const bad = (edit: (j: Record<string, unknown>) => void, words: string) => {
      const j = index();
      edit(j);
      expect(() => parseIndex(j)).toThrow(BundleError);
      expect(() => parseIndex(j)).toThrow(words);
    };
    bad((j) => (j.format = 'other/2'), 'format');
    bad((j) => delete j.cells, 'cells is not a list');
    bad((j) => ((j.cells as any)[0].byte_length = 99), 'past the end');
    bad((j) => ((j.cells as any)[0].full = [[0, 9, 0, 1]]), 'past its cell block');
    bad((j) => ((j.cells as any)[0].full = []), 'has 0 items, not 1');
    bad((j) => (j.sample_rate_hz = 'x'), 'sample_rate_hz is not a number');
    bad((j) => (j.encoding = 'gzip'), 'encoding');
    bad((j) => (j.encoding = 'deflate'), 'cells[0].raw_length is not a number');
  });

  test('the bands come from the bundle, octaves or thirds', () => {
    const j = index();
    expect(parseIndex(j).bands).toBeNull(); // a bundle without them
    j.field = { bands_hz: [125, 250, 500, 1000, 2000, 4000] }; // written before thirds: octaves
    expect(bandsLabel(parseIndex(j).bands)).toBe('6 octaves, 125 Hz – 4 kHz');
    j.field = { bands_hz: [100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250, 1600, 2000, 2500, 3150, 4000, 5000], bands: 'third-octave' };
    const b = parseIndex(j).bands!;
    expect(b.centresHz.length).toBe(18);
    expect(bandsLabel(b)).toBe('18 third-octaves, 100 Hz – 5 kHz');
    j.field = { bands_hz: [1000, 500] };
    expect(() => parseIndex(j)).toThrow('field.bands_hz is not increasing');
    j.field = { bands_hz: [1000], bands: 'sixth' };
    expect(() => parseIndex(j)).toThrow('field.bands');
  });

  test('the bundle folder URL ends in a slash', () => {
    expect(bundleBase(null, 'http://h/p/index.html')).toBe('http://h/p/bundle/');
    expect(bundleBase('/data/b', 'http://h/p/')).toBe('http://h/data/b/');
  });
});

describe('responses.bin', () => {
  test('CRC-32 is zlib\u2019s', () => {
    expect(crc32(new TextEncoder().encode('123456789'))).toBe(0xcbf43926);
  });

  test('a block decodes with its delay and scale; a corrupt one is refused', async () => {
    const words = new Int16Array([10, -20, 30, 0]);
    const bytes = new Uint8Array(words.buffer);
    const j = index();
    (j.cells as any)[0].crc32 = crc32(bytes);
    const ix = parseIndex(j);
    const c = await decodeCell(ix, ix.cells[0], words.buffer.slice(0));
    expect(c.full[0].delay).toBe(2);
    expect(Array.from(c.full[0].samples)).toEqual([5, -10, 15]);
    expect(Array.from(c.direct[0].samples)).toEqual([5]);
    const broken = words.slice();
    broken[1] = 21;
    await expect(decodeCell(ix, ix.cells[0], broken.buffer)).rejects.toThrow('CRC-32');
  });

  test('a deflated block (zlib, as Python writes it) inflates to the same responses', async () => {
    const words = new Int16Array([10, -20, 30, 0]);
    const stored = await deflated(words);
    expect(Array.from(new Uint8Array(stored, 0, 1))).toEqual([0x78]); // a zlib header, as Python's
    const j = index();
    j.encoding = 'deflate';
    j.responses_bytes = stored.byteLength;
    Object.assign((j.cells as any)[0], { byte_length: stored.byteLength, raw_length: 8, crc32: crc32(new Uint8Array(stored)) });
    const ix = parseIndex(j);
    const c = await decodeCell(ix, ix.cells[0], stored.slice(0));
    expect(Array.from(c.full[0].samples)).toEqual([5, -10, 15]);
    // Inflating to another size than raw_length is refused with the cell named.
    Object.assign((j.cells as any)[0], { raw_length: 16, full: [[2, 3, 0, 0.5]] });
    const wrong = parseIndex(j);
    await expect(decodeCell(wrong, wrong.cells[0], stored.slice(0))).rejects.toThrow('cell 0: inflates to 8 bytes');
    // A stream that is not zlib (but matches its CRC) is refused, not decoded.
    const junk = new Uint8Array(stored.byteLength).fill(7);
    Object.assign((j.cells as any)[0], { raw_length: 8, crc32: crc32(junk) });
    const ij = parseIndex(j);
    await expect(decodeCell(ij, ij.cells[0], junk.buffer)).rejects.toThrow('could not be inflated');
  });
});
