/**
 * Chromium for the tests: Debian's /usr/bin/chromium (or $CHROMIUM), driven by playwright-core
 * from web/node_modules, never a downloaded browser. Flags from shared/NOTES.md: SwiftShader
 * for WebGL 2, no background networking on this machine's closed network.
 */
import { mkdtempSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

const require = createRequire(new URL('../../../web/package.json', import.meta.url));
// eslint-disable-next-line @typescript-eslint/no-require-imports
const { chromium } = require('playwright-core') as typeof import('playwright-core');
type BrowserContext = import('playwright-core').BrowserContext;
export type Page = import('playwright-core').Page;

export const FLAGS = [
  '--headless',
  '--no-sandbox',
  '--disable-gpu',
  '--disable-quic',
  '--no-first-run',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-sync',
  '--enable-unsafe-swiftshader',
  '--use-angle=swiftshader',
  '--autoplay-policy=no-user-gesture-required',
];

export interface Session {
  ctx: BrowserContext;
  page: Page;
  errors: string[];
  close: () => Promise<void>;
}

export async function launch(options: { width?: number; height?: number; touch?: boolean } = {}): Promise<Session> {
  const profile = mkdtempSync(join(tmpdir(), 'sonolux-chromium-'));
  const ctx = await chromium.launchPersistentContext(profile, {
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    headless: true,
    args: FLAGS,
    viewport: { width: options.width ?? 480, height: options.height ?? 320 },
    hasTouch: options.touch ?? false,
  });
  const page = ctx.pages()[0] ?? (await ctx.newPage());
  const errors: string[] = [];
  page.on('pageerror', (e) => errors.push(e.message));
  return {
    ctx,
    page,
    errors,
    close: async () => {
      await ctx.close();
      rmSync(profile, { recursive: true, force: true });
    },
  };
}

/** Opens the viewer and waits until it is walking (or has shown an error). */
export async function open(page: Page, url: string, timeoutMs = 60_000): Promise<void> {
  await page.goto(url);
  await page.waitForFunction(() => window.sonolux?.ready || !document.getElementById('error')?.hidden, null, { timeout: timeoutMs });
  const error = await page.evaluate(() => (document.getElementById('error')?.hidden ? null : document.getElementById('error')?.textContent));
  if (error) throw new Error(`the page shows an error: ${error}`);
  await waitFrames(page, 3);
}

export async function waitFrames(page: Page, n: number): Promise<void> {
  const start = await page.evaluate(() => (window.sonolux.state!() as { frameCount: number }).frameCount);
  await page.waitForFunction((s) => (window.sonolux.state!() as { frameCount: number }).frameCount >= s, start + n, { timeout: 60_000 });
}

/** Decodes a PNG (a screenshot) in the page: width, height and RGBA bytes as a plain array. */
export async function pixels(page: Page, png: Buffer): Promise<{ width: number; height: number; rgba: number[] }> {
  return page.evaluate(async (b64) => {
    const img = new Image();
    img.src = `data:image/png;base64,${b64}`;
    await img.decode();
    const c = document.createElement('canvas');
    c.width = img.width;
    c.height = img.height;
    const g = c.getContext('2d')!;
    g.drawImage(img, 0, 0);
    return { width: c.width, height: c.height, rgba: Array.from(g.getImageData(0, 0, c.width, c.height).data) };
  }, png.toString('base64'));
}

export function luminanceAt(p: { width: number; rgba: number[] }, x: number, y: number): number {
  const i = 4 * (Math.round(y) * p.width + Math.round(x));
  return 0.2126 * p.rgba[i] + 0.7152 * p.rgba[i + 1] + 0.0722 * p.rgba[i + 2];
}
