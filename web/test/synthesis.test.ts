import { describe, expect, test } from 'vitest';
import { fft } from '../src/synth/fft';
import { bandSplit, bandWeights, decodeHistogram, fadeCut, panArrival, synthesisePart, weightedSequences, type CompactPart, type SynthesisSpec } from '../src/synth/synthesis';
import { mulberry32 } from '../src/mulberry32';

const SPEC: SynthesisSpec = {
  sampleRateHz: 48000,
  earlyBins: 8,
  lateBinSamples: 4,
  lateSplit: 2,
  envelopeSplit: 4,
  bandsHz: [500, 1000, 2000],
  volumeM3: 100,
  speedOfSoundMS: 343,
  fadeOutS: 0.0001,
  padPeriods: 12.5,
  directions: 1,
  azimuthBands: 1,
};

describe('fft', () => {
  test.each([16, 256])('matches the definition of the DFT (to 1e-11), n = %i', (n) => {
    const u = mulberry32(3);
    const x = Array.from({ length: n }, () => [u() - 0.5, u() - 0.5]);
    const re = Float64Array.from(x, (v) => v[0]);
    const im = Float64Array.from(x, (v) => v[1]);
    fft(re, im);
    for (let k = 0; k < n; k++) {
      let r = 0;
      let i = 0;
      for (let j = 0; j < n; j++) {
        const a = (-2 * Math.PI * j * k) / n;
        r += x[j][0] * Math.cos(a) - x[j][1] * Math.sin(a);
        i += x[j][0] * Math.sin(a) + x[j][1] * Math.cos(a);
      }
      expect(re[k]).toBeCloseTo(r, 11);
      expect(im[k]).toBeCloseTo(i, 11);
    }
    fft(re, im, true);
    re.forEach((v, j) => expect(v / n).toBeCloseTo(x[j][0], 11));
  });
});

describe('exact arrivals from their own direction', () => {
  const eight = { ...SPEC, directions: 8, azimuthBands: 8 };
  test('at a sector centre: all in that sector; between two: equal power; energy kept', () => {
    expect(panArrival(eight, 90, 0)).toEqual([
      [2, 1],
      [3, 0],
    ]);
    const [[a, ga], [b, gb]] = panArrival(eight, 22.5, 0);
    expect([a, b]).toEqual([0, 1]);
    expect(ga).toBeCloseTo(Math.SQRT1_2, 12);
    expect(gb).toBeCloseTo(Math.SQRT1_2, 12);
    for (const az of [3, 100, 200, 359]) {
      const p = panArrival(eight, az, 10);
      expect(p[0][1] ** 2 + p[1][1] ** 2).toBeCloseTo(1, 12);
      // VBAP: the gains' vector sum points at the arrival
      const x = p.reduce((s, [d, g]) => s + g * Math.cos((d * 45 * Math.PI) / 180), 0);
      const y = p.reduce((s, [d, g]) => s + g * Math.sin((d * 45 * Math.PI) / 180), 0);
      expect((((Math.atan2(y, x) * 180) / Math.PI + 360) % 360)).toBeCloseTo(az, 9);
    }
  });

  test('an arrival moves from its sector to the two around its direction, its energy kept', () => {
    const spec = { ...SPEC, directions: 8, azimuthBands: 8, bandsHz: [1000] };
    const eb = spec.earlyBins;
    // one arrival at sample 3 from 22.5° (between sectors 0 and 1), stored in sector 0
    const part: CompactPart = {
      onset: 0,
      cell: Uint32Array.from([3]),
      value: Float32Array.from([2]),
      envelope: new Float32Array(8 * 2),
      envelopeBins: 2,
      late: new Float32Array(0),
      lateBins: 0,
      exactSample: Uint32Array.from([3, 0]),
      exactDirection: Float32Array.from([22.5, 0]),
      exactEnergy: Float32Array.from([2]),
    };
    const r = synthesisePart(spec, part, eb, 1, [0, 0, 0], []);
    const e = r.full.map((x) => x.reduce((a, v) => a + v * v, 0) / spec.sampleRateHz);
    expect(e[0]).toBeCloseTo(1, 6); // float32 output
    expect(e[1]).toBeCloseTo(1, 6);
    expect(r.full[0][3]).toBeCloseTo(r.full[1][3], 12); // in phase: one phantom source
    expect(e.slice(2).every((v) => v === 0)).toBe(true);
  });
});

describe('the synthesis', () => {
  test('the band weights sum to one at every frequency', () => {
    const w = bandWeights([125, 250, 500, 1000], 1024, 48000);
    for (let k = 0; k < w[0].length; k++) expect(w.reduce((a, b) => a + b[k], 0)).toBeCloseTo(1, 12);
  });

  test('decodes a compact part as CompactArray.receiver does', () => {
    // one direction, 3 bands, 8 early samples (2 envelope bins), 2 stored late bins
    const part: CompactPart = {
      onset: 2,
      cell: Uint32Array.from([2, 8 + 5]), // band 0 sample 2, band 1 sample 5
      value: Float32Array.from([1, 0.5]),
      envelope: Float32Array.from([0.2, 0.4, 0, 0, 0, 0]),
      envelopeBins: 2,
      late: Float32Array.from([0.1, 0.1, 0, 0, 0, 0]),
      lateBins: 2,
    };
    const h = decodeHistogram(SPEC, part, 0);
    expect(h[0].length).toBe(8 + 4);
    // envelope bin 0 covers samples 0..3, from the onset (2) on: 0.2 over 2 samples.
    expect(Array.from(h[0].subarray(0, 8))).toEqual([0, 0, Math.fround(Math.fround(0.1) + 1), Math.fround(0.1), 0.1, 0.1, 0.1, 0.1].map(Math.fround));
    expect(h[1][5]).toBe(Math.fround(0.5));
    // a flat late part spreads evenly (its log step is 0): 0.05 in each dense bin
    expect(Array.from(h[0].subarray(8))).toEqual([0.05, 0.05, 0.05, 0.05].map(Math.fround));
  });

  test('each bin of the weighted sequences holds its energy exactly, per band', () => {
    const h = [0, 1, 2].map((b) => Float64Array.from({ length: 12 }, (_, t) => (t === 0 ? 2 : 1e-3 * (b + 1) * Math.exp(-t / 4))));
    const q = weightedSequences(SPEC, h, mulberry32(1));
    for (let b = 0; b < 3; b++) {
      for (let t = 0; t < 12; t++) {
        const a = t < 8 ? t : 8 + (t - 8) * 4;
        const e = t < 8 ? a + 1 : a + 4;
        let sum = 0;
        for (let i = a; i < e; i++) sum += q.s[b][i] ** 2;
        expect(sum / SPEC.sampleRateHz).toBeCloseTo(h[b][t], 12);
      }
    }
    // the same histogram in every band: p is s (the bank sums to one)
    const flat = [0, 1, 2].map(() => h[0]);
    const qf = weightedSequences(SPEC, flat, mulberry32(2));
    const [p] = bandSplit(SPEC, [qf]);
    p.forEach((v, i) => expect(v).toBeCloseTo(qf.s[0][i], 9));
    expect(fadeCut(p, 10, 48000, 0.0001).length).toBe(10);
  });
});
