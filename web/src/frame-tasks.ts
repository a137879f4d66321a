/**
 * Work that is too slow for one frame, done a little each frame. Setting a ConvolverNode's
 * buffer costs 10–50 ms of main-thread time for a 2 s response; filling a cell's convolvers at
 * once would stall the picture, so each is a task here, and the frame loop runs a few
 * milliseconds of them a frame.
 *
 * Order: what makes a cell audible (its first segments) before what completes it (its later
 * reverberation), and within each, the cell the listener is in (urgent) before the cell
 * prepared ahead; first come, first served otherwise.
 */
interface Task {
  run: () => void;
  owner: unknown;
  urgent: boolean;
  first: boolean;
}

const rank = (t: Task) => (t.first ? 0 : 2) + (t.urgent ? 0 : 1);

export class FrameTasks {
  private queue: Task[] = [];
  /** Milliseconds each recent task took (the last 64). */
  readonly recentMs: number[] = [];

  push(run: () => void, owner: unknown, urgent = false, first = true): void {
    const t = { run, owner, urgent, first };
    const r = rank(t);
    const at = this.queue.findIndex((q) => rank(q) > r);
    if (at < 0) this.queue.push(t);
    else this.queue.splice(at, 0, t);
  }

  /** Makes an owner's queued tasks urgent. */
  hurry(owner: unknown): void {
    let changed = false;
    for (const q of this.queue) {
      if (q.owner === owner && !q.urgent) q.urgent = changed = true;
    }
    if (changed) this.queue = this.queue.map((q, i) => [q, i] as const).sort((a, b) => rank(a[0]) - rank(b[0]) || a[1] - b[1]).map((e) => e[0]);
  }

  drop(owner: unknown): void {
    this.queue = this.queue.filter((q) => q.owner !== owner);
  }

  get pending(): number {
    return this.queue.length;
  }

  /** Runs tasks for up to about `budgetMs` (at least one, if any): one more only when the
   * last one suggests it fits. Returns the time spent, ms. */
  runFor(budgetMs: number): number {
    let spent = 0;
    let last = 0;
    while (this.queue.length && (spent === 0 || spent + last <= budgetMs)) {
      last = this.runOne();
      spent += last;
    }
    return spent;
  }

  /** Runs the next task, if any; returns its time in ms (0 when there was none). */
  runOne(): number {
    const t = this.queue.shift();
    if (!t) return 0;
    const start = performance.now();
    t.run();
    const ms = performance.now() - start;
    this.recentMs.push(ms);
    if (this.recentMs.length > 64) this.recentMs.shift();
    return ms;
  }

  runAll(): void {
    while (this.queue.length) this.runOne();
  }
}
