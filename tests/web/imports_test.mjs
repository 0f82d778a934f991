#!/usr/bin/env node
// The page's module structure: no import cycle among web/src's modules, the views never import
// one another, the store, actions and effects import nothing that needs a browser, and the
// viewer is made in main.js only (nothing constructs it at import time).
//   node --test tests/web/imports_test.mjs
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import test from 'node:test';
import { fileURLToPath } from 'node:url';

const src = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..', 'web', 'src');

// Every module's imports: relative ones as file names, bare ones ('three', ...) as they are.
function importGraph() {
  const graph = new Map();
  for (const name of fs.readdirSync(src).filter((f) => f.endsWith('.js'))) {
    const text = fs.readFileSync(path.join(src, name), 'utf8');
    const found = new Set();
    for (const m of text.matchAll(/^\s*(?:import|export)\s[^'"]*?\bfrom\s*['"]([^'"]+)['"]|^\s*import\s*['"]([^'"]+)['"]|\bimport\(\s*['"]([^'"]+)['"]\s*\)/gm)) {
      const spec = m[1] ?? m[2] ?? m[3];
      found.add(spec.startsWith('./') ? path.normalize(spec.slice(2)) : spec);
    }
    graph.set(name, found);
  }
  return graph;
}

// The cycles of a directed graph (each as the path that closes it), by depth-first search.
export function findCycles(graph) {
  const cycles = [];
  const state = new Map(); // name -> 'open' | 'done'
  const stack = [];
  const visit = (name) => {
    state.set(name, 'open');
    stack.push(name);
    for (const next of graph.get(name) ?? []) {
      if (!graph.has(next)) continue;
      if (state.get(next) === 'open') cycles.push([...stack.slice(stack.indexOf(next)), next]);
      else if (!state.has(next)) visit(next);
    }
    stack.pop();
    state.set(name, 'done');
  };
  for (const name of [...graph.keys()].sort()) if (!state.has(name)) visit(name);
  return cycles;
}

// Everything `name` imports, directly or not.
function reachable(graph, name) {
  const seen = new Set();
  const walk = (n) => {
    for (const next of graph.get(n) ?? []) if (!seen.has(next)) seen.add(next), walk(next);
  };
  walk(name);
  return seen;
}

const graph = importGraph();
const VIEWS = ['panel.js', 'options_panel.js', 'segmentation_panel.js', 'viewer_view.js'];
const CONTROLS = ['picking.js', 'keyboard.js', 'downloads.js'];
const BROWSER_FREE = ['store.js', 'model.js', 'actions.js', 'line_requests.js', 'mesh_effects.js', 'segmentation.js', 'trace.js'];

test('the cycle finder finds a cycle (a -> b -> c -> a) and none in a tree', () => {
  const cyclic = new Map([['a', new Set(['b'])], ['b', new Set(['c'])], ['c', new Set(['a'])], ['d', new Set(['a'])]]);
  assert.deepEqual(findCycles(cyclic), [['a', 'b', 'c', 'a']]);
  assert.deepEqual(findCycles(new Map([['a', new Set(['b', 'c'])], ['b', new Set(['c'])], ['c', new Set()]])), []);
});

test('web/src has no import cycle', () => {
  assert.ok(graph.size > 15, `read ${graph.size} modules`);
  const cycles = findCycles(graph);
  assert.deepEqual(cycles, [], `import cycles: ${cycles.map((c) => c.join(' -> ')).join('; ')}`);
});

test('views and controls import no view or control', () => {
  for (const name of [...VIEWS, ...CONTROLS]) {
    assert.ok(graph.has(name), `${name} exists`);
    const others = [...VIEWS, ...CONTROLS].filter((v) => v !== name && reachable(graph, name).has(v));
    assert.deepEqual(others, [], `${name} imports ${others.join(', ')}`);
  }
});

test('the store, actions and effects need no browser: no DOM module, no viewer, no three.js', () => {
  for (const name of BROWSER_FREE) {
    const reached = [...reachable(graph, name)];
    const browser = reached.filter((m) => m === 'dom.js' || m === 'viewer.js' || m === 'main.js' || m.startsWith('three') || VIEWS.includes(m) || CONTROLS.includes(m));
    assert.deepEqual(browser, [], `${name} reaches ${browser.join(', ')}`);
    const text = fs.readFileSync(path.join(src, name), 'utf8');
    assert.doesNotMatch(text, /\bdocument\.|\bwindow\./, `${name} touches the DOM`);
  }
});

test('only main.js makes the viewer, and nothing imports main.js', () => {
  for (const [name, imports] of graph) {
    assert.ok(!imports.has('main.js'), `${name} imports main.js`);
    if (name === 'main.js') continue;
    assert.doesNotMatch(fs.readFileSync(path.join(src, name), 'utf8'), /new Viewer\(/, `${name} makes a viewer`);
  }
  assert.match(fs.readFileSync(path.join(src, 'main.js'), 'utf8'), /new Viewer\(/);
});
