// A live session over WebSocket (docs/spec/streaming-protocol.md, "WebSocket
// transport"), in the worker: the same session as StreamService.Open, its
// protobuf messages in binary frames tagged by their first byte (1: a
// ClientMessage, 2: a ServerMessage, 3: a datagram, the codec's bytes). The
// refinements are handed to each stream's decoder as the blob reader's events
// are ('control', 'datagram', 'end'); the bases were decoded from the file's
// prefix, and the session's base bytes must equal them (a file and a session
// of different versions would not decode).
//
// source: { url (ws:// or wss://, path /v1/stream), asset, version (0: latest),
//           token (a bearer token, sent as the subprotocol "bearer.TOKEN",
//           which a browser can set where it cannot set headers) }

import { ProtoReader, ProtoWriter } from './protowire.js';

const FRAME_CLIENT = 1, FRAME_SERVER = 2, FRAME_DATAGRAM = 3;
const TRANSPORT_GRPC = 2;
// gRPC status codes, for a close code 4000 + code.
const CODES = ['OK', 'CANCELLED', 'UNKNOWN', 'INVALID_ARGUMENT', 'DEADLINE_EXCEEDED', 'NOT_FOUND', 'ALREADY_EXISTS',
  'PERMISSION_DENIED', 'RESOURCE_EXHAUSTED', 'FAILED_PRECONDITION', 'ABORTED', 'OUT_OF_RANGE', 'UNIMPLEMENTED',
  'INTERNAL', 'UNAVAILABLE', 'DATA_LOSS', 'UNAUTHENTICATED'];

function frame(type, body) {
  const out = new Uint8Array(1 + body.byteLength);
  out[0] = type;
  out.set(body, 1);
  return out;
}

// A View (docs/spec/streaming-protocol.md, "Views"): { camera: [x, y, z],
// viewProjection: 16 numbers, column-major, width, height } in pixels.
function viewWriter(view) {
  const v = new ProtoWriter();
  v.doubles(1, view.camera);
  v.doubles(2, view.viewProjection);
  v.uint(3, view.width);
  v.uint(4, view.height);
  return v;
}

export function openMessage({ asset, version = 0, lod = -1, view = null }) {
  const open = new ProtoWriter();
  open.string(1, asset);
  open.int(2, version);
  open.int(3, lod);
  open.uint(4, TRANSPORT_GRPC);
  if (view) open.message(9, viewWriter(view));
  const m = new ProtoWriter();
  m.message(1, open);
  return m.finish();
}

export function viewMessage(view) {
  const m = new ProtoWriter();
  m.message(5, viewWriter(view));
  return m.finish();
}

function reportMessage(r) {
  const report = new ProtoWriter();
  report.uint(1, r.primitive);
  report.uint(2, r.refinement);
  report.uint(3, r.received);
  report.uint(6, r.bytes);
  report.bool(7, true);
  const m = new ProtoWriter();
  m.message(2, report);
  return m.finish();
}

function doneMessage(reason) {
  const done = new ProtoWriter();
  done.string(1, reason);
  const m = new ProtoWriter();
  m.message(3, done);
  return m.finish();
}

function readPrimitiveStart(r) {
  const p = { primitive: 0, mesh: 0, meshPrimitive: 0, header: null, base: null, refinements: 0 };
  r.message({
    1: (x) => { p.primitive = x.varint(); },
    2: (x) => { p.mesh = x.varint(); },
    3: (x) => { p.meshPrimitive = x.varint(); },
    4: (x) => { p.header = x.bytes(); },
    5: (x) => { p.base = x.bytes(); },
    6: (x) => { p.refinements = x.varint(); },
  });
  return p;
}

// A ServerMessage: { kind, ... } of the fields the browser uses.
export function readServerMessage(bytes) {
  const r = new ProtoReader(bytes);
  let out = { kind: 'unknown' };
  r.message({
    1: (x) => {
      const start = { kind: 'start', primitives: [], transport: 0, sessionId: '' };
      x.sub().message({
        1: (y) => { start.sessionId = y.string(); },
        4: (y) => { start.primitives.push(readPrimitiveStart(y.sub())); },
        5: (y) => { start.transport = y.varint(); },
      });
      out = start;
    },
    2: (x) => {
      const c = { kind: 'control', primitive: 0, refinement: 0, control: new Uint8Array(0), datagrams: 0 };
      x.sub().message({
        1: (y) => { c.primitive = y.varint(); },
        2: (y) => { c.refinement = y.varint(); },
        3: (y) => { c.control = y.bytes(); },
        4: (y) => { c.datagrams = y.varint(); },
      });
      out = c;
    },
    3: (x) => {
      const e = { kind: 'refinementEnd', primitive: 0, refinement: 0, datagrams: 0 };
      x.sub().message({
        1: (y) => { e.primitive = y.varint(); },
        2: (y) => { e.refinement = y.varint(); },
        3: (y) => { e.datagrams = y.varint(); },
      });
      out = e;
    },
    4: (x) => {
      const d = { kind: 'datagram', payload: new Uint8Array(0) };
      x.sub().message({ 1: (y) => { d.payload = y.bytes(); } });
      out = d;
    },
    5: (x) => {
      const e = { kind: 'end', reason: '' };
      x.sub().message({ 1: (y) => { e.reason = y.string(); } });
      out = e;
    },
    6: (x) => {
      const t = { kind: 'transportChange', transport: 0, reason: '' };
      x.sub().message({ 1: (y) => { t.transport = y.varint(); }, 2: (y) => { t.reason = y.string(); } });
      out = t;
    },
    // A LevelPlan: the scene's levels after a view. The browser's levels are
    // each stream's own refinements, so only its arrival counts.
    8: (x) => {
      const l = { kind: 'levelPlan', firstChangedLevel: 0 };
      x.sub().message({ 1: (y) => { l.firstChangedLevel = y.varint(); } });
      out = l;
    },
  });
  return out;
}

// The stream number of a codec datagram (docs/spec/progressive-format.md,
// section 6: magic, version, kind, then the stream as a varint); -1 when
// malformed.
export function datagramStream(d) {
  if (d.byteLength < 4 || d[0] !== 0x4d) return -1;
  try {
    return new ProtoReader(d, 3).varint();
  } catch (e) {
    return -1;
  }
}

function sameBytes(a, b) {
  if (a.byteLength !== b.byteLength) return false;
  for (let i = 0; i < a.byteLength; ++i) if (a[i] !== b[i]) return false;
  return true;
}

// Runs the session until its SessionEnd; `take(streamId, event)` gets each
// stream's pieces. Resolves with the end's reason; rejects with the server's
// status (a close code 4000 + the gRPC code, its reason the message).
export function openSessionSource(job, source, take) {
  return new Promise((resolve, reject) => {
    const protocols = ['meshstream.v1'];
    if (source.token) protocols.push('bearer.' + source.token);
    const ws = new WebSocket(source.url, protocols);
    ws.binaryType = 'arraybuffer';
    let ended = false;
    let failed = false;
    const counts = new Map();  // "primitive/refinement" -> datagrams received
    const fail = (error) => {
      if (failed || ended) return;
      failed = true;
      try { ws.close(1000); } catch (e) { /* closing */ }
      reject(error);
    };
    job.abort.signal.addEventListener('abort', () => fail(new Error('closed')));
    ws.onopen = () => {
      ws.send(frame(FRAME_CLIENT, openMessage({ asset: source.asset, version: source.version || 0,
                                                 lod: source.lod === undefined ? -1 : source.lod,
                                                 view: job.view || null })));
      job.view = null;
      // Views the page sends during the session (the server acts on one a second).
      job.sendView = (view) => {
        if (ended || failed) return;
        ws.send(frame(FRAME_CLIENT, viewMessage(view)));
        job.stats.viewsSent = (job.stats.viewsSent || 0) + 1;
      };
    };
    ws.onerror = () => fail(new Error(source.url + ': the WebSocket failed'));
    ws.onclose = (event) => {
      if (ended || failed) return;
      const code = event.code >= 4000 && event.code < 4000 + CODES.length ? CODES[event.code - 4000] : 'closed ' + event.code;
      fail(new Error(`${source.url}: ${code}${event.reason ? ': ' + event.reason : ''}`));
    };
    ws.onmessage = (event) => {
      if (failed || ended) return;
      try {
        const bytes = new Uint8Array(event.data);
        if (bytes.byteLength === 0) throw new Error('an empty frame');
        job.stats.bytes += bytes.byteLength;
        const body = bytes.subarray(1);
        if (bytes[0] === FRAME_DATAGRAM) return datagram(body);
        if (bytes[0] !== FRAME_SERVER) throw new Error('a frame of type ' + bytes[0]);
        const m = readServerMessage(body);
        if (m.kind === 'start') {
          for (const p of m.primitives) {
            if (p.header === null || p.base === null) {
              throw new Error('primitive ' + p.primitive + ': the SessionStart has no header or no base mesh');
            }
            const s = job.streams.get(p.primitive);
            if (!s) throw new Error('the session has primitive ' + p.primitive + ', the file does not');
            if (!sameBytes(p.base, s.baseBytes)) {
              throw new Error('primitive ' + p.primitive + ': the session\'s base differs from the file\'s (another version?)');
            }
            take(p.primitive, { kind: 'header', bytes: p.header });
          }
          if (m.primitives.length !== job.streams.size) {
            throw new Error('the session has ' + m.primitives.length + ' primitives, the file ' + job.streams.size);
          }
        } else if (m.kind === 'control') {
          take(m.primitive, { kind: 'control', refinement: m.refinement, bytes: m.control });
        } else if (m.kind === 'datagram') {
          datagram(m.payload);
        } else if (m.kind === 'refinementEnd') {
          take(m.primitive, { kind: 'end', refinement: m.refinement, datagrams: m.datagrams });
          const key = m.primitive + '/' + m.refinement;
          ws.send(frame(FRAME_CLIENT, reportMessage({ primitive: m.primitive, refinement: m.refinement,
                                                       received: counts.get(key) || 0, bytes: job.stats.bytes })));
          counts.delete(key);
        } else if (m.kind === 'levelPlan') {
          job.stats.levelPlans = (job.stats.levelPlans || 0) + 1;
        } else if (m.kind === 'end') {
          ended = true;
          ws.send(frame(FRAME_CLIENT, doneMessage('complete')));
          ws.close(1000);
          resolve(m.reason);
        }
      } catch (e) {
        fail(e);
      }
    };
    function datagram(d) {
      const stream = datagramStream(d);
      if (!job.streams.has(stream)) return;  // malformed or another stream: dropped, as the reconstructor would
      if (d[2] !== 3) {  // not an END: counted for the refinement's report
        try {
          const r = new ProtoReader(d, 3);
          r.varint();
          const key = stream + '/' + r.varint();
          counts.set(key, (counts.get(key) || 0) + 1);
        } catch (e) {
          /* malformed: the reconstructor drops and counts it */
        }
      }
      take(stream, { kind: 'datagram', refinement: -1, bytes: d });
    }
  });
}
