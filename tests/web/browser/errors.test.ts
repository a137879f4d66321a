/** Missing or broken bundle files are shown on the page, naming the file, never a blank page.
 * The files are broken on the way with Playwright's request routing. */
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { afterEach, beforeEach, describe, expect, inject, test } from 'vitest';
import { launch, open, type Session } from './browser';

type Route = import('playwright-core').Route;

let s: Session;
beforeEach(async () => {
  s = await launch();
});
// Routes still in flight when a test ends (the page keeps fetching after its assertions) would
// reject once the browser closes; Playwright's advice is to drop them first, ignoring their errors.
afterEach(async () => {
  await s?.page.unrouteAll({ behavior: 'ignoreErrors' });
  await s?.close();
});

async function shownError(path: string, handler: (r: Route) => Promise<void>, startSound = false): Promise<string> {
  await s.page.route(`**/bundle/${path}`, handler);
  await s.page.goto(inject('litUrl'));
  if (startSound) await s.page.waitForFunction(() => window.sonolux?.ready || !document.getElementById('error')!.hidden);
  await s.page.waitForSelector('#error:not([hidden])', { timeout: 30_000 });
  return (await s.page.textContent('#error')) ?? '';
}

describe('a broken bundle is shown, not a blank page', () => {
  test('field.json missing', async () => {
    const text = await shownError('field.json', (r) => r.fulfill({ status: 404, body: 'nothing here' }));
    expect(text).toContain('field.json');
    expect(text).toContain('HTTP 404');
    writeFileSync(join(inject('shots'), 'error-missing-index.png'), await s.page.screenshot());
  });

  test('field.json not JSON', async () => {
    const text = await shownError('field.json', (r) => r.fulfill({ status: 200, body: '{"format": "sonolux-web/1", "cells": [' }));
    expect(text).toContain('not valid JSON');
  });

  test('field.json from another version', async () => {
    const text = await shownError('field.json', async (r) => {
      const j = await (await r.fetch()).json();
      j.format = 'sonolux-web/9';
      await r.fulfill({ status: 200, body: JSON.stringify(j) });
    });
    expect(text).toContain('sonolux-web/9');
  });

  test('field.json with a cell past the end of responses.bin', async () => {
    const text = await shownError('field.json', async (r) => {
      const j = await (await r.fetch()).json();
      j.cells[3].byte_length += j.responses_bytes;
      await r.fulfill({ status: 200, body: JSON.stringify(j) });
    });
    expect(text).toContain('cells[3]');
  });

  test('scene.glb missing, or not glTF', async () => {
    expect(await shownError('scene.glb', (r) => r.fulfill({ status: 404 }))).toContain('scene.glb');
    await s.page.unrouteAll();
    const text = await shownError('scene.glb', (r) => r.fulfill({ status: 200, body: Buffer.from('glTF but not really') }));
    expect(text).toContain('scene.glb');
    expect(text).toContain('glTF');
  });

  test('responses.bin missing', async () => {
    const text = await shownError('responses.bin', (r) => r.fulfill({ status: 404 }));
    expect(text).toContain('responses.bin');
    expect(text).toContain('HTTP 404');
  });

  test('responses.bin cut short', async () => {
    const text = await shownError('responses.bin', (r) => r.fulfill({ status: 200, body: Buffer.alloc(1000) }));
    expect(text).toContain('responses.bin');
    expect(text).toContain('re-export');
  });

  test('responses.bin with a flipped byte', async () => {
    const text = await shownError('responses.bin', async (r) => {
      const res = await r.fetch();
      const body = Buffer.from(await res.body());
      body[Math.floor(body.length / 2)] ^= 0x40;
      await r.fulfill({ response: res, body });
    });
    expect(text).toContain('CRC-32');
  });
});

test('a server without byte ranges (the whole file at once) works too', async () => {
  let whole = 0;
  await s.page.route('**/bundle/responses.bin', async (r) => {
    const headers = { ...r.request().headers() };
    delete headers.range;
    const res = await r.fetch({ headers });
    whole++;
    await r.fulfill({ status: 200, body: await res.body(), headers: { 'content-type': 'application/octet-stream' } });
  });
  await open(s.page, inject('litUrl'));
  await s.page.waitForFunction(() => (window.sonolux.app!.store as unknown as { whole: ArrayBuffer | null }).whole !== null, null, { timeout: 30_000 });
  expect(whole).toBeGreaterThanOrEqual(1);
  expect(await s.page.isHidden('#error')).toBe(true);
});
