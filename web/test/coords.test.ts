import { describe, expect, test } from 'vitest';
import { cameraYawRad, headAzimuthDeg, sonoluxFromThree, threeFromSonolux, webAudioFromHead, wrapDeg } from '../src/coords';

describe('axes', () => {
  test('sonolux z up is three.js y up, and back', () => {
    expect(threeFromSonolux([1, 2, 3])).toEqual([1, 3, -2]);
    expect(sonoluxFromThree(threeFromSonolux([1, 2, 3]))).toEqual([1, 2, 3]);
  });

  test('the mapping is a rotation: it keeps handedness (triangle winding)', () => {
    const [ex, ey, ez] = [threeFromSonolux([1, 0, 0]), threeFromSonolux([0, 1, 0]), threeFromSonolux([0, 0, 1])];
    const cross = [ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2], ex[0] * ey[1] - ex[1] * ey[0]];
    cross.forEach((v, i) => expect(v).toBeCloseTo(ez[i], 12));
  });

  test('the camera looks along the heading', () => {
    for (const h of [0, 45, 90, 180, 270, 333]) {
      const psi = cameraYawRad(h);
      const forwardThree: [number, number, number] = [-Math.sin(psi), 0, -Math.cos(psi)];
      const [x, y, z] = sonoluxFromThree(forwardThree);
      expect(x).toBeCloseTo(Math.cos((h * Math.PI) / 180), 12);
      expect(y).toBeCloseTo(Math.sin((h * Math.PI) / 180), 12);
      expect(z).toBeCloseTo(0, 12);
    }
  });
});

describe('head frame', () => {
  test('azimuths are relative to the heading, wrapped into (-180, 180]', () => {
    expect(headAzimuthDeg(90, 0)).toBe(90); // +y is left when facing +x
    expect(headAzimuthDeg(0, 90)).toBe(-90); // +x is right when facing +y
    expect(headAzimuthDeg(10, 200)).toBe(170);
    expect(wrapDeg(-180)).toBe(180);
    expect(wrapDeg(540)).toBe(180);
  });

  test('Web Audio: ahead is -z, left is -x, up is +y', () => {
    const near = (v: number[], w: number[]) => v.forEach((a, i) => expect(a).toBeCloseTo(w[i], 12));
    near(webAudioFromHead(0, 0), [0, 0, -1]);
    near(webAudioFromHead(90, 0), [-1, 0, 0]);
    near(webAudioFromHead(-90, 0), [1, 0, 0]);
    near(webAudioFromHead(180, 0), [0, 0, 1]);
    near(webAudioFromHead(0, 90), [0, 1, 0]);
  });
});
