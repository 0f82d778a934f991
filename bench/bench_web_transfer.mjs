#!/usr/bin/env node
// What the page downloads to show a mesh, and how long until it is on screen: for the bunny
// (70k triangles) and igea (269k), the bytes of mesh.glb (float, and the compact form the page
// reads) and of the curvature on the wire with and without gzip, and the time from choosing the file to the first frame showing it in
// Debian's headless Chromium (software WebGL), median of 3 opens.
//
//   node bench/bench_web_transfer.mjs            (from the repository root, after building)
//
// Environment: SERVER (default build/server/featureline-server), CHROMIUM (/usr/bin/chromium),
// RUNS (3). Meshes come from ../shared/data/meshes; a missing one is an error naming it.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const SERVER = path.resolve(repo, process.env.SERVER || 'build/server/featureline-server');
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const RUNS = Number(process.env.RUNS || 3);
const MESHES = ['bunny_closed.off', 'igea.ply'];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

for (const m of MESHES) {
  const p = path.join(repo, '..', 'shared', 'data', 'meshes', m);
  if (!fs.existsSync(p)) {
    console.error(`bench_web_transfer: missing ${path.relative(repo, p)}`);
    process.exit(1);
  }
}
if (!fs.existsSync(SERVER)) {
  console.error(`bench_web_transfer: ${SERVER} not found (build featureline-server, or set SERVER)`);
  process.exit(1);
}

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'featureline-bench-web-'));
const { build } = await import(path.join(repo, 'web', 'build.mjs'));
const webRoot = build(path.join(tmp, 'web')).outDir;
const portFile = path.join(tmp, 'port');
const server = spawn(SERVER, ['--host', '127.0.0.1', '--port', '0', '--port-file', portFile, '--web-root', webRoot, '--threads', '2'], {
  stdio: 'ignore',
});
let port = 0;
for (let i = 0; i < 100 && !port; ++i) {
  await sleep(50);
  const text = fs.existsSync(portFile) ? fs.readFileSync(portFile, 'utf8').trim() : '';
  if (/^\d+$/.test(text)) port = Number(text);
}
const base = `http://127.0.0.1:${port}`;

// Bytes on the wire (Content-Length of the answer as sent) and the time to read it.
async function fetchBytes(url, headers) {
  const t = performance.now();
  const response = await fetch(url, { headers });
  const body = new Uint8Array(await response.arrayBuffer()); // decoded by fetch when gzip
  const ms = performance.now() - t;
  return { wire: Number(response.headers.get('Content-Length')) || body.byteLength, decoded: body.byteLength, encoding: response.headers.get('Content-Encoding') || 'identity', ms };
}

let context;
try {
  const rows = [];
  for (const name of MESHES) {
    const file = path.join(repo, '..', 'shared', 'data', 'meshes', name);
    const upload = await fetch(`${base}/v1/meshes`, { method: 'POST', headers: { 'Content-Type': 'application/octet-stream' }, body: fs.readFileSync(file) });
    const description = await upload.json();
    const id = description.mesh_id;
    const raw = await fetchBytes(`${base}/v1/meshes/${id}/mesh.glb`, { 'Accept-Encoding': 'identity' });
    const gz = await fetchBytes(`${base}/v1/meshes/${id}/mesh.glb`, { 'Accept-Encoding': 'gzip, deflate, br' });
    const compactRaw = await fetchBytes(`${base}/v1/meshes/${id}/mesh.glb?compact=1`, { 'Accept-Encoding': 'identity' });
    const compact = await fetchBytes(`${base}/v1/meshes/${id}/mesh.glb?compact=1`, { 'Accept-Encoding': 'gzip, deflate, br' });
    const curvature = await fetchBytes(`${base}/v1/meshes/${id}/curvature`, { Accept: 'application/octet-stream', 'Accept-Encoding': 'gzip, deflate, br' });
    rows.push({ name, triangles: description.faces, fileBytes: fs.statSync(file).size, raw, gz, compactRaw, compact, curvature, renders: [] });
    await fetch(`${base}/v1/meshes/${id}`, { method: 'DELETE' });
  }

  const { chromium } = await import('playwright-core');
  context = await chromium.launchPersistentContext(path.join(tmp, 'profile'), {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1280, height: 800 },
    args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-background-networking'],
  });
  const page = context.pages()[0] || (await context.newPage());
  for (const row of rows) {
    for (let run = 0; run < RUNS; ++run) {
      await page.goto(`${base}/`);
      await page.waitForFunction(() => window.featureline);
      await page.setInputFiles('#file-input', path.join(repo, '..', 'shared', 'data', 'meshes', row.name));
      const timings = await page.waitForFunction((n) => window.featureline.openTimings?.name === n && window.featureline.openTimings, row.name, { timeout: 120000 });
      row.renders.push(await timings.jsonValue());
    }
  }

  console.log('mesh download of the page (mesh.glb; the curvature field is fetched beside it), 127.0.0.1:');
  console.log('mesh               triangles  file bytes   glb raw    glb gzip  gzip/raw  gzip ms  raw ms  curvature wire');
  for (const r of rows)
    console.log(
      `${r.name.padEnd(18)} ${String(r.triangles).padStart(9)} ${String(r.fileBytes).padStart(11)} ${String(r.raw.wire).padStart(9)} ${String(r.gz.wire).padStart(11)}` +
        `  ${(r.gz.wire / r.raw.wire).toFixed(3).padStart(8)} ${r.gz.ms.toFixed(0).padStart(8)} ${r.raw.ms.toFixed(0).padStart(7)} ${String(r.curvature.wire).padStart(10)} (${r.curvature.encoding})`,
    );
  console.log('\nwhat the page downloads: mesh.glb?compact=1 (KHR_mesh_quantization; carries the curvature, so /curvature is not fetched)');
  console.log('mesh               compact raw  compact gzip  gzip ms  wire / float glb raw');
  for (const r of rows)
    console.log(
      `${r.name.padEnd(18)} ${String(r.compactRaw.wire).padStart(11)} ${String(r.compact.wire).padStart(13)} ${r.compact.ms.toFixed(0).padStart(8)}` +
        `  ${(r.compact.wire / r.raw.wire).toFixed(3).padStart(20)}`,
    );
  console.log(`load average: ${os.loadavg().map((x) => x.toFixed(1)).join(' ')}`);
  console.log(`\ntime to first render in headless Chromium (software WebGL), median of ${RUNS}: choose the file -> first frame with the mesh`);
  console.log('mesh               upload+prepare ms  download+build ms  first render ms');
  for (const r of rows) {
    const m = (k) => median(r.renders.map((t) => t[k])).toFixed(0);
    console.log(`${r.name.padEnd(18)} ${m('uploadMs').padStart(17)} ${m('downloadAndBuildMs').padStart(18)} ${m('firstRenderMs').padStart(16)}`);
  }
} finally {
  if (context) await context.close();
  process.kill(server.pid, 'SIGTERM');
  fs.rmSync(tmp, { recursive: true, force: true });
}
