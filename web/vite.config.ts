/// <reference types="vitest/config" />
// Builds the viewer into the Python package (python/sonolux/web_dist), which ships it, so that
// `sonolux serve` needs no Node.js. build-info.json records a hash of the sources it was built
// from; a Python test compares it with the sources (tests/web/test_viewer_dist.py).
import { createHash } from 'node:crypto';
import { readdirSync, readFileSync, statSync, writeFileSync } from 'node:fs';
import { join, relative, resolve, sep } from 'node:path';
import { fileURLToPath } from 'node:url';
import { defineConfig, type Plugin } from 'vite';

const here = fileURLToPath(new URL('.', import.meta.url));
const outDir = resolve(here, '../python/sonolux/web_dist');

/** The files the build depends on, as sorted paths relative to web/ (with / separators). */
export function sourceFiles(): string[] {
  const out: string[] = [];
  const walk = (dir: string) => {
    for (const name of readdirSync(dir)) {
      const p = join(dir, name);
      if (statSync(p).isDirectory()) walk(p);
      else out.push(relative(here, p).split(sep).join('/'));
    }
  };
  walk(join(here, 'src'));
  for (const f of ['index.html', 'package-lock.json', 'tsconfig.json', 'vite.config.ts']) out.push(f);
  return out.sort();
}

/** sha256 over (path, NUL, bytes, NUL) of every source file, in order. */
export function sourcesHash(): string {
  const h = createHash('sha256');
  for (const f of sourceFiles()) {
    h.update(f);
    h.update('\0');
    h.update(readFileSync(join(here, f)));
    h.update('\0');
  }
  return h.digest('hex');
}

function buildInfo(): Plugin {
  return {
    name: 'sonolux-build-info',
    apply: 'build',
    closeBundle() {
      const info = { sources_sha256: sourcesHash(), files: sourceFiles().length };
      writeFileSync(join(outDir, 'build-info.json'), JSON.stringify(info, null, 1) + '\n');
    },
  };
}

export default defineConfig({
  base: './',
  plugins: [buildInfo()],
  build: {
    outDir,
    emptyOutDir: true,
    chunkSizeWarningLimit: 1500,
    assetsInlineLimit: 0,
  },
  server: {
    // `npm run dev` with `sonolux serve FIELD` running: the bundle comes from there.
    proxy: { '/bundle': 'http://127.0.0.1:8765' },
  },
  test: {
    include: ['test/**/*.test.ts'],
    environment: 'node',
  },
});
