// Rendering the panel from the state (lines, keys, status, timings) and the mesh colours.
import { $, num, serverText, state, viewer } from './app.js';
import { diverging } from './colors.js';
import { activeLine, deleteKey, deleteLine, isStale, keysProblem, renameLine, renderHistoryButtons, requestKey, setActiveLine } from './lines.js';
import { renderSegmentStaleness, segmentColor } from './segmentation_panel.js';
import { rememberUpAxis } from './session.js';

// ---- colours --------------------------------------------------------------------------------
export function applyColors() {
  if (!state.mesh) return;
  const seg = state.segmentation;
  if ($('segments-toggle').checked && seg) {
    if (seg.faceColored) {
      const labels = seg.answer.labels;
      viewer.setFaceColors((f) => segmentColor(seg, labels[f]));
    } else {
      viewer.showSegmentScene(true);
    }
    state.colorMode = 'segments';
    $('legend').hidden = true;
  } else if ($('curvature-toggle').checked && state.curvature) {
    const h = state.curvature;
    const r = state.curvatureRange;
    viewer.setVertexColors((v) => diverging(h[v] / r));
    $('legend-min').textContent = num(-r, 3);
    $('legend-max').textContent = num(r, 3);
    $('legend').hidden = false;
    state.colorMode = 'curvature';
  } else {
    viewer.setPlainColors();
    state.colorMode = 'plain';
    $('legend').hidden = true;
  }
  renderSegmentStaleness();
}

export function setUpAxis(axis) {
  if (!state.mesh || (axis !== 'y' && axis !== 'z')) return;
  state.upAxis = axis;
  rememberUpAxis(state.mesh.name, axis);
  viewer.setUpAxis(axis);
  renderUpAxis();
}

export function renderUpAxis() {
  for (const el of document.querySelectorAll('input[name="up-axis"]')) el.checked = el.value === state.upAxis;
}

// ---- rendering the panel ---------------------------------------------------------------------------
export function refresh() {
  viewer.selectedKey = state.selectedKey;
  viewer.setLines(
    state.lines.map((l) => ({ ...l, stale: isStale(l) })),
    state.activeLineId,
  );
  renderLineList();
  renderKeyList();
  renderLineStatus();
  renderTimings();
  renderHistoryButtons();
  renderSegmentStaleness();
  $('snap-toggle').checked = state.snapping;
  $('trace-toggle').checked = state.traceMode;
}

export function lineStateText(line) {
  if (line.error && line.failedKey === requestKey(line)) return { text: 'error', error: true };
  if (line.trace) return { text: isStale(line) || !line.result ? 'traced · updating…' : `traced · length ${num(line.result.refined.length, 3)}` };
  if (keysProblem(line)) return { text: `${line.keys.length} key${line.keys.length === 1 ? '' : 's'}` };
  if (isStale(line) || !line.result) return { text: `${line.keys.length} keys · updating…` };
  return { text: `${line.keys.length} keys · length ${num(line.result.refined.length, 3)}` };
}

// Set while the list is rebuilt: the rename field it removes loses focus, which is no answer.
let drawingLineList = false;

export function renderLineList() {
  const ul = $('line-list');
  const renameFocused = document.activeElement?.classList.contains('rename');
  drawingLineList = true;
  ul.innerHTML = '';
  drawingLineList = false;
  for (const line of state.lines) {
    const li = document.createElement('li');
    li.classList.toggle('active', line.id === state.activeLineId);
    li.classList.toggle('stale', isStale(line));
    li.dataset.lineId = line.id;
    li.tabIndex = 0;
    li.title = 'Make this the active line (new keys go to it)';
    const name = state.renaming?.lineId === line.id ? renameField(line) : nameLabel(line);
    const st = document.createElement('span');
    st.className = 'state';
    const { text, error } = lineStateText(line);
    st.textContent = text;
    st.classList.toggle('error', !!error);
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = `Delete ${line.name} (undo brings it back)`;
    del.setAttribute('aria-label', `delete ${line.name}`);
    del.textContent = '×';
    del.addEventListener('click', (e) => {
      e.stopPropagation();
      deleteLine(line.id);
    });
    const rename = document.createElement('button');
    rename.className = 'rename-line';
    rename.type = 'button';
    rename.title = `Rename ${line.name} (or double-click its name)`;
    rename.setAttribute('aria-label', `rename ${line.name}`);
    rename.textContent = '✎';
    rename.addEventListener('click', (e) => {
      e.stopPropagation();
      startRenaming(line);
    });
    li.append(name, st, rename, del);
    li.addEventListener('click', () => setActiveLine(line.id));
    li.addEventListener('keydown', (e) => {
      if (e.key === 'Enter' || e.key === ' ') setActiveLine(line.id);
    });
    ul.appendChild(li);
  }
  if (renameFocused) ul.querySelector('input.rename')?.focus();
  const line = activeLine();
  $('closed-toggle').checked = !!line?.closed;
}

function nameLabel(line) {
  const name = document.createElement('span');
  name.className = 'name';
  name.textContent = `${line.name}${line.closed ? ' (loop)' : ''}`;
  name.addEventListener('dblclick', (e) => {
    e.stopPropagation();
    startRenaming(line);
  });
  return name;
}

// Renaming in place: the typed text survives the list being drawn again (answers arriving);
// Enter or leaving the field keeps it, Esc drops it.
export function startRenaming(line) {
  state.renaming = { lineId: line.id, draft: line.name };
  renderLineList();
  const field = document.querySelector('#line-list input.rename');
  field?.focus();
  field?.select();
}

function finishRenaming(keep) {
  const renaming = state.renaming;
  if (!renaming) return;
  state.renaming = null;
  if (!keep || !renameLine(renaming.lineId, renaming.draft)) renderLineList();
}

function renameField(line) {
  const field = document.createElement('input');
  field.className = 'rename';
  field.value = state.renaming.draft;
  field.setAttribute('aria-label', `new name for ${line.name}`);
  field.maxLength = 80;
  field.addEventListener('input', () => (state.renaming.draft = field.value));
  field.addEventListener('click', (e) => e.stopPropagation());
  field.addEventListener('keydown', (e) => {
    e.stopPropagation(); // typing a name is not a shortcut
    if (e.key === 'Enter') finishRenaming(true);
    if (e.key === 'Escape') finishRenaming(false);
  });
  field.addEventListener('blur', () => {
    if (!drawingLineList) finishRenaming(true);
  });
  return field;
}

export function renderKeyList() {
  const ol = $('key-list');
  ol.innerHTML = '';
  const line = activeLine();
  if (!line) return;
  line.keys.forEach((v, i) => {
    const li = document.createElement('li');
    const selected = state.selectedKey?.lineId === line.id && state.selectedKey.keyIndex === i;
    li.classList.toggle('selected', selected);
    const label = document.createElement('span');
    label.textContent = `vertex ${v}`;
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = `Delete key ${i + 1}`;
    del.setAttribute('aria-label', `delete key ${i + 1}`);
    del.textContent = '×';
    del.addEventListener('click', () => deleteKey(line, i));
    li.append(label, del);
    ol.appendChild(li);
  });
}

export function renderLineStatus() {
  const line = activeLine();
  const el = $('line-status');
  el.classList.remove('error', 'stale');
  if (!state.mesh) {
    el.textContent = 'Open a mesh first.';
    return;
  }
  if (!line) return (el.textContent = '');
  const parts = [];
  const failedNow = line.error && line.failedKey === requestKey(line);
  if (keysProblem(line)) {
    el.textContent = `${line.name}: ${keysProblem(line)}.`;
    return;
  }
  if (failedNow) {
    parts.push(`${line.name} could not be detected: ${line.error}`);
    el.classList.add('error');
    if (line.result) parts.push('The dashed line is the last one that worked, for earlier keys.');
    el.textContent = parts.join('\n');
    return;
  }
  const r = line.result;
  if (!r) {
    el.textContent = `${line.name}: detecting…`;
    return;
  }
  if (isStale(line)) {
    parts.push(`${line.name}: updating… (the dashed line is for the earlier keys)`);
    el.classList.add('stale');
  }
  parts.push(
    `initial (${r.initial.method}): ${r.initial.vertices.length} vertices, length ${num(r.initial.length)}`,
    `refined: ${r.refined.points.length} points, length ${num(r.refined.length)}`,
  );
  if (r.stats.fallbacks?.length)
    parts.push(...r.stats.fallbacks.map((f) => `segment ${f.segment + 1} (keys ${f.segment + 1} to ${((f.segment + 1) % r.keys.length) + 1}): ${f.from} → ${f.to} (${serverText(f.reason)})`));
  if (r.stats.warnings?.length) parts.push(...r.stats.warnings.map((w) => `warning: ${serverText(w)}`));
  el.textContent = parts.join('\n');
}

// The timings of the active line's own last answer; marked out of date when the line changed.
export function renderTimings() {
  const tbody = $('timings').querySelector('tbody');
  tbody.innerHTML = '';
  const line = activeLine();
  const r = line?.result;
  const stale = line ? isStale(line) : false;
  $('timings-title').textContent = line ? `Last run of ${line.name}${stale ? ' (out of date: the line changed since)' : ''}` : 'Last run';
  $('timings').classList.toggle('stale', stale);
  if (!r) {
    tbody.innerHTML = '<tr><td colspan="2">no run yet</td></tr>';
    return;
  }
  const t = r.stats.timings_ms;
  const rows = [
    ['initial line', `${num(t.initial, 3)} ms`],
    ['feature strip', `${num(t.strip, 3)} ms`],
    ['flattening', `${num(t.flatten, 3)} ms`],
    ['snake', `${num(t.snake, 3)} ms`],
    ['total', `${num(t.total, 3)} ms`],
    ['snake iterations', String(r.stats.iterations)],
    ['strip faces', String(r.stats.strip_faces)],
    ['pieces / splits', `${r.stats.pieces} / ${r.stats.splits}`],
    ['requests sent', String(state.requestCount)],
  ];
  for (const [k, v] of rows) {
    const tr = document.createElement('tr');
    const a = document.createElement('td');
    a.textContent = k;
    const b = document.createElement('td');
    b.textContent = v;
    tr.append(a, b);
    tbody.appendChild(tr);
  }
}
