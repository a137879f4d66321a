/**
 * The bundle's index, field.json (written by `sonolux export FIELD --web DIR`), read and
 * checked: anything missing or out of range is a BundleError that names the file and the
 * field, which the page shows. Formats: sonolux-web/3 (each cell its source fields' compact
 * fields, synthesised here: synth/), sonolux-web/2 (each cell its responses, deflated) and
 * sonolux-web/1 (the same, never compressed).
 */
import type { Vec3 } from './coords';
import type { SynthesisSpec } from './synth/synthesis';

export const FORMAT = 'sonolux-web/3';
const FORMATS = ['sonolux-web/1', 'sonolux-web/2', FORMAT];

/** One source field's part of a /3 cell block (byteOffset into the inflated block). */
export interface CompactRef {
  onset: number;
  arrivals: number;
  envelopeBins: number;
  lateBins: number;
  /** A hybrid bake's exact early arrivals stored after the late part (0 without). */
  exactArrivals: number;
  byteOffset: number;
}

/** A source field of a /3 bundle: its name and its sources' positions. */
export interface SourceField {
  name: string;
  positions: Vec3[];
}

/** How a cell's block is stored in responses.bin: as is, or zlib-compressed (RFC 1950). */
export type Encoding = 'none' | 'deflate';

/** `delay` zeros, then `length` samples from `offset` (samples into the cell's block), × `scale`. */
export interface ResponseRef {
  delay: number;
  length: number;
  offset: number;
  scale: number;
}

export interface Direction {
  name: string;
  azimuthDeg: number;
  elevationDeg: number;
}

export interface Cell {
  index: number;
  position: Vec3;
  gridIndex: [number, number] | null;
  byteOffset: number;
  /** Bytes of the block as stored (what a range request fetches; the CRC-32 is of these). */
  byteLength: number;
  /** Bytes of the block once inflated (byteLength when not compressed). */
  rawLength: number;
  crc32: number;
  full: ResponseRef[];
  direct: ResponseRef[];
  /** /3: the responses' length (samples) and the source fields' parts of the block. */
  lengthSamples: number;
  fields: CompactRef[];
}

export interface Source {
  position: Vec3;
  powerW: number;
}

export interface BundleIndex {
  format: string;
  sceneFile: string;
  sceneLit: boolean;
  sceneName: string;
  sceneSource: string;
  sampleRateHz: number;
  responseLengthSamples: number;
  sampleFormat: 'int16' | 'float32';
  encoding: Encoding;
  responsesFile: string;
  responsesBytes: number;
  playbackGain: number;
  headHeightM: number;
  directions: Direction[];
  gridSpacingM: number | null;
  radiusM: number;
  sources: Source[];
  boundsMin: Vec3;
  boundsMax: Vec3;
  planSegments: [number, number, number, number][];
  cells: Cell[];
  /** The field's frequency bands, as the bundle names them (none in bundles without them). */
  bands: Bands | null;
  /** /3: how the cells' responses are synthesised; null in /1 and /2 (responses stored). */
  synthesis: SynthesisSpec | null;
  /** /3: the source fields (one, "all", unless the field holds a field per source). */
  sourceFields: SourceField[];
  seed: number;
}

/** Frequency bands of the field: their kind and nominal centres, read from field.json. */
export interface Bands {
  kind: 'octave' | 'third-octave';
  centresHz: number[];
}

function hz(f: number): string {
  return f >= 1000 ? `${+(f / 1000).toPrecision(3)} kHz` : `${+f.toPrecision(3)} Hz`;
}

/** '6 octaves, 125 Hz – 4 kHz', '18 third-octaves, 100 Hz – 5 kHz'. */
export function bandsLabel(b: Bands | null): string {
  if (!b || b.centresHz.length === 0) return '';
  const n = b.centresHz.length;
  const kind = b.kind === 'octave' ? (n === 1 ? 'octave' : 'octaves') : n === 1 ? 'third-octave' : 'third-octaves';
  const span = n === 1 ? hz(b.centresHz[0]) : `${hz(b.centresHz[0])} – ${hz(b.centresHz[n - 1])}`;
  return `${n} ${kind}, ${span}`;
}

export class BundleError extends Error {
  constructor(
    readonly file: string,
    message: string,
  ) {
    super(`${file}: ${message}`);
    this.name = 'BundleError';
  }
}

type Json = Record<string, unknown>;

class Reader {
  constructor(readonly file: string) {}

  fail(path: string, what: string): never {
    throw new BundleError(this.file, `${path} ${what}`);
  }

  obj(v: unknown, path: string): Json {
    if (typeof v !== 'object' || v === null || Array.isArray(v)) this.fail(path, 'is not an object');
    return v as Json;
  }

  arr(v: unknown, path: string, length?: number): unknown[] {
    if (!Array.isArray(v)) this.fail(path, 'is not a list');
    if (length !== undefined && v.length !== length) this.fail(path, `has ${v.length} items, not ${length}`);
    return v;
  }

  num(v: unknown, path: string, lo = -Infinity, hi = Infinity): number {
    if (typeof v !== 'number' || !Number.isFinite(v)) this.fail(path, 'is not a number');
    if (v < lo || v > hi) this.fail(path, `= ${v} is outside [${lo}, ${hi}]`);
    return v;
  }

  int(v: unknown, path: string, lo = 0, hi = Number.MAX_SAFE_INTEGER): number {
    const n = this.num(v, path, lo, hi);
    if (!Number.isInteger(n)) this.fail(path, `= ${n} is not a whole number`);
    return n;
  }

  str(v: unknown, path: string): string {
    if (typeof v !== 'string') this.fail(path, 'is not a string');
    return v;
  }

  vec3(v: unknown, path: string): Vec3 {
    const a = this.arr(v, path, 3);
    return [this.num(a[0], `${path}[0]`), this.num(a[1], `${path}[1]`), this.num(a[2], `${path}[2]`)];
  }
}

/** Checks a parsed field.json and returns it in the viewer's terms. */
export function parseIndex(raw: unknown, file = 'field.json'): BundleIndex {
  const r = new Reader(file);
  const j = r.obj(raw, 'the index');
  const format = r.str(j.format, 'format');
  if (!FORMATS.includes(format)) r.fail('format', `is ${JSON.stringify(format)}; this viewer reads ${FORMATS.join(', ')}`);
  const encoding = j.encoding === undefined ? 'none' : r.str(j.encoding, 'encoding');
  if (encoding !== 'none' && encoding !== 'deflate') r.fail('encoding', `is ${JSON.stringify(encoding)}, not "none" or "deflate"`);
  const scene = r.obj(j.scene, 'scene');
  const compact = format === FORMAT;
  const sampleFormat = compact ? 'float32' : r.str(j.sample_format, 'sample_format');
  if (sampleFormat !== 'int16' && sampleFormat !== 'float32') r.fail('sample_format', `is ${sampleFormat}`);
  const itemBytes = sampleFormat === 'int16' ? 2 : 4;
  const responsesBytes = r.int(j.responses_bytes, 'responses_bytes');
  const directions = r.arr(j.directions, 'directions').map((d, k) => {
    const o = r.obj(d, `directions[${k}]`);
    return {
      name: r.str(o.name, `directions[${k}].name`),
      azimuthDeg: r.num(o.azimuth_deg, `directions[${k}].azimuth_deg`, -360, 360),
      elevationDeg: r.num(o.elevation_deg, `directions[${k}].elevation_deg`, -90, 90),
    };
  });
  if (directions.length === 0) r.fail('directions', 'is empty');
  const refs = (v: unknown, path: string, block: number): ResponseRef[] =>
    r.arr(v, path, directions.length).map((e, k) => {
      const a = r.arr(e, `${path}[${k}]`, 4);
      const ref = {
        delay: r.int(a[0], `${path}[${k}][0] (delay)`),
        length: r.int(a[1], `${path}[${k}][1] (length)`),
        offset: r.int(a[2], `${path}[${k}][2] (offset)`),
        scale: r.num(a[3], `${path}[${k}][3] (scale)`, 0),
      };
      if ((ref.offset + ref.length) * itemBytes > block) r.fail(`${path}[${k}]`, 'reaches past its cell block');
      return ref;
    });
  const synthesis = compact ? readSynthesis(r, j.synthesis, directions.length) : null;
  const sourceFields: SourceField[] = compact
    ? r.arr(j.source_fields, 'source_fields').map((f, k) => {
        const o = r.obj(f, `source_fields[${k}]`);
        return { name: r.str(o.name, `source_fields[${k}].name`), positions: r.arr(o.positions_m, `source_fields[${k}].positions_m`).map((p, m) => r.vec3(p, `source_fields[${k}].positions_m[${m}]`)) };
      })
    : [];
  if (compact && sourceFields.length === 0) r.fail('source_fields', 'is empty');
  const parts = (v: unknown, path: string, block: number): CompactRef[] =>
    r.arr(v, path, sourceFields.length).map((e, k) => {
      const o = r.obj(e, `${path}[${k}]`);
      const ref = {
        onset: r.int(o.onset, `${path}[${k}].onset`),
        arrivals: r.int(o.arrivals, `${path}[${k}].arrivals`),
        envelopeBins: r.int(o.envelope_bins, `${path}[${k}].envelope_bins`),
        lateBins: r.int(o.late_bins, `${path}[${k}].late_bins`),
        exactArrivals: o.exact_arrivals === undefined ? 0 : r.int(o.exact_arrivals, `${path}[${k}].exact_arrivals`),
        byteOffset: r.int(o.byte_offset, `${path}[${k}].byte_offset`),
      };
      const db = directions.length * synthesis!.bandsHz.length;
      const bytes = 4 * (2 * ref.arrivals + db * (ref.envelopeBins + ref.lateBins) + ref.exactArrivals * (4 + synthesis!.bandsHz.length));
      if (ref.byteOffset % 4 !== 0 || ref.byteOffset + bytes > block) r.fail(`${path}[${k}]`, 'reaches past its cell block');
      return ref;
    });
  const cells = r.arr(j.cells, 'cells').map((c, i): Cell => {
    const o = r.obj(c, `cells[${i}]`);
    const byteOffset = r.int(o.byte_offset, `cells[${i}].byte_offset`);
    const byteLength = r.int(o.byte_length, `cells[${i}].byte_length`);
    if (byteOffset + byteLength > responsesBytes) r.fail(`cells[${i}]`, 'reaches past the end of responses_bytes');
    const rawLength = encoding === 'deflate' ? r.int(o.raw_length, `cells[${i}].raw_length`) : byteLength;
    const gi = o.grid_index === null ? null : r.arr(o.grid_index, `cells[${i}].grid_index`, 2);
    return {
      index: i,
      position: r.vec3(o.position_m, `cells[${i}].position_m`),
      gridIndex: gi === null ? null : [r.num(gi[0], 'grid_index'), r.num(gi[1], 'grid_index')],
      byteOffset,
      byteLength,
      rawLength,
      crc32: r.int(o.crc32, `cells[${i}].crc32`, 0, 0xffffffff),
      full: compact ? [] : refs(o.full, `cells[${i}].full`, rawLength),
      direct: compact ? [] : refs(o.direct, `cells[${i}].direct`, rawLength),
      lengthSamples: compact ? r.int(o.length_samples, `cells[${i}].length_samples`) : 0,
      fields: compact ? parts(o.fields, `cells[${i}].fields`, rawLength) : [],
    };
  });
  if (cells.length === 0) r.fail('cells', 'is empty');
  const grid = r.obj(j.grid, 'grid');
  const bounds = r.obj(j.bounds_m, 'bounds_m');
  const out: BundleIndex = {
    format,
    sceneFile: r.str(scene.file, 'scene.file'),
    sceneLit: Boolean(scene.lit),
    sceneName: typeof scene.name === 'string' ? scene.name : '',
    sceneSource: typeof scene.source === 'string' ? scene.source : '',
    sampleRateHz: r.int(j.sample_rate_hz, 'sample_rate_hz', 3000, 768000),
    responseLengthSamples: r.int(j.response_length_samples, 'response_length_samples'),
    sampleFormat: sampleFormat as 'int16' | 'float32',
    encoding: encoding as Encoding,
    responsesFile: r.str(j.responses_file, 'responses_file'),
    responsesBytes,
    playbackGain: r.num(j.playback_gain, 'playback_gain', 0),
    headHeightM: r.num(j.head_height_m, 'head_height_m'),
    directions,
    gridSpacingM: grid.spacing_m === null ? null : r.num(grid.spacing_m, 'grid.spacing_m', 0),
    radiusM: r.num(grid.radius_m, 'grid.radius_m', 0),
    sources: r.arr(j.sources, 'sources').map((s, k) => {
      const o = r.obj(s, `sources[${k}]`);
      return { position: r.vec3(o.position_m, `sources[${k}].position_m`), powerW: r.num(o.power_w, 'power_w') };
    }),
    boundsMin: r.vec3(bounds.min, 'bounds_m.min'),
    boundsMax: r.vec3(bounds.max, 'bounds_m.max'),
    planSegments: r.arr(j.plan_segments_m, 'plan_segments_m').map((s, k) => {
      const a = r.arr(s, `plan_segments_m[${k}]`, 4).map((v) => r.num(v, `plan_segments_m[${k}]`));
      return [a[0], a[1], a[2], a[3]];
    }),
    cells,
    bands: readBands(r, j.field),
    synthesis,
    sourceFields,
    seed: j.seed === undefined ? 0 : r.int(j.seed, 'seed'),
  };
  if (out.synthesis) out.synthesis.sampleRateHz = out.sampleRateHz;
  return out;
}

/** field.json's synthesis block (/3): the time axis of the compact cells and the room. */
function readSynthesis(r: Reader, v: unknown, directions: number): SynthesisSpec {
  const s = r.obj(v, 'synthesis');
  const bandsHz = r.arr(s.bands_hz, 'synthesis.bands_hz').map((b, k) => r.num(b, `synthesis.bands_hz[${k}]`, 0));
  if (bandsHz.length === 0) r.fail('synthesis.bands_hz', 'is empty');
  for (let k = 1; k < bandsHz.length; k++) if (!(bandsHz[k] > bandsHz[k - 1])) r.fail('synthesis.bands_hz', 'is not increasing');
  return {
    sampleRateHz: 0, // set from sample_rate_hz below
    earlyBins: r.int(s.early_bins, 'synthesis.early_bins'),
    lateBinSamples: r.int(s.late_bin_samples, 'synthesis.late_bin_samples', 1),
    lateSplit: r.int(s.late_split, 'synthesis.late_split', 1),
    envelopeSplit: r.int(s.envelope_split, 'synthesis.envelope_split', 1),
    bandsHz,
    volumeM3: r.num(s.volume_m3, 'synthesis.volume_m3', 1e-9),
    speedOfSoundMS: r.num(s.speed_of_sound_m_s, 'synthesis.speed_of_sound_m_s', 1),
    fadeOutS: r.num(s.fade_out_s, 'synthesis.fade_out_s', 0, 1),
    padPeriods: r.num(s.pad_periods, 'synthesis.pad_periods', 0, 1000),
    directions,
    azimuthBands: s.azimuth_bands === undefined ? directions : r.int(s.azimuth_bands, 'synthesis.azimuth_bands', 1, directions),
  };
}

/** field.bands_hz and field.bands (the kind; octaves in bundles written before thirds). */
function readBands(r: Reader, field: unknown): Bands | null {
  if (field === undefined || field === null) return null;
  const f = r.obj(field, 'field');
  if (f.bands_hz === undefined) return null;
  const centresHz = r.arr(f.bands_hz, 'field.bands_hz').map((v, k) => r.num(v, `field.bands_hz[${k}]`, 0));
  for (let k = 1; k < centresHz.length; k++) {
    if (!(centresHz[k] > centresHz[k - 1])) r.fail('field.bands_hz', 'is not increasing');
  }
  const kind = f.bands === undefined || f.bands === null ? 'octave' : r.str(f.bands, 'field.bands');
  if (kind !== 'octave' && kind !== 'third-octave') r.fail('field.bands', `= ${kind} is not "octave" or "third-octave"`);
  return { kind, centresHz };
}

/** The bundle's folder URL, always ending in '/'. */
export function bundleBase(param: string | null, pageUrl: string): string {
  const u = new URL(param && param.length ? param : 'bundle/', pageUrl);
  if (!u.pathname.endsWith('/')) u.pathname += '/';
  return u.href;
}

/** Fetches and checks field.json. */
export async function loadIndex(base: string, fetchFn: typeof fetch = fetch): Promise<BundleIndex> {
  const file = 'field.json';
  let res: Response;
  try {
    res = await fetchFn(new URL(file, base).href);
  } catch (e) {
    throw new BundleError(file, `could not be fetched from ${base} (${(e as Error).message})`);
  }
  if (!res.ok) throw new BundleError(file, `could not be fetched from ${base} (HTTP ${res.status})`);
  const text = await res.text();
  let raw: unknown;
  try {
    raw = JSON.parse(text);
  } catch (e) {
    throw new BundleError(file, `is not valid JSON (${(e as Error).message})`);
  }
  return parseIndex(raw, file);
}
