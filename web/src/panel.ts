/** The control panel: start the sound, pick or drop a dry signal, the two toggles (full
 * field or direct sound only; HRTF panning or the paper's 8-speaker cube), volume, and a
 * status line. The settings fold away (folded from the start on small screens, so that a
 * phone shows the room). It only reports what the user chose; the app acts on it. */
import type { Rendering } from './audio/spatializer';
import { SIGNALS, type SignalName } from './audio/signals';
import type { Mode } from './responses';

export interface PanelHandlers {
  toggleSound(): void;
  signal(name: SignalName): void;
  file(f: File): void;
  mode(m: Mode): void;
  rendering(r: Rendering): void;
  volume(v: number): void;
}

function el<K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}, ...children: (Node | string)[]): HTMLElementTagNameMap[K] {
  const e = document.createElement(tag);
  Object.assign(e, props);
  e.append(...children);
  return e;
}

function radios<T extends string>(name: string, options: [T, string][], onChange: (v: T) => void): HTMLElement {
  const box = el('div', { className: 'radios' });
  box.setAttribute('role', 'radiogroup');
  options.forEach(([value, label], i) => {
    const input = el('input', { type: 'radio', name, value, checked: i === 0, id: `${name}-${value}` });
    input.addEventListener('change', () => input.checked && onChange(value));
    box.append(el('label', { htmlFor: input.id }, input, ` ${label}`));
  });
  return box;
}

export class Panel {
  private readonly startButton: HTMLButtonElement;
  private readonly status: HTMLElement;
  private readonly signalSelect: HTMLSelectElement;
  private readonly settings: HTMLElement;
  private readonly fold: HTMLButtonElement;

  constructor(root: HTMLElement, title: string, h: PanelHandlers) {
    this.startButton = el('button', { className: 'start', textContent: '▶ Start sound', type: 'button', id: 'start' });
    this.startButton.addEventListener('click', () => h.toggleSound());
    this.fold = el('button', { className: 'fold', type: 'button', title: 'settings', id: 'fold' });
    this.fold.addEventListener('click', () => this.setFolded(!this.settings.hidden));
    this.signalSelect = el('select', { id: 'signal', title: 'the dry signal played at the source' });
    for (const s of SIGNALS) this.signalSelect.append(el('option', { value: s.name, textContent: s.label }));
    this.signalSelect.addEventListener('change', () => h.signal(this.signalSelect.value as SignalName));
    const file = el('input', { type: 'file', accept: 'audio/*', id: 'file' });
    file.addEventListener('change', () => file.files?.[0] && h.file(file.files[0]));
    const volume = el('input', { type: 'range', min: '0', max: '2', step: '0.01', value: '1', id: 'volume' });
    volume.addEventListener('input', () => h.volume(Number(volume.value)));
    this.status = el('div', { className: 'status', id: 'status' });
    this.settings = el(
      'div',
      { className: 'settings' },
      el('div', { className: 'row' }, el('label', { htmlFor: 'signal', className: 'label' }, 'Signal'), this.signalSelect),
      el('div', { className: 'row small' }, el('label', { htmlFor: 'file' }, 'or a dry sound file (or drop one here): '), file),
      el('div', { className: 'row' }, el('span', { className: 'label' }, 'Sound'), radios<Mode>('mode', [['full', 'full field'], ['direct', 'direct only']], h.mode)),
      el('div', { className: 'row' }, el('span', { className: 'label' }, 'Playback'), radios<Rendering>('rendering', [['hrtf', 'HRTF'], ['cube', '8-speaker cube']], h.rendering)),
      el('div', { className: 'row' }, el('label', { htmlFor: 'volume', className: 'label' }, 'Volume'), volume),
      el(
        'details',
        { className: 'help' },
        el('summary', {}, 'How to walk (headphones recommended)'),
        'Click the view to look around with the mouse (Esc lets it go) · W A S D or the arrows walk · Q/E turn · Shift runs · on a phone: the left thumb walks, the right thumb looks.',
      ),
    );
    root.append(el('div', { className: 'bar' }, this.startButton, el('span', { className: 'title' }, title), this.fold), this.settings, this.status);
    this.setFolded(window.innerWidth < 700 || window.innerHeight < 520);
    // A file dropped anywhere on the page is played too.
    window.addEventListener('dragover', (e) => e.preventDefault());
    window.addEventListener('drop', (e) => {
      e.preventDefault();
      const f = e.dataTransfer?.files?.[0];
      if (f) h.file(f);
    });
  }

  setFolded(folded: boolean): void {
    this.settings.hidden = folded;
    this.fold.textContent = folded ? '⚙ ▾' : '⚙ ▴';
    this.fold.setAttribute('aria-expanded', String(!folded));
  }

  setPlaying(playing: boolean): void {
    this.startButton.textContent = playing ? '■ Stop sound' : '▶ Start sound';
  }

  setSignalLabel(name: string): void {
    if (![...this.signalSelect.options].some((o) => o.value === name)) {
      this.signalSelect.append(el('option', { value: name, textContent: name }));
    }
    this.signalSelect.value = name;
  }

  /** The source fields' mixer (shown only when there are several): a checkbox and a level
   * per source; `onGains` gets every source's linear gain (0 when unchecked). */
  setSources(names: string[], onGains: (gains: number[]) => void): void {
    if (names.length < 2) return;
    const levels: HTMLInputElement[] = [];
    const on: HTMLInputElement[] = [];
    const report = () => onGains(levels.map((l, k) => (on[k].checked ? Number(l.value) : 0)));
    const rows = names.map((name, k) => {
      const box = el('input', { type: 'checkbox', checked: true, id: `source-${k}`, title: `hear ${name}` });
      const level = el('input', { type: 'range', min: '0', max: '2', step: '0.05', value: '1', id: `source-level-${k}`, title: `${name}: level` });
      box.addEventListener('change', report);
      level.addEventListener('change', report);
      on.push(box);
      levels.push(level);
      return el('div', { className: 'row small' }, el('label', { htmlFor: box.id }, box, ` ${name}`), level);
    });
    const section = el('div', { className: 'sources', id: 'sources' }, el('span', { className: 'label' }, 'Sources'), ...rows);
    this.settings.insertBefore(section, this.settings.firstChild);
  }

  setStatus(text: string): void {
    if (this.status.textContent !== text) this.status.textContent = text;
  }
}
