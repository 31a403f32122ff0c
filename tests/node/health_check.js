#!/usr/bin/env node
// One grpc.health.v1 Check of a server: `node health_check.js HOST:PORT [SERVICE]`.
// Prints the status; exit 0 when SERVING, 1 otherwise (NOT_SERVING, no answer
// within 2 s, an error). MESHSTREAM_TOKEN, when set, is sent as a bearer token.
'use strict';

const { connect, unary } = require('./client');

async function main() {
  const address = process.argv[2];
  const service = process.argv[3] || '';
  if (!address) {
    console.error('usage: health_check.js HOST:PORT [SERVICE]');
    return 2;
  }
  const c = connect(address, process.env.MESHSTREAM_TOKEN);
  try {
    const response = await unary(c.health, 'Check', { service }, c.metadata(), 2);
    console.log(`${address}: ${response.status}`);
    return response.status === 'SERVING' ? 0 : 1;
  } catch (err) {
    console.log(`${address}: ${err.code !== undefined ? `status ${err.code}: ` : ''}${err.details || err.message}`);
    return 1;
  } finally {
    c.close();
  }
}

main().then((code) => process.exit(code));
