import { describe, expect, test } from 'vitest';
import { WALK_M_S, look, step, still, type Listener } from '../src/walker';
import { stickIntent } from '../src/touch';

const free = (_x0: number, _y0: number, x1: number, y1: number): [number, number] => [x1, y1];
const at = (headingDeg: number): Listener => ({ x: 0, y: 0, headingDeg, pitchDeg: 0, vx: 0, vy: 0 });

describe('the listener', () => {
  test('walks along the heading, steps to the left at +90°', () => {
    const a = step(at(90), { ...still(), forward: 1 }, 1, free);
    expect(a.x).toBeCloseTo(0, 12);
    expect(a.y).toBeCloseTo(WALK_M_S, 12);
    const b = step(at(0), { ...still(), left: 1 }, 1, free);
    expect(b.y).toBeCloseTo(WALK_M_S, 12);
    expect(b.vy).toBeCloseTo(WALK_M_S, 12);
  });

  test('diagonals are not faster', () => {
    const a = step(at(0), { ...still(), forward: 1, left: 1 }, 1, free);
    expect(Math.hypot(a.x, a.y)).toBeCloseTo(WALK_M_S, 12);
  });

  test('looking wraps the heading and clamps the pitch', () => {
    const l = look(at(350), 20, 200);
    expect(l.headingDeg).toBeCloseTo(10, 12);
    expect(l.pitchDeg).toBe(85);
  });

  test('the touch joystick: up walks, left steps left, within its radius', () => {
    expect(stickIntent(0, -60).forward).toBeCloseTo(1, 12);
    expect(stickIntent(-60, 0).left).toBeCloseTo(1, 12);
    expect(stickIntent(0, -600).forward).toBeCloseTo(1, 12);
    expect(stickIntent(2, 2).forward).toBe(-0); // the dead zone
  });
});
