/**
 * The synthesis Web Worker: receives one cell's compact parts (synth/client.ts posts them),
 * makes their responses (synth/synthesis.ts) off the main thread, and sends them back
 * (their buffers transferred, not copied).
 */
import { synthesisePart, type CompactPart, type PartResponses, type SynthesisSpec } from './synthesis';

export interface SynthRequest {
  id: number;
  spec: SynthesisSpec;
  parts: { part: CompactPart; seed: number; sources: number[][] }[];
  length: number;
  receiver: number[];
  /** Given impulses per part and direction (the tests': the library's own). */
  impulses?: (Float64Array[] | undefined)[];
}

export interface SynthReply {
  id: number;
  parts?: PartResponses[];
  ms?: number;
  error?: string;
}

export function run(req: SynthRequest): SynthReply {
  const t0 = performance.now();
  const parts = req.parts.map((p, j) => synthesisePart(req.spec, p.part, req.length, p.seed, req.receiver, p.sources, req.impulses?.[j]));
  return { id: req.id, parts, ms: performance.now() - t0 };
}

// In a worker (not when imported by the client's in-thread fallback or the unit tests).
const scope = globalThis as unknown as { importScripts?: unknown; onmessage: unknown; postMessage: (m: unknown, t: Transferable[]) => void };
if (typeof scope.importScripts === 'function') {
  scope.onmessage = (e: MessageEvent<SynthRequest>) => {
    let reply: SynthReply;
    try {
      reply = run(e.data);
    } catch (err) {
      reply = { id: e.data.id, error: (err as Error).message ?? String(err) };
    }
    const transfer: Transferable[] = [];
    for (const p of reply.parts ?? []) for (const x of [...p.full, ...p.direct]) transfer.push(x.buffer as ArrayBuffer);
    scope.postMessage(reply, transfer);
  };
}
