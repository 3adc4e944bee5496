#!/usr/bin/env node
// Validates glTF / GLB files with the Khronos glTF validator.
// Usage: node .ci/validate_gltf.js FILE...
// Prints one summary line per file (and its first errors and warnings); exits 1 if any file
// has errors (or cannot be read), 2 on bad usage or when the validator is not installed. The validator is looked up in .ci/node_modules first, then the usual way.
'use strict';
const fs = require('fs');
const path = require('path');

function loadValidator() {
  try {
    return require(path.join(__dirname, 'node_modules', 'gltf-validator'));
  } catch (e) {
    try {
      return require('gltf-validator');
    } catch (e2) {
      console.error(
        'validate_gltf.js: cannot find the gltf-validator package; install it with\n' +
          '  npm install --prefix .ci gltf-validator'
      );
      process.exit(2);
    }
  }
}

async function validate(validator, file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: () => Promise.reject(new Error('external resources are not loaded')),
  });
  const i = report.issues;
  const firsts = i.messages
    .filter((m) => m.severity <= 1)
    .slice(0, 5)
    .map((m) => `  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ${m.message}`);
  console.log(
    `${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`
  );
  for (const line of firsts) console.log(line);
  return i.numErrors === 0;
}

async function main() {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    console.error('usage: node validate_gltf.js FILE...');
    process.exit(2);
  }
  const validator = loadValidator();
  let ok = true;
  for (const f of files) {
    try {
      ok = (await validate(validator, f)) && ok;
    } catch (e) {
      console.log(`${f}: cannot validate: ${e && e.message ? e.message : e}`);
      ok = false;
    }
  }
  process.exit(ok ? 0 : 1);
}

main();
