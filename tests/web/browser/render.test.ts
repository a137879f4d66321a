/** The picture: the scene renders (not blank), the strip light is bright where it should
 * be, and the plan view shows the source and the listener. */
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { afterAll, beforeAll, describe, expect, inject, test } from 'vitest';
import { launch, luminanceAt, open, pixels, type Session } from './browser';

let s: Session;
beforeAll(async () => {
  s = await launch({ width: 480, height: 320 });
});
afterAll(async () => s?.close());

async function look(url: string, name: string) {
  // From the west end at head height, looking along the room and a little up at the light.
  await open(s.page, `${url}?x=1&y=1.25&heading=0&pitch=20`);
  const png = await s.page.screenshot();
  writeFileSync(join(inject('shots'), `${name}.png`), png);
  const p = await pixels(s.page, png);
  const lum: number[] = [];
  for (let y = 0; y < p.height; y += 2) for (let x = 0; x < p.width; x += 2) lum.push(luminanceAt(p, x, y));
  const mean = lum.reduce((a, v) => a + v, 0) / lum.length;
  const sd = Math.sqrt(lum.reduce((a, v) => a + (v - mean) ** 2, 0) / lum.length);
  // The middle of the strip light (paper-small: x 1.5..4.5, y 1.19..1.31, just under the ceiling).
  const at = await s.page.evaluate(() => window.sonolux.project!(3, 1.25, 1.99));
  return { p, mean, sd, at };
}

describe('the scene', () => {
  for (const kind of ['lit', 'unlit'] as const) {
    test(`${kind}: renders, and the strip light is the brightest thing in view`, async () => {
      const { p, mean, sd, at } = await look(inject(kind === 'lit' ? 'litUrl' : 'unlitUrl'), `scene-${kind}`);
      expect(sd, 'a blank or flat picture').toBeGreaterThan(12);
      expect(mean).toBeGreaterThan(30);
      expect(at, 'the light should be in view').not.toBeNull();
      const [x, y] = at!;
      let light = 0;
      for (let dy = -2; dy <= 2; dy++) for (let dx = -2; dx <= 2; dx++) light += luminanceAt(p, x + dx, y + dy) / 25;
      expect(light).toBeGreaterThan(235);
      expect(light).toBeGreaterThan(mean + 60);
      expect(s.errors).toEqual([]);
    });
  }

  test('the plan view shows the source (red) and the listener (cyan), and follows a turn', async () => {
    await open(s.page, `${inject('litUrl')}?x=1&y=1.25&heading=0`);
    const count = () =>
      s.page.evaluate(() => {
        const c = document.getElementById('plan') as HTMLCanvasElement;
        const d = c.getContext('2d')!.getImageData(0, 0, c.width, c.height).data;
        let red = 0;
        let cyan = 0;
        let cyanX = 0;
        let cyanY = 0;
        for (let i = 0; i < d.length; i += 4) {
          if (d[i] > 200 && d[i + 1] < 120 && d[i + 2] < 120) red++;
          if (d[i] < 160 && d[i + 1] > 200 && d[i + 2] > 200) {
            cyan++;
            cyanX += (i / 4) % c.width;
            cyanY += Math.floor(i / 4 / c.width);
          }
        }
        return { red, cyan, cx: cyanX / cyan, cy: cyanY / cyan, w: c.width, h: c.height };
      });
    const east = await count();
    expect(east.red).toBeGreaterThan(20);
    expect(east.cyan).toBeGreaterThan(20);
    await s.page.evaluate(() => window.sonolux.teleport!({ headingDeg: 90 }));
    await s.page.waitForTimeout(300);
    const north = await count();
    // Facing +x the arrow's pixels lie right of the dot; facing +y (up in the plan) above it.
    expect(north.cy).toBeLessThan(east.cy - 1);
    expect(north.cx).toBeLessThan(east.cx - 1);
  });
});
