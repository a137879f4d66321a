import { describe, expect, test } from 'vitest';
import { CellGrid } from '../src/cells';
import type { Vec3 } from '../src/coords';

// paper-small's grid: 5 × 3 receivers, 1 m apart, x = 1..5, y = 0.25, 1.25, 2.25.
const positions: Vec3[] = [];
for (const y of [0.25, 1.25, 2.25]) for (const x of [1, 2, 3, 4, 5]) positions.push([x, y, 1.5]);
const grid = new CellGrid(positions, 1, 0.25);

describe('cell lookup', () => {
  test('the nearest receiver in plan, as SoundField.cell_at', () => {
    expect(grid.nearest(1, 0.25)).toBe(0);
    expect(grid.nearest(3.4, 1.3)).toBe(7);
    expect(grid.nearest(3.6, 1.3)).toBe(8);
    expect(grid.nearest(5.4, 2.4)).toBe(14);
  });

  test('outside the field is farther than half a cell diagonal', () => {
    expect(grid.inside(3, 1.25)).toBe(true);
    expect(grid.inside(5.45, 2.7)).toBe(true);
    expect(grid.inside(6.0, 3.0)).toBe(false);
  });

  test('hysteresis keeps the current cell at the boundary, not beyond it', () => {
    expect(grid.choose(7, 3.52, 1.25)).toBe(7); // 2 cm past the boundary
    expect(grid.choose(7, 3.6, 1.25)).toBe(8); // 10 cm past
    expect(grid.choose(8, 3.48, 1.25)).toBe(8);
    expect(grid.choose(-1, 3.48, 1.25)).toBe(7);
  });

  test('the next cell: where the motion leads, else across the nearest boundary', () => {
    expect(grid.predict(3.2, 1.25, 1.4, 0, 7)).toBe(8);
    expect(grid.predict(3.2, 1.25, -1.4, 0, 7)).toBe(6);
    expect(grid.predict(3.0, 1.6, 0, 0, 7)).toBe(12); // standing still, nearer to y = 2.25
  });

  test('neighbours within 1.5 spacings, nearest first', () => {
    expect(grid.neighbours(7)).toEqual([2, 6, 8, 12, 1, 3, 11, 13]);
    expect(grid.neighbours(0)).toEqual([1, 5, 6]);
  });
});
