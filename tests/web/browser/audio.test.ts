/** The sound, rendered by the page's own audio graph in an OfflineAudioContext. */
import { afterAll, beforeAll, describe, expect, inject, test } from 'vitest';
import { launch, open, type Session } from './browser';

let s: Session;
beforeAll(async () => {
  s = await launch();
  await open(s.page, inject('litUrl'));
});
afterAll(async () => s?.close());

// paper-small: the source is at (3, 1.25); cell 5 at (1, 1.25) hears it from the front (+x).
const CELL = 5;
const HEADINGS = [0, 45, 90, 135, 180, 225, 270, 315];

/** Left/right level difference (dB) of renders at each heading: of the whole render, or of
 * the first arrival only (the 2 ms from where the direct-only render first reaches a tenth of
 * its peak: the HRTF panners add a latency of their own). */
async function levels(mode: 'full' | 'direct', rendering: 'hrtf' | 'cube', firstArrival: boolean): Promise<number[]> {
  return s.page.evaluate(
    async ({ cell, headings, mode, rendering, firstArrival }) => {
      const out: number[] = [];
      for (const h of headings) {
        const base = { cells: [cell], headingDeg: h, rendering, signal: firstArrival ? ('clicks' as const) : ('noise' as const), seconds: firstArrival ? 0.1 : 1 };
        const b = await window.sonolux.renderOffline!({ ...base, mode });
        const L = b.getChannelData(0);
        const R = b.getChannelData(1);
        let i0 = 0;
        let i1 = L.length;
        if (firstArrival) {
          const d = await window.sonolux.renderOffline!({ ...base, mode: 'direct' });
          const dl = d.getChannelData(0);
          const dr = d.getChannelData(1);
          let peak = 0;
          for (let i = 0; i < dl.length; i++) peak = Math.max(peak, Math.abs(dl[i]) + Math.abs(dr[i]));
          while (Math.abs(dl[i0]) + Math.abs(dr[i0]) < 0.1 * peak) i0++;
          i1 = i0 + Math.round(0.002 * b.sampleRate);
        }
        let el = 0;
        let er = 0;
        for (let i = i0; i < i1; i++) {
          el += L[i] * L[i];
          er += R[i] * R[i];
        }
        out.push(10 * Math.log10(el / er));
      }
      return out;
    },
    { cell: CELL, headings: HEADINGS, mode, rendering, firstArrival },
  );
}

/** The source is at world azimuth 0; at heading h it is at −h: left of the head (louder
 * left ear) for h in (180, 360), right for h in (0, 180), centred at 0 and 180. */
function expectFollowsHeading(ild: number[], atLeast: number) {
  HEADINGS.forEach((h, k) => {
    const side = Math.sin((-h * Math.PI) / 180);
    if (Math.abs(side) < 1e-9) expect(Math.abs(ild[k]), `heading ${h}: centred`).toBeLessThan(1.5);
    else if (side > 0) expect(ild[k], `heading ${h}: the left ear`).toBeGreaterThan(atLeast * Math.abs(side));
    else expect(ild[k], `heading ${h}: the right ear`).toBeLessThan(-atLeast * Math.abs(side));
  });
}

describe('turning the head', () => {
  for (const rendering of ['hrtf', 'cube'] as const) {
    test(`${rendering}: the direct sound moves from one ear to the other`, async () => {
      const ild = await levels('direct', rendering, false);
      console.log(`${rendering}, direct only, L-R dB by heading ${HEADINGS.join('/')}: ${ild.map((v) => v.toFixed(1)).join(' ')}`);
      expectFollowsHeading(ild, 2.5);
    });

    test(`${rendering}: in the full field, the first arrival does too`, async () => {
      const ild = await levels('full', rendering, true);
      console.log(`${rendering}, full field, first arrival, L-R dB: ${ild.map((v) => v.toFixed(1)).join(' ')}`);
      expectFollowsHeading(ild, 2);
    });
  }
});

describe('cell changes', () => {
  test('the equal-power cross-fade has no discontinuity', async () => {
    const r = await s.page.evaluate(async () => {
      // A steady 200 Hz sine: once the responses have filled (about 1.1 s), each cell's output
      // is a steady sine too, so any jump stands out against its sample-to-sample slope.
      const fs = window.sonolux.index!.sampleRateHz;
      const base = { signal: 'sine' as const, sineHz: 200, seconds: 2.3, headingDeg: 30 };
      const A = (await window.sonolux.renderOffline!({ ...base, cells: [5] })).getChannelData(0);
      const B = (await window.sonolux.renderOffline!({ ...base, cells: [6] })).getChannelData(0);
      const X = (await window.sonolux.renderOffline!({ ...base, cells: [5, 6], switchAtS: [1.5] })).getChannelData(0);
      // Changing one's mind half way: back to cell 5 at 1.6 s.
      const Y = (await window.sonolux.renderOffline!({ ...base, cells: [5, 6, 5], switchAtS: [1.5, 1.6] })).getChannelData(0);
      const slope = (x: Float32Array, t0: number, t1: number) => {
        let m = 0;
        for (let i = Math.round(t0 * fs); i < Math.round(t1 * fs); i++) m = Math.max(m, Math.abs(x[i + 1] - x[i]));
        return m;
      };
      const steady = Math.max(slope(A, 1.2, 2.2), slope(B, 1.2, 2.2));
      const ts = Math.round(1.5 * fs);
      // Equal power: during the fade the output is cos·A + sin·B (the graph is linear), the
      // gains seen through the panners' latency, which is found here as the best fit.
      let misfit = Infinity;
      let latency = 0;
      let peak = 0;
      for (let i = ts; i < ts + Math.round(0.3 * fs); i++) peak = Math.max(peak, Math.abs(X[i]));
      for (let lag = 0; lag <= 1024; lag += 1) {
        let m = 0;
        for (let i = ts; i < ts + Math.round(0.3 * fs) && m < misfit; i += 1) {
          const u = Math.min(Math.max((i - lag - ts) / fs / 0.25, 0), 1) * (Math.PI / 2);
          m = Math.max(m, Math.abs(X[i] - (Math.cos(u) * A[i] + Math.sin(u) * B[i])));
        }
        if (m < misfit) [misfit, latency] = [m, lag];
      }
      return {
        steady,
        fade: slope(X, 1.4, 2.0),
        reversed: slope(Y, 1.4, 2.0),
        hardJump: Math.abs(A[ts] - B[ts]),
        misfit,
        peak,
        latency,
      };
    });
    console.log(`cross-fade: steady slope ${r.steady.toExponential(2)}, during the fade ${r.fade.toExponential(2)}, reversed ${r.reversed.toExponential(2)}, a hard switch would jump ${r.hardJump.toExponential(2)}; output = cos·A + sin·B to ${((100 * r.misfit) / r.peak).toFixed(3)}% of the peak, panner latency ${r.latency} samples`);
    // cos·a + sin·b with |a'|, |b'| ≤ m has a slope of at most √2·m (plus the gains' own slope).
    expect(r.fade).toBeLessThan(1.5 * r.steady);
    expect(r.reversed).toBeLessThan(1.5 * r.steady);
    // The test can see a click: switching without a fade would jump several slopes.
    expect(r.hardJump).toBeGreaterThan(4 * r.steady);
    expect(r.misfit).toBeLessThan(0.005 * r.peak);
  });
});

describe('the toggles', () => {
  test('direct only keeps the direct sound and drops the reverberation', async () => {
    const r = await s.page.evaluate(async () => {
      const fs = window.sonolux.index!.sampleRateHz;
      const render = async (mode: 'full' | 'direct') => (await window.sonolux.renderOffline!({ cells: [5], mode, signal: 'clicks', seconds: 0.45 })).getChannelData(0);
      const full = await render('full');
      const direct = await render('direct');
      let peak = 0;
      for (const v of direct) peak = Math.max(peak, Math.abs(v));
      let t0 = 0;
      while (Math.abs(direct[t0]) < 0.1 * peak) t0++;
      // The direct sound, up to the first reflection (the ceiling, 0.69 ms later at 2 m).
      const [e0, e1] = [t0 - Math.round(0.0005 * fs), t0 + Math.round(0.0006 * fs)];
      const energy = (x: Float32Array, a: number, b: number) => {
        let e = 0;
        for (let i = a; i < b; i++) e += x[i] * x[i];
        return e;
      };
      const late = t0 + Math.round(0.01 * fs);
      return { fullEarly: energy(full, e0, e1), directEarly: energy(direct, e0, e1), fullLate: energy(full, late, full.length), directLate: energy(direct, late, full.length) };
    });
    console.log(`direct only: direct sound ${(10 * Math.log10(r.directEarly / r.fullEarly)).toFixed(2)} dB of the full field's; after it ${(10 * Math.log10(r.directLate / r.fullLate)).toFixed(1)} dB`);
    expect(Math.abs(10 * Math.log10(r.directEarly / r.fullEarly))).toBeLessThan(1.5);
    expect(r.directLate).toBeLessThan(1e-4 * r.fullLate);
    expect(r.fullLate).toBeGreaterThan(r.fullEarly); // a reverberant room: most energy comes later
  });
});
