/**
 * From direction bands to the ears. Every band has a bus; from there it plays either through
 * its own HRTF PannerNode at the band's direction turned by the heading ("hrtf"), or through
 * the paper's cube of 8 loudspeakers ("cube"): pairwise-panned into virtual speakers at the
 * cube's corners, which are fixed to the head, each an HRTF PannerNode. Both paths are built;
 * switching fades one out and the other in.
 */
import type { Direction } from '../bundle';
import { headAzimuthDeg, webAudioFromHead } from '../coords';
import { CUBE_SPEAKERS, cubeGains } from '../panning';

export type Rendering = 'hrtf' | 'cube';

const SMOOTH_S = 0.012; // time constant of heading changes: no zipper noise when the mouse turns

function hrtfPanner(ctx: BaseAudioContext): PannerNode {
  // At 1 m with no roll-off: the level is the response's own, the panner only gives direction.
  return new PannerNode(ctx, { panningModel: 'HRTF', distanceModel: 'inverse', refDistance: 1, rolloffFactor: 0 });
}

function place(p: PannerNode, v: number[], t: number | null): void {
  const params = [p.positionX, p.positionY, p.positionZ];
  params.forEach((param, i) => {
    if (t === null) param.value = v[i];
    else param.setTargetAtTime(v[i], t, SMOOTH_S);
  });
}

export class Spatializer {
  readonly buses: GainNode[];
  private readonly panners: PannerNode[];
  private readonly sends: GainNode[][];
  private readonly hrtfOut: GainNode;
  private readonly cubeOut: GainNode;
  headingDeg = 0;
  rendering: Rendering = 'hrtf';

  constructor(
    ctx: BaseAudioContext,
    private readonly directions: Direction[],
    out: AudioNode,
  ) {
    this.hrtfOut = new GainNode(ctx, { gain: 1 });
    this.cubeOut = new GainNode(ctx, { gain: 0 });
    this.hrtfOut.connect(out);
    this.cubeOut.connect(out);
    this.buses = directions.map(() => new GainNode(ctx, { gain: 1 }));
    this.panners = this.buses.map((bus) => {
      const p = hrtfPanner(ctx);
      bus.connect(p).connect(this.hrtfOut);
      return p;
    });
    const speakers = CUBE_SPEAKERS.map((s) => {
      const p = hrtfPanner(ctx);
      place(p, webAudioFromHead(s.azimuthDeg, s.elevationDeg), null);
      p.connect(this.cubeOut);
      return p;
    });
    this.sends = this.buses.map((bus) =>
      speakers.map((sp) => {
        const g = new GainNode(ctx, { gain: 0 });
        bus.connect(g).connect(sp);
        return g;
      }),
    );
    this.setHeading(0, null);
  }

  /** Turns the virtual sources for a heading (degrees, sonolux); t null: at once. */
  setHeading(headingDeg: number, t: number | null): void {
    this.headingDeg = headingDeg;
    this.directions.forEach((d, k) => {
      const az = headAzimuthDeg(d.azimuthDeg, headingDeg);
      place(this.panners[k], webAudioFromHead(az, d.elevationDeg), t);
      cubeGains(az, d.elevationDeg).forEach((g, s) => {
        const param = this.sends[k][s].gain;
        if (t === null) param.value = g;
        else param.setTargetAtTime(g, t, SMOOTH_S);
      });
    });
  }

  /** Chooses the HRTF path or the cube; t null: at once. */
  setRendering(r: Rendering, t: number | null): void {
    this.rendering = r;
    const on = r === 'hrtf' ? this.hrtfOut.gain : this.cubeOut.gain;
    const off = r === 'hrtf' ? this.cubeOut.gain : this.hrtfOut.gain;
    if (t === null) {
      on.value = 1;
      off.value = 0;
    } else {
      on.setTargetAtTime(1, t, 0.05);
      off.setTargetAtTime(0, t, 0.05);
    }
  }
}
