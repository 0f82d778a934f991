// api/openapi.yaml agrees with the option tables (api/options_table.cpp), as `featureline
// options` prints them: every option's type, limits, default and accepted names, no option
// missing from the spec and none in the spec that the server would refuse; request-shape limits too.
//   FEATURELINE=build/cli/featureline node --test tests/api/openapi_options_test.mjs
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import YAML from 'yaml';

const root = path.join(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const cli = process.env.FEATURELINE ?? path.join(root, 'build/cli/featureline');
const tables = JSON.parse(execFileSync(cli, ['options'], { encoding: 'utf8' }));
const spec = YAML.parse(fs.readFileSync(path.join(root, 'api/openapi.yaml'), 'utf8'));
const schemas = spec.components.schemas;

const resolve = (s) => (s?.$ref ? schemas[s.$ref.split('/').at(-1)] : s);

// The schema of a dotted option name below an object schema, following $refs.
function property(object, name) {
  let s = resolve(object);
  for (const part of name.split('.')) {
    s = resolve(s?.properties?.[part]);
    if (!s) return undefined;
  }
  return s;
}

// Every leaf property of an object schema, as dotted names.
function leaves(object, prefix = '') {
  const names = [];
  for (const [k, v] of Object.entries(resolve(object).properties)) {
    const s = resolve(v);
    if (s.type === 'object' && s.properties) names.push(...leaves(s, `${prefix}${k}.`));
    else names.push(prefix + k);
  }
  return names;
}

function expectAgreement(rows, object, ignore = []) {
  for (const row of rows) {
    const s = property(object, row.name);
    assert.ok(s, `${row.name} is in the table but not in api/openapi.yaml`);
    assert.equal(s.type, row.type, `${row.name}: type`);
    assert.deepEqual(s.default, row.default, `${row.name}: default`);
    assert.equal(s.minimum, row.minimum, `${row.name}: minimum`);
    assert.equal(s.maximum, row.maximum, `${row.name}: maximum`);
    assert.deepEqual(s.enum, row.enum, `${row.name}: enum`);
    assert.ok(s.description, `${row.name}: the spec describes it`);
  }
  const names = new Set(rows.map((r) => r.name));
  for (const name of leaves(object)) {
    if (!ignore.includes(name)) assert.ok(names.has(name), `${name} is in api/openapi.yaml but not in the table`);
  }
}

test('a line\'s options agree with the feature-line table', () => {
  expectAgreement(tables.feature_line, schemas.Options);
});

test('the features route\'s options agree with the feature-seed table', () => {
  expectAgreement(tables.features, schemas.FeatureSeedOptions);
  const route = spec.paths['/v1/meshes/{mesh_id}/features'].get;
  const names = route.parameters.filter((p) => p.in === 'query').map((p) => p.name).sort();
  assert.deepEqual(names, tables.features.map((r) => r.name).sort());
});

test('a segmentation request\'s options agree with the segmentation table', () => {
  expectAgreement(tables.segmentation, schemas.SegmentationRequest, ['lines']);
});

test('request-shape limits agree', () => {
  assert.equal(schemas.LineRequest.properties.keys.maxItems, tables.limits.max_keys_per_line);
  assert.equal(schemas.LineBatchRequest.properties.lines.maxItems, tables.limits.max_lines);
  assert.equal(schemas.SegmentationRequest.properties.lines.maxItems, tables.limits.max_lines);
});

test('the check itself notices a disagreement', () => {
  const row = structuredClone(tables.feature_line.find((r) => r.name === 'snake.iterations'));
  row.maximum += 1;
  assert.throws(() => expectAgreement([row], schemas.Options), /snake.iterations: maximum/);
  assert.throws(() => expectAgreement(tables.feature_line.slice(1), schemas.Options), /is in api\/openapi.yaml but not in the table/);
});
