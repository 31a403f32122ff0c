#!/usr/bin/env node
// The asset service seen by an independent client (Node, @grpc/grpc-js), from
// the public proto only. Drives one upload through the whole contract:
// Ingest -> WatchJob -> ListVersions (page by page) -> GetVersion -> Export
// (progressive GLB and GLB), then the error codes of bad requests.
//
//   MESHSTREAM_SERVER=127.0.0.1:7600 MESHSTREAM_TEST_MODEL=model.obj \
//     [MESHSTREAM_TOKEN=...] node tests/node/asset_client.test.js
//
// tests/node/run.sh starts a server and runs this. Exit status non-zero on any
// failure (node:test), each failure with its reason.
'use strict';

const { test, before, after } = require('node:test');
const assert = require('node:assert/strict');
const crypto = require('node:crypto');
const fs = require('node:fs');
const path = require('node:path');

const { connect, deadline, unary } = require('./client');

const SERVER = process.env.MESHSTREAM_SERVER || '127.0.0.1:7600';
const TOKEN = process.env.MESHSTREAM_TOKEN || '';
const MODEL = process.env.MESHSTREAM_TEST_MODEL || '';
const MiB = 1024 * 1024;
// Chunks of an upload: at most 1 MiB each (the proto's limit).
const CHUNK_BYTES = Math.min(Number(process.env.MESHSTREAM_TEST_CHUNK_BYTES) || MiB, MiB);
const JOB_TIMEOUT_S = 120;

const STATUS = { INVALID_ARGUMENT: 3, NOT_FOUND: 5, UNAUTHENTICATED: 16 };

const sha256 = (data) => crypto.createHash('sha256').update(data).digest('hex');

// Shared by the steps: what the upload produced.
const state = {};
let c;

before(() => {
  c = connect(SERVER, TOKEN);
});
after(() => c && c.close());

// Writes the messages of a client stream, waiting for 'drain' when the
// stream's buffer is full; then ends it. Resolves with the call's response.
function clientStream(method, messages, seconds) {
  return new Promise((resolve, reject) => {
    const call = c.assets[method](c.metadata(), { deadline: deadline(seconds) }, (err, response) =>
      err ? reject(err) : resolve(response));
    let i = 0;
    const pump = () => {
      while (i < messages.length) {
        if (!call.write(messages[i++])) {
          call.once('drain', pump);
          return;
        }
      }
      call.end();
    };
    pump();
  });
}

// Collects a server stream's messages until it ends.
function serverStream(method, request, seconds) {
  return new Promise((resolve, reject) => {
    const call = c.assets[method](request, c.metadata(), { deadline: deadline(seconds) });
    const messages = [];
    call.on('data', (m) => messages.push(m));
    call.on('error', reject);
    call.on('end', () => resolve(messages));
  });
}

// Asserts that `promise` fails with gRPC status `code`.
async function rejectsWith(promise, code, what) {
  let response;
  try {
    response = await promise;
  } catch (err) {
    assert.equal(err.code, code, `${what}: expected status ${code}, got ${err.code} (${err.details})`);
    return err;
  }
  assert.fail(`${what}: expected status ${code}, the call succeeded: ${JSON.stringify(response)}`);
}

test('the model file is given', () => {
  assert.ok(MODEL, 'set MESHSTREAM_TEST_MODEL to a model file (.obj, .ply, .glb, ...)');
  assert.ok(fs.existsSync(MODEL), `MESHSTREAM_TEST_MODEL=${MODEL} does not exist`);
});

test('health: the server is SERVING', async () => {
  const response = await unary(c.health, 'Check', { service: '' }, c.metadata(), 10);
  assert.equal(response.status, 'SERVING');
});

test('Ingest: metadata then chunks of at most 1 MiB', async () => {
  const data = fs.readFileSync(MODEL);
  const digest = sha256(data);
  // A fresh name per run, within [A-Za-z0-9._-]{1,128}.
  const asset = `node-client-${process.pid}-${Date.now()}`;
  const messages = [{
    metadata: { asset, filename: path.basename(MODEL), size: String(data.length), sha256: digest },
  }];
  for (let off = 0; off < data.length; off += CHUNK_BYTES) {
    messages.push({ chunk: data.subarray(off, Math.min(off + CHUNK_BYTES, data.length)) });
  }
  const response = await clientStream('Ingest', messages, 120);
  assert.equal(response.asset, asset, 'IngestResponse.asset');
  assert.ok(BigInt(response.version) >= 1n, `IngestResponse.version ${response.version} >= 1`);
  assert.ok(response.job_id, 'IngestResponse.job_id is set');
  assert.equal(response.sha256, digest, 'IngestResponse.sha256 is the SHA-256 of the bytes sent');
  Object.assign(state, { asset, digest, size: data.length, version: response.version, jobId: response.job_id });
});

test('WatchJob: until JOB_STATE_SUCCEEDED', async (t) => {
  if (!state.jobId) return t.skip('Ingest failed');
  const job = await new Promise((resolve, reject) => {
    const call = c.assets.WatchJob({ job_id: state.jobId }, c.metadata(), { deadline: deadline(JOB_TIMEOUT_S + 5) });
    let last = null;
    let done = false;
    const finish = (fn, value) => {
      if (done) return;
      done = true;
      clearTimeout(timer);
      call.cancel();
      fn(value);
    };
    const timer = setTimeout(() => finish(reject, new Error(
      `job ${state.jobId} not finished after ${JOB_TIMEOUT_S} s (last: ${JSON.stringify(last)})`)), JOB_TIMEOUT_S * 1000);
    call.on('data', (j) => {
      last = j;
      if (!(j.progress >= 0 && j.progress <= 1)) finish(reject, new Error(`progress ${j.progress} outside 0..1`));
      if (j.state === 'JOB_STATE_SUCCEEDED') finish(resolve, j);
      if (j.state === 'JOB_STATE_FAILED') finish(reject, new Error(`job ${j.id} FAILED: ${j.message}`));
    });
    call.on('error', (err) => finish(reject, err));
    call.on('end', () => finish(reject, new Error(`WatchJob ended before SUCCEEDED (last: ${JSON.stringify(last)})`)));
  });
  assert.equal(job.id, state.jobId, 'Job.id');
  if (job.asset) assert.equal(job.asset, state.asset, 'Job.asset');
  if (job.version !== '0') assert.equal(job.version, state.version, 'Job.version');
  state.succeeded = true;
});

test('ListVersions: page_size 1, following next_page_token to the end', async (t) => {
  if (!state.succeeded) return t.skip('the job did not succeed');
  const seen = [];
  const tokens = new Set();
  let pageToken = '';
  for (let page = 0; ; page++) {
    assert.ok(page < 1000, 'more than 1000 pages for page_size 1');
    const response = await unary(c.assets, 'ListVersions',
      { asset: state.asset, page_size: 1, page_token: pageToken }, c.metadata());
    assert.ok(response.versions.length <= 1, `page ${page} holds ${response.versions.length} versions, page_size was 1`);
    seen.push(...response.versions);
    if (!response.next_page_token) break;
    assert.ok(!tokens.has(response.next_page_token), `next_page_token ${response.next_page_token} came twice`);
    tokens.add(response.next_page_token);
    pageToken = response.next_page_token;
  }
  const ours = seen.find((v) => v.version === state.version);
  assert.ok(ours, `version ${state.version} not listed (saw ${seen.map((v) => v.version).join(', ') || 'none'})`);
  assert.equal(ours.asset, state.asset);
});

test('GetVersion: READY with its figures', async (t) => {
  if (!state.succeeded) return t.skip('the job did not succeed');
  const v = await unary(c.assets, 'GetVersion', { asset: state.asset, version: state.version }, c.metadata());
  assert.equal(v.asset, state.asset, 'Version.asset');
  assert.equal(v.version, state.version, 'Version.version');
  assert.equal(v.state, 'VERSION_STATE_READY', 'Version.state');
  assert.equal(v.source_sha256, state.digest, 'Version.source_sha256');
  assert.equal(v.source_size, String(state.size), 'Version.source_size');
  assert.ok(BigInt(v.vertices) > 0n, `Version.vertices ${v.vertices} > 0`);
  assert.ok(v.level_vertices.length > 0, 'Version.level_vertices is not empty');
  state.ready = true;
});

for (const format of ['FORMAT_PROGRESSIVE_GLB', 'FORMAT_GLB']) {
  test(`Export ${format}: a GLB whose last chunk carries the SHA-256 of all bytes`, async (t) => {
    if (!state.ready) return t.skip('the version is not READY');
    const chunks = await serverStream('Export', { asset: state.asset, version: state.version, format }, 120);
    assert.ok(chunks.length > 0, 'Export sent no chunk');
    chunks.forEach((ch, i) => assert.ok(ch.data.length <= MiB, `chunk ${i} holds ${ch.data.length} bytes, more than 1 MiB`));
    const data = Buffer.concat(chunks.map((ch) => ch.data));
    assert.equal(chunks[chunks.length - 1].sha256, sha256(data), 'last ExportChunk.sha256 is the SHA-256 of all data');
    assert.ok(data.length >= 12, `${data.length} bytes is shorter than a GLB header`);
    assert.equal(data.subarray(0, 4).toString('latin1'), 'glTF', 'GLB magic');
    assert.equal(data.readUInt32LE(4), 2, 'GLB container version');
    assert.equal(data.readUInt32LE(8), data.length, 'GLB header length is the byte count');
  });
}

test('Ingest whose first message is a chunk: INVALID_ARGUMENT', async () => {
  await rejectsWith(clientStream('Ingest', [{ chunk: Buffer.from('v 0 0 0\n') }], 30),
    STATUS.INVALID_ARGUMENT, 'Ingest starting with a chunk');
});

test('GetVersion of an unknown asset: NOT_FOUND', async () => {
  const asset = `no-such-asset-${crypto.randomBytes(8).toString('hex')}`;
  await rejectsWith(unary(c.assets, 'GetVersion', { asset, version: 0 }, c.metadata()),
    STATUS.NOT_FOUND, 'GetVersion of an unknown asset');
});

test('ListAssets with page_size -1: INVALID_ARGUMENT', async () => {
  await rejectsWith(unary(c.assets, 'ListAssets', { page_size: -1, page_token: '' }, c.metadata()),
    STATUS.INVALID_ARGUMENT, 'ListAssets page_size -1');
});

test('a call without the token: UNAUTHENTICATED', async (t) => {
  if (!TOKEN) return t.skip('MESHSTREAM_TOKEN not set (server without --auth)');
  await rejectsWith(unary(c.assets, 'ListAssets', { page_size: 1, page_token: '' }, new c.grpc.Metadata()),
    STATUS.UNAUTHENTICATED, 'ListAssets without a token');
});
