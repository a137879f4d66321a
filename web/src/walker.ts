/**
 * The listener: where they stand (sonolux plan coordinates, metres), where they face
 * (heading, degrees, 0 = +x, counter-clockwise; pitch up from the horizon) and how they move.
 * The head is at the field's head height throughout, as in the paper.
 */
import { headingVector } from './coords';

export interface Listener {
  x: number;
  y: number;
  headingDeg: number;
  pitchDeg: number;
  /** Velocity (m/s) of the last step, for predicting the next cell. */
  vx: number;
  vy: number;
}

/** What the controls ask for: each in [−1, 1]. */
export interface MoveIntent {
  forward: number;
  left: number; // strafe, +1 = to the left
  turn: number; // +1 = counter-clockwise (to the left)
  run: boolean;
}

export const WALK_M_S = 1.4;
export const RUN_M_S = 3.0;
export const TURN_DEG_S = 100;
export const MAX_PITCH_DEG = 85;

export type Collide = (fromX: number, fromY: number, toX: number, toY: number) => [number, number];

export function still(): MoveIntent {
  return { forward: 0, left: 0, turn: 0, run: false };
}

/** The listener after dt seconds of this intent, moved as far as the walls allow. */
export function step(l: Listener, intent: MoveIntent, dtS: number, collide: Collide): Listener {
  const headingDeg = l.headingDeg + intent.turn * TURN_DEG_S * dtS;
  const [fx, fy] = headingVector(headingDeg);
  let mx = intent.forward * fx - intent.left * fy;
  let my = intent.forward * fy + intent.left * fx;
  const m = Math.hypot(mx, my);
  if (m > 1) {
    mx /= m;
    my /= m;
  }
  const speed = intent.run ? RUN_M_S : WALK_M_S;
  const [x, y] = m > 0 ? collide(l.x, l.y, l.x + mx * speed * dtS, l.y + my * speed * dtS) : [l.x, l.y];
  const dt = dtS > 0 ? dtS : 1;
  return { x, y, headingDeg: normalizeHeading(headingDeg), pitchDeg: l.pitchDeg, vx: (x - l.x) / dt, vy: (y - l.y) / dt };
}

/** Turns by mouse or touch: degrees to add to heading and pitch (pitch clamped). */
export function look(l: Listener, dHeadingDeg: number, dPitchDeg: number): Listener {
  const pitchDeg = Math.max(-MAX_PITCH_DEG, Math.min(MAX_PITCH_DEG, l.pitchDeg + dPitchDeg));
  return { ...l, headingDeg: normalizeHeading(l.headingDeg + dHeadingDeg), pitchDeg };
}

/** Heading in [0, 360). */
export function normalizeHeading(h: number): number {
  return ((h % 360) + 360) % 360;
}
