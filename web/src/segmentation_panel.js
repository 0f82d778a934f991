// The decomposition as a view of the state: the segments table, the status, and marking both
// out of date when the lines change since Decompose ran. Decompose itself is an effect
// (segmentation.js).
import { $ } from './dom.js';
import { colorMode, segmentColor, segmentationStale } from './model.js';
import { rgbCss } from './colors.js';
import { num } from './text.js';

export function createSegmentationView(store) {
  let shown;

  function renderSegments(seg) {
    const tbody = $('segments').querySelector('tbody');
    tbody.innerHTML = '';
    $('segments').hidden = !seg;
    if (!seg) return;
    let totalArea = 0;
    for (const s of seg.answer.segments) {
      totalArea += Number(s.area) || 0;
      const tr = document.createElement('tr');
      const sw = document.createElement('td');
      const box = document.createElement('span');
      box.className = 'swatch';
      box.style.background = rgbCss(segmentColor(seg, s.label));
      sw.appendChild(box);
      tr.appendChild(sw);
      // Labels are shown from 1, like every other count on the page.
      for (const v of [s.label + 1, s.faces, num(s.area), num(s.boundary_length)]) {
        const td = document.createElement('td');
        td.textContent = String(v);
        tr.appendChild(td);
      }
      tbody.appendChild(tr);
    }
    const tr = document.createElement('tr');
    tr.innerHTML = '<td></td><td>total</td><td></td><td></td><td></td>';
    tr.children[3].textContent = num(totalArea);
    tbody.appendChild(tr);
  }

  function render(state) {
    const seg = state.segmentation;
    if (seg !== shown) {
      shown = seg;
      renderSegments(seg);
    }
    const status = $('decompose-status');
    if (status.textContent !== state.decomposeStatus) status.textContent = state.decomposeStatus;
    status.classList.toggle('error', state.decomposeError);
    $('download-segmented').disabled = !seg;
    $('decompose').disabled = state.decomposing;
    $('toolbar-decompose').disabled = state.decomposing;
    const stale = segmentationStale(state);
    $('segments').classList.toggle('stale', stale);
    $('segments-stale').hidden = !stale;
    $('view-stale').hidden = !(stale && colorMode(state) === 'segments');
  }

  store.subscribe(render);
  return { render: () => render(store.state) };
}
