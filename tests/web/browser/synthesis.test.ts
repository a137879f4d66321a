/**
 * sonolux-web/3: the browser's worker synthesises a cell's responses as the library does.
 * Given the library's own impulses, its response is the library's to rounding; with its own
 * random impulses, its energy per direction and its decay follow the library's. And a bundle
 * of two source fields shows the source mixer, whose gains change what is heard.
 */
import { execFileSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { afterAll, beforeAll, describe, expect, inject, test } from 'vitest';
import { launch, open, type Session } from './browser';

const CELL = 7;

interface Reference {
  length: number;
  parts: { impulses: number[][]; full: number[][] }[];
}

function reference(cell: number): Reference {
  const script = fileURLToPath(new URL('./reference.py', import.meta.url));
  const out = execFileSync(inject('python'), [script, inject('litField'), String(cell)], { maxBuffer: 1 << 30 });
  return JSON.parse(out.toString()) as Reference;
}

function energy(x: number[]): number {
  return x.reduce((a, v) => a + v * v, 0);
}

/** Samples until the energy still to come is 20 dB below the whole (a decay's length). */
function decay20(x: number[]): number {
  const total = energy(x);
  let left = total;
  for (let i = 0; i < x.length; i++) {
    if (left <= 0.01 * total) return i;
    left -= x[i] * x[i];
  }
  return x.length;
}

describe('the worker synthesises the library response', () => {
  let s: Session;
  let ref: Reference;
  beforeAll(async () => {
    ref = reference(CELL);
    s = await launch();
    await open(s.page, inject('litUrl'));
  });
  afterAll(async () => s?.close());

  test('with the library impulses: the same response, to 1e-4 of its peak', async () => {
    const got = await s.page.evaluate(({ cell, imp }) => window.sonolux.synthesise!(cell, imp), { cell: CELL, imp: ref.parts.map((p) => p.impulses) });
    expect(got.length).toBe(ref.parts.length);
    const want = ref.parts[0].full;
    let worstAll = 0;
    for (let d = 0; d < want.length; d++) {
      const a = got[0].full[d];
      const b = want[d];
      expect(a.length, `direction ${d}: length`).toBe(b.length);
      const peak = Math.max(...b.map(Math.abs));
      let worst = 0;
      for (let i = 0; i < b.length; i++) worst = Math.max(worst, Math.abs(a[i] - b[i]));
      // Tolerance: the browser's FFT is a power of two long, the library's the next fast
      // length of the whole axis; the bank's responses keep ~2e-9 of their energy past the
      // padding (synthesis.py, PAD_PERIODS), so the two differ by ~1e-5 of the peak at most;
      // the output is float32 (6e-8 relative).
      expect(worst / peak, `direction ${d}: worst difference / peak`).toBeLessThan(1e-4);
      worstAll = Math.max(worstAll, worst / peak);
    }
    console.log(`cell ${CELL}, ${want.length} directions, ${want[0].length} samples: worker vs library with the same impulses, worst difference ${worstAll.toExponential(2)} of the peak`);
  });

  test('with its own impulses: the energy per direction within 1 dB, the decay within 5 %', async () => {
    const got = await s.page.evaluate((cell) => window.sonolux.synthesise!(cell), CELL);
    const want = ref.parts[0].full;
    let eGot = 0;
    let eWant = 0;
    let worstDb = 0;
    for (let d = 0; d < want.length; d++) {
      const g = energy(got[0].full[d]);
      const w = energy(want[d]);
      eGot += g;
      eWant += w;
      // Each time bin's energy is exact per band in the weighted sequences; what differs is the
      // band split's cross terms over different random impulses: 1 dB (26 %) allows for them
      // in the sparse early part of a quiet direction.
      expect(Math.abs(10 * Math.log10(g / w)), `direction ${d}: energy (dB)`).toBeLessThan(1);
      worstDb = Math.max(worstDb, Math.abs(10 * Math.log10(g / w)));
    }
    expect(Math.abs(10 * Math.log10(eGot / eWant))).toBeLessThan(0.2);
    const sum = (p: number[][]) => p[0].map((_, i) => p.reduce((a, x) => a + (x[i] ?? 0) ** 2, 0));
    const dg = decay20(sum(got[0].full).map(Math.sqrt));
    const dw = decay20(sum(want).map(Math.sqrt));
    expect(Math.abs(dg - dw) / dw).toBeLessThan(0.05);
    console.log(`own impulses: energy per direction within ${worstDb.toFixed(3)} dB (all: ${(10 * Math.log10(eGot / eWant)).toFixed(3)} dB), 20 dB decay ${dg} vs ${dw} samples`);
  });
});

describe('a bundle of two source fields', () => {
  let s: Session;
  beforeAll(async () => {
    s = await launch();
    const dir = inject('twoSources');
    // The bundle is served from its folder (whole files: the viewer then slices the responses).
    await s.page.route('**/two/**', (route) => {
      const name = new URL(route.request().url()).pathname.split('/').pop()!;
      route.fulfill({ status: 200, body: readFileSync(join(dir, name)) });
    });
    await open(s.page, new URL('?bundle=two/', inject('litUrl')).href);
  });
  afterAll(async () => s?.close());

  test('the mixer shows both sources, and their gains set what is heard', async () => {
    const names = await s.page.evaluate(() => [...document.querySelectorAll('#sources label')].map((l) => l.textContent!.trim()));
    expect(names).toEqual(['talker', 'second']);
    const render = (gains: number[]) =>
      s.page.evaluate(async (g) => {
        window.sonolux.setGains!(g);
        const b = await window.sonolux.renderOffline!({ cells: [5], signal: 'noise', seconds: 1 });
        let e = 0;
        for (const ch of [b.getChannelData(0), b.getChannelData(1)]) for (const v of ch) e += v * v;
        return e;
      }, gains);
    const both = await render([1, 1]);
    const first = await render([1, 0]);
    const second = await render([0, 1]);
    // The second field holds half the first's energy: its render a quarter less loud... half:
    // energy 0.5 of the first's within 1 dB (different random fine structure, HRTF panning).
    expect(Math.abs(10 * Math.log10(second / first) - 10 * Math.log10(0.5))).toBeLessThan(1);
    // Uncorrelated sources add in energy: 1.5 × the first's, within 1 dB.
    expect(Math.abs(10 * Math.log10(both / first) - 10 * Math.log10(1.5))).toBeLessThan(1);
    console.log(`mixer: second/first ${(10 * Math.log10(second / first)).toFixed(2)} dB (field: -3.01), both/first ${(10 * Math.log10(both / first)).toFixed(2)} dB (energy sum: +1.76)`);
    expect(s.errors).toEqual([]);
  });
});

describe('an older bundle (sonolux-web/2, the responses themselves)', () => {
  let s: Session;
  beforeAll(async () => {
    s = await launch();
    const dir = inject('pcmBundle');
    await s.page.route('**/pcm/**', (route) => {
      const name = new URL(route.request().url()).pathname.split('/').pop()!;
      route.fulfill({ status: 200, body: readFileSync(join(dir, name)) });
    });
    await open(s.page, new URL('?bundle=pcm/', inject('litUrl')).href);
  });
  afterAll(async () => s?.close());

  test('still reads and plays, without a source mixer', async () => {
    const r = await s.page.evaluate(async () => {
      const b = await window.sonolux.renderOffline!({ cells: [5], signal: 'noise', seconds: 0.5 });
      let e = 0;
      for (const v of b.getChannelData(0)) e += v * v;
      return { format: window.sonolux.index!.format, e, mixer: document.querySelectorAll('#sources').length };
    });
    expect(r.format).toBe('sonolux-web/2');
    expect(r.e).toBeGreaterThan(0);
    expect(r.mixer).toBe(0);
    expect(s.errors).toEqual([]);
  });
});
