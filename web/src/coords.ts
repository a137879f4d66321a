/**
 * Axes, in one place.
 *
 * - sonolux (field.json, the listener's state, cells, the plan view): metres, z up; azimuths
 *   and headings are 0° along +x and grow counter-clockwise seen from above (+90° is +y, the
 *   listener's left when facing +x).
 * - three.js and glTF (scene.glb, the camera, raycasts): y up. A sonolux point (x, y, z) is the
 *   three.js point (x, z, −y), a rotation of −90° about x; the exporter writes scene.glb with
 *   the same mapping (sonolux.web.geometry.to_gltf).
 * - Web Audio: the AudioListener keeps its defaults (at the origin, facing −z, +y up, +x to
 *   its right) and never moves; virtual sources are placed around it in this head frame, so
 *   the listener's heading is applied here and not by turning the AudioListener.
 */

export type Vec3 = [number, number, number];

const RAD = Math.PI / 180;

/** A sonolux point or direction in three.js axes. */
export function threeFromSonolux(p: Readonly<Vec3>): Vec3 {
  return [p[0], p[2], -p[1]];
}

/** A three.js point or direction in sonolux axes. */
export function sonoluxFromThree(p: Readonly<Vec3>): Vec3 {
  return [p[0], -p[2], p[1]];
}

/** The angle wrapped into (−180°, 180°]. */
export function wrapDeg(a: number): number {
  const w = ((((a + 180) % 360) + 360) % 360) - 180;
  return w === -180 ? 180 : w;
}

/** A world azimuth (sonolux) as seen by a listener with this heading: 0 ahead, +90 left. */
export function headAzimuthDeg(worldAzimuthDeg: number, headingDeg: number): number {
  return wrapDeg(worldAzimuthDeg - headingDeg);
}

/** The unit vector of a head-relative direction in the Web Audio listener's frame. */
export function webAudioFromHead(azimuthDeg: number, elevationDeg: number): Vec3 {
  const a = azimuthDeg * RAD;
  const e = elevationDeg * RAD;
  return [-Math.sin(a) * Math.cos(e), Math.sin(e), -Math.cos(a) * Math.cos(e)];
}

/** The horizontal unit vector (sonolux x, y) of a heading. */
export function headingVector(headingDeg: number): [number, number] {
  return [Math.cos(headingDeg * RAD), Math.sin(headingDeg * RAD)];
}

/** The heading (sonolux, degrees) of a horizontal vector. */
export function headingOf(x: number, y: number): number {
  return Math.atan2(y, x) / RAD;
}

/**
 * The three.js camera's yaw about +y (radians, rotation order 'YXZ') for a sonolux heading:
 * a camera looks along −z, and a yaw ψ turns that to (−sin ψ, 0, −cos ψ); heading h looks
 * along three's (cos h, 0, −sin h); so ψ = h − 90°.
 */
export function cameraYawRad(headingDeg: number): number {
  return (headingDeg - 90) * RAD;
}

export function radians(deg: number): number {
  return deg * RAD;
}
