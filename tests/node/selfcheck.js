#!/usr/bin/env node
// Checks the Node client without the C++ server:
//   1. both protos load with proto-loader (Timestamp included) and the
//      services have the methods, with the streaming kinds, the test calls;
//   2. every message field the test reads or writes exists in the proto
//      (protobufjs drops unknown fields silently, so a typo would not fail);
//   3. asset_client.test.js passes against mock_server.js, with and without a
//      bearer token, and fails against a mock whose Export digest is wrong.
// Usage: node tests/node/selfcheck.js    Exit 0 when all of it holds.
'use strict';

const assert = require('node:assert/strict');
const { spawn } = require('node:child_process');
const fs = require('node:fs');
const os = require('node:os');
const path = require('node:path');

const { loadProtos } = require('./client');
const { startMockServer } = require('./mock_server');

function checkProtos() {
  const { definition, AssetService, Health } = loadProtos();
  const kinds = (service) => Object.fromEntries(Object.entries(service.service).map(([name, m]) => [
    name, `${m.requestStream ? 'stream ' : ''}${m.requestType.type.name} -> ${m.responseStream ? 'stream ' : ''}${m.responseType.type.name}`,
  ]));
  const methods = { AssetService: kinds(AssetService), Health: kinds(Health) };
  for (const [service, list] of Object.entries(methods)) {
    for (const [name, kind] of Object.entries(list)) console.log(`  ${service}.${name}: ${kind}`);
  }
  const expected = {
    Ingest: 'stream IngestRequest -> IngestResponse',
    QueryUpload: 'QueryUploadRequest -> UploadStatus',
    GetJob: 'GetJobRequest -> Job',
    WatchJob: 'GetJobRequest -> stream Job',
    ListAssets: 'ListAssetsRequest -> ListAssetsResponse',
    ListVersions: 'ListVersionsRequest -> ListVersionsResponse',
    GetVersion: 'GetVersionRequest -> Version',
    Export: 'ExportRequest -> stream ExportChunk',
  };
  assert.deepEqual(methods.AssetService, expected, 'AssetService methods');
  assert.deepEqual(methods.Health, {
    Check: 'HealthCheckRequest -> HealthCheckResponse',
    Watch: 'HealthCheckRequest -> stream HealthCheckResponse',
  }, 'Health methods');
  assert.ok(definition['google.protobuf.Timestamp'], 'google.protobuf.Timestamp resolved');

  // The fields the client test and health check use, by message.
  const used = {
    'meshstream.v1.IngestMetadata': ['asset', 'filename', 'size', 'sha256'],
    'meshstream.v1.IngestRequest': ['metadata', 'chunk'],
    'meshstream.v1.IngestResponse': ['asset', 'version', 'job_id', 'sha256'],
    'meshstream.v1.GetJobRequest': ['job_id'],
    'meshstream.v1.Job': ['id', 'state', 'progress', 'message', 'asset', 'version'],
    'meshstream.v1.ListAssetsRequest': ['page_size', 'page_token'],
    'meshstream.v1.ListVersionsRequest': ['asset', 'page_size', 'page_token'],
    'meshstream.v1.ListVersionsResponse': ['versions', 'next_page_token'],
    'meshstream.v1.GetVersionRequest': ['asset', 'version'],
    'meshstream.v1.Version': ['asset', 'version', 'state', 'source_sha256', 'source_size', 'vertices', 'level_vertices'],
    'meshstream.v1.ExportRequest': ['asset', 'version', 'format'],
    'meshstream.v1.ExportChunk': ['data', 'sha256'],
    'grpc.health.v1.HealthCheckRequest': ['service'],
    'grpc.health.v1.HealthCheckResponse': ['status'],
  };
  for (const [message, fields] of Object.entries(used)) {
    const type = definition[message];
    assert.ok(type && type.type, `message ${message} exists`);
    const names = type.type.field.map((f) => f.name);
    for (const f of fields) assert.ok(names.includes(f), `${message}.${f} exists (has: ${names.join(', ')})`);
  }
  const enumValues = (name) => definition[name].type.value.map((v) => v.name);
  for (const v of ['JOB_STATE_SUCCEEDED', 'JOB_STATE_FAILED']) assert.ok(enumValues('meshstream.v1.JobState').includes(v), v);
  assert.ok(enumValues('meshstream.v1.VersionState').includes('VERSION_STATE_READY'));
  for (const v of ['FORMAT_GLB', 'FORMAT_PROGRESSIVE_GLB']) assert.ok(enumValues('meshstream.v1.Format').includes(v), v);
}

// Asynchronous on purpose: the mock serves from this process's event loop.
function runClientTest(address, env) {
  return new Promise((resolve) => {
    const child = spawn(process.execPath, [path.join(__dirname, 'asset_client.test.js')], {
      env: { ...process.env, MESHSTREAM_SERVER: address, MESHSTREAM_TOKEN: '', ...env },
    });
    let output = '';
    child.stdout.on('data', (d) => { output += d; });
    child.stderr.on('data', (d) => { output += d; });
    const timer = setTimeout(() => child.kill('SIGKILL'), 120000);
    child.on('close', (code) => {
      clearTimeout(timer);
      resolve({ code, output });
    });
  });
}

async function main() {
  console.log('protos:');
  checkProtos();
  console.log('ok: protos load, methods and fields as the client test uses them');

  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'meshstream-node-'));
  try {
    const model = path.join(tmp, 'cube.obj');
    fs.writeFileSync(model, 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n'
      + 'f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n');
    const cases = [
      // Small chunks, so the upload is many messages and exercises 'drain'.
      { name: 'without a token', mock: {}, env: { MESHSTREAM_TEST_CHUNK_BYTES: '16' }, pass: true },
      { name: 'with a bearer token', mock: { token: 'tok-123' }, env: { MESHSTREAM_TOKEN: 'tok-123' }, pass: true },
      { name: 'against a wrong Export digest', mock: { wrongExportDigest: true }, env: {}, pass: false },
    ];
    for (const c of cases) {
      const mock = await startMockServer(c.mock);
      let result;
      try {
        result = await runClientTest(mock.address, { MESHSTREAM_TEST_MODEL: model, ...c.env });
      } finally {
        await mock.stop();
      }
      const passed = result.code === 0;
      if (passed !== c.pass) {
        console.log(result.output);
        throw new Error(`asset_client.test.js ${c.name}: exit ${result.code}, expected it to ${c.pass ? 'pass' : 'fail'}`);
      }
      if (!c.pass && !/SHA-256 of all data/.test(result.output)) {
        console.log(result.output);
        throw new Error(`asset_client.test.js ${c.name} failed, but not on the digest`);
      }
      console.log(`ok: asset_client.test.js ${c.pass ? 'passes' : 'fails'} against the mock ${c.name}`);
    }
  } finally {
    fs.rmSync(tmp, { recursive: true, force: true });
  }
}

main().then(() => console.log('selfcheck: all passed'), (err) => {
  console.error(`selfcheck: FAILED: ${err.message}`);
  process.exit(1);
});
