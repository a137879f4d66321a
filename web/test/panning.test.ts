import { describe, expect, test } from 'vitest';
import { CUBE_ELEVATION_DEG, CUBE_SPEAKERS, cubeGains, pairGains } from '../src/panning';

const power = (g: number[]) => g.reduce((s, v) => s + v * v, 0);

describe('pairwise panning (2-D VBAP)', () => {
  test('on a speaker: all of it there; half way: equal gains; unit power throughout', () => {
    expect(pairGains(0, 0, 90)).toEqual([1, 0]);
    const [a, b] = pairGains(45, 0, 90);
    expect(a).toBeCloseTo(Math.SQRT1_2, 12);
    expect(b).toBeCloseTo(Math.SQRT1_2, 12);
    for (let t = 0; t <= 90; t += 7.5) expect(power(pairGains(t, 0, 90))).toBeCloseTo(1, 12);
  });

  test('the gain vector points at the source (VBAP: g·L ∝ p)', () => {
    const t = 20;
    const [ga, gb] = pairGains(t, 0, 90);
    expect(Math.atan2(gb, ga) * (180 / Math.PI)).toBeCloseTo(t, 10);
  });
});

describe('the cube of 8 speakers', () => {
  test('corners at ±45°, ±135° and ±35.26° elevation', () => {
    expect(CUBE_ELEVATION_DEG).toBeCloseTo(35.2644, 4);
    expect(CUBE_SPEAKERS).toHaveLength(8);
  });

  test('a level source between two columns: four speakers, upper and lower alike', () => {
    const g = cubeGains(0, 0); // straight ahead: front-left and front-right columns
    expect(power(g)).toBeCloseTo(1, 12);
    expect(g[0]).toBeCloseTo(0.5, 12); // upper front-left
    expect(g[3]).toBeCloseTo(0.5, 12); // upper front-right
    expect(g[4]).toBeCloseTo(0.5, 12);
    expect(g[7]).toBeCloseTo(0.5, 12);
    expect(g[1] + g[2] + g[5] + g[6]).toBe(0);
  });

  test('to the left (+90°): the left columns only', () => {
    const g = cubeGains(90, 0);
    expect(g[0]).toBeCloseTo(0.5, 12);
    expect(g[1]).toBeCloseTo(0.5, 12);
    expect(g[2] + g[3]).toBe(0);
  });

  test('behind, wrapping round ±180°', () => {
    for (const az of [180, -180, 179, -179]) {
      const g = cubeGains(az, 0);
      expect(power(g)).toBeCloseTo(1, 12);
      expect(g[1] + g[2]).toBeGreaterThan(0.99); // back-left and back-right, upper
    }
  });

  test('unit power for every direction, above and below too', () => {
    for (let az = -180; az <= 180; az += 15) for (const el of [-60, -20, 0, 30, 80]) expect(power(cubeGains(az, el))).toBeCloseTo(1, 12);
  });
});
