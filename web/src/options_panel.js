// The options form as a view of the state: its limits and tooltips from the server's option
// tables; what is typed goes to the setOptions action (an undo step), and the form shows the
// state's options when they change otherwise (undo, redo, a loaded session).
import { $ } from './dom.js';

// ---- options -----------------------------------------------------------------------------------------
export function readOptions() {
  const options = {};
  const problems = [];
  for (const el of $('options-form').elements) {
    if (!el.name || el.value === '') continue;
    let value = el.value;
    if (el.type === 'number') {
      value = Number(el.value);
      const min = el.min === '' ? -Infinity : Number(el.min);
      const max = el.max === '' ? Infinity : Number(el.max);
      const integer = el.step === '1';
      if (!Number.isFinite(value) || value < min || value > max || (integer && !Number.isInteger(value))) {
        problems.push(`${el.labels?.[0]?.textContent ?? el.name} must be ${integer ? 'an integer' : 'a number'} from ${min} to ${max}`);
        continue;
      }
    } else if (el.name === 'refine' || el.name === 'fitted.enabled') {
      value = value === 'true';
    }
    const path = el.name.split('.');
    let o = options;
    for (const p of path.slice(0, -1)) o = o[p] ??= {};
    o[path[path.length - 1]] = value;
  }
  return { options, problems };
}

// The inputs' limits, steps, choices and tooltips come from the server's option tables
// (GET /v1/options), so the page never accepts what the server refuses or refuses what it
// accepts. Until they arrive the server's own checks answer.
export function applyOptionTables(tables) {
  const rows = new Map(tables.feature_line.map((row) => [row.name, row]));
  oldNames = new Map(tables.feature_line.map((row) => [row.name, row.old_names ?? []]));
  for (const el of $('options-form').elements) {
    const row = rows.get(el.name);
    if (!row) continue;
    const shown = typeof row.default === 'number' ? String(row.default) : JSON.stringify(row.default);
    el.title = `${row.description} (default ${shown.replaceAll('"', '')})`;
    if (el.type === 'number') {
      el.min = String(row.minimum);
      el.max = String(row.maximum);
      el.step = row.type === 'integer' ? '1' : 'any';
      el.title = `${row.description} (${row.minimum} to ${row.maximum}; default ${shown})`;
    } else if (el.tagName === 'SELECT' && row.enum) {
      const chosen = el.value;
      while (el.options.length > 1) el.remove(1);  // the first option is "default"
      for (const name of row.enum) el.add(new Option(name, name));
      el.value = row.enum.includes(chosen) ? chosen : '';
    }
  }
}

// A row's paths before it was renamed, from the option tables: a session saved with an old
// name ("rings") still fills its input ("strip.rings"); the next edit saves the new name.
let oldNames = new Map();

function valueAt(options, path) {
  let v = options;
  for (const p of path.split('.')) v = v?.[p];
  return v;
}

// The form shows `options` (undo, redo, a loaded session).
export function writeOptionsForm(options) {
  for (const el of $('options-form').elements) {
    if (!el.name) continue;
    let v = valueAt(options, el.name);
    for (const old of oldNames.get(el.name) ?? []) {
      const before = valueAt(options, old);  // "initial" held the method's name, now the group
      if (v == null && typeof before !== 'object') v = before;
    }
    el.value = v === undefined || v === null ? '' : String(v);
  }
}

// api: optionTables() (GET /v1/options).
export function createOptionsView(store, actions, api) {
  let shown = store.state.options;
  let timer = 0;

  function changed() {
    clearTimeout(timer);
    timer = setTimeout(() => {
      const { options, problems } = readOptions();
      actions.setOptions(options, problems);
    }, 250);
  }

  function render(state) {
    $('options-error').hidden = state.optionsProblems.length === 0;
    $('options-error').textContent = state.optionsProblems.join('\n');
    if (state.options === shown) return;
    shown = state.options;
    // Typed options are already in the form; others (undo, a session) are written into it.
    if (JSON.stringify(readOptions().options) !== JSON.stringify(state.options)) writeOptionsForm(state.options);
  }

  $('options-form').addEventListener('input', changed);
  $('options-form').addEventListener('change', changed);
  $('options-form').addEventListener('submit', (e) => e.preventDefault());
  store.subscribe(render);
  api
    .optionTables()
    .then(applyOptionTables)
    .catch((e) => console.warn('option tables unavailable; the server checks the options', e));
}
