import { describe, expect, test } from 'vitest';
import { FADE_S, FULL, SILENT, fadeCurve, fadeTo, gainAt, still, thetaAt } from '../src/crossfade';

describe('equal-power cross-fade', () => {
  test('two voices fading together keep unit power at every instant', () => {
    const out = fadeTo(still(FULL), 1, SILENT);
    const inn = fadeTo(still(SILENT), 1, FULL);
    for (let t = 0.9; t <= 1.4; t += 0.01) expect(gainAt(out, t) ** 2 + gainAt(inn, t) ** 2).toBeCloseTo(1, 12);
    expect(gainAt(inn, 1 + FADE_S)).toBe(1);
    expect(gainAt(out, 1 + FADE_S)).toBe(0);
  });

  test('the gains are continuous: no step bigger than the slope allows', () => {
    const f = fadeTo(still(SILENT), 0, FULL);
    const dt = 1e-4;
    let maxStep = 0;
    for (let t = -0.01; t < FADE_S + 0.01; t += dt) maxStep = Math.max(maxStep, Math.abs(gainAt(f, t + dt) - gainAt(f, t)));
    expect(maxStep).toBeLessThanOrEqual((Math.PI / 2 / FADE_S) * dt * 1.0001);
  });

  test('a fade reversed half way starts from where it was, at the same rate', () => {
    const f = fadeTo(still(SILENT), 0, FULL);
    const mid = FADE_S / 2;
    const back = fadeTo(f, mid, SILENT);
    expect(back.theta0).toBeCloseTo(thetaAt(f, mid), 12);
    expect(back.t1 - back.t0).toBeCloseTo(FADE_S / 2, 12);
  });

  test('the automation curve starts and ends where the fade does', () => {
    const f = fadeTo(still(0.3), 2, FULL);
    const c = fadeCurve(f, 100);
    expect(c[0]).toBeCloseTo(Math.sin(0.3), 6);
    expect(c[99]).toBeCloseTo(1, 6);
    for (let i = 1; i < c.length; i++) expect(c[i]).toBeGreaterThanOrEqual(c[i - 1]);
  });
});
