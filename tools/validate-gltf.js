#!/usr/bin/env node
// Validates glTF/GLB files with the Khronos glTF validator.
// Usage: node tools/validate-gltf.js FILE...
// Prints one JSON line per file: {"file","errors","warnings","infos","messages":[first errors]}
// Exit status: 0 when no file has an error, 1 otherwise, 2 on usage or I/O problems.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
  const data = new Uint8Array(fs.readFileSync(file));
  const dir = path.dirname(path.resolve(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 200,
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
      const p = path.resolve(dir, decodeURIComponent(uri));
      if (!p.startsWith(dir + path.sep)) { reject(new Error('outside asset folder')); return; }
      fs.readFile(p, (err, buf) => err ? reject(err) : resolve(new Uint8Array(buf)));
    }),
  });
  const issues = report.issues;
  const errors = issues.messages.filter((m) => m.severity === 0)
      .slice(0, 10).map((m) => `${m.code} ${m.pointer || ''} ${m.message}`);
  return {file, errors: issues.numErrors, warnings: issues.numWarnings,
          infos: issues.numInfos, messages: errors};
}

(async () => {
  const files = process.argv.slice(2);
  if (files.length === 0) { console.error('usage: validate-gltf.js FILE...'); process.exit(2); }
  let failed = false;
  for (const f of files) {
    try {
      const r = await validate(f);
      console.log(JSON.stringify(r));
      if (r.errors > 0) failed = true;
    } catch (e) {
      console.error(`${f}: ${e.message}`);
      process.exit(2);
    }
  }
  process.exit(failed ? 1 : 0);
})();
