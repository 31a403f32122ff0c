#!/usr/bin/env node
// Parses deploy/compose.yaml (js-yaml from tools/node_modules) and checks what
// the several-server deployment relies on: the servers share PostgreSQL with
// tokens required, every "service_healthy" dependency has a healthcheck, stop
// timeouts exceed the grace period, and nginx.conf's upstream names exactly the
// meshstream servers of the compose file. Usage: check_compose.js PROJECT_ROOT
// Prints one line per problem; exit 0 (all good), 1 (problems), 2 (cannot run).
'use strict';

const fs = require('fs');
const path = require('path');

const root = path.resolve(process.argv[2] || path.join(__dirname, '..', '..'));
const deployDir = path.join(root, 'deploy');

let yaml;
try {
  yaml = require(path.join(root, 'tools', 'node_modules', 'js-yaml'));
} catch (e) {
  console.error('check_compose: js-yaml is not installed in tools/node_modules (run scripts/install-deps)');
  process.exit(2);
}

const problems = [];
const problem = (msg) => problems.push(msg);

let compose;
try {
  compose = yaml.load(fs.readFileSync(path.join(deployDir, 'compose.yaml'), 'utf8'));
} catch (e) {
  console.log(`compose.yaml does not parse: ${e.message}`);
  process.exit(1);
}
if (!compose || typeof compose !== 'object' || !compose.services || typeof compose.services !== 'object') {
  console.log('compose.yaml has no services mapping');
  process.exit(1);
}
const services = compose.services;

// "45s", "1m30s", "2m", 45 -> seconds; NaN when unreadable.
function seconds(value) {
  if (typeof value === 'number') return value;
  if (typeof value !== 'string' || !/^(\d+(\.\d+)?(h|m|s|ms|us))+$/.test(value)) return NaN;
  const unit = { h: 3600, m: 60, s: 1, ms: 1e-3, us: 1e-6 };
  let total = 0;
  for (const [, n, , u] of value.matchAll(/(\d+(\.\d+)?)(h|ms|us|m|s)/g)) total += Number(n) * unit[u];
  return total;
}

// environment: as a mapping or as a list of KEY=VALUE.
function environment(service) {
  const env = service.environment || {};
  if (!Array.isArray(env)) return env;
  const out = {};
  for (const item of env) {
    const i = String(item).indexOf('=');
    if (i > 0) out[item.slice(0, i)] = item.slice(i + 1);
  }
  return out;
}

// depends_on: as a list of names (condition service_started) or a mapping.
function dependsOn(service) {
  const d = service.depends_on;
  if (!d) return {};
  if (Array.isArray(d)) return Object.fromEntries(d.map((n) => [n, { condition: 'service_started' }]));
  return d;
}

function healthTest(service) {
  const hc = service.healthcheck;
  if (!hc || hc.disable) return null;
  return Array.isArray(hc.test) ? hc.test.join(' ') : String(hc.test || '');
}

// Every service that builds from a path builds from one that exists.
for (const [name, svc] of Object.entries(services)) {
  if (!svc || typeof svc !== 'object') {
    problem(`service ${name} is not a mapping`);
    continue;
  }
  if (!svc.image && !svc.build) problem(`service ${name} has neither image nor build`);
  if (svc.build) {
    const ctx = path.resolve(deployDir, typeof svc.build === 'string' ? svc.build : svc.build.context || '.');
    const file = path.resolve(ctx, (svc.build && svc.build.dockerfile) || 'Dockerfile');
    if (!fs.existsSync(ctx)) problem(`service ${name}: build context ${ctx} does not exist`);
    if (!fs.existsSync(file)) problem(`service ${name}: ${file} does not exist`);
  }
  for (const [dep, spec] of Object.entries(dependsOn(svc))) {
    if (!services[dep]) {
      problem(`service ${name} depends on ${dep}, which is not a service`);
      continue;
    }
    const condition = (spec && spec.condition) || 'service_started';
    if (!['service_started', 'service_healthy', 'service_completed_successfully'].includes(condition)) {
      problem(`service ${name}: depends_on ${dep} has an unknown condition "${condition}"`);
    }
    if (condition === 'service_healthy' && !healthTest(services[dep])) {
      problem(`service ${name} waits for ${dep} to be healthy, but ${dep} has no healthcheck`);
    }
  }
}

// PostgreSQL 15 with a named volume and pg_isready.
const pg = services.postgres;
if (!pg) {
  problem('no service "postgres"');
} else {
  if (!/(^|\/)postgres:15([.-]|$)/.test(String(pg.image || ''))) problem(`postgres image is "${pg.image}", not PostgreSQL 15`);
  if (!/pg_isready/.test(healthTest(pg) || '')) problem('postgres healthcheck does not use pg_isready');
  const data = (pg.volumes || []).map(String).find((v) => v.split(':')[1] === '/var/lib/postgresql/data');
  if (!data) problem('postgres keeps /var/lib/postgresql/data on no volume');
  else if (!(compose.volumes && data.split(':')[0] in compose.volumes)) problem(`postgres volume "${data.split(':')[0]}" is not a named volume of the file`);
}

// The meshstream servers: services built from deploy/Containerfile.
const servers = Object.entries(services).filter(([, s]) => s && s.build && String(s.build.dockerfile || '').endsWith('deploy/Containerfile'));
if (servers.length < 2) problem(`${servers.length} service(s) build deploy/Containerfile; several servers need at least 2`);
for (const [name, svc] of servers) {
  const env = environment(svc);
  if (!/^postgresql:\/\//.test(String(env.MESHSTREAM_STORE || ''))) problem(`${name}: MESHSTREAM_STORE is not a postgresql:// URL`);
  if (!['true', '1', 'yes'].includes(String(env.MESHSTREAM_AUTH).toLowerCase())) problem(`${name}: MESHSTREAM_AUTH is not true`);
  const grace = Number(env.MESHSTREAM_GRACE_PERIOD);
  const stop = seconds(svc.stop_grace_period);
  if (!Number.isFinite(grace)) problem(`${name}: MESHSTREAM_GRACE_PERIOD is not set to a number of seconds`);
  if (!Number.isFinite(stop)) problem(`${name}: stop_grace_period "${svc.stop_grace_period}" is missing or unreadable`);
  if (Number.isFinite(grace) && Number.isFinite(stop) && !(stop > grace)) {
    problem(`${name}: stop_grace_period ${stop}s is not longer than the grace period ${grace}s (SIGKILL would cut the drain)`);
  }
  if (svc.stop_signal && svc.stop_signal !== 'SIGTERM') problem(`${name}: stop_signal is ${svc.stop_signal}, the server drains on SIGTERM`);
  const dep = dependsOn(svc).postgres;
  if (!dep || dep.condition !== 'service_healthy') problem(`${name} does not wait for postgres to be healthy`);
  if (!healthTest(svc)) problem(`${name} has no healthcheck`);
}

// nginx: mounts deploy/nginx.conf, waits for every server, publishes 7600, and
// its upstream lists exactly the servers.
const lb = services.nginx;
if (!lb) {
  problem('no service "nginx"');
} else {
  const mount = (lb.volumes || []).map(String).find((v) => v.split(':')[1] === '/etc/nginx/nginx.conf');
  if (!mount || path.resolve(deployDir, mount.split(':')[0]) !== path.join(deployDir, 'nginx.conf')) {
    problem('nginx does not mount deploy/nginx.conf as /etc/nginx/nginx.conf');
  }
  for (const [name] of servers) {
    const dep = dependsOn(lb)[name];
    if (!dep || dep.condition !== 'service_healthy') problem(`nginx does not wait for ${name} to be healthy`);
  }
  if (!(lb.ports || []).map(String).some((p) => /(^|:)7600$/.test(p))) problem('nginx publishes no port 7600');
  let conf = '';
  try {
    conf = fs.readFileSync(path.join(deployDir, 'nginx.conf'), 'utf8').replace(/#.*$/gm, '');
  } catch (e) {
    problem(`cannot read deploy/nginx.conf: ${e.message}`);
  }
  const upstream = /upstream\s+(\S+)\s*\{([^}]*)\}/.exec(conf);
  if (!upstream) {
    problem('nginx.conf has no upstream block');
  } else {
    if (!new RegExp(`grpc_pass\\s+grpcs?://${upstream[1]}\\s*;`).test(conf)) problem(`nginx.conf does not grpc_pass to upstream ${upstream[1]}`);
    const listed = [...upstream[2].matchAll(/server\s+([^\s;]+)/g)].map((m) => m[1]).sort();
    const expected = servers.map(([name]) => `${name}:7600`).sort();
    if (JSON.stringify(listed) !== JSON.stringify(expected)) {
      problem(`nginx.conf upstream lists ${listed.join(', ') || 'nothing'}; compose has ${expected.join(', ')}`);
    }
  }
}

for (const p of problems) console.log(p);
process.exit(problems.length ? 1 : 0);
