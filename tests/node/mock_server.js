// An in-memory stand-in of the asset service, for selfcheck.js only: it lets
// the Node client test run (and be checked) without the C++ server. It follows
// the contract of proto/meshstream/v1/asset_service.proto as far as the client
// test looks (messages, paging, the status codes of bad requests); it encodes
// nothing: a version's "artifact" is a small valid GLB made up here. It is
// never a reference for the real server's behaviour.
'use strict';

const crypto = require('node:crypto');
const { grpc, loadProtos } = require('./client');

const NAME = /^[A-Za-z0-9._-]{1,128}$/;
const MiB = 1024 * 1024;
const sha256 = (data) => crypto.createHash('sha256').update(data).digest('hex');
const status = (code, details) => Object.assign(new Error(details), { code, details });

// A GLB: 12-byte header, a JSON chunk (padded with spaces) and nothing else.
function makeGlb(json) {
  let text = Buffer.from(JSON.stringify(json));
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const out = Buffer.alloc(12 + 8 + text.length);
  out.write('glTF', 0, 'latin1');
  out.writeUInt32LE(2, 4);
  out.writeUInt32LE(out.length, 8);
  out.writeUInt32LE(text.length, 12);
  out.write('JSON', 16, 'latin1');
  text.copy(out, 20);
  return out;
}

// Starts the mock on `address` (default 127.0.0.1 and a free port). With `token`, every AssetService
// call needs "authorization: Bearer <token>" (health needs none). With
// `wrongExportDigest`, Export's last chunk carries a wrong SHA-256 (a fault the
// client test must catch). Resolves with { address, stop() }.
function startMockServer({ address = '127.0.0.1:0', token = '', wrongExportDigest = false } = {}) {
  const { AssetService, Health } = loadProtos();
  const assets = new Map();   // name -> [version records]
  const jobs = new Map();     // id -> job

  const authorized = (call) => {
    if (!token) return true;
    const [value] = call.metadata.get('authorization');
    return value === `Bearer ${token}`;
  };
  const guard = (handler) => (call, callback) => {
    if (!authorized(call)) {
      const err = status(grpc.status.UNAUTHENTICATED, 'missing or wrong bearer token');
      return callback ? callback(err) : call.destroy(err);
    }
    return handler(call, callback);
  };
  const page = (items, request) => {
    if (request.page_size < 0) throw status(grpc.status.INVALID_ARGUMENT, 'page_size must be >= 0');
    const size = request.page_size || 50;
    const start = request.page_token ? Number(Buffer.from(request.page_token, 'base64url').toString()) : 0;
    if (!Number.isInteger(start) || start < 0 || start > items.length) throw status(grpc.status.INVALID_ARGUMENT, 'bad page_token');
    const end = Math.min(start + size, items.length);
    return { slice: items.slice(start, end), next: end < items.length ? Buffer.from(String(end)).toString('base64url') : '' };
  };
  const findVersion = (asset, version) => {
    const versions = assets.get(asset);
    if (!versions) throw status(grpc.status.NOT_FOUND, `asset ${asset} not found`);
    const v = Number(version) === 0 ? versions[versions.length - 1] : versions[Number(version) - 1];
    if (!v) throw status(grpc.status.NOT_FOUND, `version ${version} of ${asset} not found`);
    return v;
  };

  const service = {
    Ingest: guard((call, callback) => {
      let meta = null;
      const parts = [];
      let failed = false;
      const fail = (code, details) => {
        if (!failed) callback(status(code, details));
        failed = true;
      };
      call.on('data', (req) => {
        if (failed) return;
        if (!meta) {
          if (req.kind !== 'metadata') return fail(grpc.status.INVALID_ARGUMENT, 'the first message must be metadata');
          meta = req.metadata;
          if (!NAME.test(meta.asset)) return fail(grpc.status.INVALID_ARGUMENT, 'bad asset name');
          return undefined;
        }
        if (req.kind !== 'chunk') return fail(grpc.status.INVALID_ARGUMENT, `unexpected ${req.kind}`);
        if (req.chunk.length > MiB) return fail(grpc.status.INVALID_ARGUMENT, 'chunk larger than 1 MiB');
        parts.push(req.chunk);
        return undefined;
      });
      call.on('end', () => {
        if (failed) return;
        if (!meta) return fail(grpc.status.INVALID_ARGUMENT, 'no metadata');
        const data = Buffer.concat(parts);
        const digest = sha256(data);
        if (String(data.length) !== meta.size) return fail(grpc.status.INVALID_ARGUMENT, `size ${meta.size}, received ${data.length}`);
        if (meta.sha256 && meta.sha256 !== digest) return fail(grpc.status.DATA_LOSS, 'sha256 mismatch');
        const versions = assets.get(meta.asset) || [];
        assets.set(meta.asset, versions);
        const number = versions.length + 1;
        const jobId = crypto.randomBytes(8).toString('hex');
        const record = {
          asset: meta.asset, version: String(number), state: 'VERSION_STATE_PROCESSING',
          source_sha256: digest, source_size: String(data.length), vertices: '0', faces: '0',
          levels: 0, level_vertices: [], created: { seconds: String(Math.floor(Date.now() / 1000)), nanos: 0 },
          comment: meta.comment, labels: meta.labels, jobId,
        };
        versions.push(record);
        jobs.set(jobId, { id: jobId, state: 'JOB_STATE_PENDING', progress: 0, message: '', asset: meta.asset, version: String(number) });
        return callback(null, { asset: meta.asset, version: String(number), job_id: jobId, sha256: digest });
      });
    }),
    QueryUpload: guard((call, callback) => callback(status(grpc.status.NOT_FOUND, 'no such upload'))),
    GetJob: guard((call, callback) => {
      const job = jobs.get(call.request.job_id);
      return job ? callback(null, job) : callback(status(grpc.status.NOT_FOUND, 'no such job'));
    }),
    WatchJob: guard((call) => {
      const job = jobs.get(call.request.job_id);
      if (!job) return call.destroy(status(grpc.status.NOT_FOUND, 'no such job'));
      // "Processing": RUNNING at 0.5, then SUCCEEDED with the version READY.
      call.write({ ...job, state: 'JOB_STATE_RUNNING', progress: 0.5 });
      const timer = setTimeout(() => {
        const record = findVersion(job.asset, job.version);
        Object.assign(record, { state: 'VERSION_STATE_READY', vertices: '8', faces: '12', levels: 2, level_vertices: ['4', '8'] });
        Object.assign(job, { state: 'JOB_STATE_SUCCEEDED', progress: 1 });
        call.write(job);
        call.end();
      }, 50);
      call.on('cancelled', () => clearTimeout(timer));
      return undefined;
    }),
    ListAssets: guard((call, callback) => {
      try {
        const all = [...assets.keys()].sort().map((name) => {
          const versions = assets.get(name);
          return { name, latest_version: String(versions.length), updated: versions[versions.length - 1].created };
        });
        const { slice, next } = page(all, call.request);
        return callback(null, { assets: slice, next_page_token: next });
      } catch (err) {
        return callback(err);
      }
    }),
    ListVersions: guard((call, callback) => {
      try {
        const versions = assets.get(call.request.asset);
        if (!versions) throw status(grpc.status.NOT_FOUND, 'asset not found');
        const { slice, next } = page(versions, call.request);
        return callback(null, { versions: slice, next_page_token: next });
      } catch (err) {
        return callback(err);
      }
    }),
    GetVersion: guard((call, callback) => {
      try {
        return callback(null, findVersion(call.request.asset, call.request.version));
      } catch (err) {
        return callback(err);
      }
    }),
    Export: guard((call) => {
      let record;
      try {
        record = findVersion(call.request.asset, call.request.version);
      } catch (err) {
        return call.destroy(err);
      }
      if (record.state !== 'VERSION_STATE_READY') return call.destroy(status(grpc.status.FAILED_PRECONDITION, 'not READY'));
      // Big enough to need several 1 MiB chunks.
      const glb = makeGlb({ asset: { version: '2.0' }, extras: { format: call.request.format, pad: 'x'.repeat(2.5 * MiB) } });
      for (let off = 0; off < glb.length; off += MiB) {
        const last = off + MiB >= glb.length;
        const digest = wrongExportDigest ? sha256(glb.subarray(1)) : sha256(glb);
        call.write({ data: glb.subarray(off, off + MiB), sha256: last ? digest : '' });
      }
      call.end();
      return undefined;
    }),
  };

  const server = new grpc.Server();
  server.addService(AssetService.service, service);
  server.addService(Health.service, {
    Check: (call, callback) => callback(null, { status: 'SERVING' }),
    Watch: (call) => {
      call.write({ status: 'SERVING' });
    },
  });
  return new Promise((resolve, reject) => {
    server.bindAsync(address, grpc.ServerCredentials.createInsecure(), (err, port) => {
      if (err) return reject(err);
      // grpc-js 1.10+ serves once bound (start() is deprecated).
      return resolve({
        address: `${address.replace(/:\d+$/, '')}:${port}`,
        stop: () => new Promise((done) => server.tryShutdown(() => done())),
      });
    });
  });
}

module.exports = { startMockServer, makeGlb };
