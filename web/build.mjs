#!/usr/bin/env node
// Builds the browser front-end into web/dist (or the folder given as the first argument):
//   - the page itself (web/src/*), plain ES modules, no bundler;
//   - the parts of three.js it imports, copied from node_modules/three (so the page works
//     offline; nothing comes from a CDN), with the relative imports of each add-on followed;
//   - the repository's own bundled samples (samples/*.off and other mesh files) and
//     samples/index.json listing them.
// Usage: node web/build.mjs [OUT_DIR]      (needs `npm ci` first, for node_modules/three)
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..');

// The three.js add-ons the page imports (under examples/jsm); their own relative imports
// are found and copied too.
const ADDONS = [
  'loaders/GLTFLoader.js',
  'exporters/GLTFExporter.js',
  'controls/OrbitControls.js',
  'lines/Line2.js',
  'lines/LineMaterial.js',
  'lines/LineGeometry.js',
];
const MESH_EXTENSIONS = ['obj', 'off', 'ply', 'stl', 'glb', 'gltf', 'drc'];

function copyFile(from, to) {
  fs.mkdirSync(path.dirname(to), { recursive: true });
  fs.copyFileSync(from, to);
}

// Relative module specifiers of a JS file: `from './x.js'`, `import './x.js'`.
function relativeImports(source) {
  const found = new Set();
  for (const m of source.matchAll(/(?:\bfrom\s*|\bimport\s*\(?\s*)['"](\.{1,2}\/[^'"]+)['"]/g)) found.add(m[1]);
  return [...found];
}

function copyModuleTree(rootDir, entry, outRoot, copied) {
  const rel = path.normalize(entry);
  if (copied.has(rel)) return;
  const from = path.join(rootDir, rel);
  if (!fs.existsSync(from)) throw new Error(`three.js file missing: ${from} (run npm ci?)`);
  copied.add(rel);
  copyFile(from, path.join(outRoot, rel));
  for (const spec of relativeImports(fs.readFileSync(from, 'utf8')))
    copyModuleTree(rootDir, path.join(path.dirname(rel), spec), outRoot, copied);
}

export function build(outDir = path.join(here, 'dist')) {
  const three = path.join(repo, 'node_modules', 'three');
  if (!fs.existsSync(path.join(three, 'package.json')))
    throw new Error('node_modules/three is missing: run `npm ci` at the repository root first');
  const threeVersion = JSON.parse(fs.readFileSync(path.join(three, 'package.json'), 'utf8')).version;

  fs.rmSync(outDir, { recursive: true, force: true });
  fs.mkdirSync(outDir, { recursive: true });

  // The page.
  const src = path.join(here, 'src');
  for (const name of fs.readdirSync(src)) copyFile(path.join(src, name), path.join(outDir, name));

  // three.js: the core build (three.module.js imports three.core.js) and the add-ons.
  const vendor = path.join(outDir, 'vendor', 'three');
  const copied = new Set();
  copyModuleTree(path.join(three, 'build'), 'three.module.js', path.join(vendor, 'build'), copied);
  const addons = new Set();
  for (const a of ADDONS) copyModuleTree(path.join(three, 'examples', 'jsm'), a, path.join(vendor, 'examples', 'jsm'), addons);
  copyFile(path.join(three, 'LICENSE'), path.join(vendor, 'LICENSE'));

  // Bundled samples: only the repository's own samples/ folder.
  const samplesIn = path.join(repo, 'samples');
  const samplesOut = path.join(outDir, 'samples');
  fs.mkdirSync(samplesOut, { recursive: true });
  const samples = [];
  for (const name of fs.readdirSync(samplesIn).sort()) {
    const ext = path.extname(name).slice(1).toLowerCase();
    if (!MESH_EXTENSIONS.includes(ext)) continue;
    copyFile(path.join(samplesIn, name), path.join(samplesOut, name));
    const stem = name.slice(0, -(ext.length + 1));
    const keysFile = path.join(samplesIn, `${stem}.keys`);
    const keys = fs.existsSync(keysFile)
      ? fs.readFileSync(keysFile, 'utf8').split(/[\s,]+/).filter(Boolean).map(Number).filter(Number.isInteger)
      : [];
    samples.push({ name: stem, file: `samples/${name}`, format: ext, bytes: fs.statSync(path.join(samplesIn, name)).size, keys });
  }
  fs.writeFileSync(path.join(samplesOut, 'index.json'), JSON.stringify({ samples }, null, 2) + '\n');

  return { outDir, threeVersion, threeFiles: copied.size + addons.size, samples: samples.map((s) => s.file) };
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  try {
    const out = path.resolve(process.argv[2] || path.join(here, 'dist'));
    const r = build(out);
    console.log(`web: built ${path.relative(process.cwd(), r.outDir) || '.'} (three ${r.threeVersion}, ${r.threeFiles} module files; samples: ${r.samples.join(', ') || 'none'})`);
  } catch (e) {
    console.error(`web/build.mjs: ${e.message}`);
    process.exit(1);
  }
}
