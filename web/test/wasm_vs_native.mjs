// The wasm decoder against the native one (docs/design/web.md, "Tests"): every
// progressive .glb given is decoded by web/dist's module (the base by
// draco3d) and by meshstream_wasm_reference (DecodeProgressiveGlb), without
// loss, at 12 % random loss and at 12 % in bursts of 4, and every refined
// primitive's vertex and index counts and PrimitiveHash must be equal.
// Without loss, each blob is also fed to the live decoder (LiveDecoder, the
// path of a file read by ranges and of a session) through BlobReader in
// chunks of 997 bytes, and must give the same mesh, one level per refinement.
// usage: node wasm_vs_native.mjs --wasm MODULE.js --reference BIN FILE.glb...
import { readFileSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { resolve } from 'node:path';
import { parseGlb, progressivePrimitives } from '../src/glb.js';
import { decodeDracoBase } from '../src/draco_base.js';
import { LiveDecoder, StreamDecoder } from '../src/decoder.js';
import { BlobReader } from '../src/blob_reader.js';

// The blob fed in odd-sized chunks, as a ranged response arrives; the
// counts of every level; the final arrays as for StreamDecoder.
function decodeLive(M, p, base) {
  const reader = new BlobReader();
  let live = null;
  const levels = [];
  try {
    for (let off = 0; off < p.blob.byteLength; off += 997) {
      for (const e of reader.push(p.blob.subarray(off, off + 997))) {
        if (e.kind === 'header') {
          live = new LiveDecoder(M, e.bytes, p.streamId);
          live.setBase(base);
        } else if (e.kind === 'control') {
          live.control(e.bytes);
        } else if (e.kind === 'datagram') {
          live.datagram(e.bytes);
        } else {
          live.end(e.refinement, e.datagrams);
          const applied = live.poll();
          if (applied !== e.refinement + 1) {
            throw new Error(`refinement ${e.refinement} complete but ${applied} applied`);
          }
          levels.push(applied);
        }
      }
    }
    if (!reader.done) throw new Error('the blob ended early');
    if (live.poll() !== live.refinements) throw new Error('not every refinement was applied');
    live.snapshot();
    const a = live.arrays();
    return { got: [String(p.streamId), String(a.vertices), String(a.indices.length), live.hash()], levels,
             finalVertices: live.finalVertices };
  } finally {
    if (live) live.close();
  }
}

const require = createRequire(import.meta.url);
const args = process.argv.slice(2);
const take = (flag) => {
  const i = args.indexOf(flag);
  if (i < 0 || i + 1 >= args.length) throw new Error('missing ' + flag);
  const v = args[i + 1];
  args.splice(i, 2);
  return v;
};
const wasmPath = take('--wasm');
const referencePath = take('--reference');
const files = args;
if (files.length === 0) throw new Error('no .glb given');

const cases = [
  // Each file carries both profiles: without loss each is compared, with loss
  // the loss-tolerant one (the reliable profile has no datagrams to lose).
  { name: 'no loss, reliable profile', loss: 0, burst: 0, seed: 1, profile: 'reliable' },
  { name: 'no loss, loss-tolerant profile', loss: 0, burst: 0, seed: 1, profile: 'loss-tolerant' },
  { name: '12 % random loss', loss: 0.12, burst: 0, seed: 1, profile: 'loss-tolerant' },
  { name: '12 % in bursts of 4', loss: 0.12, burst: 4, seed: 2, profile: 'loss-tolerant' },
];

// The module's glue rethrows unhandled rejections from inside itself (node
// then prints the whole inlined module): every error is caught here.
async function main() {
  const D = await require('draco3d').createDecoderModule({});
  const M = await require(resolve(wasmPath))();
  let failures = 0, checked = 0;
  for (const file of files) {
    const glb = parseGlb(new Uint8Array(readFileSync(file)));
    const byProfile = { reliable: progressivePrimitives(glb, 'reliable'),
                        'loss-tolerant': progressivePrimitives(glb, 'loss-tolerant') };
    const prims = byProfile.reliable;
    if (prims.length === 0) {
      console.error(file + ': no progressive primitive');
      ++failures;
      continue;
    }
    const bases = prims.map((p) => decodeDracoBase(D, p.base, p.ids));
    for (const c of cases) {
      const prims = byProfile[c.profile];
      const native = execFileSync(referencePath, [file, '--loss', String(c.loss), '--burst', String(c.burst),
                                                  '--seed', String(c.seed), '--profile', c.profile], { encoding: 'utf8' })
                         .trim().split('\n').map((l) => l.split(' '));
      if (native.length !== prims.length) {
        console.error(`${file} (${c.name}): the native decoder has ${native.length} streams, the file ${prims.length}`);
        ++failures;
        continue;
      }
      prims.forEach((p, i) => {
        const d = new StreamDecoder(M, p.blob, p.streamId);
        try {
          d.setBase(bases[i]);
          d.decode({ loss: c.loss, burst: c.burst, seed: c.seed, reliable: p.reliable });
          const a = d.arrays();
          const got = [String(p.streamId), String(a.vertices), String(a.indices.length), d.hash()];
          ++checked;
          if (got.join(' ') !== native[i].join(' ')) {
            console.error(`${file} ${p.where} (${c.name}): wasm ${got.join(' ')} native ${native[i].join(' ')}`);
            ++failures;
          }
          if (c.loss === 0) {
            const live = decodeLive(M, p, bases[i]);
            ++checked;
            if (live.got.join(' ') !== native[i].join(' ') || String(live.finalVertices) !== native[i][1]) {
              console.error(`${file} ${p.where} (live): wasm ${live.got.join(' ')} (final ${live.finalVertices}) ` +
                            `native ${native[i].join(' ')}`);
              ++failures;
            }
          }
        } finally {
          d.close();
        }
      });
    }
    console.log(`${file}: ${prims.length} streams x ${cases.length} cases`);
  }
  console.log(`${checked} decodes compared, ${failures} differ`);
  return failures === 0 && checked > 0 ? 0 : 1;
}

main().then((code) => process.exit(code), (e) => {
  console.error('wasm_vs_native: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
