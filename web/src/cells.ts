/**
 * Which cell the listener is in: the receiver nearest in plan (the field's own rule, as
 * SoundField.cell_at), with a little hysteresis so that standing on a boundary does not flip
 * between two cells; and which cell the listener is about to enter, to prepare it ahead.
 */
import type { Vec3 } from './coords';

export const HYSTERESIS_M = 0.05;
export const LOOKAHEAD_S = 0.6;

export class CellGrid {
  readonly x: Float64Array;
  readonly y: Float64Array;
  /** Farther than this from every receiver is outside the field (one cell's half diagonal). */
  readonly reachM: number;
  readonly spacingM: number;

  constructor(positions: Readonly<Vec3>[], spacingM: number | null, radiusM: number) {
    this.x = Float64Array.from(positions, (p) => p[0]);
    this.y = Float64Array.from(positions, (p) => p[1]);
    this.spacingM = spacingM ?? 2 * radiusM;
    this.reachM = this.spacingM * (Math.SQRT2 / 2) + 1e-9;
  }

  get size(): number {
    return this.x.length;
  }

  distance(cell: number, x: number, y: number): number {
    return Math.hypot(this.x[cell] - x, this.y[cell] - y);
  }

  /** The nearest receiver in plan (the lowest index among equals). */
  nearest(x: number, y: number, except = -1): number {
    let best = -1;
    let bestD = Infinity;
    for (let i = 0; i < this.x.length; i++) {
      if (i === except) continue;
      const d = (this.x[i] - x) ** 2 + (this.y[i] - y) ** 2;
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    }
    return best;
  }

  inside(x: number, y: number): boolean {
    return this.distance(this.nearest(x, y), x, y) <= this.reachM;
  }

  /** The cell to use at (x, y) when `current` was used until now: the nearest, unless the
   * current one is within HYSTERESIS_M of being as near. */
  choose(current: number, x: number, y: number, hysteresisM = HYSTERESIS_M): number {
    const n = this.nearest(x, y);
    if (current < 0 || current >= this.size || n === current) return n;
    return this.distance(current, x, y) <= this.distance(n, x, y) + hysteresisM ? current : n;
  }

  /** The cell the listener will most likely enter next: where the motion leads within
   * LOOKAHEAD_S, or else the nearest other cell (across the nearest boundary). */
  predict(x: number, y: number, vx: number, vy: number, current: number, lookaheadS = LOOKAHEAD_S): number {
    const ahead = this.nearest(x + vx * lookaheadS, y + vy * lookaheadS);
    if (ahead !== current) return ahead;
    return this.nearest(x, y, current);
  }

  /** Cells within 1.5 spacings of this one, nearest first. */
  neighbours(cell: number): number[] {
    const out: [number, number][] = [];
    for (let i = 0; i < this.x.length; i++) {
      const d = this.distance(i, this.x[cell], this.y[cell]);
      if (i !== cell && d <= 1.5 * this.spacingM + 1e-9) out.push([d, i]);
    }
    return out.sort((a, b) => a[0] - b[0] || a[1] - b[1]).map((e) => e[1]);
  }
}
