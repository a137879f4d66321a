/**
 * Keyboard and mouse. W/S or ↑/↓ walk, A/D step sideways, ←/→ or Q/E turn, Shift runs.
 * A click on the view locks the pointer (Esc releases it) and the mouse then looks around;
 * where pointer lock is refused, dragging with the button held looks around instead.
 */
import type { MoveIntent } from './walker';

const MOUSE_DEG_PER_PX = 0.15;

export class KeyboardMouse {
  private readonly down = new Set<string>();
  private dragging = false;
  private lastX = 0;
  private lastY = 0;
  /** Looks (degrees) gathered since the last frame. */
  private dHeading = 0;
  private dPitch = 0;

  constructor(private readonly surface: HTMLElement) {
    window.addEventListener('keydown', (e) => {
      if (isTyping(e)) return;
      if (MOVE_KEYS.has(e.code)) e.preventDefault();
      this.down.add(e.code);
    });
    window.addEventListener('keyup', (e) => this.down.delete(e.code));
    window.addEventListener('blur', () => this.down.clear());
    surface.addEventListener('click', () => {
      if (document.pointerLockElement !== surface) {
        const p = surface.requestPointerLock?.() as unknown as Promise<void> | undefined;
        p?.catch?.(() => {}); // refused (e.g. in a frame): dragging still works
      }
    });
    surface.addEventListener('pointerdown', (e) => {
      if (e.pointerType !== 'mouse') return;
      this.dragging = true;
      this.lastX = e.clientX;
      this.lastY = e.clientY;
    });
    window.addEventListener('pointerup', () => (this.dragging = false));
    window.addEventListener('mousemove', (e) => {
      // Locked, the pointer stays put and only movementX/Y tell; dragging, the positions do.
      let dx = 0;
      let dy = 0;
      if (document.pointerLockElement === surface) {
        dx = e.movementX;
        dy = e.movementY;
      } else if (this.dragging) {
        dx = e.clientX - this.lastX;
        dy = e.clientY - this.lastY;
        this.lastX = e.clientX;
        this.lastY = e.clientY;
      }
      this.dHeading -= dx * MOUSE_DEG_PER_PX;
      this.dPitch -= dy * MOUSE_DEG_PER_PX;
    });
  }

  get locked(): boolean {
    return document.pointerLockElement === this.surface;
  }

  intent(): MoveIntent {
    const k = (...codes: string[]) => (codes.some((c) => this.down.has(c)) ? 1 : 0);
    return {
      forward: k('KeyW', 'ArrowUp') - k('KeyS', 'ArrowDown'),
      left: k('KeyA') - k('KeyD'),
      turn: k('ArrowLeft', 'KeyQ') - k('ArrowRight', 'KeyE'),
      run: k('ShiftLeft', 'ShiftRight') === 1,
    };
  }

  /** The mouse's look since the last call: [dHeading, dPitch] in degrees. */
  takeLook(): [number, number] {
    const r: [number, number] = [this.dHeading, this.dPitch];
    this.dHeading = this.dPitch = 0;
    return r;
  }
}

const MOVE_KEYS = new Set(['ArrowUp', 'ArrowDown', 'ArrowLeft', 'ArrowRight', 'Space']);

function isTyping(e: KeyboardEvent): boolean {
  const t = e.target as HTMLElement | null;
  return !!t && (t.tagName === 'INPUT' || t.tagName === 'TEXTAREA' || t.isContentEditable);
}
