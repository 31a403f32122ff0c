// The live session over WebSocket (docs/spec/streaming-protocol.md, "WebSocket
// transport") with a client of its own (`ws` from npm), against a real
// `meshstream serve --http-listen`:
//   - each asset streams to the end: the first message is a SessionStart
//     (TRANSPORT_GRPC), then per refinement its ControlBlock, type-3
//     datagrams and its RefinementEnd, then SessionEnd "complete" and a
//     close with 1000; fed to the wasm live decoder the stream gives the
//     native decode of the same file (hash, counts);
//   - the example bytes of the spec open a session;
//   - refusals: another site's Origin (403), subprotocols without
//     meshstream.v1 (400), a text message, an unknown frame type, a first
//     message that is not open, an unknown asset (4005), and with --auth no
//     token, a bad token (4016) and another tenant's asset (4005); a token
//     sent as the subprotocol "bearer.T" works; after all of it the server
//     still streams.
// usage: node ws_session_test.mjs --base http://HOST:PORT/ --reference BIN --wasm MODULE
//          [--token T --other-token T2] ASSET...
import { mkdtempSync, writeFileSync, rmSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { createRequire } from 'node:module';
import { LiveDecoder } from '../../web/src/decoder.js';
import { decodeDracoBase } from '../../web/src/draco_base.js';
import { datagramStream, openMessage, readServerMessage } from '../../web/src/session.js';
import { parseGlb, progressivePrimitives } from '../../web/src/glb.js';
import { flagTaker } from '../../web/tools/node_support.mjs';

const require = createRequire(import.meta.url);
const WebSocket = require('../../web/node_modules/ws');

const args = process.argv.slice(2);
const take = flagTaker(args);
const base = take('--base');
const reference = take('--reference');
const wasm = take('--wasm');
const token = take('--token', '');
const otherToken = take('--other-token', '');
const assets = args;
const wsUrl = new URL('v1/stream', base).href.replace(/^http/, 'ws');

let failures = 0;
function check(ok, what) {
  if (!ok) {
    console.error('FAIL: ' + what);
    ++failures;
  }
}

function frame(type, body) {
  const out = new Uint8Array(1 + body.byteLength);
  out[0] = type;
  out.set(body, 1);
  return out;
}

// Opens a socket; resolves { messages: [{type, bytes}], code, reason } when
// it closes, or { status } when the upgrade was refused.
function session({ protocols = ['meshstream.v1'], headers = {}, send = [], origin } = {}) {
  return new Promise((resolve) => {
    const options = { headers: Object.assign({}, headers) };
    if (origin) options.origin = origin;
    const ws = new WebSocket(wsUrl, protocols, options);
    const messages = [];
    ws.binaryType = 'nodebuffer';
    ws.on('unexpected-response', (req, res) => {
      resolve({ status: res.statusCode });
      req.destroy();
    });
    ws.on('open', () => {
      for (const m of send) ws.send(m.text !== undefined ? m.text : m);
    });
    ws.on('message', (data, binary) => {
      const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
      messages.push({ type: bytes[0], bytes: bytes.slice(1), binary });
      if (bytes[0] === 2) {
        const m = readServerMessage(bytes.slice(1));
        if (m.kind === 'end') ws.send(frame(1, Uint8Array.from([0x1a, 0x0a, 0x0a, 0x08, ...Buffer.from('complete')])));
      }
    });
    ws.on('close', (code, reason) => resolve({ messages, code, reason: reason.toString() }));
    ws.on('error', () => {});
  });
}

const authHeaders = (t) => (t ? { Authorization: 'Bearer ' + t } : {});

async function nativeOf(asset, work, M, D) {
  const response = await fetch(new URL(`v1/assets/${asset}/versions/latest/progressive`, base), { headers: authHeaders(token) });
  if (!response.ok) throw new Error(`${asset}: HTTP ${response.status}`);
  const bytes = new Uint8Array(await response.arrayBuffer());
  const file = join(work, asset + '.glb');
  writeFileSync(file, bytes);
  const lines = execFileSync(reference, [file, '--loss', '0', '--burst', '0', '--seed', '1'], { encoding: 'utf8' }).trim().split('\n');
  const prims = progressivePrimitives(parseGlb(bytes));
  return { lines, prims, bases: prims.map((p) => decodeDracoBase(D, p.base, p.ids)) };
}

async function streamOne(asset, M, D, work, extra = {}) {
  const native = await nativeOf(asset, work, M, D);
  const r = await session(Object.assign({ headers: authHeaders(token), send: [frame(1, openMessage({ asset }))] }, extra));
  if (r.status) return check(false, `${asset}: upgrade refused with ${r.status}`);
  check(r.code === 1000, `${asset}: closed with ${r.code} ${r.reason}`);
  const decoders = new Map();
  const order = [];
  let ended = null;
  let datagrams = 0;
  try {
    for (const m of r.messages) {
      check(m.binary, `${asset}: a text message`);
      if (m.type === 3) {
        ++datagrams;
        const d = decoders.get(datagramStream(m.bytes));
        check(d !== undefined, `${asset}: a datagram of an unknown stream`);
        if (d) d.datagram(m.bytes);
        continue;
      }
      check(m.type === 2, `${asset}: a message of type ${m.type}`);
      const s = readServerMessage(m.bytes);
      order.push(s.kind);
      if (s.kind === 'start') {
        check(order.length === 1, `${asset}: the SessionStart is not first`);
        check(s.transport === 2, `${asset}: transport ${s.transport}, not TRANSPORT_GRPC`);
        for (const p of s.primitives) {
          const d = new LiveDecoder(M, p.header, p.primitive);
          d.setBase(native.bases[p.primitive]);
          decoders.set(p.primitive, d);
        }
      } else if (s.kind === 'control') {
        decoders.get(s.primitive).control(s.control);
      } else if (s.kind === 'refinementEnd') {
        const d = decoders.get(s.primitive);
        d.end(s.refinement, s.datagrams);
        check(d.poll() === s.refinement + 1, `${asset}: refinement ${s.refinement} not decoded at its RefinementEnd`);
      } else if (s.kind === 'end') {
        ended = s.reason;
      }
    }
    check(ended === 'complete', `${asset}: SessionEnd ${ended}`);
    check(decoders.size === native.prims.length, `${asset}: ${decoders.size} primitives, the file ${native.prims.length}`);
    for (const [id, d] of decoders) {
      d.snapshot();
      const a = d.arrays();
      const got = [String(id), String(a.vertices), String(a.indices.length), d.hash()].join(' ');
      check(got === native.lines[id], `${asset} stream ${id}: ${got}, native ${native.lines[id]}`);
    }
  } finally {
    for (const d of decoders.values()) d.close();
  }
  console.log(`${asset}: ${r.messages.length} messages (${datagrams} datagrams), ${decoders.size} streams as the native decode`);
}

async function refused(what, options, expect) {
  const r = await session(options);
  if (typeof expect === 'number' && expect < 1000) {
    check(r.status === expect, `${what}: expected HTTP ${expect}, got ${r.status || 'close ' + r.code}`);
  } else {
    check(r.code === expect, `${what}: expected close ${expect}, got ${r.status ? 'HTTP ' + r.status : r.code + ' ' + r.reason}`);
  }
  console.log(`${what}: ${r.status ? 'HTTP ' + r.status : 'close ' + r.code + ' ' + r.reason}`);
}

async function main() {
  const M = await require(resolve(wasm))();
  const D = await require('../../web/node_modules/draco3d').createDecoderModule({});
  const work = mkdtempSync(join(tmpdir(), 'meshstream-ws-'));
  try {
    for (const asset of assets) await streamOne(asset, M, D, work);
    // Sessions whose client closes the moment SessionEnd arrives, without
    // `done` (the server's last writes and its close race the client's):
    // each must end, and the next must stream. A session's end once stopped
    // the server's send loop for good (its last reference dropped on the
    // send loop's thread); the loop of the next session would hang.
    for (let i = 0; i < 20; ++i) {
      const r = await new Promise((resolve) => {
        const ws = new WebSocket(wsUrl, ['meshstream.v1'], { headers: authHeaders(token) });
        const timer = setTimeout(() => { ws.terminate(); resolve('stalled'); }, 20000);
        ws.on('open', () => ws.send(frame(1, openMessage({ asset: assets[0] }))));
        ws.on('message', (data) => {
          const b = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
          if (b[0] === 2 && readServerMessage(b.slice(1)).kind === 'end') (i % 2 ? ws.terminate() : ws.close(1000));
        });
        ws.on('close', () => { clearTimeout(timer); resolve('ended'); });
        ws.on('error', () => {});
      });
      check(r === 'ended', `abrupt session ${i}: ${r}`);
    }
    console.log('20 sessions closed by their client at SessionEnd: every one ended');
    const open = frame(1, openMessage({ asset: assets[0] }));
    const h = authHeaders(token);
    await refused('another origin', { headers: h, origin: 'http://evil.example', send: [open] }, 403);
    await refused('subprotocols without meshstream.v1', { protocols: ['chat'], headers: h, send: [open] }, 400);
    await refused('a text message', { headers: h, send: [{ text: 'hello' }] }, 4003);
    await refused('an unknown frame type', { headers: h, send: [frame(7, new Uint8Array([1]))] }, 4003);
    await refused('a first message that is not open', { headers: h, send: [frame(1, Uint8Array.from([0x1a, 0]))] }, 4003);
    await refused('a ClientMessage that does not parse', { headers: h, send: [frame(1, Uint8Array.from([0x0a, 0x7f]))] }, 4003);
    await refused('an unknown asset', { headers: h, send: [frame(1, openMessage({ asset: 'no-such-asset' }))] }, 4005);
    if (token) {
      await refused('no token', { send: [open] }, 4016);
      await refused('a bad token', { headers: authHeaders('ms_bad'), send: [open] }, 4016);
      await refused('a bad token as a subprotocol', { protocols: ['meshstream.v1', 'bearer.ms_bad'], send: [open] }, 4016);
      if (otherToken) await refused("another tenant's asset", { headers: authHeaders(otherToken), send: [open] }, 4005);
      // The browser's way: the token as a subprotocol, the page's own origin.
      await streamOne(assets[0], M, D, work, { headers: {}, protocols: ['meshstream.v1', 'bearer.' + token],
                                              origin: new URL(base).origin });
    } else {
      await streamOne(assets[0], M, D, work, { origin: new URL(base).origin });
    }
  } finally {
    rmSync(work, { recursive: true, force: true });
  }
  console.log(failures === 0 ? 'ws_session_test: every check passed' : `ws_session_test: ${failures} failures`);
  return failures === 0 ? 0 : 1;
}

main().then((code) => process.exit(code), (e) => {
  console.error('ws_session_test: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
