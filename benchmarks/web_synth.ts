/**
 * The browser's synthesis of a sonolux-web/3 bundle's cells, timed in Node.js (the same
 * V8 and the same code as the viewer's Web Worker: web/src/synth): for each of the given
 * cells, inflate its block, read its parts and synthesise its responses. Prints JSON
 * {cells: [{cell, ms, samples}]}. Run by benchmarks/web_bundle.py:
 *   web/node_modules/.bin/vite-node benchmarks/web_synth.ts BUNDLE_DIR CELL...
 */
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { inflateSync } from 'node:zlib';
import { parseIndex } from '../web/src/bundle';
import { readParts } from '../web/src/synth/client';
import { run } from '../web/src/synth/worker';

const [dir, ...cells] = process.argv.slice(2);
const index = parseIndex(JSON.parse(readFileSync(join(dir, 'field.json'), 'utf8')));
const data = readFileSync(join(dir, index.responsesFile));
const spec = index.synthesis!;
const out = [];
for (const k of cells.map(Number)) {
  const cell = index.cells[k];
  let block: Uint8Array = data.subarray(cell.byteOffset, cell.byteOffset + cell.byteLength);
  if (index.encoding === 'deflate') block = inflateSync(block);
  const buf = block.buffer.slice(block.byteOffset, block.byteOffset + block.byteLength) as ArrayBuffer;
  const parts = readParts(index, cell, buf);
  const nCells = index.cells.length;
  const t0 = performance.now();
  const reply = run({
    id: 0,
    spec,
    parts: parts.map((part, j) => ({ part, seed: (j * nCells + k) * spec.directions, sources: index.sourceFields[j].positions })),
    length: cell.lengthSamples,
    receiver: cell.position,
  });
  const ms = performance.now() - t0;
  out.push({ cell: k, ms, samples: Math.max(...reply.parts!.flatMap((p) => p.full.map((x) => x.length))) });
}
console.log(JSON.stringify({ cells: out }));
