/** Walking: keys move the listener across a cell boundary, the sound follows without a
 * stall (the next cell was prepared ahead), walls stop the listener, touch and mouse work. */
import { afterEach, beforeEach, describe, expect, inject, test } from 'vitest';
import { launch, open, waitFrames, type Page, type Session } from './browser';

interface State {
  listener: { x: number; y: number; headingDeg: number; pitchDeg: number };
  cell: number;
  predicted: number;
  frameCount: number;
  audio: null | { state: string; voices: { cell: number; mode: string; ready: boolean; current: boolean }[]; changes: { cell: number }[] };
}

const state = (page: Page) => page.evaluate(() => window.sonolux.state!()) as Promise<State>;

let s: Session;
beforeEach(async () => {
  s = await launch({ width: 480, height: 320, touch: true });
});
afterEach(async () => s?.close());

describe('walking', () => {
  test('across cell boundaries: the cell changes, the sound follows at once, no frame over 50 ms', async () => {
    const page = s.page;
    // paper-small: cell 5 is at (1, 1.25), cell 6 at (2, 1.25); the boundary is x = 1.5.
    await open(page, `${inject('litUrl')}?x=1.2&y=1.25&heading=0`);
    expect((await state(page)).cell).toBe(5);
    await page.evaluate(() => window.sonolux.startSound!());
    // The sound of cell 5 plays, and cell 6 (the nearest other cell) is prepared ahead.
    await page.waitForFunction(() => {
      const a = (window.sonolux.state!() as State).audio;
      return !!a && a.changes.some((c) => c.cell === 5) && a.voices.some((v) => v.cell === 6 && v.ready);
    }, null, { timeout: 90_000, polling: 100 });
    expect((await state(page)).audio!.state).toBe('running');
    const from = await page.evaluate(() => window.sonolux.app!.frames.length);
    await page.keyboard.down('KeyW');
    await page.waitForFunction(() => (window.sonolux.state!() as State).cell === 6, null, { timeout: 30_000, polling: 16 });
    // Heard at once: the voice of cell 6, prepared ahead, fades in in the frame that enters it.
    expect(await page.evaluate(() => window.sonolux.app!.audio!.engine.current!.cell)).toBe(6);
    // Walk on through cells 7 and 8, whose voices are prepared while walking.
    await page.waitForFunction(() => (window.sonolux.state!() as State).cell === 8, null, { timeout: 30_000, polling: 16 });
    await page.keyboard.up('KeyW');
    await page.waitForFunction(() => (window.sonolux.state!() as State).audio!.changes.some((c) => c.cell === 8), null, { timeout: 60_000 });
    await waitFrames(page, 5);
    const after = await state(page);
    expect(after.listener.x).toBeGreaterThan(3.5);
    expect(after.audio!.changes.map((c) => c.cell)).toEqual(expect.arrayContaining([5, 6, 7, 8]));
    // Frame time from the first step to the last cell's fade (ours: moving, sound bookkeeping,
    // convolver tasks, drawing; SwiftShader's drawing in the GPU process is not on this thread).
    const frames = await page.evaluate((n) => window.sonolux.app!.frames.slice(n), from);
    const worst = frames.reduce((m, f) => (f.workMs > m.workMs ? f : m), frames[0]);
    const tasks = frames.reduce((a, f) => a + f.taskMs, 0);
    const intervals = frames.map((f) => f.dtMs).sort((a, b) => a - b);
    console.log(
      `walking through 3 cells: ${frames.length} frames, convolver tasks ${tasks.toFixed(0)} ms in all; worst frame ${worst.workMs.toFixed(1)} ms ` +
        `(moving ${worst.moveMs.toFixed(1)}, sound ${worst.audioMs.toFixed(1)}, tasks ${worst.taskMs.toFixed(1)}, drawing ${worst.drawMs.toFixed(1)}); ` +
        `frame intervals median ${intervals[intervals.length >> 1].toFixed(0)} ms, max ${intervals[intervals.length - 1].toFixed(0)} ms`,
    );
    expect(tasks).toBeGreaterThan(0); // cells were prepared during the walk
    expect(worst.workMs).toBeLessThanOrEqual(50);
    expect(s.errors).toEqual([]);
  });

  test('responses are fetched by position: the start cell and its neighbours, then more on the way', async () => {
    const page = s.page;
    // Every request for responses.bin, as the cells whose blocks its byte range covers.
    const ranges: string[] = [];
    page.on('request', (r) => {
      if (r.url().endsWith('/bundle/responses.bin')) ranges.push(r.headers().range ?? 'whole file');
    });
    await open(page, `${inject('litUrl')}?x=1.2&y=1.25&heading=0`);
    const cells = await page.evaluate(() => window.sonolux.index!.cells.map((c) => ({ first: c.byteOffset, x: c.position[0], y: c.position[1] })));
    const cellOf = (range: string) => {
      const m = /^bytes=(\d+)-(\d+)$/.exec(range);
      expect(m, `a range request, not ${range}`).not.toBeNull();
      return cells.findIndex((c) => c.first === Number(m![1]));
    };
    await page.waitForFunction(() => window.sonolux.app!.store.requested.length >= 1, null, { timeout: 30_000 });
    await waitFrames(page, 10);
    // paper-small: 15 cells 1 m apart; at cell 5, (1, 1.25), only it and the cells within
    // 1.5 m of it (x ≤ 2) are fetched, one range each.
    const atStart = ranges.map(cellOf);
    expect(atStart[0]).toBe(5);
    expect(new Set(atStart).size).toBe(atStart.length);
    for (const c of atStart) expect(Math.hypot(cells[c].x - 1, cells[c].y - 1.25)).toBeLessThanOrEqual(1.5 * 1 + 1e-9);
    expect(atStart.length).toBeLessThan(cells.length / 2);
    // Walking along +x fetches the cells ahead as they come near, each once.
    await page.keyboard.down('ShiftLeft');
    await page.keyboard.down('KeyW');
    await page.waitForFunction(() => window.sonolux.app!.cell === 8, null, { timeout: 30_000, polling: 16 });
    await page.keyboard.up('KeyW');
    await page.keyboard.up('ShiftLeft');
    await waitFrames(page, 10);
    const all = ranges.map(cellOf);
    expect(new Set(all).size).toBe(all.length);
    const later = all.slice(atStart.length);
    expect(later.length).toBeGreaterThan(0);
    for (const c of later) expect(cells[c].x).toBeGreaterThan(2); // new cells, ahead of the start
    expect(later).toContain(8);
    const synthMs = ((await page.evaluate(() => window.sonolux.state!())) as { synthMs: number[] }).synthMs;
    if (synthMs.length) console.log(`the worker synthesised ${synthMs.length} cells, ${Math.min(...synthMs).toFixed(0)}–${Math.max(...synthMs).toFixed(0)} ms each`);
    console.log(`responses fetched: at the start cells ${atStart.join(', ')} of ${cells.length}; walking to cell 8 then cells ${later.join(', ')}`);
    expect(s.errors).toEqual([]);
  });

  test('walls stop the listener one body radius away', async () => {
    const page = s.page;
    await open(page, `${inject('litUrl')}?x=5&y=1.25&heading=0`);
    await page.keyboard.down('ShiftLeft');
    await page.keyboard.down('KeyW');
    await page.waitForTimeout(1500);
    await page.keyboard.up('KeyW');
    await page.keyboard.up('ShiftLeft');
    const l = (await state(page)).listener;
    expect(l.x).toBeGreaterThan(5.6);
    expect(l.x).toBeLessThanOrEqual(6 - 0.25 + 1e-6);
    // Along the wall at a slant: slides, stays inside.
    await page.evaluate(() => window.sonolux.teleport!({ x: 5.5, y: 1.25, headingDeg: 30 }));
    await page.keyboard.down('KeyW');
    await page.waitForTimeout(1500);
    await page.keyboard.up('KeyW');
    const m = (await state(page)).listener;
    expect(m.x).toBeLessThanOrEqual(5.75 + 1e-6);
    expect(m.y).toBeGreaterThan(1.6);
    expect(m.y).toBeLessThanOrEqual(2.25 + 1e-6);
  });

  test('arrow keys turn, the mouse looks around', async () => {
    const page = s.page;
    await open(page, `${inject('litUrl')}?x=2&y=1.25&heading=0`);
    await page.keyboard.down('ArrowLeft');
    await page.waitForTimeout(500);
    await page.keyboard.up('ArrowLeft');
    const turned = (await state(page)).listener.headingDeg;
    expect(turned).toBeGreaterThan(20);
    expect(turned).toBeLessThan(180);
    // Drag with the mouse (pointer lock may be refused headless; dragging also looks).
    await page.mouse.move(240, 160);
    await page.mouse.down();
    await page.mouse.move(340, 140, { steps: 5 });
    await page.mouse.up();
    await waitFrames(page, 2);
    const looked = (await state(page)).listener;
    expect(looked.headingDeg).toBeCloseTo(turned - 15, 0);
    expect(looked.pitchDeg).toBeCloseTo(3, 0);
  });

  test('touch: the left thumb walks, the right thumb looks', async () => {
    const page = s.page;
    await open(page, `${inject('litUrl')}?x=2&y=1.25&heading=0`);
    const cdp = await s.ctx.newCDPSession(page);
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchStart', touchPoints: [{ x: 100, y: 150 }] });
    for (let k = 1; k <= 5; k++) await cdp.send('Input.dispatchTouchEvent', { type: 'touchMove', touchPoints: [{ x: 100, y: 150 - 12 * k }] });
    await page.waitForTimeout(800);
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchEnd', touchPoints: [] });
    const walked = (await state(page)).listener;
    expect(walked.x).toBeGreaterThan(2.3);
    expect(Math.abs(walked.y - 1.25)).toBeLessThan(0.05);
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchStart', touchPoints: [{ x: 380, y: 150 }] });
    for (let k = 1; k <= 5; k++) await cdp.send('Input.dispatchTouchEvent', { type: 'touchMove', touchPoints: [{ x: 380 - 8 * k, y: 150 }] });
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchEnd', touchPoints: [] });
    await waitFrames(page, 2);
    expect((await state(page)).listener.headingDeg).toBeCloseTo(10, 0); // 40 px × 0.25°/px to the left
    expect(s.errors).toEqual([]);
  });
});
