/**
 * Once for the browser tests: bake a small field of paper-small (sound and light), make a
 * copy without its light field (so the viewer's own lighting is tested too), and serve each
 * with `sonolux serve --port 0` (which exports the bundle into a cache folder, so the export
 * and the server are tested on the way). The tests get the addresses through inject().
 */
import { execFileSync, spawn, type ChildProcess } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const repo = resolve(dirname(fileURLToPath(import.meta.url)), '../../..');

function sonolux(): string {
  const exe = process.env.SONOLUX ?? join(repo, '.venv/bin/sonolux');
  if (!existsSync(exe)) throw new Error(`${exe} is missing: run \`make build\` first (or set SONOLUX)`);
  return exe;
}

function serve(exe: string, field: string, cache: string): Promise<{ url: string; proc: ChildProcess }> {
  return new Promise((ok, fail) => {
    const proc = spawn(exe, ['serve', field, '--port', '0'], { env: { ...process.env, SONOLUX_CACHE: cache }, stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    let err = '';
    const timer = setTimeout(() => fail(new Error(`sonolux serve did not start in 240 s:\n${out}\n${err}`)), 240_000);
    proc.stdout!.on('data', (d) => {
      out += d;
      const m = /at (http:\/\/\S+)/.exec(out);
      if (m) {
        clearTimeout(timer);
        ok({ url: m[1], proc });
      }
    });
    proc.stderr!.on('data', (d) => (err += d));
    proc.on('exit', (code) => fail(new Error(`sonolux serve exited (${code}):\n${out}\n${err}`)));
  });
}

export default async function setup({ provide }: { provide: (key: string, value: unknown) => void }) {
  const exe = sonolux();
  const work = mkdtempSync(join(tmpdir(), 'sonolux-web-test-'));
  const shots = join(repo, 'out', 'web-test');
  mkdirSync(shots, { recursive: true });
  const lit = join(work, 'small.h5');
  execFileSync(exe, ['bake', 'paper-small', '-o', lit, '--rays', '3000', '--particles', '100000', '-q'], { stdio: ['ignore', 'ignore', 'inherit'] });
  const unlit = join(work, 'small-unlit.h5');
  const python = join(dirname(exe), 'python');
  execFileSync(python, ['-c', `import h5py, shutil; shutil.copy(${JSON.stringify(lit)}, ${JSON.stringify(unlit)}); f = h5py.File(${JSON.stringify(unlit)}, "a"); f.__delitem__("light") if "light" in f else None; f.close()`]);
  // A bundle of two source fields (the contract with a field per source: a list of (name,
  // field)): the baked field as "talker" and, as "second", the same at half the energy.
  const two = join(work, 'two-sources');
  execFileSync(python, ['-c', [
    'import sys, numpy as np; from dataclasses import replace; import sonolux',
    'from sonolux.web.bundle import write_compact_bundle',
    'f = sonolux.open(sys.argv[1])',
    'h = replace(f, energy=f.energy.map_values(lambda v: np.asarray(v) * 0.5, np.float32), source_positions_m=np.atleast_2d(f.source_positions_m) + [0.5, 0.0, 0.0])',
    'write_compact_bundle([("talker", f), ("second", h)], sys.argv[1], sys.argv[2])',
  ].join('\n'), lit, two]);
  // The same field as a bundle of responses (sonolux-web/2), which the viewer still reads.
  const pcm = join(work, 'pcm');
  execFileSync(exe, ['export', lit, '--web', pcm, '--responses', 'pcm'], { stdio: ['ignore', 'ignore', 'inherit'] });
  const cache = join(work, 'cache');
  const servers = await Promise.all([serve(exe, lit, cache), serve(exe, unlit, cache)]);
  provide('litUrl', servers[0].url);
  provide('unlitUrl', servers[1].url);
  provide('shots', shots);
  provide('litField', lit);
  provide('twoSources', two);
  provide('pcmBundle', pcm);
  provide('python', python);
  return () => {
    for (const s of servers) s.proc.kill();
    rmSync(work, { recursive: true, force: true });
  };
}

declare module 'vitest' {
  export interface ProvidedContext {
    litUrl: string;
    unlitUrl: string;
    shots: string;
    litField: string;
    twoSources: string;
    pcmBundle: string;
    python: string;
  }
}
