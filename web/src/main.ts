/**
 * The page: read ?bundle= (default bundle/, beside the page), load and check the bundle,
 * then walk. Optional: ?x=&y=&heading= (metres, degrees) to start elsewhere. Any failure is
 * shown on the page.
 */
import './style.css';
import { WalkThrough } from './app';
import { bundleBase, loadIndex } from './bundle';
import { showError } from './error-view';
import { ResponseStore } from './responses';
import { SceneView } from './scene-view';
import { installHooks } from './test-hooks';
import type { Listener } from './walker';

window.sonolux = { ready: false, error: null };

function startParams(q: URLSearchParams): Partial<Listener> {
  const out: Partial<Listener> = {};
  for (const [key, name] of [
    ['x', 'x'],
    ['y', 'y'],
    ['heading', 'headingDeg'],
    ['pitch', 'pitchDeg'],
  ] as const) {
    const v = q.get(key);
    if (v !== null && Number.isFinite(Number(v))) out[name] = Number(v);
  }
  return out;
}

async function main(): Promise<void> {
  const q = new URLSearchParams(location.search);
  const base = bundleBase(q.get('bundle'), location.href);
  const view = new SceneView(document.getElementById('view')!);
  const index = await loadIndex(base);
  await view.load(new URL(index.sceneFile, base).href, index);
  const store = new ResponseStore(base, index);
  const app = new WalkThrough(index, view, store, startParams(q));
  installHooks(app);
  document.getElementById('loading')?.remove();
  app.run();
  window.sonolux.ready = true;
}

function fail(e: unknown): void {
  window.sonolux.error = e instanceof Error ? e.message : String(e);
  showError(e);
}

window.addEventListener('unhandledrejection', (e) => fail(e.reason));
window.addEventListener('error', (e) => fail(e.error ?? e.message));
main().catch(fail);
