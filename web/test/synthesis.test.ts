import { describe, expect, test } from 'vitest';
import { fft } from '../src/synth/fft';
import { bandSplit, bandWeights, decodeHistogram, fadeCut, generator, weightedSequences, type CompactPart, type SynthesisSpec } from '../src/synth/synthesis';

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
};

describe('fft', () => {
  test.each([16, 256])('matches the definition of the DFT (to 1e-11), n = %i', (n) => {
    const u = generator(3);
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
    const q = weightedSequences(SPEC, h, generator(1));
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
    const qf = weightedSequences(SPEC, flat, generator(2));
    const [p] = bandSplit(SPEC, [qf]);
    p.forEach((v, i) => expect(v).toBeCloseTo(qf.s[0][i], 9));
    expect(fadeCut(p, 10, 48000, 0.0001).length).toBe(10);
  });
});
