/** Errors on the page, never a blank screen: what went wrong, in which file, and what to do. */
import { BundleError } from './bundle';

export function describeError(e: unknown): { title: string; detail: string; hint: string } {
  if (e instanceof BundleError) {
    return {
      title: 'The bundle could not be loaded',
      detail: e.message,
      hint: 'Export it again with `sonolux export FIELD --web DIR` (or restart `sonolux serve FIELD --rebuild`), and check the page\'s ?bundle= address.',
    };
  }
  const message = e instanceof Error ? e.message : String(e);
  return { title: 'Something went wrong', detail: message, hint: 'Reload the page; if it happens again, the browser console has the details.' };
}

export function showError(e: unknown): void {
  const box = document.getElementById('error');
  document.getElementById('loading')?.remove();
  if (!box) {
    document.body.textContent = `Error: ${String(e)}`;
    return;
  }
  if (!box.hidden) return; // the first error is the one that explains the rest
  const { title, detail, hint } = describeError(e);
  box.replaceChildren();
  const h = document.createElement('h2');
  h.textContent = title;
  const p = document.createElement('p');
  p.className = 'detail';
  p.textContent = detail;
  const q = document.createElement('p');
  q.className = 'hint';
  q.textContent = hint;
  box.append(h, p, q);
  box.hidden = false;
  box.setAttribute('role', 'alert');
  console.error(e);
}
