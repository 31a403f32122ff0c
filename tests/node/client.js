// The independent Node client of the asset service: loads the public proto
// (proto/meshstream/v1/asset_service.proto) and tests/node/health.proto with
// @grpc/proto-loader and connects with @grpc/grpc-js, both from
// tools/node_modules (pinned in tools/package.json, installed by
// scripts/install-deps). Nothing here comes from the C++ side but the proto.
'use strict';

const path = require('path');

const ROOT = path.resolve(__dirname, '..', '..');
const MODULES = path.join(ROOT, 'tools', 'node_modules');

function requireTool(name) {
  try {
    return require(path.join(MODULES, name));
  } catch (e) {
    throw new Error(`${name} is not installed in tools/node_modules (run scripts/install-deps): ${e.message}`);
  }
}

const grpc = requireTool('@grpc/grpc-js');
const protoLoader = requireTool('@grpc/proto-loader');

// keepCase: the proto's snake_case names (job_id, next_page_token); longs as
// decimal strings (int64 versions and counts); enums by name; unset scalars
// as their defaults; which member of a oneof is set in `kind`.
const LOADER_OPTIONS = {
  keepCase: true,
  longs: String,
  enums: String,
  defaults: true,
  oneofs: true,
  // google/protobuf/timestamp.proto comes with protobufjs (proto-loader's
  // parser), which resolves the well-known types itself.
  includeDirs: [path.join(ROOT, 'proto'), __dirname],
};

function loadProtos() {
  const definition = protoLoader.loadSync(['meshstream/v1/asset_service.proto', 'health.proto'], LOADER_OPTIONS);
  const loaded = grpc.loadPackageDefinition(definition);
  return {
    definition,
    AssetService: loaded.meshstream.v1.AssetService,
    Health: loaded.grpc.health.v1.Health,
  };
}

// Plaintext channel; with MESHSTREAM_TOKEN set, every call carries
// "authorization: Bearer <token>".
function connect(address, token) {
  const protos = loadProtos();
  const credentials = grpc.credentials.createInsecure();
  const options = {
    // The server sends at most 1 MiB per message; leave room above that.
    'grpc.max_receive_message_length': 8 * 1024 * 1024,
  };
  const metadata = () => {
    const md = new grpc.Metadata();
    if (token) md.set('authorization', `Bearer ${token}`);
    return md;
  };
  return {
    grpc,
    protos,
    assets: new protos.AssetService(address, credentials, options),
    health: new protos.Health(address, credentials, options),
    metadata,
    close() {
      this.assets.close();
      this.health.close();
    },
  };
}

function deadline(seconds) {
  return new Date(Date.now() + seconds * 1000);
}

// Promise form of a unary call: resolves with the response, rejects with the
// grpc error (its .code is the status code).
function unary(client, method, request, metadata, seconds = 30) {
  return new Promise((resolve, reject) => {
    client[method](request, metadata, { deadline: deadline(seconds) }, (err, response) =>
      err ? reject(err) : resolve(response));
  });
}

module.exports = { grpc, loadProtos, connect, deadline, unary, ROOT };
