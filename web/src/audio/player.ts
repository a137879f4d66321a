/** Plays a dry signal in a loop into the engine's input, with short fades so that starting,
 * stopping and switching signals do not click. */
export class DryPlayer {
  private source: AudioBufferSourceNode | null = null;
  private gain: GainNode | null = null;
  name = '';

  constructor(
    private readonly ctx: BaseAudioContext,
    private readonly destination: AudioNode,
  ) {}

  get playing(): boolean {
    return this.source !== null;
  }

  play(samples: Float32Array, name: string, when = this.ctx.currentTime): void {
    this.stop(when);
    const buffer = new AudioBuffer({ length: Math.max(1, samples.length), sampleRate: this.ctx.sampleRate, numberOfChannels: 1 });
    buffer.copyToChannel(samples as Float32Array<ArrayBuffer>, 0);
    const source = new AudioBufferSourceNode(this.ctx, { buffer, loop: true });
    const gain = new GainNode(this.ctx, { gain: 0 });
    gain.gain.setValueAtTime(0, when);
    gain.gain.linearRampToValueAtTime(1, when + 0.02);
    source.connect(gain).connect(this.destination);
    source.start(when);
    this.source = source;
    this.gain = gain;
    this.name = name;
  }

  stop(when = this.ctx.currentTime): void {
    if (!this.source || !this.gain) return;
    this.gain.gain.cancelScheduledValues(when);
    this.gain.gain.setValueAtTime(this.gain.gain.value, when);
    this.gain.gain.linearRampToValueAtTime(0, when + 0.02);
    this.source.stop(when + 0.03);
    const g = this.gain;
    this.source.onended = () => g.disconnect();
    this.source = null;
    this.gain = null;
  }
}
