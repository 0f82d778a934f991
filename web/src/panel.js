// The panel as a view of the state: the status line, progress, mesh information, the lines and
// keys, the active line's status and timings, undo and redo, the toggles and the colour legend.
// It subscribes to the store and edits nothing itself: controls call the actions.
import { $ } from './dom.js';
import { activeLine, colorMode, isStale, keysProblem, requestKey } from './model.js';
import { formatBytes, num, serverText } from './text.js';

export function lineStateText(line, options) {
  if (line.error && line.failedKey === requestKey(line, options)) return { text: 'error', error: true };
  if (line.trace) return { text: isStale(line, options) || !line.result ? 'traced · updating…' : `traced · length ${num(line.result.refined.length, 3)}` };
  if (keysProblem(line)) return { text: `${line.keys.length} key${line.keys.length === 1 ? '' : 's'}` };
  if (isStale(line, options) || !line.result) return { text: `${line.keys.length} keys · updating…` };
  return { text: `${line.keys.length} keys · length ${num(line.result.refined.length, 3)}` };
}

export function createPanelView(store, actions) {
  const drawn = { lineList: '', keyList: '', samples: null };
  // Set while the list is rebuilt: the rename field it removes loses focus, which is no answer.
  let drawingLineList = false;

  function renderMessage(state) {
    const el = $('message');
    if (el.textContent !== state.message) el.textContent = state.message;
    el.classList.toggle('error', state.messageIsError);
  }

  function renderProgress(state) {
    $('upload-progress').hidden = !state.progress;
    if (!state.progress) return;
    const bar = $('upload-bar');
    if (state.progress.fraction === null) bar.removeAttribute('value');
    else bar.value = state.progress.fraction;
    $('upload-text').textContent = state.progress.text;
  }

  function renderMeshInfo(state) {
    const m = state.mesh;
    if (!m) {
      $('mesh-info').textContent = 'No mesh open.';
      return;
    }
    const d = m.description;
    const lines = [
      `${m.name} (${d.format}): ${d.vertices} vertices, ${d.faces} triangles`,
      `${d.components} component(s), ${d.boundary_loops} boundary loop(s); mean edge ${num(d.mean_edge)}`,
      `loaded in ${num(d.timings_ms.load, 3)} ms, prepared in ${num(d.timings_ms.prepare, 3)} ms`,
      d.expires_in_s == null ? 'preloaded: never expires' : `the server forgets it after ${Math.round(d.expires_in_s)} s unused${state.source ? ' (it is then uploaded again)' : ''}`,
    ];
    if (state.download)
      lines.push(`mesh download: ${formatBytes(state.download.wireBytes)} on the wire${state.download.encoding !== 'identity' ? ` (${state.download.encoding}, ${formatBytes(state.download.received)} unpacked)` : ''}`);
    if (state.cad) lines.push('looks like a CAD part: flat shading and sharp edges on');
    if (d.warnings?.length) lines.push(`warnings: ${d.warnings.join('; ')}`);
    const text = lines.join('\n');
    if ($('mesh-info').textContent !== text) $('mesh-info').textContent = text;
  }

  function renderSamples(state) {
    if (state.samples === drawn.samples) return;
    drawn.samples = state.samples;
    const select = $('sample-select');
    select.innerHTML = '';
    for (const s of state.samples) {
      const o = document.createElement('option');
      o.value = s.file;
      o.textContent = `${s.name} (${s.format}, ${formatBytes(s.bytes)})`;
      select.appendChild(o);
    }
    if (!state.samples.length) select.innerHTML = '<option value="">(none bundled)</option>';
  }

  function renderToggles(state) {
    $('snap-toggle').checked = state.snapping;
    $('trace-toggle').checked = state.traceMode;
    $('closed-toggle').checked = !!activeLine(state)?.closed;
    $('flat-toggle').checked = state.flatShading;
    $('edges-toggle').checked = state.edgesShown;
    $('ortho-toggle').checked = state.orthographic;
    for (const el of document.querySelectorAll('input[name="up-axis"]')) el.checked = el.value === state.upAxis;
    $('busy').hidden = !state.inFlight;
  }

  function renderColors(state) {
    const mode = colorMode(state);
    const seg = state.segmentation;
    $('curvature-toggle').checked = state.colorChoice === 'curvature';
    $('segments-toggle').disabled = !(seg && (seg.faceColored || seg.sceneLoaded));
    $('segments-toggle').checked = mode === 'segments';
    $('legend').hidden = mode !== 'curvature';
    if (mode === 'curvature') {
      $('legend-min').textContent = num(-state.curvatureRange, 3);
      $('legend-max').textContent = num(state.curvatureRange, 3);
    }
  }

  function renderHistoryButtons() {
    const { history } = store;
    $('undo').disabled = !history.canUndo;
    $('redo').disabled = !history.canRedo;
    $('undo').title = history.canUndo ? `Undo: ${history.undoLabel} (Ctrl+Z)` : 'Nothing to undo (Ctrl+Z)';
    $('redo').title = history.canRedo ? `Redo: ${history.redoLabel} (Ctrl+Shift+Z)` : 'Nothing to redo (Ctrl+Shift+Z)';
  }

  function renderLineList(state) {
    const signature = JSON.stringify([state.activeLineId, state.renaming?.lineId ?? null, state.lines.map((l) => [l.id, l.name, l.closed, isStale(l, state.options), lineStateText(l, state.options)])]);
    if (signature === drawn.lineList) return;
    drawn.lineList = signature;
    const ul = $('line-list');
    const renameFocused = document.activeElement?.classList.contains('rename');
    drawingLineList = true;
    ul.innerHTML = '';
    drawingLineList = false;
    for (const line of state.lines) {
      const li = document.createElement('li');
      li.classList.toggle('active', line.id === state.activeLineId);
      li.classList.toggle('stale', isStale(line, state.options));
      li.dataset.lineId = line.id;
      li.tabIndex = 0;
      li.title = 'Make this the active line (new keys go to it)';
      const name = state.renaming?.lineId === line.id ? renameField(state, line) : nameLabel(line);
      const st = document.createElement('span');
      st.className = 'state';
      const { text, error } = lineStateText(line, state.options);
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
        actions.deleteLine(line.id);
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
      li.addEventListener('click', () => actions.setActiveLine(line.id));
      li.addEventListener('keydown', (e) => {
        if (e.key === 'Enter' || e.key === ' ') actions.setActiveLine(line.id);
      });
      ul.appendChild(li);
    }
    if (renameFocused) ul.querySelector('input.rename')?.focus();
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
  function startRenaming(line) {
    actions.startRenaming(line.id);
    store.flush();
    const field = document.querySelector('#line-list input.rename');
    field?.focus();
    field?.select();
  }

  function renameField(state, line) {
    const field = document.createElement('input');
    field.className = 'rename';
    field.value = state.renaming.draft;
    field.setAttribute('aria-label', `new name for ${line.name}`);
    field.maxLength = 80;
    field.addEventListener('input', () => actions.editRenameDraft(field.value));
    field.addEventListener('click', (e) => e.stopPropagation());
    field.addEventListener('keydown', (e) => {
      e.stopPropagation(); // typing a name is not a shortcut
      if (e.key === 'Enter') actions.finishRenaming(true);
      if (e.key === 'Escape') actions.finishRenaming(false);
    });
    field.addEventListener('blur', () => {
      if (!drawingLineList) actions.finishRenaming(true);
    });
    return field;
  }

  function renderKeyList(state) {
    const line = activeLine(state);
    const signature = JSON.stringify([line?.id ?? null, line?.keys ?? [], state.selectedKey]);
    if (signature === drawn.keyList) return;
    drawn.keyList = signature;
    const ol = $('key-list');
    ol.innerHTML = '';
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
      del.addEventListener('click', () => actions.deleteKey(line, i));
      li.append(label, del);
      ol.appendChild(li);
    });
  }

  function renderLineStatus(state) {
    const line = activeLine(state);
    const el = $('line-status');
    el.classList.remove('error', 'stale');
    if (!state.mesh) {
      el.textContent = 'Open a mesh first.';
      return;
    }
    if (!line) return (el.textContent = '');
    const parts = [];
    const failedNow = line.error && line.failedKey === requestKey(line, state.options);
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
    if (isStale(line, state.options)) {
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
  function renderTimings(state) {
    const tbody = $('timings').querySelector('tbody');
    tbody.innerHTML = '';
    const line = activeLine(state);
    const r = line?.result;
    const stale = line ? isStale(line, state.options) : false;
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

  function render(state) {
    renderMessage(state);
    renderProgress(state);
    renderMeshInfo(state);
    renderSamples(state);
    $('empty-hint').hidden = !!state.mesh;
    renderToggles(state);
    renderColors(state);
    renderLineList(state);
    renderKeyList(state);
    renderLineStatus(state);
    renderTimings(state);
    renderHistoryButtons();
  }

  store.subscribe(render);
  return { render: () => render(store.state) };
}
