/**
 * Equal-power cross-fades. A voice's level is sin θ with θ in [0, π/2]; a fade moves θ at a
 * constant rate (π/2 per FADE_S), so a voice fading in from 0 while another fades out from
 * π/2 keeps sin² + cos² = 1: constant power for uncorrelated signals (the cells' responses are
 * synthesized with different seeds). A fade that starts mid-way starts from where θ is, so
 * a change of mind (the listener turns back) never jumps.
 */
export const FADE_S = 0.25;
const HALF_PI = Math.PI / 2;

export interface Fade {
  t0: number;
  theta0: number;
  t1: number;
  theta1: number;
}

export function still(theta: number, t = 0): Fade {
  return { t0: t, theta0: theta, t1: t, theta1: theta };
}

export function thetaAt(f: Fade, t: number): number {
  if (t <= f.t0 || f.t1 <= f.t0) return t >= f.t1 ? f.theta1 : f.theta0;
  if (t >= f.t1) return f.theta1;
  return f.theta0 + ((f.theta1 - f.theta0) * (t - f.t0)) / (f.t1 - f.t0);
}

export function gainAt(f: Fade, t: number): number {
  return Math.sin(thetaAt(f, t));
}

/** A fade from wherever `f` is at time `t` to `target` (0: silent, π/2: full). */
export function fadeTo(f: Fade, t: number, target: number, fadeS = FADE_S): Fade {
  const theta0 = thetaAt(f, t);
  const duration = (Math.abs(target - theta0) / HALF_PI) * fadeS;
  return { t0: t, theta0, t1: t + duration, theta1: target };
}

/** The gains of a fade at n evenly spaced times from t0 to t1 (for setValueCurveAtTime). */
export function fadeCurve(f: Fade, n = 256): Float32Array {
  const c = new Float32Array(Math.max(2, n));
  for (let i = 0; i < c.length; i++) {
    c[i] = Math.sin(f.theta0 + ((f.theta1 - f.theta0) * i) / (c.length - 1));
  }
  return c;
}

export const FULL = HALF_PI;
export const SILENT = 0;
