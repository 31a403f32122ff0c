// The browser's parsers of outside bytes under seeded random mutations
// (docs/design/web.md): what a server or a file hands web/src, mutated by bit flips,
// truncations, insertions, deletions, duplications and random bytes (and, for
// a .glb, by values swapped inside its JSON), a fixed seed per case so that
// any case is reproduced alone (--case N). The parsers:
//   - BlobReader.push (blob_reader.js) on the stream blobs of real progressive
//     files (`meshstream encode` of spot.obj, split and bundled), fed whole
//     and in random chunk sizes (empty chunks too);
//   - parseGlb with and without { truncated: true }, glbJsonEnd,
//     firstBlobOffset and progressivePrimitives (glb.js) on those files, on
//     their prefixes (what an HTTP range returns) and mutated;
//   - readServerMessage and datagramStream (session.js over protowire.js) on
//     real ServerMessages written with ProtoWriter after
//     proto/meshstream/v1/stream.proto (a SessionStart with the file's
//     header and base, every ControlBlock, RefinementEnd, StreamDatagram,
//     SessionEnd, TransportChange, RepairEnd) and mutated;
//   - openSessionSource (session.js) through a stand-in WebSocket that
//     delivers the real session of a file as its frames, with some frames
//     mutated, dropped, repeated or swapped.
// The properties:
//   - every call returns or throws an Error; a TypeError or a RangeError (a
//     bug of ours: a null read, an index out of range, a bad length), or a
//     thrown value that is not an Error, fails the case; openSessionSource
//     settles, rejecting only with such an Error;
//   - nothing hangs: the cases run in a worker thread, and a case that takes
//     more than 5 s fails the test, printed;
//   - BlobReader's events on an unmutated blob fed in any chunking equal
//     those of feeding it whole (and end with the blob done); on a mutated
//     blob the whole feed and any chunking end the same way (the same error,
//     or none) and their events agree;
//   - unmutated inputs parse to what was written: the ServerMessages'
//     fields, a datagram's stream, a prefix's blobs (null beyond it) and
//     bases, and the session's pieces equal the blob's events.
// A failing case prints its kind, its mutations, the input in hex (the first
// KiB; the whole input is written beside, its path printed) and the stack;
// failures of the same kind (message and place) are printed once, counted.
// usage: node parsers_fuzz.mjs --cli MESHSTREAM --models DIR [--cases N]
//          [--seed S] [--case N] [--max-failures N]
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { Worker, isMainThread, parentPort, workerData } from 'node:worker_threads';
import { BlobReader } from '../../web/src/blob_reader.js';
import { firstBlobOffset, glbJsonEnd, parseGlb, progressivePrimitives } from '../../web/src/glb.js';
import { ProtoWriter } from '../../web/src/protowire.js';
import { datagramStream, openSessionSource, readServerMessage } from '../../web/src/session.js';

// A case that gives no result for this long hangs: far above what any case
// takes on a loaded machine (milliseconds), so the verdict is never the
// scheduler's (the first case's clock includes the worker's start).
const HANG_MS = 30000;
const HEX_LIMIT = 1024;

// --- seeded randomness ---------------------------------------------------------

function mulberry32(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

class Rng {
  constructor(seed, index) {
    this.next = mulberry32(Math.imul(seed ^ 0x9e3779b9, 0x85ebca6b) ^ Math.imul(index + 1, 0xc2b2ae35));
  }
  int(n) { return Math.floor(this.next() * n); }  // 0 .. n-1
  range(lo, hi) { return lo + this.int(hi - lo + 1); }
  pick(list) { return list[this.int(list.length)]; }
  chance(p) { return this.next() < p; }
  bytes(n) {
    const out = new Uint8Array(n);
    for (let i = 0; i < n; ++i) out[i] = this.int(256);
    return out;
  }
}

const INTERESTING = [0x00, 0x01, 0x7f, 0x80, 0xff, 0xfe, 0x08, 0x0a, 0x10, 0x12, 0x22, 0x5b, 0x7b];

function concat(...parts) {
  const out = new Uint8Array(parts.reduce((n, p) => n + p.byteLength, 0));
  let at = 0;
  for (const p of parts) {
    out.set(p, at);
    at += p.byteLength;
  }
  return out;
}

// One to four byte-level mutations of `input` (a copy); `log` gets what was done.
function mutateBytes(rng, input, log) {
  let b = input.slice();
  const count = rng.range(1, 4);
  for (let k = 0; k < count; ++k) {
    const at = rng.int(b.byteLength + 1);
    switch (rng.int(8)) {
      case 0: {  // bit flips
        if (b.byteLength === 0) break;
        const flips = rng.range(1, 8);
        for (let i = 0; i < flips; ++i) {
          const p = rng.int(b.byteLength);
          b[p] ^= 1 << rng.int(8);
        }
        log.push(`flip ${flips} bits`);
        break;
      }
      case 1:  // truncation
        b = b.slice(0, at);
        log.push(`truncate at ${at}`);
        break;
      case 2: {  // insertion of random bytes
        const n = rng.range(1, 16);
        b = concat(b.subarray(0, at), rng.bytes(n), b.subarray(at));
        log.push(`insert ${n} at ${at}`);
        break;
      }
      case 3: {  // random bytes over
        const n = Math.min(rng.range(1, 16), b.byteLength - Math.min(at, b.byteLength));
        b.set(rng.bytes(n), Math.min(at, b.byteLength));
        log.push(`overwrite ${n} at ${at}`);
        break;
      }
      case 4: {  // an interesting byte
        if (b.byteLength === 0) break;
        const p = rng.int(b.byteLength);
        b[p] = rng.pick(INTERESTING);
        log.push(`byte ${b[p]} at ${p}`);
        break;
      }
      case 5: {  // deletion
        const n = rng.range(1, 64);
        b = concat(b.subarray(0, at), b.subarray(Math.min(at + n, b.byteLength)));
        log.push(`delete ${n} at ${at}`);
        break;
      }
      case 6: {  // duplication of a range
        const n = rng.range(1, 64);
        b = concat(b.subarray(0, at), b.subarray(at, at + n), b.subarray(at));
        log.push(`duplicate ${n} at ${at}`);
        break;
      }
      default: {  // a varint-sized run of 0xff / 0x80 (long or huge varints)
        const n = rng.range(1, 12);
        const run = new Uint8Array(n).fill(rng.chance(0.5) ? 0xff : 0x80);
        b = concat(b.subarray(0, at), run, b.subarray(at));
        log.push(`insert ${n} continuation bytes at ${at}`);
        break;
      }
    }
  }
  return b;
}

// The fields of a protobuf message, nested messages parsed too (a
// length-delimited field whose bytes parse whole as fields); null when
// `bytes` is not a message.
function protoFields(bytes, depth = 0) {
  const fields = [];
  let pos = 0;
  const varint = () => {
    let v = 0, scale = 1;
    for (let i = 0; i < 10; ++i) {
      if (pos >= bytes.byteLength) return null;
      const b = bytes[pos++];
      v += (b & 0x7f) * scale;
      scale *= 128;
      if ((b & 0x80) === 0) return v;
    }
    return null;
  };
  while (pos < bytes.byteLength) {
    const tag = varint();
    if (tag === null || tag < 8) return null;
    const field = { number: Math.floor(tag / 8), wire: tag % 8 };
    if (field.wire === 0) {
      field.value = varint();
      if (field.value === null) return null;
    } else if (field.wire === 1 || field.wire === 5) {
      const n = field.wire === 1 ? 8 : 4;
      if (pos + n > bytes.byteLength) return null;
      field.bytes = bytes.subarray(pos, pos + n);
      pos += n;
    } else if (field.wire === 2) {
      const n = varint();
      if (n === null || n > bytes.byteLength - pos) return null;
      field.bytes = bytes.subarray(pos, pos + n);
      pos += n;
      if (depth < 4 && n > 0) field.sub = protoFields(field.bytes, depth + 1);
    } else {
      return null;
    }
    fields.push(field);
  }
  return fields;
}

function lengthDelimited(bytes) {
  const w = new ProtoWriter();
  w.varint(bytes.byteLength);
  w.raw(bytes);
  return w.finish();
}

function protoBytes(fields) {
  const w = new ProtoWriter();
  for (const f of fields) {
    w.tag(f.number, f.wire);
    if (f.wire === 0) w.varint(f.value);
    else if (f.wire === 2) w.raw(lengthDelimited(f.sub ? protoBytes(f.sub) : f.bytes));
    else w.raw(f.bytes);
  }
  return w.finish();
}

// Every field list of the message (the top one and the nested ones).
function fieldLists(fields, out = []) {
  out.push(fields);
  for (const f of fields) if (f.sub) fieldLists(f.sub, out);
  return out;
}

// One to three field-level changes of a message: a field dropped, repeated,
// renumbered, given another wire type, or a varint set to an odd value.
function mutateProto(rng, bytes, log) {
  const fields = protoFields(bytes);
  if (fields === null) return mutateBytes(rng, bytes, log);
  const count = rng.range(1, 3);
  for (let k = 0; k < count; ++k) {
    const lists = fieldLists(fields).filter((l) => l.length > 0);
    if (lists.length === 0) break;
    const list = rng.pick(lists);
    const i = rng.int(list.length);
    const f = list[i];
    switch (rng.int(5)) {
      case 0:
        list.splice(i, 1);
        log.push(`drop field ${f.number}`);
        break;
      case 1:
        list.splice(i, 0, structuredClone(f));
        log.push(`repeat field ${f.number}`);
        break;
      case 2: {
        const number = rng.pick([1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 15, 16, 100, 536870911]);
        log.push(`field ${f.number} renumbered ${number}`);
        f.number = number;
        break;
      }
      case 3: {
        // Another wire type, its payload kept in a shape that still frames.
        const wire = rng.pick([0, 1, 2, 5]);
        log.push(`field ${f.number} wire ${f.wire} -> ${wire}`);
        const payload = f.wire === 2 ? (f.sub ? protoBytes(f.sub) : f.bytes) : f.bytes || new Uint8Array(0);
        delete f.sub;
        f.wire = wire;
        if (wire === 0) f.value = f.value !== undefined ? f.value : payload.byteLength;
        else if (wire === 1) f.bytes = new Uint8Array(8);
        else if (wire === 5) f.bytes = new Uint8Array(4);
        else f.bytes = f.value !== undefined ? Uint8Array.of(f.value & 0x7f) : payload;
        break;
      }
      default: {
        const value = rng.pick([0, 1, 255, 256, 2 ** 31, 2 ** 32, 2 ** 53 - 1, rng.int(1 << 20)]);
        if (f.wire === 0) {
          log.push(`field ${f.number} = ${value}`);
          f.value = value;
        } else {
          list.splice(i, 1);
          log.push(`drop field ${f.number}`);
        }
      }
    }
  }
  return protoBytes(fields);
}

// --- the inputs: real files, their blobs, their session ------------------------

const pad4 = (n) => (n + 3) & ~3;

function glbOf(json, bin) {
  const text = new TextEncoder().encode(JSON.stringify(json));
  const jsonLength = pad4(text.byteLength);
  const binLength = bin ? pad4(bin.byteLength) : 0;
  const total = 12 + 8 + jsonLength + (bin ? 8 + binLength : 0);
  const out = new Uint8Array(total);
  const dv = new DataView(out.buffer);
  dv.setUint32(0, 0x46546c67, true);
  dv.setUint32(4, 2, true);
  dv.setUint32(8, total, true);
  dv.setUint32(12, jsonLength, true);
  dv.setUint32(16, 0x4e4f534a, true);
  out.fill(0x20, 20, 20 + jsonLength);
  out.set(text, 20);
  if (bin) {
    dv.setUint32(20 + jsonLength, binLength, true);
    dv.setUint32(24 + jsonLength, 0x004e4942, true);
    out.set(bin, 28 + jsonLength);
  }
  return out;
}

function blobEventsWhole(blob) {
  const r = new BlobReader();
  const events = r.push(blob);
  return { events, done: r.done };
}

// A ServerMessage with one field set: `kind` its number, `body` a writer.
function serverMessage(kind, body) {
  const m = new ProtoWriter();
  m.message(kind, body);
  return m.finish();
}

function fixed64(w, field, lo, hi) {
  w.tag(field, 1);
  const b = new Uint8Array(8);
  const dv = new DataView(b.buffer);
  dv.setUint32(0, lo, true);
  dv.setUint32(4, hi, true);
  w.raw(b);
}

// The messages of a session of one file, and what each must read back as.
function sessionOf(file, prims) {
  const messages = [];  // { bytes, expect, frame }
  const add = (kind, body, expect) => messages.push({ bytes: serverMessage(kind, body), expect, frame: 2 });
  const start = new ProtoWriter();
  start.string(1, 'session-0123');
  start.string(2, 'spot');
  start.int(3, 7);
  const expectPrims = [];
  const events = prims.map((p) => blobEventsWhole(p.blob).events);
  prims.forEach((p, i) => {
    const header = events[i][0].bytes;
    const refinements = events[i].filter((e) => e.kind === 'end').length;
    const w = new ProtoWriter();
    w.uint(1, p.streamId);
    w.uint(2, p.mesh);
    w.uint(3, p.primitive);
    w.bytesField(4, header);
    w.bytesField(5, p.base);
    w.uint(6, refinements);
    for (const [name, id] of [['POSITION', p.ids.position], ['NORMAL', p.ids.normal]]) {
      if (id < 0) continue;
      const entry = new ProtoWriter();
      entry.string(1, name);
      entry.int(2, id);
      w.message(7, entry);
    }
    const levels = new ProtoWriter();  // packed repeated uint32
    for (let k = 1; k <= refinements; ++k) levels.varint(k);
    w.message(8, levels);
    start.message(4, w);
    expectPrims.push({ primitive: p.streamId, mesh: p.mesh, meshPrimitive: p.primitive, header, base: p.base,
                       refinements });
  });
  start.uint(5, 2);  // TRANSPORT_GRPC
  fixed64(start, 7, 0xdeadbeef, 0x01234567);
  start.bytesField(8, new Uint8Array(32).fill(1));
  start.bytesField(9, new Uint8Array(32).fill(2));
  start.uint(10, 1200);
  start.bytesField(11, file.subarray(0, 64));
  add(1, start, { kind: 'start', sessionId: 'session-0123', transport: 2, primitives: expectPrims });

  const frames = [{ type: 2, bytes: messages[0].bytes }];
  const pieces = [];  // what take() must get: [stream, kind, refinement, bytes | datagrams]
  prims.forEach((p, i) => pieces.push([p.streamId, 'header', undefined, events[i][0].bytes]));
  prims.forEach((p, i) => {
    for (const e of events[i].slice(1)) {
      if (e.kind === 'control') {
        const datagrams = events[i].filter((x) => x.kind === 'datagram' && x.refinement === e.refinement).length;
        const c = new ProtoWriter();
        c.uint(1, p.streamId);
        c.uint(2, e.refinement);
        c.bytesField(3, e.bytes);
        c.uint(4, datagrams);
        fixed64(c, 5, e.refinement * 1000, 0);
        c.bool(6, e.refinement === 0);
        c.bool(7, true);
        add(2, c, { kind: 'control', primitive: p.streamId, refinement: e.refinement, control: e.bytes, datagrams });
        frames.push({ type: 2, bytes: messages[messages.length - 1].bytes });
        pieces.push([p.streamId, 'control', e.refinement, e.bytes]);
      } else if (e.kind === 'datagram') {
        // A datagram in a ServerMessage (the gRPC shape) for the parser, and as
        // a type-3 frame (the socket's) for the session.
        const d = new ProtoWriter();
        d.bytesField(1, e.bytes);
        add(4, d, { kind: 'datagram', payload: e.bytes });
        messages.push({ bytes: e.bytes, expect: { stream: p.streamId }, frame: 3 });
        frames.push({ type: 3, bytes: e.bytes });
        pieces.push([p.streamId, 'datagram', -1, e.bytes]);
      } else if (e.kind === 'end') {
        const r = new ProtoWriter();
        r.uint(1, p.streamId);
        r.uint(2, e.refinement);
        r.uint(3, e.datagrams);
        add(3, r, { kind: 'refinementEnd', primitive: p.streamId, refinement: e.refinement, datagrams: e.datagrams });
        frames.push({ type: 2, bytes: messages[messages.length - 1].bytes });
        pieces.push([p.streamId, 'end', e.refinement, e.datagrams]);
      }
    }
  });
  const change = new ProtoWriter();
  change.uint(1, 2);
  change.string(2, 'udp blocked: falling back to the stream');
  add(6, change, { kind: 'transportChange', transport: 2, reason: 'udp blocked: falling back to the stream' });
  const repair = new ProtoWriter();
  repair.uint(1, 3);
  repair.uint(2, 4000);
  add(7, repair, { kind: 'unknown' });
  const end = new ProtoWriter();
  end.string(1, 'complete');
  add(5, end, { kind: 'end', reason: 'complete' });
  frames.push({ type: 2, bytes: messages[messages.length - 1].bytes });
  return { messages, frames, pieces };
}

function loadInputs(files) {
  const inputs = [];
  for (const [name, bytes] of files) {
    const file = new Uint8Array(bytes);
    const glb = parseGlb(file);
    const prims = progressivePrimitives(glb);
    if (prims.length === 0) throw new Error(name + ': no refined primitive');
    for (const p of prims) {
      if (!p.blob) throw new Error(name + ': a blob is missing');
      const whole = blobEventsWhole(p.blob);
      if (!whole.done) throw new Error(name + ': the blob does not end');
    }
    const session = sessionOf(file, prims);
    inputs.push({ name, file, glb, prims, session, jsonEnd: glbJsonEnd(file) });
  }
  return inputs;
}

// --- checking -------------------------------------------------------------------

class Failure extends Error {}

function isOurBug(e) {
  return !(e instanceof Error) || e instanceof TypeError || e instanceof RangeError;
}

// Runs `fn`; returns { value } or { error }; a TypeError/RangeError is a failure.
function guarded(what, fn) {
  try {
    return { value: fn() };
  } catch (e) {
    if (e instanceof Failure) throw e;
    if (isOurBug(e)) {
      const f = new Failure(`${what} threw ${e && e.constructor ? e.constructor.name : typeof e}: ${e && e.message}`);
      f.cause = e;
      throw f;
    }
    return { error: e };
  }
}

function expect(condition, message) {
  if (!condition) throw new Failure(message);
}

function sameBytes(a, b) {
  if (!(a instanceof Uint8Array) || !(b instanceof Uint8Array) || a.byteLength !== b.byteLength) return false;
  for (let i = 0; i < a.byteLength; ++i) if (a[i] !== b[i]) return false;
  return true;
}

function sameEvent(a, b) {
  return a.kind === b.kind && a.refinement === b.refinement && a.datagrams === b.datagrams &&
         (a.bytes === undefined ? b.bytes === undefined : sameBytes(a.bytes, b.bytes));
}

function showEvent(e) {
  if (!e) return '(none)';
  return `${e.kind}${e.refinement === undefined ? '' : ' ' + e.refinement}` +
         (e.bytes ? ` ${e.bytes.byteLength} bytes` : '') + (e.datagrams === undefined ? '' : ` ${e.datagrams} datagrams`);
}

// The blob fed in `chunks` (sizes, the rest at the end): events, error, done.
function feed(blob, sizes, what) {
  const r = new BlobReader();
  const events = [];
  let at = 0;
  const pushes = sizes.concat([blob.byteLength]);
  for (const size of pushes) {
    const end = Math.min(blob.byteLength, at + size);
    const got = guarded(`${what}: BlobReader.push(bytes ${at}..${end})`, () => r.push(blob.subarray(at, end)));
    if (got.error) return { events, error: got.error.message, done: r.done };
    expect(Array.isArray(got.value), `${what}: push returned no array`);
    events.push(...got.value);
    at = end;
    if (at >= blob.byteLength) break;
  }
  return { events, error: null, done: r.done };
}

function randomChunks(rng, length) {
  const sizes = [];
  const style = rng.int(4);
  for (let at = 0; at < length;) {
    let n;
    if (style === 0) n = rng.range(1, 3);
    else if (style === 1) n = rng.range(0, 64);
    else if (style === 2) n = rng.pick([0, 1, 5, 997, 4096, rng.range(1, length)]);
    else n = rng.range(0, Math.max(1, length >> 2));
    sizes.push(n);
    at += n;
  }
  return sizes;
}

function compareFeeds(what, a, b, exact) {
  if (exact) {
    expect(a.error === b.error, `${what}: the whole feed ${a.error ? 'threw "' + a.error + '"' : 'passed'}, ` +
                                `the chunked one ${b.error ? 'threw "' + b.error + '"' : 'passed'}`);
  }
  const n = Math.min(a.events.length, b.events.length);
  for (let i = 0; i < n; ++i) {
    expect(sameEvent(a.events[i], b.events[i]),
           `${what}: event ${i} differs: ${showEvent(a.events[i])} whole, ${showEvent(b.events[i])} chunked`);
  }
  if (exact && !a.error) {
    expect(a.events.length === b.events.length && a.done === b.done,
           `${what}: ${a.events.length} events whole, ${b.events.length} chunked`);
  }
}

// --- the cases ------------------------------------------------------------------

function caseBlob(rng, inputs, mutate) {
  const input = rng.pick(inputs);
  const prim = rng.pick(input.prims);
  const log = [`${input.name} stream ${prim.streamId} blob`];
  const blob = mutate ? mutateBytes(rng, prim.blob, log) : prim.blob;
  const chunkings = [randomChunks(rng, blob.byteLength), randomChunks(rng, blob.byteLength)];
  return {
    log, input: blob,
    run() {
      const whole = feed(blob, [], 'whole');
      for (const [k, sizes] of chunkings.entries()) {
        const chunked = feed(blob, sizes, `chunking ${k} (${sizes.length} pushes)`);
        compareFeeds(`chunking ${k}`, whole, chunked, true);
      }
      if (!mutate) {
        expect(!whole.error && whole.done, 'the unmutated blob ' + (whole.error ? 'threw ' + whole.error : 'did not end'));
        expect(whole.events.length > 2 && whole.events[0].kind === 'header' &&
               whole.events[whole.events.length - 1].kind === 'end', 'the unmutated blob gave no refinement');
      }
    },
  };
}

// Every place in the JSON (keys and indices from the root), where a value
// can be swapped.
function jsonPaths(value, path = [], out = []) {
  out.push(path);
  if (value && typeof value === 'object') {
    for (const key of Object.keys(value)) jsonPaths(value[key], path.concat([key]), out);
  }
  return out;
}

const ODD_VALUES = [null, -1, 0, 1, 2, 1.5, -0.5, 1e300, 2 ** 53 + 2, 4294967296, '', '0', 'x', true, false, [],
  {}, [null], { bufferView: 0 }, [0, 1], { POSITION: 'x' }];

function mutateJson(rng, input, log) {
  const json = structuredClone(input.glb.json);
  const count = rng.range(1, 3);
  for (let k = 0; k < count; ++k) {
    const paths = jsonPaths(json).filter((p) => p.length > 0);
    const path = rng.pick(paths);
    let parent = json;
    for (const key of path.slice(0, -1)) parent = parent[key];
    const key = path[path.length - 1];
    if (rng.chance(0.15) && !Array.isArray(parent)) {
      delete parent[key];
      log.push(`delete ${path.join('.')}`);
    } else {
      const v = structuredClone(rng.pick(ODD_VALUES));
      parent[key] = v;
      log.push(`${path.join('.')} = ${JSON.stringify(v)}`);
    }
  }
  return glbOf(json, input.glb.bin);
}

function checkGlb(bytes, what, input, unmutatedPrefix) {
  const end = guarded(`${what}: glbJsonEnd`, () => glbJsonEnd(bytes));
  for (const truncated of [false, true]) {
    const label = `${what}: parseGlb(truncated: ${truncated})`;
    const parsed = guarded(label, () => parseGlb(bytes, { truncated }));
    if (unmutatedPrefix && truncated && end.value !== null && end.value !== undefined &&
        bytes.byteLength >= end.value + 8) {
      expect(!parsed.error, `${label} of an unmutated prefix of ${bytes.byteLength} bytes threw ${parsed.error && parsed.error.message}`);
    }
    if (parsed.error) continue;
    const glb = parsed.value;
    guarded(`${label}: firstBlobOffset`, () => firstBlobOffset(glb.json, glb.binOffset, bytes.byteLength));
    const prims = guarded(`${label}: progressivePrimitives`, () => progressivePrimitives(glb));
    if (prims.error || !unmutatedPrefix) {
      if (!prims.error && glb.bin) {
        // Whatever a mutated file says, a blob or base returned lies within the
        // binary chunk, at its bufferView's place.
        for (const p of prims.value) {
          for (const [name, b] of [['blob', p.blob], ['base', p.base]]) {
            if (b === null) continue;
            expect(b instanceof Uint8Array && b.buffer === bytes.buffer &&
                   b.byteOffset >= glb.bin.byteOffset && b.byteOffset + b.byteLength <= glb.bin.byteOffset + glb.bin.byteLength,
                   `${label}: ${p.where}'s ${name} lies outside the binary chunk`);
          }
        }
      }
      continue;
    }
    // An unmutated prefix: the same primitives, each blob whole or null, each
    // base whole.
    expect(prims.value.length === input.prims.length, `${label}: ${prims.value.length} primitives`);
    prims.value.forEach((p, i) => {
      const full = input.prims[i];
      expect(p.blob === null || sameBytes(p.blob, full.blob), `${label}: ${p.where}'s blob differs`);
      expect(sameBytes(p.base, full.base), `${label}: ${p.where}'s base differs`);
      const blobEnd = full.blobRange.end;
      expect((p.blob !== null) === (blobEnd <= bytes.byteLength), `${label}: ${p.where}'s blob ${p.blob ? 'is there' : 'is missing'}`);
    });
  }
}

function caseGlb(rng, inputs, how) {
  const input = rng.pick(inputs);
  const log = [`${input.name} ${how}`];
  let bytes;
  if (how === 'prefix') {
    const at = rng.chance(0.5) ? rng.range(input.jsonEnd, input.file.byteLength) : rng.range(0, input.file.byteLength);
    bytes = input.file.slice(0, at);
    log.push(`first ${at} bytes`);
  } else if (how === 'json') {
    bytes = mutateJson(rng, input, log);
    if (rng.chance(0.3)) bytes = mutateBytes(rng, bytes, log);
  } else {
    bytes = mutateBytes(rng, input.file, log);
  }
  return { log, input: bytes, run: () => checkGlb(bytes, 'glb', input, how === 'prefix') };
}

function checkReadBack(m, expected) {
  const mismatch = (field) => { throw new Failure(`the ${expected.kind} message read back with another ${field}`); };
  if (m.kind !== expected.kind) mismatch('kind: ' + m.kind);
  for (const [k, v] of Object.entries(expected)) {
    if (k === 'primitives') {
      if (m.primitives.length !== v.length) mismatch('primitive count');
      v.forEach((p, i) => {
        const q = m.primitives[i];
        for (const f of ['primitive', 'mesh', 'meshPrimitive', 'refinements']) if (q[f] !== p[f]) mismatch(f);
        if (!sameBytes(q.header, p.header) || !sameBytes(q.base, p.base)) mismatch('header or base');
      });
    } else if (v instanceof Uint8Array) {
      if (!sameBytes(m[k], v)) mismatch(k);
    } else if (m[k] !== v) {
      mismatch(k);
    }
  }
}

function caseMessage(rng, inputs, mutate) {
  const input = rng.pick(inputs);
  // The SessionStart (the richest message) a quarter of the time.
  const index = rng.chance(0.25) ? 0 : rng.int(input.session.messages.length);
  const message = input.session.messages[index];
  const log = [`${input.name} message ${index} (${message.expect.kind || 'datagram of stream ' + message.expect.stream})`];
  const bytes = !mutate ? message.bytes
                : message.frame === 2 && rng.chance(0.5) ? mutateProto(rng, message.bytes, log)
                : mutateBytes(rng, message.bytes, log);
  return {
    log, input: bytes,
    run() {
      const m = guarded('readServerMessage', () => readServerMessage(bytes));
      const s = guarded('datagramStream', () => datagramStream(bytes));
      expect(s.error === undefined, 'datagramStream threw ' + (s.error && s.error.message));
      expect(Number.isInteger(s.value) && s.value >= -1, 'datagramStream gave ' + s.value);
      if (mutate) return;
      if (message.frame === 3) {
        expect(s.value === message.expect.stream, `datagramStream gave ${s.value}, not ${message.expect.stream}`);
      } else {
        expect(!m.error, 'readServerMessage threw on a real message: ' + (m.error && m.error.message));
        checkReadBack(m.value, message.expect);
      }
    },
  };
}

// A WebSocket that delivers `frames` once opened; sent frames are kept.
class StandInSocket {
  constructor(url, protocols) {
    this.url = url;
    this.protocols = protocols;
    this.sent = [];
    this.closed = null;
    StandInSocket.last = this;
  }
  send(bytes) { this.sent.push(bytes); }
  close(code) { this.closed = code; }
}

async function runSession(input, frames, log) {
  globalThis.WebSocket = StandInSocket;
  const job = { abort: new AbortController(), stats: { bytes: 0 }, streams: new Map() };
  for (const p of input.prims) job.streams.set(p.streamId, { baseBytes: p.base });
  const taken = [];
  let settled = null;
  const promise = guarded('openSessionSource', () => openSessionSource(
    job, { url: 'ws://127.0.0.1:7680/v1/stream', asset: 'spot', version: 0, token: 'mst_x' },
    (stream, event) => taken.push([stream, event])));
  expect(!promise.error, 'openSessionSource threw ' + (promise.error && promise.error.message));
  promise.value.then((v) => { settled = { value: v }; }, (e) => { settled = { error: e }; });
  const ws = StandInSocket.last;
  ws.onopen();
  for (const f of frames) {
    guarded('onmessage', () => ws.onmessage({ data: f.slice().buffer }));
    if (ws.closed !== null) break;
  }
  guarded('onclose', () => ws.onclose({ code: 1006, reason: '' }));
  for (let i = 0; i < 10 && settled === null; ++i) await null;
  expect(settled !== null, 'openSessionSource never settled');
  if (settled.error !== undefined) {
    const e = settled.error;
    if (isOurBug(e)) {
      const f = new Failure(`openSessionSource rejected with ${e && e.constructor ? e.constructor.name : typeof e}: ${e && e.message}`);
      f.cause = e;
      throw f;
    }
  } else {
    expect(typeof settled.value === 'string', 'openSessionSource resolved with ' + typeof settled.value);
  }
  return { settled, taken, ws };
}

function caseSession(rng, inputs, mutate) {
  const input = rng.pick(inputs);
  const log = [`${input.name} session`];
  let frames = input.session.frames.map((f) => concat(Uint8Array.of(f.type), f.bytes));
  if (mutate) {
    const changes = rng.range(1, 3);
    for (let k = 0; k < changes; ++k) {
      const what = rng.int(6);
      const i = what <= 2 && rng.chance(0.3) ? 0 : rng.int(frames.length);  // the start often
      if (what <= 2) {
        const sub = [];
        if (frames[i][0] === 2 && rng.chance(0.6)) {
          frames[i] = concat(frames[i].subarray(0, 1), mutateProto(rng, frames[i].subarray(1), sub));
        } else {
          frames[i] = mutateBytes(rng, frames[i], sub);
        }
        log.push(`frame ${i}: ${sub.join(', ')}`);
      } else if (what === 3) {
        frames.splice(i, 1);
        log.push(`drop frame ${i}`);
      } else if (what === 4) {
        frames.splice(i, 0, frames[i]);
        log.push(`repeat frame ${i}`);
      } else {
        const j = rng.int(frames.length);
        [frames[i], frames[j]] = [frames[j], frames[i]];
        log.push(`swap frames ${i} and ${j}`);
      }
    }
  }
  return {
    log, input: frames,
    async run() {
      const { settled, taken, ws } = await runSession(input, frames, log);
      if (mutate) return;
      expect(settled.value === 'complete', 'the real session did not end complete: ' +
             (settled.error ? settled.error.message : settled.value));
      const pieces = input.session.pieces;
      expect(taken.length === pieces.length, `the session gave ${taken.length} pieces, the blob ${pieces.length}`);
      taken.forEach(([stream, e], i) => {
        const [s, kind, refinement, payload] = pieces[i];
        const same = stream === s && e.kind === kind && (refinement === undefined || e.refinement === refinement) &&
                     (kind === 'end' ? e.datagrams === payload : sameBytes(e.bytes, payload));
        expect(same, `session piece ${i}: ${showEvent(e)} of stream ${stream}, expected ${kind} of stream ${s}`);
      });
      expect(ws.closed === 1000 && ws.sent.length > 1 && ws.sent[0][0] === 1, 'the session did not open, report and close');
    },
  };
}

const KINDS = [
  ['blob', (rng, inputs) => caseBlob(rng, inputs, false)],
  ['blob mutated', (rng, inputs) => caseBlob(rng, inputs, true)],
  ['blob mutated', (rng, inputs) => caseBlob(rng, inputs, true)],
  ['glb prefix', (rng, inputs) => caseGlb(rng, inputs, 'prefix')],
  ['glb mutated', (rng, inputs) => caseGlb(rng, inputs, 'bytes')],
  ['glb json', (rng, inputs) => caseGlb(rng, inputs, 'json')],
  ['glb json', (rng, inputs) => caseGlb(rng, inputs, 'json')],
  ['message', (rng, inputs) => caseMessage(rng, inputs, false)],
  ['message mutated', (rng, inputs) => caseMessage(rng, inputs, true)],
  ['message mutated', (rng, inputs) => caseMessage(rng, inputs, true)],
  ['session', (rng, inputs) => caseSession(rng, inputs, false)],
  ['session mutated', (rng, inputs) => caseSession(rng, inputs, true)],
];

function makeCase(seed, index, inputs) {
  const rng = new Rng(seed, index);
  const [kind, make] = KINDS[index % KINDS.length];
  const c = make(rng, inputs);
  c.kind = kind;
  return c;
}

function hex(bytes) {
  const shown = bytes.subarray(0, HEX_LIMIT);
  let s = Buffer.from(shown.buffer, shown.byteOffset, shown.byteLength).toString('hex');
  if (bytes.byteLength > HEX_LIMIT) s += `... (${bytes.byteLength} bytes)`;
  return s;
}

// What a failing case prints: its kind, mutations and input (the whole of it
// written to a file), then the message and stack.
function describe(seed, index, c, outDir) {
  const lines = [`case ${index} (seed ${seed}, ${c.kind}): ${c.log.join('; ')}`];
  const parts = Array.isArray(c.input) ? c.input : [c.input];
  if (Array.isArray(c.input)) lines.push(`  ${parts.length} frames (type byte first)`);
  // A frame sequence as one frame a line in hex, other inputs as their bytes.
  const file = join(outDir, `parsers_fuzz-case-${index}.${Array.isArray(c.input) ? 'hex' : 'bin'}`);
  if (Array.isArray(c.input)) {
    writeFileSync(file, parts.map((p) => Buffer.from(p).toString('hex')).join('\n') + '\n');
  } else {
    writeFileSync(file, c.input);
  }
  if (Array.isArray(c.input)) {
    parts.forEach((p, i) => {
      if (i < 3 || c.log.some((l) => l.includes(`frame ${i}`))) lines.push(`  frame ${i}: ${hex(p)}`);
    });
  } else {
    lines.push(`  input (${c.input.byteLength} bytes): ${hex(c.input)}`);
  }
  lines.push(`  the whole input: ${file}`);
  return lines.join('\n');
}

// --- the worker: runs the cases -------------------------------------------------

async function runCases({ files, seed, first, count, progress, maxFailures, outDir }) {
  const inputs = loadInputs(files);
  const counter = new Int32Array(progress);
  const failures = [];
  const kinds = new Map();
  for (let index = first; index < first + count; ++index) {
    Atomics.store(counter, 0, index);
    const c = makeCase(seed, index, inputs);
    kinds.set(c.kind, (kinds.get(c.kind) || 0) + 1);
    try {
      await c.run();
    } catch (e) {
      const cause = e.cause || e;
      const stack = String(cause && cause.stack);
      // Same failure: the same message without its numbers, at the same place in web/src.
      const where = (stack.split('\n').find((l) => l.includes('/web/src/')) || '').trim();
      const signature = where ? (cause && cause.constructor ? cause.constructor.name : '') + ' ' + where
                              : e.message.replace(/[0-9]+/g, 'N');
      const seen = failures.find((f) => f.signature === signature);
      if (seen) {
        seen.cases.push(index);
        continue;
      }
      const text = describe(seed, index, c, outDir) + '\n  ' + e.message +
                   (e instanceof Failure && !e.cause ? '' : '\n' + stack.split('\n').map((l) => '    ' + l).join('\n'));
      failures.push({ signature, text, cases: [index] });
      if (failures.length >= maxFailures) break;
    }
  }
  return { failures, kinds: [...kinds.entries()] };
}

if (!isMainThread) {
  runCases(workerData).then((result) => parentPort.postMessage(result));
}

// --- the main thread: files, the worker, the watchdog ---------------------------

function arg(args, flag, fallback) {
  const i = args.indexOf(flag);
  if (i < 0) {
    if (fallback === undefined) throw new Error('missing ' + flag);
    return fallback;
  }
  return args[i + 1];
}

async function main() {
  const args = process.argv.slice(2);
  const cli = arg(args, '--cli');
  const models = arg(args, '--models');
  const seed = Number(arg(args, '--seed', '20261205'));
  const only = arg(args, '--case', null);
  const count = only === null ? Number(arg(args, '--cases', '5000')) : 1;
  const first = only === null ? 0 : Number(only);
  const maxFailures = Number(arg(args, '--max-failures', '20'));

  const work = mkdtempSync(join(tmpdir(), 'parsers_fuzz-'));
  const outDir = mkdtempSync(join(tmpdir(), 'parsers_fuzz-failures-'));
  let failed = true;
  try {
    const files = [];
    for (const [name, extra] of [['spot-split', []], ['spot-bundled', ['--packing', 'bundled', '--packet-bytes', '300']]]) {
      const out = join(work, name + '.glb');
      execFileSync(cli, ['encode', join(models, 'spot.obj'), '-o', out, ...extra], { stdio: ['ignore', 'ignore', 'inherit'] });
      const b = readFileSync(out);
      files.push([name, b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength)]);
    }
    const started = Date.now();
    const progress = new SharedArrayBuffer(4);
    const worker = new Worker(new URL(import.meta.url), {
      workerData: { files, seed, first, count, progress, maxFailures, outDir },
    });
    const counter = new Int32Array(progress);
    const result = await new Promise((resolve, reject) => {
      let last = -1, since = Date.now();
      const watchdog = setInterval(() => {
        const now = Atomics.load(counter, 0);
        if (now !== last) {
          last = now;
          since = Date.now();
        } else if (Date.now() - since > HANG_MS) {
          clearInterval(watchdog);
          worker.terminate();
          // The case is made again here, from its seed, to be printed.
          const inputs = loadInputs(files);
          const c = makeCase(seed, now, inputs);
          resolve({ failures: [{ text: describe(seed, now, c, outDir) + `\n  hangs: no result after ${HANG_MS} ms`,
                               cases: [now] }], kinds: [], hung: true });
        }
      }, 200);
      worker.on('message', (r) => { clearInterval(watchdog); resolve(r); });
      worker.on('error', (e) => { clearInterval(watchdog); reject(e); });
    });
    await worker.terminate();
    const seconds = ((Date.now() - started) / 1000).toFixed(1);
    const kinds = result.kinds.map(([k, n]) => `${n} ${k}`).join(', ');
    if (result.failures.length > 0) {
      for (const f of result.failures) {
        const also = f.cases.length > 1 ? `\n  the same failure in ${f.cases.length - 1} other case(s): ` +
                     f.cases.slice(1, 21).join(' ') + (f.cases.length > 21 ? ' ...' : '') : '';
        console.error('FAIL ' + f.text + also + '\n');
      }
      const total = result.failures.reduce((n, f) => n + f.cases.length, 0);
      console.error(`parsers_fuzz: ${total} failing case(s) of ${result.failures.length} kind(s)${result.hung ? ' (a hang)' : ''} ` +
                    `(seed ${seed}; reproduce one with --case N); inputs in ${outDir}`);
      return;
    }
    console.log(`parsers_fuzz: ${count} cases (${kinds}) passed in ${seconds} s (seed ${seed})`);
    failed = false;
  } finally {
    rmSync(work, { recursive: true, force: true });
    if (!failed) rmSync(outDir, { recursive: true, force: true });
    process.exitCode = failed ? 1 : 0;
  }
}

if (isMainThread) {
  main().catch((e) => {
    console.error('parsers_fuzz: ' + (e && e.stack || e));
    process.exitCode = 1;
  });
}
