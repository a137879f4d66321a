/**
 * A cell's responses from its compact field (bundle format sonolux-web/3), as the library
 * makes them (python/sonolux/sound/synthesis.py, python/sonolux/web/compact_cells.py):
 *
 * 1. the dense histogram [direction][band][time] decoded as CompactArray.receiver does: the
 *    early envelope spread evenly over its 1 ms bins from the onset on, the exact arrivals
 *    added, each stored late bin spread over its dense bins as the exponential its neighbours
 *    show (spread_late), every value rounded to float32 as there;
 * 2. per direction, Schröder's and Vorländer's synthesis: random-sign impulses with the
 *    arrival density of a room, dN/dt = 4π c³ t² / V (Kuttruff, Room Acoustics, ch. 4), each
 *    time bin's impulses scaled per band so that their energy is the bin's, split into bands by
 *    a zero-phase filter bank that sums to one (raised-cosine crossovers in log frequency at
 *    the geometric means of the centres), summed;
 * 3. cut at the cell's length with a 10 ms raised-cosine fade.
 *
 * The random fine structure comes from this file's own generator (seeded per cell, source and
 * direction), not numpy's: a browser's response equals the library's in its energy per band
 * and time bin, not sample by sample. Given the same impulses (`impulses`), it is the
 * library's response to rounding (tests/web/browser/synthesis.test.ts).
 */
import { fft, nextPowerOfTwo } from './fft';
import { mulberry32 } from '../mulberry32';

export interface SynthesisSpec {
  sampleRateHz: number;
  earlyBins: number;
  lateBinSamples: number;
  lateSplit: number;
  envelopeSplit: number;
  bandsHz: number[];
  volumeM3: number;
  speedOfSoundMS: number;
  fadeOutS: number;
  padPeriods: number;
  directions: number;
  /** Azimuth sectors per elevation band (directions = azimuthBands × elevation bands). */
  azimuthBands: number;
}

/** One source field's part of a cell (arrays as in compact_cells.py). */
export interface CompactPart {
  onset: number;
  cell: Uint32Array;
  value: Float32Array;
  envelope: Float32Array; // [direction, band, envelopeBins]
  envelopeBins: number;
  late: Float32Array; // [direction, band, lateBins]
  lateBins: number;
  /** A hybrid bake's exact early arrivals (none without [early]): sample, (azimuth,
   * elevation) in degrees where the sound comes from, energy per band (J/m²). */
  exactSample?: Uint32Array; // [arrival, 2]: sample, direction bin
  exactDirection?: Float32Array; // [arrival, 2]
  exactEnergy?: Float32Array; // [arrival, band]
}

/** The sectors an arrival from azimuth φ (degrees) is panned between and their gains: the
 * two sector centres around it, with 2-D vector base amplitude panning (Pulkki, JAES 45(6),
 * 1997: g ∝ the base's inverse applied to the source's unit vector, normalised to
 * g1² + g2² = 1), so that the two virtual sources at the sector centres make a phantom
 * source at φ. Elevation: the arrival's own elevation band (bands of equal solid angle). */
export function panArrival(spec: SynthesisSpec, azimuthDeg: number, elevationDeg: number): [number, number][] {
  const nAz = spec.azimuthBands;
  const nEl = spec.directions / nAz;
  const e = Math.min(nEl - 1, Math.max(0, Math.floor(((Math.sin((elevationDeg * Math.PI) / 180) + 1) / 2) * nEl)));
  if (nAz === 1) return [[e * nAz, 1]];
  const step = 360 / nAz;
  const az = ((azimuthDeg % 360) + 360) % 360;
  const lower = Math.floor(az / step) % nAz;
  const upper = (lower + 1) % nAz;
  const phi = ((az - lower * step) * Math.PI) / 180; // from the lower centre
  const span = (step * Math.PI) / 180;
  let g1 = Math.sin(span - phi) / Math.sin(span);
  let g2 = Math.sin(phi) / Math.sin(span);
  const norm = Math.hypot(g1, g2);
  g1 /= norm;
  g2 /= norm;
  return [
    [e * nAz + lower, g1],
    [e * nAz + upper, g2],
  ];
}

/** The largest change of level a late spread allows across one stored bin (compact.py). */
const MAX_LOG_STEP = Math.log(1e6);
const f32 = Math.fround;

/** Dense bins of a part: early one-sample bins, then lateBins × lateSplit late ones. */
export function denseBins(spec: SynthesisSpec, part: CompactPart): number {
  return spec.earlyBins + part.lateBins * spec.lateSplit;
}

/** Start (in samples) of dense bin t. */
export function binStart(spec: SynthesisSpec, t: number): number {
  return t < spec.earlyBins ? t : spec.earlyBins + (t - spec.earlyBins) * spec.lateBinSamples;
}

export function binEnd(spec: SynthesisSpec, t: number): number {
  return t < spec.earlyBins ? t + 1 : binStart(spec, t) + spec.lateBinSamples;
}

/** The histogram [band][time] (float32 values in float64) of direction d. */
export function decodeHistogram(spec: SynthesisSpec, part: CompactPart, d: number): Float64Array[] {
  const nb = spec.bandsHz.length;
  const eb = spec.earlyBins;
  const T = denseBins(spec, part);
  const out: Float64Array[] = [];
  const split = spec.envelopeSplit;
  const start = part.onset;
  for (let b = 0; b < nb; b++) {
    const row = new Float64Array(T);
    // spread_even: each envelope bin shared by its samples from the onset on.
    const env = (d * nb + b) * part.envelopeBins;
    for (let j = 0; j < part.envelopeBins; j++) {
      const lo = j * split;
      const hi = Math.min(lo + split, eb);
      const from = Math.min(Math.max(start, lo), hi);
      const counts = hi - from;
      if (counts <= 0) continue;
      const share = f32(part.envelope[env + j] / counts);
      for (let i = from; i < hi; i++) row[i] = share;
    }
    // spread_late (or the stored bins as they are).
    const lb = part.lateBins;
    const base = (d * nb + b) * lb;
    const ln = (k: number) => (k >= 0 && k < lb && part.late[base + k] > 0 ? Math.log(part.late[base + k]) : NaN);
    for (let k = 0; k < lb; k++) {
      const e = part.late[base + k];
      if (spec.lateSplit === 1) {
        row[eb + k] = e;
        continue;
      }
      if (!(e > 0)) continue;
      const l = ln(k);
      const p = ln(k - 1);
      const n = ln(k + 1);
      let step = Number.isFinite(p) && Number.isFinite(n) ? 0.5 * (n - p) : Number.isFinite(n) ? n - l : Number.isFinite(p) ? l - p : 0;
      step = Math.min(MAX_LOG_STEP, Math.max(-MAX_LOG_STEP, step));
      let sum = 0;
      const w = new Float64Array(spec.lateSplit);
      for (let i = 0; i < spec.lateSplit; i++) {
        w[i] = Math.exp(step * ((i + 0.5) / spec.lateSplit - 0.5));
        sum += w[i];
      }
      for (let i = 0; i < spec.lateSplit; i++) row[eb + k * spec.lateSplit + i] = f32(e * (w[i] / sum));
    }
    out.push(row);
  }
  // The exact arrivals, added in float64 and rounded once (CompactArray.receiver).
  const per = nb * eb;
  for (let i = 0; i < part.cell.length; i++) {
    const c = part.cell[i];
    const dd = Math.floor(c / per);
    if (dd !== d) continue;
    const rest = c - dd * per;
    const b = Math.floor(rest / eb);
    const t = rest - b * eb;
    out[b][t] = f32(out[b][t] + part.value[i]);
  }
  return out;
}

/** Poisson draw of a small mean (≤ 0.5 here: the rate is capped at fs/2), Knuth's method. */
function poisson(mean: number, u: () => number): number {
  const limit = Math.exp(-mean);
  let k = 0;
  let p = u();
  while (p > limit) {
    k++;
    p *= u();
  }
  return k;
}

/** The impulses from sample k0 to n: +1 at k0, then random-sign Poisson arrivals. */
export function poissonImpulses(spec: SynthesisSpec, n: number, k0: number, u: () => number): Float64Array {
  const fs = spec.sampleRateHz;
  const c = spec.speedOfSoundMS;
  const x = new Float64Array(n);
  if (k0 >= n) return x;
  const a = (4 * Math.PI * c ** 3) / spec.volumeM3;
  const rateMax = 0.5 * fs;
  const tCap = Math.sqrt(rateMax / a);
  const until = (t: number) => (t <= tCap ? (a * t ** 3) / 3 : (a * tCap ** 3) / 3 + rateMax * (t - tCap));
  x[k0] = 1;
  let prev = until((k0 + 1) / fs);
  for (let i = k0 + 1; i < n; i++) {
    const next = until((i + 1) / fs);
    const count = poisson(next - prev, u);
    prev = next;
    let v = 0;
    for (let j = 0; j < count; j++) v += u() < 0.5 ? 1 : -1;
    x[i] = v;
  }
  return x;
}

/** The bank's weights [band][k] at f = k fs / nFft, k ≤ nFft / 2 (synthesis.py). */
export function bandWeights(bandsHz: number[], nFft: number, fs: number): Float64Array[] {
  const nb = bandsHz.length;
  const m = nFft / 2 + 1;
  const w = Array.from({ length: nb }, () => new Float64Array(m));
  for (let k = 0; k < m; k++) {
    const f = (k * fs) / nFft;
    let below = 0; // low[b - 1]
    for (let b = 0; b < nb; b++) {
      let low = 1;
      if (b < nb - 1) {
        const lo = bandsHz[b];
        const hi = bandsHz[b + 1];
        const x = Math.log(Math.max(f, 1e-300) / lo) / Math.log(hi / lo);
        low = f <= lo ? 1 : f >= hi ? 0 : Math.cos(0.5 * Math.PI * x) ** 2;
      }
      w[b][k] = low - below;
      below = low;
    }
  }
  return w;
}

const weightsCache = new Map<string, Float64Array[]>();

/** bandWeights by size: the cells of a bundle share a few sizes (kept: the last eight). */
function cachedWeights(bandsHz: number[], nFft: number, fs: number): Float64Array[] {
  const key = `${nFft} ${fs} ${bandsHz.join(',')}`;
  let w = weightsCache.get(key);
  if (!w) {
    if (weightsCache.size >= 8) weightsCache.delete(weightsCache.keys().next().value!);
    w = bandWeights(bandsHz, nFft, fs);
    weightsCache.set(key, w);
  }
  return w;
}

interface Sequences {
  s: Float64Array[]; // [band][n]
  n: number;
}

/** weighted_sequences of synthesis.py for a histogram on the spec's bins. */
export function weightedSequences(spec: SynthesisSpec, h: Float64Array[], u: () => number, impulses?: Float64Array): Sequences {
  const nb = h.length;
  const T = h[0].length;
  const fs = spec.sampleRateHz;
  let first = -1;
  let last = -1;
  const total = new Float64Array(T);
  for (let t = 0; t < T; t++) {
    let sum = 0;
    for (let b = 0; b < nb; b++) sum += h[b][t];
    total[t] = sum;
    if (sum > 0) {
      if (first < 0) first = t;
      last = t;
    }
  }
  if (first < 0) return { s: h.map(() => new Float64Array(0)), n: 0 };
  const n = binEnd(spec, last);
  const x = impulses ? Float64Array.from(impulses.subarray(0, n)) : poissonImpulses(spec, n, binStart(spec, first), u);
  const nBins = last + 1;
  const power = new Float64Array(nBins);
  for (let t = 0; t < nBins; t++) {
    const a = binStart(spec, t);
    const e = binEnd(spec, t);
    for (let i = a; i < e; i++) power[t] += x[i] * x[i];
    // A bin with energy but no impulse gets one, of random sign, at a random sample.
    if (total[t] > 0 && power[t] === 0) {
      const at = a + Math.floor(u() * (e - a));
      x[at] = u() < 0.5 ? -1 : 1;
      power[t] = 1;
    }
  }
  const s: Float64Array[] = [];
  for (let b = 0; b < nb; b++) {
    const row = new Float64Array(n);
    for (let t = 0; t < nBins; t++) {
      if (!(power[t] > 0) || !(h[b][t] > 0)) continue;
      const g = Math.sqrt((h[b][t] * fs) / power[t]);
      const e = binEnd(spec, t);
      for (let i = binStart(spec, t); i < e; i++) row[i] = g * x[i];
    }
    s.push(row);
  }
  return { s, n };
}

/** Pressure responses of several directions' weighted sequences (float64, each its own n):
 * p = Σ_b w_b ⊛ s_b, two bands per forward FFT and two directions per inverse FFT. */
export function bandSplit(spec: SynthesisSpec, seqs: Sequences[]): Float64Array[] {
  const nb = spec.bandsHz.length;
  const fs = spec.sampleRateHz;
  const out: Float64Array[] = seqs.map((q) => new Float64Array(q.n));
  if (nb === 1) {
    seqs.forEach((q, i) => q.n && out[i].set(q.s[0]));
    return out;
  }
  const nMax = Math.max(0, ...seqs.map((q) => q.n));
  if (nMax === 0) return out;
  let minGap = Infinity;
  for (let b = 1; b < nb; b++) minGap = Math.min(minGap, spec.bandsHz[b] - spec.bandsHz[b - 1]);
  const N = nextPowerOfTwo(nMax + Math.ceil((spec.padPeriods * fs) / minGap));
  const w = cachedWeights(spec.bandsHz, N, fs);
  const half = N / 2;
  const spectrum = (q: Sequences): [Float64Array, Float64Array] => {
    const pr = new Float64Array(half + 1);
    const pi = new Float64Array(half + 1);
    for (let b = 0; b < nb; b += 2) {
      const re = new Float64Array(N);
      const im = new Float64Array(N);
      re.set(q.s[b]);
      if (b + 1 < nb) im.set(q.s[b + 1]);
      fft(re, im);
      for (let k = 0; k <= half; k++) {
        const j = (N - k) % N;
        // Z = S1 + i S2 with S1, S2 Hermitian: S1 = (Z[k] + conj Z[N-k]) / 2, S2 = (Z[k] − conj Z[N-k]) / 2i.
        const s1r = 0.5 * (re[k] + re[j]);
        const s1i = 0.5 * (im[k] - im[j]);
        const s2r = 0.5 * (im[k] + im[j]);
        const s2i = -0.5 * (re[k] - re[j]);
        pr[k] += w[b][k] * s1r;
        pi[k] += w[b][k] * s1i;
        if (b + 1 < nb) {
          pr[k] += w[b + 1][k] * s2r;
          pi[k] += w[b + 1][k] * s2i;
        }
      }
    }
    return [pr, pi];
  };
  for (let i = 0; i < seqs.length; i += 2) {
    const a = seqs[i].n ? spectrum(seqs[i]) : null;
    const b = i + 1 < seqs.length && seqs[i + 1].n ? spectrum(seqs[i + 1]) : null;
    if (!a && !b) continue;
    // Y = P_a + i P_b over the whole circle; its inverse has p_a as real part, p_b as imaginary.
    const re = new Float64Array(N);
    const im = new Float64Array(N);
    for (let k = 0; k <= half; k++) {
      const ar = a ? a[0][k] : 0;
      const ai = a ? a[1][k] : 0;
      const br = b ? b[0][k] : 0;
      const bi = b ? b[1][k] : 0;
      re[k] = ar - bi;
      im[k] = ai + br;
      if (k > 0 && k < half) {
        // P[N-k] = conj P[k] for both.
        re[N - k] = ar + bi;
        im[N - k] = -ai + br;
      }
    }
    fft(re, im, true);
    if (a) for (let k = 0; k < seqs[i].n; k++) out[i][k] = re[k] / N;
    if (b) for (let k = 0; k < seqs[i + 1].n; k++) out[i + 1][k] = im[k] / N;
  }
  return out;
}

/** The response cut at `length` samples with the fade of compact_cells.fade_cut. */
export function fadeCut(x: Float64Array, length: number, fs: number, fadeOutS: number): Float32Array {
  if (x.length <= length) return Float32Array.from(x);
  const y = Float32Array.from(x.subarray(0, length));
  const k = Math.min(length, Math.max(1, Math.round(fadeOutS * fs)));
  for (let i = 0; i < k; i++) y[length - k + i] *= 0.5 * (1 + Math.cos((Math.PI * (i + 1)) / k));
  return y;
}

/** Bins of the histogram that hold a source's direct sound (web/responses.py direct_bins). */
export function directMask(spec: SynthesisSpec, T: number, receiver: number[], sources: number[][]): Uint8Array {
  const fs = spec.sampleRateHz;
  const keep = new Uint8Array(T);
  const spread = 0.5 / fs;
  for (const p of sources) {
    const t = Math.hypot(receiver[0] - p[0], receiver[1] - p[1], receiver[2] - p[2]) / spec.speedOfSoundMS;
    for (let k = 0; k < T; k++) {
      if (binStart(spec, k) / fs < t + spread && binEnd(spec, k) / fs > t - spread) keep[k] = 1;
    }
  }
  return keep;
}

export interface PartResponses {
  full: Float32Array[];
  direct: Float32Array[];
}

/** Full and direct-sound responses of every direction of one source field's part of a cell.
 * seed: of the part's first direction (direction d uses seed + d). */
export function synthesisePart(
  spec: SynthesisSpec,
  part: CompactPart,
  length: number,
  seed: number,
  receiver: number[],
  sources: number[][],
  impulses?: Float64Array[],
): PartResponses {
  const fs = spec.sampleRateHz;
  const nb = spec.bandsHz.length;
  const hs = Array.from({ length: spec.directions }, (_, d) => decodeHistogram(spec, part, d));
  const T = denseBins(spec, part);
  const mask = directMask(spec, T, receiver, sources);
  const direct = hs.map((h) => h.map((row) => row.map((v, k) => (mask[k] ? v : 0))));
  // A hybrid bake's exact arrivals leave their sector's histogram, to be added back as spikes
  // panned from their own direction (in phase in both sectors: one phantom source).
  const n = (part.exactSample?.length ?? 0) / 2;
  const spikes: { sample: number; pan: [number, number][]; amp: number[] }[] = [];
  for (let a = 0; a < n; a++) {
    const sample = part.exactSample![2 * a];
    const home = part.exactSample![2 * a + 1];
    if (sample >= spec.earlyBins || home >= spec.directions) continue;
    const pan = panArrival(spec, part.exactDirection![2 * a], part.exactDirection![2 * a + 1]);
    const e = Array.from({ length: nb }, (_, b) => part.exactEnergy![a * nb + b]);
    for (let b = 0; b < nb; b++) {
      hs[home][b][sample] = Math.max(0, hs[home][b][sample] - e[b]);
      direct[home][b][sample] = Math.max(0, direct[home][b][sample] - e[b]);
    }
    spikes.push({ sample, pan, amp: e.map((v) => Math.sqrt(v * fs)) });
  }
  const withSpikes = (qs: Sequences[], keep: (sample: number) => boolean): Sequences[] => {
    for (const sp of spikes) {
      if (!keep(sp.sample)) continue;
      for (const [d, g] of sp.pan) {
        const q = qs[d];
        if (sp.sample >= q.n) {
          q.s = q.s.map((row) => {
            const grown = new Float64Array(sp.sample + 1);
            grown.set(row);
            return grown;
          });
          q.n = sp.sample + 1;
        }
        for (let b = 0; b < nb; b++) q.s[b][sp.sample] += g * sp.amp[b];
      }
    }
    return qs;
  };
  const full = bandSplit(
    spec,
    withSpikes(
      hs.map((h, d) => weightedSequences(spec, h, mulberry32(seed + d), impulses?.[d])),
      () => true,
    ),
  ).map((x) => fadeCut(x, length, fs, spec.fadeOutS));
  const directOnly = bandSplit(
    spec,
    withSpikes(
      direct.map((h, d) => weightedSequences(spec, h, mulberry32(seed + d + 0x9e3779b9))),
      (sample) => mask[sample] === 1,
    ),
  ).map((x) => fadeCut(x, length, fs, spec.fadeOutS));
  return { full, direct: directOnly };
}
