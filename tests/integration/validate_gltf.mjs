#!/usr/bin/env node
// Runs the Khronos glTF validator (npm package gltf-validator) on a .glb or .gltf file.
//
//   node validate_gltf.mjs [--report OUT.json] FILE.glb|FILE.gltf
//
// Prints the counts of errors, warnings, infos and hints and every message (at most 50 per
// severity). The format is taken from the file name (.glb / .gltf; other names are
// auto-detected from the first byte), so a truncated GLB is still checked as GLB.
// External buffers of a .gltf are read from beside the file; data URIs are checked as well.
// --report writes the validator's full JSON report.
//
// Exit status: 0 no errors (warnings allowed), 1 errors or the validator refused the file,
// 2 usage error (bad arguments, unreadable file).

import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const validator = require('gltf-validator');

const USAGE = 'usage: node validate_gltf.mjs [--report OUT.json] FILE.glb|FILE.gltf';
const SEVERITIES = ['ERROR', 'WARNING', 'INFO', 'HINT'];
const SHOWN_PER_SEVERITY = 50;

function usage(message) {
  console.error(`validate_gltf: ${message}`);
  return 2;
}

async function main(argv) {
  const args = [...argv];
  let reportFile = null;
  if (args[0] === '--report') {
    if (args.length < 2) return usage(USAGE);
    reportFile = args[1];
    args.splice(0, 2);
  }
  if (args.length !== 1 || args[0].startsWith('-')) return usage(USAGE);
  const file = args[0];

  let bytes;
  try {
    bytes = fs.readFileSync(file);
  } catch (e) {
    return usage(`cannot read ${file}: ${e.message}`);
  }
  const ext = path.extname(file).toLowerCase();
  const format = ext === '.glb' ? 'glb' : ext === '.gltf' ? 'gltf' : undefined;
  const dir = path.dirname(path.resolve(file));

  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(bytes), {
      uri: path.basename(file),
      format,
      maxIssues: 0,
      writeTimestamp: false,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        const target = path.resolve(dir, decodeURIComponent(uri));
        if (path.relative(dir, target).startsWith('..')) {
          reject(new Error(`external resource ${uri} is outside ${dir}`));
          return;
        }
        fs.readFile(target, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
      }),
    });
  } catch (e) {
    console.error(`FAILED ${file}: the validator refused it: ${e && e.message ? e.message : e}`);
    return 1;
  }

  if (reportFile) fs.writeFileSync(reportFile, JSON.stringify(report, null, 2) + '\n');

  const issues = report.issues;
  console.log(`glTF validator ${report.validatorVersion}: ${file} (${bytes.length} bytes): ` +
    `${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints` +
    (issues.truncated ? ' (messages truncated)' : ''));
  if (report.info) {
    const i = report.info;
    console.log(`  asset: version ${i.version}, generator ${JSON.stringify(i.generator || '')}, ` +
      `${i.drawCallCount} draw calls, ${i.totalVertexCount} vertices, ${i.totalTriangleCount} triangles`);
  }
  SEVERITIES.forEach((name, severity) => {
    const messages = issues.messages.filter((m) => m.severity === severity);
    for (const m of messages.slice(0, SHOWN_PER_SEVERITY))
      console.log(`  ${name} ${m.code}${m.pointer ? ` at ${m.pointer}` : ''}${m.offset !== undefined ? ` (byte ${m.offset})` : ''}: ${m.message}`);
    if (messages.length > SHOWN_PER_SEVERITY) console.log(`  ... and ${messages.length - SHOWN_PER_SEVERITY} more ${name} messages`);
  });
  if (issues.numErrors > 0) {
    console.error(`INVALID ${file}: ${issues.numErrors} glTF validation error(s)`);
    return 1;
  }
  return 0;
}

main(process.argv.slice(2)).then(
  (code) => { process.exitCode = code; },
  (e) => { console.error(e && e.stack ? e.stack : String(e)); process.exitCode = 2; },
);
