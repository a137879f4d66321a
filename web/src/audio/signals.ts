/**
 * Dry signals made in the page, as the paper asks ("computer generated, or recorded in an
 * acoustically dead room"): no echo of their own. Each returns mono samples at `fs` that loop
 * seamlessly; the same seed gives the same samples.
 */
import { mulberry32 } from '../mulberry32';

export type SignalName = 'talker' | 'clicks' | 'noise' | 'melody';

export const SIGNALS: { name: SignalName; label: string }[] = [
  { name: 'talker', label: 'talker (speech-like)' },
  { name: 'clicks', label: 'clicks' },
  { name: 'noise', label: 'noise bursts' },
  { name: 'melody', label: 'plucked melody' },
];

/** The named signal, its peak at 0.8. */
export function makeSignal(name: SignalName, fs: number, seed = 1): Float32Array {
  const make = { clicks: () => clicks(fs), noise: () => noiseBursts(fs, seed), melody: () => melody(fs, seed), talker: () => talker(fs, seed) };
  return normalize(make[name](), 0.8);
}

export function normalize(x: Float32Array, peak: number): Float32Array {
  const m = x.reduce((a, v) => Math.max(a, Math.abs(v)), 0);
  if (m > 0) for (let i = 0; i < x.length; i++) x[i] *= peak / m;
  return x;
}

/** A short raised-cosine click (1 ms) every half second: each one rings out in the room. */
export function clicks(fs: number, periodS = 0.5, seconds = 2): Float32Array {
  const x = new Float32Array(Math.round(seconds * fs));
  const w = Math.max(2, Math.round(0.001 * fs));
  for (let t0 = 0; t0 < x.length; t0 += Math.round(periodS * fs)) {
    for (let i = 0; i < w && t0 + i < x.length; i++) x[t0 + i] = 0.9 * Math.sin((Math.PI * i) / w) ** 2;
  }
  return x;
}

/** 250 ms of pink-ish noise a second, with 5 ms ramps. */
export function noiseBursts(fs: number, seed = 1, seconds = 2): Float32Array {
  const x = new Float32Array(Math.round(seconds * fs));
  const rnd = mulberry32(seed);
  const on = Math.round(0.25 * fs);
  const ramp = Math.round(0.005 * fs);
  let b0 = 0;
  let b1 = 0;
  let b2 = 0;
  for (let i = 0; i < x.length; i++) {
    // Paul Kellet's economy pink filter.
    const w = rnd() * 2 - 1;
    b0 = 0.99765 * b0 + w * 0.099046;
    b1 = 0.963 * b1 + w * 0.2965164;
    b2 = 0.57 * b2 + w * 1.0526913;
    const pink = (b0 + b1 + b2 + w * 0.1848) * 0.2;
    const k = i % fs;
    const env = k >= on ? 0 : Math.min(1, k / ramp, (on - k) / ramp);
    x[i] = pink * env;
  }
  return x;
}

/** A plucked-string melody (Karplus–Strong), a note every 0.4 s. */
export function melody(fs: number, seed = 1): Float32Array {
  const notes = [0, 4, 7, 12, 7, 4, 2, 5, 9, 5]; // semitones above A3
  const step = Math.round(0.4 * fs);
  const x = new Float32Array(step * notes.length);
  const rnd = mulberry32(seed);
  notes.forEach((n, k) => {
    const f = 220 * 2 ** (n / 12);
    const period = Math.max(2, Math.round(fs / f));
    const buf = Float32Array.from({ length: period }, () => rnd() * 2 - 1);
    const len = step;
    for (let i = 0; i < len; i++) {
      const j = i % period;
      const next = buf[(j + 1) % period];
      const v = buf[j];
      buf[j] = 0.996 * 0.5 * (v + next);
      x[(k * step + i) % x.length] += 0.5 * v * Math.min(1, (len - i) / (0.01 * fs));
    }
  });
  return x;
}

/** A speech-like talker: a glottal pulse train (about 120 Hz, with intonation and jitter)
 * through vowel formants that change every syllable, syllables at about 4 a second, with
 * pauses between phrases. Not words, but the rhythm and spectrum of speech. */
export function talker(fs: number, seed = 1, seconds = 4): Float32Array {
  const x = new Float32Array(Math.round(seconds * fs));
  const rnd = mulberry32(seed);
  const vowels = [
    [730, 1090, 2440], // a
    [270, 2290, 3010], // i
    [300, 870, 2240], // u
    [530, 1840, 2480], // e
    [570, 840, 2410], // o
  ];
  const syllableS = 0.22;
  const syllables: { t0: number; t1: number; v: number[] }[] = [];
  for (let t = 0.05; t < seconds - 0.3; ) {
    const n = 3 + Math.floor(rnd() * 4); // a phrase
    for (let k = 0; k < n && t < seconds - 0.3; k++) {
      const len = syllableS * (0.7 + 0.6 * rnd());
      syllables.push({ t0: t, t1: t + len, v: vowels[Math.floor(rnd() * vowels.length)] });
      t += len + 0.03;
    }
    t += 0.25 + 0.3 * rnd(); // a pause
  }
  // Glottal source: pulses at f0 with a little jitter, falling intonation over each phrase.
  const src = new Float32Array(x.length);
  let phase = 0;
  for (let i = 0; i < x.length; i++) {
    const f0 = 125 - 25 * ((i / fs) % 1.5) + 4 * (rnd() - 0.5);
    phase += f0 / fs;
    if (phase >= 1) {
      phase -= 1;
      src[i] = 1;
    }
  }
  // Formants: three two-pole resonators per syllable, added, with a syllable envelope.
  for (const s of syllables) {
    const i0 = Math.round(s.t0 * fs);
    const i1 = Math.min(x.length, Math.round(s.t1 * fs));
    s.v.forEach((f, k) => {
      const bw = 60 + 40 * k;
      const r = Math.exp((-Math.PI * bw) / fs);
      const a1 = 2 * r * Math.cos((2 * Math.PI * f) / fs);
      const a2 = -r * r;
      const g = (1 - r) * [1, 0.5, 0.25][k];
      let y1 = 0;
      let y2 = 0;
      for (let i = i0; i < i1; i++) {
        const y = g * src[i] + a1 * y1 + a2 * y2;
        y2 = y1;
        y1 = y;
        const u = (i - i0) / (i1 - i0);
        x[i] += 8 * y * Math.sin(Math.PI * u) ** 0.6;
      }
    });
  }
  return x;
}

/** A mono mix of an AudioBuffer's channels. */
export function mono(b: AudioBuffer): Float32Array {
  const out = new Float32Array(b.length);
  for (let c = 0; c < b.numberOfChannels; c++) {
    const d = b.getChannelData(c);
    for (let i = 0; i < out.length; i++) out[i] += d[i] / b.numberOfChannels;
  }
  return out;
}
