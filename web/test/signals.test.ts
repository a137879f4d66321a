import { describe, expect, test } from 'vitest';
import { makeSignal } from '../src/audio/signals';

describe('dry signals', () => {
  test('the same seed gives the same samples, within [-1, 1]', () => {
    for (const name of ['talker', 'clicks', 'noise', 'melody'] as const) {
      const a = makeSignal(name, 48000, 3);
      const b = makeSignal(name, 48000, 3);
      expect(a.every((v, i) => v === b[i])).toBe(true);
      expect(a.length).toBeGreaterThan(48000);
      expect(a.reduce((m, v) => Math.max(m, Math.abs(v)), 0)).toBeLessThanOrEqual(1);
      expect(a.some((v) => v !== 0)).toBe(true);
    }
  });
});
