// api/openapi.yaml agrees with the option tables (api/options_table.cpp), as `featureline
// options` prints them: every option's type, limits, default and accepted names, no option
// missing from the spec and none in the spec that the server would refuse; a renamed option's old
// names are in the spec too, marked deprecated, with the same schema; request-shape limits too.
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

// The schema a local $ref points at ("#/components/schemas/StripOptions/properties/rings").
const at = (ref) => ref.slice(2).split('/').reduce((s, k) => s?.[k.replaceAll('~1', '/').replaceAll('~0', '~')], spec);
const resolve = (s) => (s?.$ref ? resolve(at(s.$ref)) : s);

// Every leaf property of an object schema: {name (dotted), schema, deprecated}. A property whose
// schema is a oneOf (an old name's form beside the new one) gives a leaf or group per branch;
// `deprecated` on a property, a branch or a group on the way marks the leaf deprecated.
function leaves(object, prefix = '', deprecated = false) {
  const found = [];
  for (const [k, v] of Object.entries(resolve(object).properties)) {
    for (const branch of resolve(v).oneOf ?? [v]) {
      const s = resolve(branch);
      const old = deprecated || Boolean(v.deprecated || branch.deprecated);
      if (s.type === 'object' && s.properties) found.push(...leaves(s, `${prefix}${k}.`, old));
      else found.push({ name: prefix + k, schema: s, deprecated: old });
    }
  }
  return found;
}

// Each row's name is a current (not deprecated) leaf and each of its old names a deprecated one,
// with the row's type, limits, default and names; every other leaf is an error.
function expectAgreement(rows, object, ignore = []) {
  const found = new Map(leaves(object).map((leaf) => [leaf.name, leaf]));
  const expected = new Map();
  for (const row of rows) {
    expected.set(row.name, { row, deprecated: false });
    for (const old of row.old_names ?? []) expected.set(old, { row, deprecated: true });
  }
  for (const [name, { row, deprecated }] of expected) {
    const leaf = found.get(name);
    assert.ok(leaf, `${name} is in the table but not in api/openapi.yaml`);
    assert.equal(leaf.deprecated, deprecated, `${name}: ${deprecated ? 'an old name, deprecated' : 'a current name, not deprecated'}`);
    const s = leaf.schema;
    assert.equal(s.type, row.type, `${name}: type`);
    assert.deepEqual(s.default, row.default, `${name}: default`);
    assert.equal(s.minimum, row.minimum, `${name}: minimum`);
    assert.equal(s.maximum, row.maximum, `${name}: maximum`);
    assert.deepEqual(s.enum, row.enum, `${name}: enum`);
    assert.ok(s.description, `${name}: the spec describes it`);
  }
  for (const name of found.keys()) {
    if (!ignore.includes(name)) assert.ok(expected.has(name), `${name} is in api/openapi.yaml but not in the table`);
  }
}

test('a line\'s options agree with the feature-line table', () => {
  expectAgreement(tables.feature_line, schemas.Options);
});

test('renamed options: each name is its member\'s path, the old names are listed', () => {
  const renamed = Object.fromEntries(tables.feature_line.filter((r) => r.old_names).map((r) => [r.name, r.old_names]));
  assert.deepEqual(renamed['initial.method'], ['initial']);
  assert.deepEqual(renamed['initial.marching_alpha'], ['weights.alpha']);
  assert.deepEqual(renamed['strip.rings'], ['rings']);
  assert.deepEqual(renamed['snake.max_iterations'], ['snake.iterations']);
  assert.equal(Object.keys(renamed).length, 15);
  for (const table of ['segmentation', 'curvature', 'features']) assert.ok(tables[table].every((r) => !r.old_names), table);
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
  const row = structuredClone(tables.feature_line.find((r) => r.name === 'snake.max_iterations'));
  row.maximum += 1;
  assert.throws(() => expectAgreement([row], schemas.Options), /snake.max_iterations: maximum/);
  row.maximum -= 1;
  row.old_names = ['snake.iterationz'];
  assert.throws(() => expectAgreement([row], schemas.Options), /snake.iterationz is in the table but not in api\/openapi.yaml/);
  row.old_names = ['snake.featureless_iterations'];
  assert.throws(() => expectAgreement([row], schemas.Options), /snake.featureless_iterations: an old name, deprecated/);
  assert.throws(() => expectAgreement(tables.feature_line.slice(1), schemas.Options), /is in api\/openapi.yaml but not in the table/);
});
