import { describe, expect, test } from 'vitest';
import { BODY_RADIUS_M, sectionAt, sectionCaster, slide, type CastRay, type Room } from '../src/collide';

const room: Room = { min: [0, 0], max: [6, 2.5], heights: [1.5] };

/** A wall along x = 3 from y = 0 to y = 1 (an obstacle inside the room), as rays see it. */
const wall: CastRay = (x, y, _z, dx, dy, far) => {
  if (Math.abs(dx) < 1e-12) return null;
  const t = (3 - x) / dx;
  if (t < 0 || t > far) return null;
  const yy = y + t * dy;
  if (yy < 0 || yy > 1) return null;
  return { distance: t, nx: dx > 0 ? -1 : 1, ny: 0 };
};

describe('walking into walls', () => {
  test('the room bounds hold the body inside', () => {
    expect(slide(room, null, 1, 1, -5, 1)).toEqual([BODY_RADIUS_M, 1]);
    expect(slide(room, null, 5, 2, 9, 9)).toEqual([6 - BODY_RADIUS_M, 2.5 - BODY_RADIUS_M]);
  });

  test('a wall found by a ray stops the body one radius before it', () => {
    const [x, y] = slide(room, wall, 2, 0.5, 3.5, 0.5);
    expect(x).toBeCloseTo(3 - BODY_RADIUS_M, 12);
    expect(y).toBe(0.5);
  });

  test('walking at a slant slides along the wall', () => {
    const [x, y] = slide(room, wall, 2.5, 0.5, 3.0, 0.9);
    expect(x).toBeCloseTo(2.75, 12);
    expect(y).toBeGreaterThan(0.5);
  });

  test('past the end of the wall nothing is in the way', () => {
    expect(slide(room, wall, 2, 1.8, 4, 1.8)).toEqual([4, 1.8]);
  });
});

describe('cross-sections of the geometry', () => {
  // A wall: the rectangle x = 3, y in [0, 1], z in [0, 2], as two triangles.
  const wallTris = [3, 0, 0, 3, 1, 0, 3, 1, 2, 3, 0, 0, 3, 1, 2, 3, 0, 2];
  // The floor, which a horizontal cut never meets.
  const floor = [0, 0, 0, 6, 0, 0, 6, 2.5, 0];

  test('a cut at height z gives the wall as segments in the plan', () => {
    const s = sectionAt([...wallTris, ...floor], 1.5);
    expect(s.length).toBe(8); // two segments, one per triangle
    for (let i = 0; i < s.length; i += 4) {
      expect(s[i]).toBeCloseTo(3, 12);
      expect(s[i + 2]).toBeCloseTo(3, 12);
    }
  });

  test('rays against the sections: distance and a normal facing the ray', () => {
    const cast = sectionCaster([{ z: 1.5, segments: sectionAt(wallTris, 1.5) }]);
    const hit = cast(2, 0.5, 1.5, 1, 0, 5)!;
    expect(hit.distance).toBeCloseTo(1, 12);
    expect(hit.nx).toBeCloseTo(-1, 12);
    const back = cast(4, 0.5, 1.5, -1, 0, 5)!;
    expect(back.nx).toBeCloseTo(1, 12);
    expect(cast(2, 1.5, 1.5, 1, 0, 5)).toBeNull(); // past the wall's end
    expect(cast(2, 0.5, 1.5, 1, 0, 0.5)).toBeNull(); // too far
    const [x] = slide(room, cast, 2, 0.5, 4, 0.5);
    expect(x).toBeCloseTo(3 - BODY_RADIUS_M, 12);
  });
});
