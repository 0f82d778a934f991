#!/usr/bin/env node
// Validates JSON bodies against the schemas of api/openapi.yaml (OpenAPI 3.1, JSON Schema 2020-12).
//
//   node validate_response.mjs [--spec FILE] METHOD PATH STATUS FILE.json   a response body
//   node validate_response.mjs [--spec FILE] --request METHOD PATH FILE.json a request body
//   node validate_response.mjs [--spec FILE] --schema NAME FILE.json        against components/schemas/NAME
//   node validate_response.mjs [--spec FILE] --check-spec                   compile every schema, check $refs and examples
//
// PATH is a path template of the spec ("/v1/meshes/{mesh_id}") or a concrete path matching one
// ("/v1/meshes/0123...cdef"); a query string is ignored. STATUS is looked up as the exact code,
// then its range ("4XX"), then "default". The body is validated against the operation's
// application/json schema, with every $ref resolved.
//
// Exit status: 0 valid, 1 invalid (errors listed on stderr), 2 usage error (unknown path,
// method or status, no JSON body documented there, unreadable file, broken spec).

import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';
import YAML from 'yaml';

const require = createRequire(import.meta.url);
const Ajv2020 = require('ajv/dist/2020').default;
const addFormats = require('ajv-formats').default;

const HERE = path.dirname(fileURLToPath(import.meta.url));
const DEFAULT_SPEC = path.resolve(HERE, '..', '..', 'api', 'openapi.yaml');
const SPEC_ID = 'urn:featureline:openapi';
const METHODS = ['get', 'put', 'post', 'delete', 'options', 'head', 'patch', 'trace'];
const JSON_MEDIA = 'application/json';

class UsageError extends Error {}

const USAGE = `usage:
  node validate_response.mjs [--spec FILE] METHOD PATH STATUS FILE.json
  node validate_response.mjs [--spec FILE] --request METHOD PATH FILE.json
  node validate_response.mjs [--spec FILE] --schema NAME FILE.json
  node validate_response.mjs [--spec FILE] --check-spec`;

// ---- the spec -------------------------------------------------------------------------------

function pointerEscape(token) {
  return String(token).replace(/~/g, '~0').replace(/\//g, '~1');
}

function pointerOf(tokens) {
  return '/' + tokens.map(pointerEscape).join('/');
}

function resolvePointer(doc, pointer) {
  if (pointer === '' || pointer === '/') return doc;
  let node = doc;
  for (const raw of pointer.replace(/^\//, '').split('/')) {
    const token = decodeURIComponent(raw).replace(/~1/g, '/').replace(/~0/g, '~');
    if (node === null || typeof node !== 'object' || !(token in node)) return undefined;
    node = node[token];
  }
  return node;
}

class Spec {
  constructor(file) {
    let text;
    try {
      text = fs.readFileSync(file, 'utf8');
    } catch (e) {
      throw new UsageError(`cannot read the spec ${file}: ${e.message}`);
    }
    try {
      this.doc = YAML.parse(text, { prettyErrors: true });
    } catch (e) {
      throw new UsageError(`the spec ${file} is not valid YAML: ${e.message}`);
    }
    if (!this.doc || typeof this.doc !== 'object' || !this.doc.paths)
      throw new UsageError(`the spec ${file} has no paths`);
    this.file = file;
    this.ajv = new Ajv2020({ strict: true, allErrors: true, verbose: true });
    addFormats(this.ajv);
    // Keywords OpenAPI 3.1 adds to JSON Schema (annotations only), and the OpenAPI document's
    // own top-level fields: the whole document is registered as one schema resource so that
    // its "#/components/..." references resolve, and Ajv compiles its root on first use.
    this.ajv.addVocabulary(['discriminator', 'xml', 'externalDocs', 'example']);
    this.ajv.addVocabulary(['openapi', 'info', 'jsonSchemaDialect', 'servers', 'paths', 'webhooks',
      'components', 'security', 'tags']);
    try {
      this.ajv.addSchema(this.doc, SPEC_ID);
    } catch (e) {
      throw new UsageError(`the spec ${file} cannot be loaded as a schema document: ${e.message}`);
    }
    this.compiled = new Map();
  }

  // Follows local $refs (Reference Objects: path items, parameters, responses, examples ...).
  // Returns {node, pointer} where pointer is where the node really lives.
  deref(node, pointer) {
    const seen = new Set();
    while (node && typeof node === 'object' && typeof node.$ref === 'string') {
      const ref = node.$ref;
      if (!ref.startsWith('#')) throw new UsageError(`${pointer}: only local $refs are supported, not ${ref}`);
      if (seen.has(ref)) throw new UsageError(`${pointer}: $ref cycle through ${ref}`);
      seen.add(ref);
      pointer = ref.slice(1);
      node = resolvePointer(this.doc, pointer);
      if (node === undefined) throw new UsageError(`unresolvable $ref ${ref}`);
    }
    return { node, pointer };
  }

  validator(pointer) {
    let v = this.compiled.get(pointer);
    if (!v) {
      try {
        v = this.ajv.compile({ $ref: `${SPEC_ID}#${pointer}` });
      } catch (e) {
        throw new UsageError(`the schema at ${pointer} does not compile: ${e.message}`);
      }
      this.compiled.set(pointer, v);
    }
    return v;
  }

  findPath(requested) {
    const clean = requested.split('?')[0];
    if (this.doc.paths[clean] !== undefined) return clean;
    const matches = Object.keys(this.doc.paths).filter((template) => {
      const re = new RegExp(
        '^' + template.split(/(\{[^}]+\})/).map((part) =>
          part.startsWith('{') ? '[^/]+' : part.replace(/[.*+?^${}()|[\]\\]/g, '\\$&')).join('') + '$');
      return re.test(clean);
    });
    if (matches.length === 1) return matches[0];
    if (matches.length > 1) throw new UsageError(`path ${requested} matches several templates: ${matches.join(', ')}`);
    throw new UsageError(`unknown path ${requested}; the spec has: ${Object.keys(this.doc.paths).join(', ')}`);
  }

  operation(method, requestedPath) {
    const template = this.findPath(requestedPath);
    const m = method.toLowerCase();
    const item = this.deref(this.doc.paths[template], pointerOf(['paths', template]));
    if (!METHODS.includes(m) || !item.node[m]) {
      const allowed = METHODS.filter((x) => item.node[x]).map((x) => x.toUpperCase());
      throw new UsageError(`${template} has no ${method.toUpperCase()} operation; it has ${allowed.join(', ')}`);
    }
    return { template, method: m, node: item.node[m], pointer: `${item.pointer}/${m}` };
  }

  // The pointer of the application/json schema of a response or request body.
  jsonSchemaPointer(content, contentPointer, what) {
    if (!content || typeof content !== 'object') throw new UsageError(`${what} documents no body`);
    const key = Object.keys(content).find((k) => k.split(';')[0].trim().toLowerCase() === JSON_MEDIA);
    if (key === undefined)
      throw new UsageError(`${what} documents no ${JSON_MEDIA} body (it has: ${Object.keys(content).join(', ') || 'none'})`);
    if (!content[key].schema) throw new UsageError(`${what} has no schema for ${key}`);
    return `${contentPointer}/${pointerEscape(key)}/schema`;
  }

  responseSchema(method, requestedPath, status) {
    if (!/^[1-5][0-9][0-9]$/.test(status)) throw new UsageError(`STATUS must be a three-digit HTTP status, not "${status}"`);
    const op = this.operation(method, requestedPath);
    const responses = op.node.responses || {};
    const key = [status, `${status[0]}XX`, `${status[0]}xx`, 'default'].find((k) => responses[k] !== undefined);
    const what = `${method.toUpperCase()} ${op.template} ${status}`;
    if (key === undefined)
      throw new UsageError(`${what}: status not documented; the operation has ${Object.keys(responses).join(', ')}`);
    const response = this.deref(responses[key], `${op.pointer}/responses/${key}`);
    return { what, pointer: this.jsonSchemaPointer(response.node.content, `${response.pointer}/content`, what) };
  }

  requestSchema(method, requestedPath) {
    const op = this.operation(method, requestedPath);
    const what = `${method.toUpperCase()} ${op.template} request`;
    if (!op.node.requestBody) throw new UsageError(`${what}: the operation takes no request body`);
    const body = this.deref(op.node.requestBody, `${op.pointer}/requestBody`);
    return { what, pointer: this.jsonSchemaPointer(body.node.content, `${body.pointer}/content`, what) };
  }

  componentSchema(name) {
    const schemas = (this.doc.components && this.doc.components.schemas) || {};
    if (!schemas[name]) throw new UsageError(`no schema components/schemas/${name}; the spec has: ${Object.keys(schemas).join(', ')}`);
    return { what: `schema ${name}`, pointer: pointerOf(['components', 'schemas', name]) };
  }
}

// ---- validation and readable errors -------------------------------------------------------

function preview(value) {
  let s = JSON.stringify(value);
  if (s === undefined) s = String(value);
  return s.length > 60 ? s.slice(0, 57) + '...' : s;
}

function describe(error) {
  const where = error.instancePath === '' ? '(root)' : error.instancePath;
  const p = error.params || {};
  let text;
  switch (error.keyword) {
    case 'required': text = `missing required property "${p.missingProperty}"`; break;
    case 'additionalProperties': text = `unexpected property "${p.additionalProperty}"`; break;
    case 'type': text = `must be ${p.type}, got ${preview(error.data)}`; break;
    case 'enum': text = `must be one of ${error.schema.map((x) => JSON.stringify(x)).join(', ')}, got ${preview(error.data)}`; break;
    case 'const': text = `must be ${JSON.stringify(p.allowedValue)}, got ${preview(error.data)}`; break;
    default: text = `${error.message}${error.keyword === 'oneOf' || error.keyword === 'anyOf' ? '' : `, got ${preview(error.data)}`}`;
  }
  return `${where}: ${text}   [${error.schemaPath}]`;
}

function uniqueLines(errors) {
  return [...new Set(errors.map(describe))];
}

// Validates; on failure returns readable lines. A top-level oneOf is explained per
// alternative: the errors of the alternative that came closest rather than all of them.
function validate(spec, pointer, data) {
  const full = spec.validator(pointer);
  if (full(data)) return [];
  const { node, pointer: schemaPointer } = spec.deref(resolvePointer(spec.doc, pointer), pointer);
  if (node && Array.isArray(node.oneOf) && node.oneOf.length > 1) {
    const branches = node.oneOf.map((branch, i) => {
      const v = spec.validator(`${schemaPointer}/oneOf/${i}`);
      const ok = v(data);
      const name = branch.$ref ? branch.$ref.split('/').pop() : `alternative ${i}`;
      return { name, ok, errors: ok ? [] : uniqueLines(v.errors) };
    });
    const passing = branches.filter((b) => b.ok);
    if (passing.length > 1) return [`(root): matches more than one of ${passing.map((b) => b.name).join(', ')} (oneOf needs exactly one)`];
    if (passing.length === 0) {
      const closest = branches.reduce((a, b) => (b.errors.length < a.errors.length ? b : a));
      return [`(root): matches none of ${branches.map((b) => b.name).join(', ')}; closest is ${closest.name}:`,
        ...closest.errors.map((l) => '  ' + l)];
    }
  }
  return uniqueLines(full.errors);
}

function readJson(file) {
  let text;
  try {
    text = fs.readFileSync(file, 'utf8');
  } catch (e) {
    throw new UsageError(`cannot read ${file}: ${e.message}`);
  }
  try {
    return { ok: true, data: JSON.parse(text) };
  } catch (e) {
    return { ok: false, error: `${file} is not valid JSON: ${e.message}${text.length === 0 ? ' (the file is empty)' : ''}` };
  }
}

function checkBody(spec, target, file) {
  const body = readJson(file);
  if (!body.ok) {
    console.error(`INVALID ${target.what}: ${body.error}`);
    return 1;
  }
  const lines = validate(spec, target.pointer, body.data);
  if (lines.length === 0) {
    console.log(`valid: ${file} against ${target.what} (${target.pointer})`);
    return 0;
  }
  console.error(`INVALID ${target.what}: ${file} (schema ${target.pointer}):`);
  for (const line of lines) console.error('  ' + line);
  return 1;
}

// ---- --check-spec ---------------------------------------------------------------------------

function checkSpec(spec) {
  const problems = [];
  let checkedSchemas = 0;
  let checkedExamples = 0;

  // every local $ref resolves
  const walk = (node, pointer) => {
    if (Array.isArray(node)) node.forEach((x, i) => walk(x, `${pointer}/${i}`));
    else if (node && typeof node === 'object') {
      if (typeof node.$ref === 'string') {
        if (!node.$ref.startsWith('#')) problems.push(`${pointer}: non-local $ref ${node.$ref}`);
        else if (resolvePointer(spec.doc, node.$ref.slice(1)) === undefined) problems.push(`${pointer}: unresolvable $ref ${node.$ref}`);
      }
      for (const [k, v] of Object.entries(node)) walk(v, `${pointer}/${pointerEscape(k)}`);
    }
  };
  walk(spec.doc, '');
  if (problems.length) return finish();

  const checkExample = (schemaPointer, value, where) => {
    checkedExamples++;
    const lines = validate(spec, schemaPointer, value);
    for (const l of lines) problems.push(`${where}: ${l}`);
  };

  // path templates' parameters are declared
  for (const [template, rawItem] of Object.entries(spec.doc.paths)) {
    const item = spec.deref(rawItem, pointerOf(['paths', template]));
    const names = [...template.matchAll(/\{([^}]+)\}/g)].map((m) => m[1]);
    for (const m of METHODS) {
      const op = item.node[m];
      if (!op) continue;
      const opPointer = `${item.pointer}/${m}`;
      const params = [...(item.node.parameters || []), ...(op.parameters || [])].map((p) => spec.deref(p, opPointer).node);
      for (const n of names)
        if (!params.some((p) => p.in === 'path' && p.name === n)) problems.push(`${m.toUpperCase()} ${template}: path parameter {${n}} not declared`);

      const contents = [];
      if (op.requestBody) {
        const b = spec.deref(op.requestBody, `${opPointer}/requestBody`);
        contents.push({ content: b.node.content, pointer: `${b.pointer}/content`, what: `${m.toUpperCase()} ${template} request` });
      }
      for (const [status, raw] of Object.entries(op.responses || {})) {
        const r = spec.deref(raw, `${opPointer}/responses/${status}`);
        contents.push({ content: r.node.content, pointer: `${r.pointer}/content`, what: `${m.toUpperCase()} ${template} ${status}` });
      }
      for (const { content, pointer, what } of contents) {
        for (const [media, mt] of Object.entries(content || {})) {
          if (!mt.schema) continue;
          const schemaPointer = `${pointer}/${pointerEscape(media)}/schema`;
          spec.validator(schemaPointer);
          checkedSchemas++;
          if (media.split(';')[0].trim() !== JSON_MEDIA) continue;
          if (mt.example !== undefined) checkExample(schemaPointer, mt.example, `${what} ${media} example`);
          for (const [name, ex] of Object.entries(mt.examples || {})) {
            const e = spec.deref(ex, `${pointer}/${pointerEscape(media)}/examples/${name}`).node;
            if (e.value !== undefined) checkExample(schemaPointer, e.value, `${what} ${media} example "${name}"`);
          }
        }
      }
    }
  }
  for (const [name, schema] of Object.entries((spec.doc.components || {}).schemas || {})) {
    const schemaPointer = pointerOf(['components', 'schemas', name]);
    spec.validator(schemaPointer);
    checkedSchemas++;
    (schema.examples || []).forEach((ex, i) => checkExample(schemaPointer, ex, `components/schemas/${name} examples[${i}]`));
  }
  return finish();

  function finish() {
    if (problems.length) {
      console.error(`spec ${spec.file} has ${problems.length} problem(s):`);
      for (const p of problems) console.error('  ' + p);
      return 1;
    }
    console.log(`spec ok: ${spec.file}: ${checkedSchemas} schemas compiled, ${checkedExamples} examples valid, all $refs resolve`);
    return 0;
  }
}

// ---- main ------------------------------------------------------------------------------------

function main(argv) {
  let specFile = DEFAULT_SPEC;
  const args = [...argv];
  if (args[0] === '--spec') {
    if (args.length < 2) throw new UsageError(USAGE);
    specFile = args[1];
    args.splice(0, 2);
  }
  if (args[0] === '-h' || args[0] === '--help') {
    console.log(USAGE);
    return 0;
  }
  const mode = args[0];
  if (mode === '--check-spec' && args.length === 1) return checkSpec(new Spec(specFile));
  if (mode === '--request' && args.length === 4) {
    const spec = new Spec(specFile);
    return checkBody(spec, spec.requestSchema(args[1], args[2]), args[3]);
  }
  if (mode === '--schema' && args.length === 3) {
    const spec = new Spec(specFile);
    return checkBody(spec, spec.componentSchema(args[1]), args[2]);
  }
  if (args.length === 4 && !args[0].startsWith('-')) {
    const spec = new Spec(specFile);
    return checkBody(spec, spec.responseSchema(args[0], args[1], args[2]), args[3]);
  }
  throw new UsageError(USAGE);
}

try {
  process.exitCode = main(process.argv.slice(2));
} catch (e) {
  if (e instanceof UsageError) {
    console.error(`validate_response: ${e.message}`);
    process.exitCode = 2;
  } else {
    console.error(e && e.stack ? e.stack : String(e));
    process.exitCode = 2;
  }
}
