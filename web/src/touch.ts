/**
 * Touch, for phones and tablets: a finger put down on the left half of the view is a
 * joystick (push up to walk, sideways to step), one on the right half looks around.
 */
import type { MoveIntent } from './walker';

export const STICK_RADIUS_PX = 60;
const LOOK_DEG_PER_PX = 0.25;

/** The intent of a joystick pushed by (dx, dy) pixels (screen axes, y down). */
export function stickIntent(dx: number, dy: number, radiusPx = STICK_RADIUS_PX): MoveIntent {
  const n = Math.hypot(dx, dy);
  const s = n > radiusPx ? radiusPx / n : 1;
  const dead = n < 6 ? 0 : 1;
  return { forward: (-dy * s * dead) / radiusPx, left: (-dx * s * dead) / radiusPx, turn: 0, run: false };
}

export class TouchControls {
  private stick: { id: number; x0: number; y0: number; x: number; y: number } | null = null;
  private lookId = -1;
  private lastX = 0;
  private lastY = 0;
  private dHeading = 0;
  private dPitch = 0;
  private readonly knob: HTMLDivElement;

  constructor(surface: HTMLElement) {
    this.knob = document.createElement('div');
    this.knob.className = 'stick';
    this.knob.hidden = true;
    surface.appendChild(this.knob);
    surface.style.touchAction = 'none';
    surface.addEventListener('pointerdown', (e) => {
      if (e.pointerType !== 'touch') return;
      // A mouse that locked the pointer on a touch screen laptop: touch takes over.
      if (document.pointerLockElement) document.exitPointerLock();
      const r = surface.getBoundingClientRect();
      if (e.clientX - r.left < r.width / 2 && !this.stick) {
        this.stick = { id: e.pointerId, x0: e.clientX, y0: e.clientY, x: e.clientX, y: e.clientY };
        this.showKnob();
      } else if (this.lookId < 0) {
        this.lookId = e.pointerId;
        this.lastX = e.clientX;
        this.lastY = e.clientY;
      }
      try {
        surface.setPointerCapture(e.pointerId);
      } catch {
        // refused (the pointer is still locked this instant): moves outside the view are lost
      }
    });
    surface.addEventListener('pointermove', (e) => {
      if (this.stick && e.pointerId === this.stick.id) {
        this.stick.x = e.clientX;
        this.stick.y = e.clientY;
        this.showKnob();
      } else if (e.pointerId === this.lookId) {
        this.dHeading -= (e.clientX - this.lastX) * LOOK_DEG_PER_PX;
        this.dPitch -= (e.clientY - this.lastY) * LOOK_DEG_PER_PX;
        this.lastX = e.clientX;
        this.lastY = e.clientY;
      }
    });
    const end = (e: PointerEvent) => {
      if (this.stick && e.pointerId === this.stick.id) {
        this.stick = null;
        this.knob.hidden = true;
      }
      if (e.pointerId === this.lookId) this.lookId = -1;
    };
    surface.addEventListener('pointerup', end);
    surface.addEventListener('pointercancel', end);
  }

  private showKnob(): void {
    if (!this.stick) return;
    this.knob.hidden = false;
    this.knob.style.left = `${this.stick.x0}px`;
    this.knob.style.top = `${this.stick.y0}px`;
    const dx = this.stick.x - this.stick.x0;
    const dy = this.stick.y - this.stick.y0;
    const n = Math.hypot(dx, dy);
    const s = n > STICK_RADIUS_PX ? STICK_RADIUS_PX / n : 1;
    this.knob.style.setProperty('--dx', `${dx * s}px`);
    this.knob.style.setProperty('--dy', `${dy * s}px`);
  }

  intent(): MoveIntent | null {
    if (!this.stick) return null;
    return stickIntent(this.stick.x - this.stick.x0, this.stick.y - this.stick.y0);
  }

  takeLook(): [number, number] {
    const r: [number, number] = [this.dHeading, this.dPitch];
    this.dHeading = this.dPitch = 0;
    return r;
  }
}
