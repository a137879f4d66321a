/**
 * The plan-view inset: the room seen from above (sonolux x to the right, y up, as in the
 * paper's plan), its walls at head height, the receiver grid's cells (the listener's filled,
 * the one prepared ahead outlined), the sources, and the listener with their heading.
 */
import type { BundleIndex } from './bundle';
import { headingVector } from './coords';
import type { Listener } from './walker';

export interface PlanState {
  listener: Listener;
  cell: number;
  preparedCell: number;
  loaded: (cell: number) => boolean;
}

const MAX_W = 260;
const MAX_H = 180;
const PAD = 10;

export class PlanView {
  private readonly ctx: CanvasRenderingContext2D;
  private readonly scale: number;
  private readonly w: number;
  private readonly h: number;

  constructor(
    canvas: HTMLCanvasElement,
    private readonly index: BundleIndex,
  ) {
    const [x0, y0] = index.boundsMin;
    const [x1, y1] = index.boundsMax;
    const sx = (MAX_W - 2 * PAD) / Math.max(x1 - x0, 1e-3);
    const sy = (MAX_H - 2 * PAD) / Math.max(y1 - y0, 1e-3);
    this.scale = Math.min(sx, sy);
    this.w = Math.ceil((x1 - x0) * this.scale + 2 * PAD);
    this.h = Math.ceil((y1 - y0) * this.scale + 2 * PAD);
    const dpr = Math.min(window.devicePixelRatio || 1, 2);
    canvas.width = this.w * dpr;
    canvas.height = this.h * dpr;
    canvas.style.width = `${this.w}px`;
    canvas.style.height = `${this.h}px`;
    canvas.hidden = false;
    this.ctx = canvas.getContext('2d')!;
    this.ctx.scale(dpr, dpr);
  }

  /** Canvas pixel of a sonolux plan point. */
  toPx(x: number, y: number): [number, number] {
    return [PAD + (x - this.index.boundsMin[0]) * this.scale, this.h - PAD - (y - this.index.boundsMin[1]) * this.scale];
  }

  draw(s: PlanState): void {
    const c = this.ctx;
    const ix = this.index;
    c.clearRect(0, 0, this.w, this.h);
    c.fillStyle = 'rgba(12, 14, 20, 0.78)';
    c.fillRect(0, 0, this.w, this.h);
    // Cells: squares of the grid spacing around each receiver.
    const half = ((ix.gridSpacingM ?? 2 * ix.radiusM) / 2) * this.scale;
    // Cells reach past the walls where the grid's edge is nearer than half a spacing: clip.
    const [rx0, ry0] = this.toPx(ix.boundsMin[0], ix.boundsMax[1]);
    const [rx1, ry1] = this.toPx(ix.boundsMax[0], ix.boundsMin[1]);
    c.save();
    c.beginPath();
    c.rect(rx0, ry0, rx1 - rx0, ry1 - ry0);
    c.clip();
    ix.cells.forEach((cell, i) => {
      const [px, py] = this.toPx(cell.position[0], cell.position[1]);
      if (i === s.cell) {
        c.fillStyle = 'rgba(255, 190, 60, 0.55)';
        c.fillRect(px - half, py - half, 2 * half, 2 * half);
      } else if (s.loaded(i)) {
        c.fillStyle = 'rgba(120, 160, 255, 0.16)';
        c.fillRect(px - half, py - half, 2 * half, 2 * half);
      }
      c.strokeStyle = i === s.preparedCell ? 'rgba(255, 190, 60, 0.9)' : 'rgba(160, 170, 200, 0.35)';
      c.lineWidth = i === s.preparedCell ? 1.5 : 1;
      c.strokeRect(px - half + 0.5, py - half + 0.5, 2 * half - 1, 2 * half - 1);
      c.fillStyle = 'rgba(200, 210, 230, 0.6)';
      c.fillRect(px - 1, py - 1, 2, 2);
    });
    c.restore();
    // Walls at head height.
    c.strokeStyle = '#e8e8f0';
    c.lineWidth = 2;
    c.beginPath();
    for (const [x0, y0, x1, y1] of ix.planSegments) {
      c.moveTo(...this.toPx(x0, y0));
      c.lineTo(...this.toPx(x1, y1));
    }
    c.stroke();
    // Sources.
    for (const src of ix.sources) {
      const [px, py] = this.toPx(src.position[0], src.position[1]);
      c.fillStyle = '#ff5a5a';
      c.beginPath();
      c.arc(px, py, 5, 0, 2 * Math.PI);
      c.fill();
    }
    // The listener: a dot and an arrow along the heading.
    const l = s.listener;
    const [px, py] = this.toPx(l.x, l.y);
    const [fx, fy] = headingVector(l.headingDeg);
    const tip: [number, number] = [px + fx * 14, py - fy * 14];
    c.strokeStyle = '#7cf0ff';
    c.fillStyle = '#7cf0ff';
    c.lineWidth = 2;
    c.beginPath();
    c.moveTo(px, py);
    c.lineTo(...tip);
    c.stroke();
    c.beginPath();
    c.moveTo(...tip);
    c.lineTo(tip[0] - fx * 6 + fy * 4, tip[1] + fy * 6 + fx * 4);
    c.lineTo(tip[0] - fx * 6 - fy * 4, tip[1] + fy * 6 - fx * 4);
    c.closePath();
    c.fill();
    c.beginPath();
    c.arc(px, py, 4, 0, 2 * Math.PI);
    c.fill();
  }
}
