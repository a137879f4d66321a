/**
 * Where the direction bands play from. Each band is the paper's virtual source: on the unit
 * sphere at the band's azimuth and elevation, turned by the listener's heading. It is either
 * given to its own HRTF panner ("hrtf"), or, as in the paper's playback room, panned into a
 * cube of 8 loudspeakers around the head ("cube"), each speaker then an HRTF panner at its
 * corner. The panning is pairwise (2-D VBAP, Pulkki 1997) in azimuth between the two corner
 * columns either side, times pairwise between the upper and lower corner in elevation; the
 * gains of one band have unit power.
 */
import { wrapDeg } from './coords';

/** Elevation of a cube's corners seen from its centre: atan(1/√2). */
export const CUBE_ELEVATION_DEG = (Math.atan(1 / Math.SQRT2) * 180) / Math.PI;

export interface Speaker {
  azimuthDeg: number; // head-relative: 0 ahead, +90 left
  elevationDeg: number;
}

/** The cube's corners: the upper four (front-left, back-left, back-right, front-right), then the lower four. */
export const CUBE_SPEAKERS: readonly Speaker[] = [CUBE_ELEVATION_DEG, -CUBE_ELEVATION_DEG].flatMap((el) =>
  [45, 135, -135, -45].map((az) => ({ azimuthDeg: az, elevationDeg: el })),
);

const RAD = Math.PI / 180;

/** 2-D VBAP gains (unit power) of a source at angle `a` between speakers at `lo` < `hi`
 * (degrees, hi − lo < 180), `a` clamped into [lo, hi]. */
export function pairGains(a: number, lo: number, hi: number): [number, number] {
  const t = Math.min(Math.max(a, lo), hi);
  const s = Math.sin((hi - lo) * RAD);
  let gLo = Math.sin((hi - t) * RAD) / s;
  let gHi = Math.sin((t - lo) * RAD) / s;
  const n = Math.hypot(gLo, gHi);
  gLo /= n;
  gHi /= n;
  return [gLo, gHi];
}

/** The 8 speaker gains (CUBE_SPEAKERS order) of a head-relative direction. */
export function cubeGains(azimuthDeg: number, elevationDeg: number): number[] {
  // The azimuth column pair: corners sit at 45 + 90k degrees.
  const a = wrapDeg(azimuthDeg);
  const k = Math.floor((a - 45) / 90); // the corner at or below a, as 45 + 90k
  const lo = 45 + 90 * k;
  const [gLo, gHi] = pairGains(a, lo, lo + 90);
  const [gDown, gUp] = pairGains(elevationDeg, -CUBE_ELEVATION_DEG, CUBE_ELEVATION_DEG);
  const g = new Array<number>(8).fill(0);
  const column = (deg: number) => CUBE_SPEAKERS.findIndex((s) => Math.abs(wrapDeg(s.azimuthDeg - deg)) < 1e-6);
  const cLo = column(lo);
  const cHi = column(lo + 90);
  g[cLo] += gLo * gUp;
  g[cHi] += gHi * gUp;
  g[cLo + 4] += gLo * gDown;
  g[cHi + 4] += gHi * gDown;
  return g;
}
