/**
 * Walking into walls: the listener is a vertical cylinder (radius BODY_RADIUS_M) that stays
 * inside the room's bounds and slides along whatever a horizontal ray finds in the way (rays
 * at knee, waist and head height, against the scene's triangles). The triangles are cut once,
 * at load, into their cross-sections at those heights; a horizontal ray against the geometry
 * is then a ray against those segments in the plan, exact and cheap (a 3-D ray cast against
 * every triangle each frame cost tens of milliseconds on big meshes).
 */
export const BODY_RADIUS_M = 0.25;

/** The nearest hit of a horizontal ray from (x, y, z) along the unit (dx, dy), within `far`:
 * its distance and the hit surface's plan normal (unit, facing the ray), or null. */
export type CastRay = (x: number, y: number, z: number, dx: number, dy: number, far: number) => { distance: number; nx: number; ny: number } | null;

export interface Room {
  min: [number, number];
  max: [number, number];
  /** Heights of the rays (metres above the floor). */
  heights: number[];
}

function clampToRoom(room: Room, x: number, y: number, r: number): [number, number] {
  const cx = (room.min[0] + room.max[0]) / 2;
  const cy = (room.min[1] + room.max[1]) / 2;
  const lx = room.min[0] + r > room.max[0] - r ? [cx, cx] : [room.min[0] + r, room.max[0] - r];
  const ly = room.min[1] + r > room.max[1] - r ? [cy, cy] : [room.min[1] + r, room.max[1] - r];
  return [Math.min(Math.max(x, lx[0]), lx[1]), Math.min(Math.max(y, ly[0]), ly[1])];
}

/** Where a move from (x0, y0) to (x1, y1) ends: stopped one body radius before a wall and
 * sliding along it with what is left of the move (at most 3 walls in one step). */
export function slide(room: Room, cast: CastRay | null, x0: number, y0: number, x1: number, y1: number, r = BODY_RADIUS_M): [number, number] {
  let x = x0;
  let y = y0;
  let mx = x1 - x0;
  let my = y1 - y0;
  for (let k = 0; k < 3 && cast; k++) {
    const len = Math.hypot(mx, my);
    if (len < 1e-9) break;
    const dx = mx / len;
    const dy = my / len;
    let hit: { distance: number; nx: number; ny: number } | null = null;
    for (const z of room.heights) {
      const h = cast(x, y, z, dx, dy, len + 4 * r);
      if (h && (!hit || h.distance < hit.distance)) hit = h;
    }
    if (!hit) {
      x += mx;
      y += my;
      mx = my = 0;
      break;
    }
    // Go until the body is one radius from the wall (measured square to it, so a slanted
    // approach stops as far away as a head-on one), then slide: drop the part of what is
    // left that goes into the wall (the normal faces the ray, so into the wall is −n).
    const cos = Math.max(1e-3, -(dx * hit.nx + dy * hit.ny));
    const go = Math.max(0, hit.distance - r / cos);
    if (go >= len) {
      x += mx;
      y += my;
      mx = my = 0;
      break;
    }
    x += dx * go;
    y += dy * go;
    const left = len - go;
    const rx = dx * left;
    const ry = dy * left;
    const into = rx * hit.nx + ry * hit.ny;
    mx = rx - (into < 0 ? into * hit.nx : 0);
    my = ry - (into < 0 ? into * hit.ny : 0);
  }
  if (!cast) {
    x += mx;
    y += my;
  }
  return clampToRoom(room, x, y, r);
}

/** The segments (x0, y0, x1, y1 flattened) where triangles (9 numbers each: three corners,
 * sonolux axes) cross the plane at height z. */
export function sectionAt(triangles: ArrayLike<number>, z: number): Float64Array {
  const out: number[] = [];
  for (let t = 0; t + 8 < triangles.length; t += 9) {
    const pts: number[] = [];
    for (let i = 0; i < 3; i++) {
      const a = t + 3 * i;
      const b = t + 3 * ((i + 1) % 3);
      const da = triangles[a + 2] - z;
      const db = triangles[b + 2] - z;
      if (da < 0 !== db < 0) {
        const s = da / (da - db);
        pts.push(triangles[a] + s * (triangles[b] - triangles[a]), triangles[a + 1] + s * (triangles[b + 1] - triangles[a + 1]));
      }
    }
    if (pts.length === 4 && Math.hypot(pts[2] - pts[0], pts[3] - pts[1]) > 1e-9) out.push(...pts);
  }
  return Float64Array.from(out);
}

/** A CastRay against cross-sections: the ray at height z uses the section cut nearest to z. */
export function sectionCaster(sections: { z: number; segments: Float64Array }[]): CastRay {
  return (x, y, z, dx, dy, far) => {
    if (!sections.length) return null;
    const sec = sections.reduce((a, b) => (Math.abs(b.z - z) < Math.abs(a.z - z) ? b : a));
    const s = sec.segments;
    let best: { distance: number; nx: number; ny: number } | null = null;
    for (let i = 0; i < s.length; i += 4) {
      // Solve (x, y) + t (dx, dy) = a + u (b − a), t in [0, far], u in [0, 1].
      const ex = s[i + 2] - s[i];
      const ey = s[i + 3] - s[i + 1];
      const den = dx * ey - dy * ex;
      if (Math.abs(den) < 1e-12) continue; // parallel
      const wx = s[i] - x;
      const wy = s[i + 1] - y;
      const t = (wx * ey - wy * ex) / den;
      const u = (wx * dy - wy * dx) / den;
      if (t < 0 || t > far || u < 0 || u > 1 || (best && t >= best.distance)) continue;
      const len = Math.hypot(ex, ey);
      let nx = -ey / len;
      let ny = ex / len;
      if (nx * dx + ny * dy > 0) [nx, ny] = [-nx, -ny]; // face the ray
      best = { distance: t, nx, ny };
    }
    return best;
  };
}
