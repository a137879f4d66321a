import { describe, expect, test } from 'vitest';
import { FrameTasks } from '../src/frame-tasks';

describe('frame tasks', () => {
  test('urgent ones first, in order', () => {
    const q = new FrameTasks();
    const done: string[] = [];
    const a = {};
    const b = {};
    q.push(() => done.push('a1'), a);
    q.push(() => done.push('a2'), a);
    q.push(() => done.push('b1'), b, true);
    q.runOne();
    expect(done).toEqual(['b1']);
    q.hurry(a);
    q.push(() => done.push('b2'), b, true);
    q.runAll();
    expect(done).toEqual(['b1', 'a1', 'a2', 'b2']);
  });

  test('what makes a cell audible comes before what completes one', () => {
    const q = new FrameTasks();
    const done: string[] = [];
    const here = {};
    const ahead = {};
    q.push(() => done.push('here-late'), here, true, false);
    q.push(() => done.push('ahead-first'), ahead, false, true);
    q.push(() => done.push('ahead-late'), ahead, false, false);
    q.push(() => done.push('here-first'), here, true, true);
    q.runAll();
    expect(done).toEqual(['here-first', 'ahead-first', 'here-late', 'ahead-late']);
  });

  test('a dropped owner runs nothing more', () => {
    const q = new FrameTasks();
    const o = {};
    let n = 0;
    q.push(() => n++, o);
    q.drop(o);
    q.runAll();
    expect(n).toBe(0);
  });
});
