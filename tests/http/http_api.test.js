#!/usr/bin/env node
// The HTTP routes of a real `meshstream serve --http-listen` (docs/spec/http-api.md),
// with node's own HTTP client and raw sockets (no npm package):
//   the files byte for byte against `meshstream export`, ETag = SHA-256, HEAD,
//   single ranges, 416, several ranges, If-None-Match, If-Range,
//   Cache-Control of a number and of latest, ?lod=K, every format, the asset
//   list, CORS, the viewer's files, and what a hostile client sends (bad
//   paths and versions, long heads, other methods, bodies, garbage, paths that
//   try to leave the web root); the server must answer all of it and stay up.
// With MESHSTREAM_TEST_TOKEN_A set (the server has --auth): no token, a bad
// token, another tenant's token, the owner's token.
//
//   MESHSTREAM_TEST_HTTP=127.0.0.1:7680 MESHSTREAM_TEST_EXPORTS=dir \
//     MESHSTREAM_TEST_WEB=dir MESHSTREAM_TEST_SECRET=file node tests/http/http_api.test.js
//
// tests/http/run.sh starts the server, ingests the asset and makes the
// exports. Exit status non-zero on any failure (node:test).
'use strict';

const { test } = require('node:test');
const assert = require('node:assert/strict');
const crypto = require('node:crypto');
const fs = require('node:fs');
const http = require('node:http');
const net = require('node:net');
const path = require('node:path');

const [HOST, PORT] = (() => {
  const a = process.env.MESHSTREAM_TEST_HTTP || '127.0.0.1:7680';
  const colon = a.lastIndexOf(':');
  return [a.slice(0, colon), Number(a.slice(colon + 1))];
})();
const EXPORTS = process.env.MESHSTREAM_TEST_EXPORTS || '';
const WEB = process.env.MESHSTREAM_TEST_WEB || '';
const SECRET = fs.readFileSync(process.env.MESHSTREAM_TEST_SECRET || '/dev/null', 'utf8').trim();
const TOKEN_A = process.env.MESHSTREAM_TEST_TOKEN_A || '';
const TOKEN_B = process.env.MESHSTREAM_TEST_TOKEN_B || '';
const AUTH = TOKEN_A !== '';
const ALLOWED_ORIGIN = 'http://allowed.example';

const FORMATS = {
  glb: 'model/gltf-binary',
  draco: 'model/gltf-binary',
  progressive: 'model/gltf-binary',
  obj: 'model/obj',
  ply: 'application/octet-stream',
};
const IMMUTABLE = `${AUTH ? 'private' : 'public'}, max-age=31536000, immutable`;

const sha256 = (data) => crypto.createHash('sha256').update(data).digest('hex');
const exported = (name) => fs.readFileSync(path.join(EXPORTS, name));
const fileUrl = (version, format, query = '') => `/v1/assets/spot/versions/${version}/${format}${query}`;

// One request with node's client: resolves { status, headers, body (Buffer) }.
// The owner's token is sent unless `headers.authorization` is given (null: none).
function request(method, target, headers = {}) {
  const h = { ...headers };
  if (AUTH && !('authorization' in h)) h.authorization = `Bearer ${TOKEN_A}`;
  if (h.authorization === null) delete h.authorization;
  return new Promise((resolve, reject) => {
    const req = http.request({ host: HOST, port: PORT, method, path: target, headers: h, agent: false }, (res) => {
      const chunks = [];
      res.on('data', (c) => chunks.push(c));
      res.on('end', () => resolve({ status: res.statusCode, headers: res.headers, body: Buffer.concat(chunks) }));
      res.on('error', reject);
    });
    req.setTimeout(60000, () => req.destroy(new Error(`${method} ${target}: no answer in 60 s`)));
    req.on('error', reject);
    req.end();
  });
}
const get = (target, headers) => request('GET', target, headers);

// Raw bytes on a socket; resolves with everything the server sent until it
// closed (or `ms` passed: then the connection is closed by us).
function raw(bytes, ms = 5000) {
  return new Promise((resolve, reject) => {
    const socket = net.connect(PORT, HOST);
    const chunks = [];
    const timer = setTimeout(() => socket.destroy(), ms);
    socket.on('connect', () => socket.write(bytes));
    socket.on('data', (c) => chunks.push(c));
    socket.on('error', (e) => (e.code === 'ECONNRESET' ? null : reject(e)));
    socket.on('close', () => {
      clearTimeout(timer);
      resolve(Buffer.concat(chunks).toString('latin1'));
    });
  });
}
const statusOf = (response) => Number((/^HTTP\/1\.[01] (\d{3})/.exec(response) || [])[1] || 0);

function assertJsonError(r, status, what) {
  assert.equal(r.status, status, `${what}: expected ${status}, got ${r.status} ${r.body}`);
  assert.match(r.headers['content-type'] || '', /^application\/json/, `${what}: content-type`);
  const body = JSON.parse(r.body.toString('utf8'));
  assert.equal(typeof body.error, 'string', `${what}: an "error" string`);
  assert.ok(body.error.length > 0, `${what}: an error message`);
  return body;
}

function assertValidGlb(bytes, what) {
  assert.ok(bytes.length >= 20, `${what}: ${bytes.length} bytes`);
  assert.equal(bytes.toString('latin1', 0, 4), 'glTF', `${what}: magic`);
  assert.equal(bytes.readUInt32LE(4), 2, `${what}: version`);
  assert.equal(bytes.readUInt32LE(8), bytes.length, `${what}: length field`);
  assert.equal(bytes.toString('latin1', 16, 20), 'JSON', `${what}: first chunk`);
  JSON.parse(bytes.toString('utf8', 20, 20 + bytes.readUInt32LE(12)));
}

test('health', async () => {
  const r = await get('/v1/health', { authorization: null });
  assert.equal(r.status, 200);
  assert.equal(JSON.parse(r.body).status, 'SERVING');
});

test('every format of a numbered version: the bytes of meshstream export, ETag its SHA-256', async () => {
  for (const [format, type] of Object.entries(FORMATS)) {
    const want = exported(`v1.${format}`);
    const r = await get(fileUrl(1, format));
    assert.equal(r.status, 200, `${format}: ${r.body}`);
    assert.ok(r.body.equals(want), `${format}: ${r.body.length} bytes, the export has ${want.length}`);
    assert.equal(r.headers.etag, `"${sha256(r.body)}"`, `${format}: ETag`);
    assert.equal(r.headers['content-type'], type, `${format}: Content-Type`);
    assert.equal(Number(r.headers['content-length']), want.length, `${format}: Content-Length`);
    assert.equal(r.headers['accept-ranges'], 'bytes', `${format}: Accept-Ranges`);
    assert.equal(r.headers['cache-control'], IMMUTABLE, `${format}: Cache-Control`);
    assert.equal(r.headers['content-location'], undefined, `${format}: no Content-Location for a number`);
    if (AUTH) assert.match(r.headers.vary || '', /Authorization/, `${format}: Vary`);
  }
  assertValidGlb(exported('v1.glb'), 'glb');
  assertValidGlb(exported('v1.progressive'), 'progressive');
});

test('HEAD: the headers of GET, no body', async () => {
  const full = await get(fileUrl(1, 'glb'));
  const r = await request('HEAD', fileUrl(1, 'glb'));
  assert.equal(r.status, 200);
  assert.equal(r.body.length, 0);
  assert.equal(r.headers['content-length'], String(full.body.length));
  assert.equal(r.headers.etag, full.headers.etag);
  assert.equal(r.headers['cache-control'], full.headers['cache-control']);
  // HEAD ignores Range.
  const ranged = await request('HEAD', fileUrl(1, 'glb'), { range: 'bytes=0-9' });
  assert.equal(ranged.status, 200);
  assert.equal(ranged.headers['content-length'], String(full.body.length));
});

test('single ranges: exact bytes and Content-Range', async () => {
  const whole = exported('v1.progressive');
  const n = whole.length;
  assert.ok(n > 1000, `the progressive file has ${n} bytes`);
  const cases = [
    ['bytes=0-99', 0, 99],             // the first bytes
    ['bytes=500-699', 500, 699],       // the middle
    ['bytes=-100', n - 100, n - 1],    // a suffix
    [`bytes=${n - 10}-`, n - 10, n - 1], // open-ended
    ['bytes=0-', 0, n - 1],
    [`bytes=10-${n + 1000}`, 10, n - 1], // past the end: cut
    [`bytes=-${n + 5}`, 0, n - 1],     // a suffix longer than the body
  ];
  for (const [range, first, last] of cases) {
    const r = await get(fileUrl(1, 'progressive'), { range });
    assert.equal(r.status, 206, `${range}: ${r.body}`);
    assert.equal(r.headers['content-range'], `bytes ${first}-${last}/${n}`, range);
    assert.equal(Number(r.headers['content-length']), last - first + 1, range);
    assert.ok(r.body.equals(whole.subarray(first, last + 1)), `${range}: the bytes`);
    assert.equal(r.headers.etag, `"${sha256(whole)}"`, `${range}: the ETag of the whole file`);
  }
});

test('416 for an unsatisfiable range, 200 for several ranges or a malformed one', async () => {
  const whole = exported('v1.progressive');
  const n = whole.length;
  for (const range of [`bytes=${n}-`, `bytes=${n + 100}-${n + 200}`, 'bytes=-0', 'bytes=99999999999999999999999-']) {
    const r = await get(fileUrl(1, 'progressive'), { range });
    assertJsonError(r, 416, range);
    assert.equal(r.headers['content-range'], `bytes */${n}`, range);
  }
  for (const range of ['bytes=0-1,5-6', 'bytes=0-10, 20-30', 'items=0-9', 'bytes=9-1', 'bytes=abc', 'bytes 0-9']) {
    const r = await get(fileUrl(1, 'progressive'), { range });
    assert.equal(r.status, 200, range);
    assert.ok(r.body.equals(whole), `${range}: the whole file`);
  }
});

test('If-None-Match: 304', async () => {
  const etag = (await get(fileUrl(1, 'glb'))).headers.etag;
  for (const inm of [etag, `"nope", ${etag}`, `W/${etag}`, '*']) {
    const r = await get(fileUrl(1, 'glb'), { 'if-none-match': inm });
    assert.equal(r.status, 304, inm);
    assert.equal(r.body.length, 0, inm);
    assert.equal(r.headers.etag, etag, inm);
    assert.equal(r.headers['cache-control'], IMMUTABLE, inm);
  }
  const other = await get(fileUrl(1, 'glb'), { 'if-none-match': '"not-this-one"' });
  assert.equal(other.status, 200);
  // If-None-Match wins over Range.
  const ranged = await get(fileUrl(1, 'glb'), { 'if-none-match': etag, range: 'bytes=0-9' });
  assert.equal(ranged.status, 304);
});

test('If-Range: the range when the ETag matches, the whole file when not', async () => {
  const whole = exported('v1.progressive');
  const etag = `"${sha256(whole)}"`;
  const match = await get(fileUrl(1, 'progressive'), { range: 'bytes=0-9', 'if-range': etag });
  assert.equal(match.status, 206);
  assert.ok(match.body.equals(whole.subarray(0, 10)));
  for (const ifRange of ['"0000"', `W/${etag}`, 'Sun, 06 Nov 1994 08:49:37 GMT']) {
    const r = await get(fileUrl(1, 'progressive'), { range: 'bytes=0-9', 'if-range': ifRange });
    assert.equal(r.status, 200, ifRange);
    assert.ok(r.body.equals(whole), `${ifRange}: the whole file`);
  }
});

test('latest: no-cache and the numbered version in Content-Location', async () => {
  const r = await get(fileUrl('latest', 'glb'));
  assert.equal(r.status, 200);
  assert.ok(r.body.equals(exported('latest.glb')), 'the bytes of meshstream export spot');
  assert.equal(r.headers['cache-control'], AUTH ? 'private, no-cache' : 'no-cache');
  assert.equal(r.headers['content-location'], fileUrl(2, 'glb'));
  assert.equal(r.headers.etag, `"${sha256(r.body)}"`);
  const lod = await get(fileUrl('latest', 'glb', '?lod=0'));
  assert.equal(lod.status, 200);
  assert.equal(lod.headers['content-location'], fileUrl(2, 'glb', '?lod=0'));
  const range = await get(fileUrl('latest', 'progressive'), { range: 'bytes=0-3' });
  assert.equal(range.status, 206);
  assert.equal(range.body.toString('latin1'), 'glTF');
  assert.equal(range.headers['content-location'], fileUrl(2, 'progressive'));
});

test('?lod=K: another, valid glb, as meshstream export --lod', async () => {
  const full = await get(fileUrl(1, 'glb'));
  const lod = await get(fileUrl(1, 'glb', '?lod=0'));
  assert.equal(lod.status, 200, String(lod.body));
  assertValidGlb(lod.body, 'lod=0');
  assert.ok(!lod.body.equals(full.body), 'lod=0 differs from the full detail');
  assert.ok(lod.body.length < full.body.length, 'the base mesh is smaller');
  assert.ok(lod.body.equals(exported('v1-lod0.glb')), 'the bytes of meshstream export --lod 0');
  assert.equal(lod.headers.etag, `"${sha256(lod.body)}"`);
  assert.equal(lod.headers['cache-control'], IMMUTABLE);
  const lod1 = await get(fileUrl(1, 'glb', '?lod=1'));
  assert.equal(lod1.status, 200, String(lod1.body));
  assertValidGlb(lod1.body, 'lod=1');
  assert.ok(!lod1.body.equals(lod.body), 'lod=1 differs from lod=0');
  for (const format of ['draco', 'obj', 'ply']) {
    const r = await get(fileUrl(1, format, '?lod=0'));
    assert.equal(r.status, 200, `${format}?lod=0: ${r.body}`);
    assert.ok(!r.body.equals(exported(`v1.${format}`)), `${format}?lod=0 differs from the full detail`);
  }
  assertJsonError(await get(fileUrl(1, 'progressive', '?lod=0')), 400, 'progressive?lod=0');
  assertJsonError(await get(fileUrl(1, 'glb', '?lod=99999')), 400, 'lod above the levels');
});

test('the asset list', async () => {
  const r = await get('/v1/assets');
  assert.equal(r.status, 200, String(r.body));
  const list = JSON.parse(r.body);
  const spot = list.assets.find((a) => a.name === 'spot');
  assert.ok(spot, JSON.stringify(list));
  assert.equal(spot.latest_version, 2);
  assert.equal(spot.ready_version, 2);
  assert.deepEqual(spot.formats, Object.keys(FORMATS));
  assert.equal(list.next_page_token, '');
  assert.match(r.headers['cache-control'], /no-cache/);
  const page = await get('/v1/assets?page_size=1');
  assert.equal(page.status, 200);
  assertJsonError(await get('/v1/assets?page_size=1000'), 400, 'page_size above the cap');
  assertJsonError(await get('/v1/assets?page_token=forged'), 400, 'a forged page token');
  assertJsonError(await get('/v1/assets?sort=name'), 400, 'an unknown parameter');
});

test('CORS: the allowed origin, another origin, preflights', async () => {
  const allowed = await get(fileUrl(1, 'glb'), { origin: ALLOWED_ORIGIN });
  assert.equal(allowed.status, 200);
  assert.equal(allowed.headers['access-control-allow-origin'], ALLOWED_ORIGIN);
  assert.match(allowed.headers.vary || '', /Origin/);
  const exposed = allowed.headers['access-control-expose-headers'] || '';
  for (const h of ['Content-Range', 'Content-Length', 'ETag', 'Accept-Ranges', 'Content-Location']) {
    assert.ok(exposed.includes(h), `exposes ${h}: ${exposed}`);
  }
  const error = await get(fileUrl(1, 'nope'), { origin: ALLOWED_ORIGIN });
  assert.equal(error.status, 400);
  assert.equal(error.headers['access-control-allow-origin'], ALLOWED_ORIGIN, 'errors are readable too');

  const other = await get(fileUrl(1, 'glb'), { origin: 'http://evil.example' });
  assert.equal(other.status, 200);
  for (const h of Object.keys(other.headers)) assert.ok(!h.startsWith('access-control-'), `no ${h} for another origin`);
  assert.match(other.headers.vary || '', /Origin/);

  const preflight = await request('OPTIONS', fileUrl(1, 'glb'), {
    origin: ALLOWED_ORIGIN,
    'access-control-request-method': 'GET',
    'access-control-request-headers': 'authorization, range',
    authorization: null,
  });
  assert.equal(preflight.status, 204);
  assert.equal(preflight.headers['access-control-allow-origin'], ALLOWED_ORIGIN);
  assert.match(preflight.headers['access-control-allow-methods'], /GET/);
  assert.match(preflight.headers['access-control-allow-methods'], /HEAD/);
  for (const h of ['Authorization', 'Range', 'If-None-Match', 'If-Range']) {
    assert.ok(preflight.headers['access-control-allow-headers'].includes(h), `allows ${h}`);
  }
  const otherPreflight = await request('OPTIONS', fileUrl(1, 'glb'), {
    origin: 'http://evil.example',
    'access-control-request-method': 'GET',
    authorization: null,
  });
  assert.equal(otherPreflight.status, 204);
  for (const h of Object.keys(otherPreflight.headers)) assert.ok(!h.startsWith('access-control-'), `no ${h}`);
});

test('the viewer files', async () => {
  const index = await get('/', { authorization: null });
  assert.equal(index.status, 200);
  assert.ok(index.body.equals(fs.readFileSync(path.join(WEB, 'index.html'))));
  assert.match(index.headers['content-type'], /^text\/html/);
  assert.equal(index.headers['cache-control'], 'no-cache');
  assert.equal(index.headers.etag, `"${sha256(index.body)}"`);
  assert.equal((await get('/', { 'if-none-match': index.headers.etag, authorization: null })).status, 304);
  const js = await get('/js/app.js', { authorization: null });
  assert.equal(js.status, 200);
  assert.match(js.headers['content-type'], /^text\/javascript/);
  assertJsonError(await get('/js/missing.js', { authorization: null }), 404, 'a missing file');
  assertJsonError(await get('/js', { authorization: null }), 404, 'a folder (no listing)');
});

test('bad routes, versions and formats', async () => {
  assertJsonError(await get('/v1/nothing'), 404, 'an unknown route');
  assertJsonError(await get('/v1/assets/spot'), 404, 'a partial path');
  assertJsonError(await get('/v1/assets/nobody/versions/1/glb'), 404, 'an unknown asset');
  assertJsonError(await get(fileUrl(9, 'glb')), 404, 'an unknown version');
  const format = assertJsonError(await get(fileUrl(1, 'fbx')), 400, 'an unknown format');
  assert.match(format.error, /format/);
  for (const v of ['0', '-1', 'abc', '01', '1.5', '99999999999999999999']) {
    const body = assertJsonError(await get(fileUrl(v, 'glb')), 400, `version ${v}`);
    assert.match(body.error, /version/, `version ${v}`);
  }
  assertJsonError(await get('/v1/assets/sp%zzot/versions/1/glb'), 400, 'a broken percent escape');
  assertJsonError(await get('/v1/assets/a%2fb/versions/1/glb'), 400, 'an encoded slash in a name');
  assertJsonError(await get('/v1/assets/%2e%2e/versions/1/glb'), 400, 'an encoded .. as a name');
  assertJsonError(await get(fileUrl(1, 'glb', '?lod=-1')), 400, 'a negative lod');
  assertJsonError(await get(fileUrl(1, 'glb', '?cache=1')), 400, 'an unknown parameter');
  // A plain GET of the WebSocket route (tests/web/ws_session_test.mjs has the session).
  const stream = assertJsonError(await get('/v1/stream'), 426, '/v1/stream');
  assert.match(stream.error, /WebSocket/);
});

test('methods, heads and bodies the server refuses', async () => {
  for (const method of ['POST', 'PUT', 'DELETE', 'PATCH']) {
    const r = await request(method, fileUrl(1, 'glb'));
    assertJsonError(r, 405, method);
    assert.match(r.headers.allow || '', /GET/);
  }
  const longHeader = await raw(`GET /v1/health HTTP/1.1\r\nHost: x\r\nX-Long: ${'a'.repeat(20000)}\r\n\r\n`);
  assert.equal(statusOf(longHeader), 431, longHeader.slice(0, 200));
  const longTarget = await raw(`GET /${'a'.repeat(20000)} HTTP/1.1\r\nHost: x\r\n\r\n`);
  assert.equal(statusOf(longTarget), 431, longTarget.slice(0, 200));
  const manyHeaders = await raw(`GET /v1/health HTTP/1.1\r\n${'X-A: b\r\n'.repeat(3000)}\r\n`);
  assert.equal(statusOf(manyHeaders), 431, manyHeaders.slice(0, 200));
  const body = await raw(`GET /v1/health HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n${'x'.repeat(100000)}`);
  assert.equal(statusOf(body), 413, body.slice(0, 200));
  const garbage = await raw('\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03 not http at all\r\n\r\n');
  assert.equal(statusOf(garbage), 400, garbage.slice(0, 200));
  const badVersion = await raw('GET / HTTP/7.5\r\nHost: x\r\n\r\n');
  assert.ok([400, 505].includes(statusOf(badVersion)) || badVersion === '', badVersion.slice(0, 200));
  const absolute = await raw('GET http://other/v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n');
  assert.equal(statusOf(absolute), 400, absolute.slice(0, 200));
  // Keep-alive: two requests on one connection, answered in order.
  const two = await raw('GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\nHEAD /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n');
  assert.equal((two.match(/HTTP\/1\.1 200/g) || []).length, 2, two);
});

test('paths that try to leave the web root are refused', async () => {
  const attempts = [
    '/%2e%2e/secret.txt', '/%2E%2E/secret.txt', '/..%2fsecret.txt', '/..%2Fsecret.txt', '/../secret.txt',
    '/static/../../etc/passwd', '/js/../../secret.txt', '/%2e%2e%2f%2e%2e%2fetc%2fpasswd', '/..%5csecret.txt',
    '/.%2e/secret.txt', '/js/%2e%2e/%2e%2e/secret.txt', '/escape.txt', '/up/secret.txt', '/secret.txt%00.html',
    '//etc/passwd', '/./index.html', '/%2fetc/passwd', '/.%00./secret.txt',
  ];
  for (const target of attempts) {
    const response = await raw(`GET ${target} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n`);
    const status = statusOf(response);
    assert.ok(status >= 400 && status < 500, `${target}: ${status} ${response.slice(0, 300)}`);
    assert.ok(!response.includes(SECRET), `${target}: served the secret`);
    assert.ok(!response.includes('root:x:0:0'), `${target}: served /etc/passwd`);
  }
});

test('authentication and tenants', { skip: !AUTH && 'the server has no --auth' }, async () => {
  const none = await get(fileUrl(1, 'glb'), { authorization: null });
  assertJsonError(none, 401, 'no token');
  assert.match(none.headers['www-authenticate'] || '', /^Bearer/);
  assertJsonError(await get('/v1/assets', { authorization: null }), 401, 'the list without a token');
  for (const bad of ['Bearer mst_not-a-token', 'Bearer ', 'Basic dXNlcjpwYXNz', `Bearer ${TOKEN_A}x`, TOKEN_A]) {
    const r = await get(fileUrl(1, 'glb'), { authorization: bad });
    assertJsonError(r, 401, `authorization '${bad.slice(0, 20)}'`);
    assert.match(r.headers['www-authenticate'] || '', /^Bearer/);
  }
  // Another tenant does not see the asset: 404, as for a name nobody has.
  const other = await get(fileUrl(1, 'glb'), { authorization: `Bearer ${TOKEN_B}` });
  assertJsonError(other, 404, 'another tenant');
  assertJsonError(await get(fileUrl('latest', 'progressive'), { authorization: `Bearer ${TOKEN_B}` }), 404,
    'another tenant, latest');
  const list = await get('/v1/assets', { authorization: `Bearer ${TOKEN_B}` });
  assert.equal(list.status, 200);
  assert.deepEqual(JSON.parse(list.body).assets, []);
  const owner = await get(fileUrl(1, 'glb'), { authorization: `Bearer ${TOKEN_A}` });
  assert.equal(owner.status, 200);
  assert.equal(owner.headers['cache-control'], 'private, max-age=31536000, immutable');
  assert.match(owner.headers.vary || '', /Authorization/);
  // The scheme is case-insensitive.
  assert.equal((await get(fileUrl(1, 'glb'), { authorization: `bearer ${TOKEN_A}` })).status, 200);
  // Malformed requests are 400 before authentication.
  assertJsonError(await get(fileUrl(0, 'glb'), { authorization: null }), 400, 'version 0 without a token');
});

test('still alive and answering', async () => {
  const r = await get('/v1/health', { authorization: null });
  assert.equal(r.status, 200);
  const file = await get(fileUrl(1, 'progressive'), { range: 'bytes=0-3' });
  assert.equal(file.status, 206);
  assert.equal(file.body.toString('latin1'), 'glTF');
});
