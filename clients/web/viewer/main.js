// The gvd web viewer: submit a scene, follow the job, show the objects and the GVD, and ask
// the API for neighbours, paths and the exploded view. Talks only to the HTTP API (api.js).
import {ApiError, cancelJob, getBytes, getJSON, postJSON, submitFiles, watchJob} from './api.js';
import {GvdView} from './view.js';

const $ = (id) => document.getElementById(id);
const enc = encodeURIComponent;

const state = {
  jobId: null,
  status: null,       // the job's status as last seen
  loaded: false,      // objects and GVD are on screen
  dimension: 3,
  labels: [],
  selected: null,     // label of the clicked object
  highlighted: [],    // labels of its k-ring neighbours (what the view colours)
  picking: [],        // path points picked so far
  path: null,         // {from, to, found, length, min_clearance, reason}
  explode: 0,
  anchor: null,
  error: null,
  busy: 0,            // requests in flight
  updates: {events: 0, poll: 0},  // job updates received by server-sent events / polling
};

let view;
try {
  view = new GvdView($('canvas'));
} catch (e) {
  showError(`This browser cannot show 3D graphics (WebGL): ${e.message}`);
}

// ---- messages ------------------------------------------------------------------------------

function showError(message) {
  state.error = String(message);
  $('error-text').textContent = state.error;
  $('error').hidden = false;
}

function clearError() {
  state.error = null;
  $('error').hidden = true;
}

$('error-close').addEventListener('click', clearError);
window.addEventListener('unhandledrejection', (e) => showError(e.reason?.message ?? e.reason));
window.addEventListener('error', (e) => showError(e.message));

/** Runs an async action, counting it as busy and showing its failure. */
async function run(action) {
  state.busy++;
  try {
    return await action();
  } catch (e) {
    showError(e.message ?? e);
    return undefined;
  } finally {
    state.busy--;
  }
}

const fmt = (x, digits = 4) => (x === null || x === undefined ? '—'
  : typeof x === 'number' ? (Number.isInteger(x) ? x.toLocaleString('en') : x.toPrecision(digits)) : String(x));
const seconds = (s) => (s === undefined ? '—' : s < 1 ? `${(s * 1000).toFixed(s < 0.01 ? 2 : 0)} ms` : `${s.toFixed(2)} s`);

const bytes = (n) => (n === undefined ? '—' : n < 1048576 ? `${(n / 1024).toFixed(0)} KB` : `${(n / 1048576).toFixed(1)} MB`);

/** Fills a table with [name, value] pairs, `perRow` pairs to a row. */
function rows(table, pairs, perRow = 1) {
  const trs = [];
  for (let i = 0; i < pairs.length; i += perRow) {
    const tr = document.createElement('tr');
    for (const [k, v] of pairs.slice(i, i + perRow)) {
      const a = document.createElement('td');
      const b = document.createElement('td');
      a.textContent = k;
      b.textContent = v;
      tr.append(a, b);
    }
    trs.push(tr);
  }
  table.replaceChildren(...trs);
}

// ---- submitting and following a job --------------------------------------------------------

async function submit(files) {
  clearError();
  if (files.length === 0) return;
  await run(async () => {
    const params = {max_depth: $('max-depth').value};
    $('job-status').textContent = `uploading ${files.length === 1 ? files[0].name : files.length + ' files'}…`;
    $('job').hidden = false;
    const doc = await submitFiles([...files], params);
    await openJob(doc.id, doc);
  });
}

let watching = null;  // aborts following the previous job when another is opened

async function openJob(id, doc) {
  watching?.abort();
  watching = new AbortController();
  const signal = watching.signal;
  resetResult();
  state.jobId = id;
  history.replaceState(null, '', `#job=${id}`);
  $('job').hidden = false;
  $('job-id').textContent = id.slice(0, 12);
  $('job-id').title = id;
  $('hint').textContent = 'Computing…';
  const final = doc && doc.status === 'done' ? doc : await watchJob(id, showStatus, signal);
  if (final === null || signal.aborted) return;  // another job was opened meanwhile
  showStatus(final);
  if (final.status === 'done') {
    await loadResult(final, signal);
  } else {
    const p = final.error;
    showError(p ? `${p.title ?? 'Job ' + final.status}: ${p.detail ?? ''}` : `The job ${final.status}.`);
    $('hint').textContent = '';
  }
}

function showStatus(doc, via) {
  state.status = doc.status;
  if (via) state.updates[via]++;
  const progress = doc.progress ?? {};
  $('progress').value = doc.status === 'done' ? 1 : progress.fraction ?? 0;
  const scene = doc.scene ? ` · ${doc.scene.dimension}D, ${fmt(doc.scene.objects)} objects, ${fmt(doc.scene.simplices)} simplices` : '';
  let text = doc.status;
  if (doc.status === 'queued' && doc.queue_position) text += ` (position ${doc.queue_position})`;
  if (doc.status === 'running' && progress.stage) text += ` — ${progress.stage} (${Math.round((progress.fraction ?? 0) * 100)} %)`;
  if (doc.recovered) text += ' · recovered after a restart';
  $('job-status').textContent = text + scene;
  $('cancel').hidden = !(doc.status === 'queued' || doc.status === 'running');
}

$('cancel').addEventListener('click', () => run(() => cancelJob(state.jobId)));
window.addEventListener('keydown', (e) => {
  if (e.key === 'Escape' && state.pickingOn) {
    setPicking(false);
    $('path-result').textContent = 'Picking cancelled.';
  }
});

function resetResult() {
  state.loaded = false;
  state.selected = null;
  state.highlighted = [];
  state.picking = [];
  state.path = null;
  state.explode = 0;
  $('explode-slider').value = 0;
  for (const id of ['info', 'neighbors', 'path', 'explode', 'display']) $(id).hidden = true;
  $('selected').textContent = 'Click an object.';
  $('neighbor-list').replaceChildren();
  $('path-result').textContent = 'Click Pick two points, then two places in the view.';
  if (state.pickingOn) setPicking(false);
  view?.clear();
}

async function loadResult(job, signal) {
  const r = job.result ?? {};
  state.dimension = r.dimension ?? job.scene?.dimension ?? 3;
  showInfo(job);
  $('hint').textContent = 'Loading the GVD…';
  const base = `/v1/jobs/${enc(job.id)}`;
  const graph = await getJSON(`${base}/graph`);
  if (signal.aborted) return;
  state.labels = graph.nodes.map((n) => n.label);
  // Anchor of the exploded view: the object with the most neighbours (the frame, the plate).
  const degree = new Map(graph.nodes.map((n) => [n.object, 0]));
  for (const e of graph.edges) {
    degree.set(e.a, degree.get(e.a) + 1);
    degree.set(e.b, degree.get(e.b) + 1);
  }
  let anchor = graph.nodes[0];
  for (const n of graph.nodes) if (degree.get(n.object) > degree.get(anchor.object)) anchor = n;
  state.anchor = anchor.label;
  const anchorSelect = $('anchor');
  anchorSelect.replaceChildren(...state.labels.map((l) => new Option(l, l, false, l === state.anchor)));

  const [objectsGlb, gvdGlb] = await Promise.all([
    getBytes(`${base}/explode?anchor=${enc(state.anchor)}&format=glb`),
    getBytes(`${base}/gvd.glb`),
  ]);
  if (!view || signal.aborted) return;
  await view.show({dimension: state.dimension, objectCount: graph.nodes.length, domain: r.domain,
                   objectsGlb, gvdGlb});
  if (signal.aborted) return;
  $('legend-max').textContent = `${fmt(view.clearanceMax, 3)}`;
  $('hint').textContent = '';
  for (const id of ['neighbors', 'path', 'explode', 'display']) $(id).hidden = false;
  state.loaded = true;
  listJobs();
}

function showInfo(job) {
  const r = job.result ?? {};
  const s = job.scene ?? {};
  rows($('info-table'), [
    ['dimension', `${r.dimension ?? s.dimension}D`],
    ['objects', fmt(r.objects ?? s.objects)],
    ['simplices', fmt(r.simplices ?? s.simplices)],
    ['octree depth', `${fmt(r.depth)} (max ${fmt(r.max_depth)})`],
    ['octree leaves', fmt(r.leaves)],
    ['GVD simplices', fmt(r.gvd_simplices)],
    ['neighbouring pairs', fmt(r.graph_edges)],
    ['octree memory', bytes(r.octree_bytes)],
    ['backend', `${r.backend ?? '—'} · ${fmt(r.threads)} threads`],
    ['total time', seconds(r.total_seconds)],
  ]);
  const stages = r.stages ?? job.progress?.stages ?? [];
  rows($('stages-table'), stages.map((st) => [st.name, seconds(st.seconds)]), 2);
  const warnings = r.warnings ?? [];
  $('warnings').replaceChildren(...warnings.map((w) => {
    const li = document.createElement('li');
    li.textContent = w.detail ?? `${w.kind}${w.object ? ' (' + w.object + ')' : ''}`;
    return li;
  }));
  $('warnings-summary').textContent = `${warnings.length} warning${warnings.length === 1 ? '' : 's'}`;
  $('warnings-box').hidden = warnings.length === 0;
  $('info').hidden = false;
}

// ---- neighbours ----------------------------------------------------------------------------

async function select(label) {
  state.selected = label;
  if (label === null) {
    state.highlighted = [];
    view.highlight(null, new Map());
    $('selected').textContent = 'Click an object.';
    $('neighbor-list').replaceChildren();
    return;
  }
  const ring = Number($('ring').value);
  await run(async () => {
    const answer = await getJSON(`/v1/jobs/${enc(state.jobId)}/objects/${enc(label)}/neighbors?ring=${ring}`);
    if (state.selected !== label) return;  // a later click won
    const ringOf = new Map(answer.neighbors.map((n) => [n.label, n.ring]));
    view.highlight(label, ringOf);
    state.highlighted = answer.neighbors.map((n) => n.label);
    $('selected').textContent = `${label}: ${answer.neighbors.length} within ${ring} ring${ring > 1 ? 's' : ''}`;
    $('neighbor-list').replaceChildren(...answer.neighbors.map((n) => {
      const li = document.createElement('li');
      const name = document.createElement('span');
      const sw = document.createElement('span');
      sw.className = 'swatch';
      sw.style.background = ['#ff7a00', '#ffd000', '#9bd45a', '#5ab4d4'][Math.min(n.ring, 4) - 1];
      name.append(sw, `${n.label}`);
      const info = document.createElement('span');
      info.className = 'muted';
      // Clearance: interface to objects; gap: between the two objects (via and this one).
      const gap = n.gap == null ? '' : ` · gap ${fmt(n.gap, 3)}`;
      info.textContent = n.touching
        ? `ring ${n.ring} · touching (clearance 0)${gap}`
        : `ring ${n.ring} · clearance ${fmt(n.min_clearance, 3)}${gap}`;
      li.append(name, info);
      li.dataset.label = n.label;
      return li;
    }));
  });
}

$('info-toggle').addEventListener('click', () => $('info').classList.toggle('folded'));
$('ring').addEventListener('change', () => state.selected !== null && select(state.selected));

// ---- paths ---------------------------------------------------------------------------------

function setPicking(on) {
  state.pickingOn = on;
  state.picking = [];
  $('pick-path').classList.toggle('active', on);
  $('view').classList.toggle('picking', on);
  if (on) {
    view.clearOverlay('marker');
    view.clearOverlay('path');
    $('path-result').textContent = 'Click the start point.';
  }
}

$('pick-path').addEventListener('click', () => setPicking(!state.pickingOn));

async function pick(point) {
  state.picking.push(point);
  view.showMarkers(state.picking);
  if (state.picking.length === 1) {
    $('path-result').textContent = 'Now click the goal.';
    return;
  }
  const [from, to] = state.picking;
  setPicking(false);
  view.showMarkers([from, to]);
  const body = {from, to, cost: $('cost').value};
  const minClearance = Number($('min-clearance').value);
  if (minClearance > 0) body.min_clearance = minClearance;
  await run(async () => {
    $('path-result').textContent = 'Searching…';
    try {
      const answer = await postJSON(`/v1/jobs/${enc(state.jobId)}/paths`, body);
      state.path = {from, to, found: true, length: answer.length, min_clearance: answer.min_clearance,
                    points: answer.points.length};
      view.showPath(answer.points);
      $('path-result').textContent =
          `length ${fmt(answer.length)}, min clearance ${fmt(answer.min_clearance, 3)} (${answer.points.length} points)`;
    } catch (e) {
      if (e instanceof ApiError && e.status === 422 && e.problem?.type?.endsWith('/no-path')) {
        const reason = e.problem.path?.reason ?? e.problem.detail;
        state.path = {from, to, found: false, reason};
        $('path-result').textContent = `No path: ${reason}`;
        return;
      }
      state.path = {from, to, found: false, reason: e.message};
      $('path-result').textContent = '';
      throw e;
    }
  });
}

// ---- exploded view ---------------------------------------------------------------------------

function setExplode(t) {
  state.explode = t;
  $('explode-slider').value = t;
  view.setExplode(t);
}

$('explode-slider').addEventListener('input', (e) => setExplode(Number(e.target.value)));

$('explode-play').addEventListener('click', () => {
  const from = state.explode;
  const to = from > 0.5 ? 0 : 1;
  const start = performance.now();
  const step = (now) => {
    const u = Math.min(1, (now - start) / 1500);
    const eased = u < 0.5 ? 2 * u * u : 1 - (-2 * u + 2) ** 2 / 2;
    setExplode(from + (to - from) * eased);
    if (u < 1) requestAnimationFrame(step);
  };
  requestAnimationFrame(step);
});

$('anchor').addEventListener('change', (e) => run(async () => {
  const answer = await getJSON(`/v1/jobs/${enc(state.jobId)}/explode?anchor=${enc(e.target.value)}`);
  state.anchor = answer.label;
  view.setDisplacements(answer.objects.map((o) => [o.label, o.displacement]));
}));

// ---- display ---------------------------------------------------------------------------------

$('show-objects').addEventListener('change', (e) => view.setVisible({objects: e.target.checked}));
$('show-gvd').addEventListener('change', (e) => view.setVisible({gvd: e.target.checked}));
$('cell-only').addEventListener('change', (e) => view.setSelectedCellOnly(e.target.checked));
$('gvd-opacity').addEventListener('input', (e) => view.setVisible({opacity: Number(e.target.value)}));

// ---- the canvas: clicks (not drags) pick ------------------------------------------------------

let down = null;
const canvas = $('canvas');
canvas.addEventListener('pointerdown', (e) => {
  down = {x: e.clientX, y: e.clientY};
});
canvas.addEventListener('pointerup', (e) => {
  if (!down || !state.loaded) return;
  const moved = Math.hypot(e.clientX - down.x, e.clientY - down.y);
  down = null;
  if (moved > 4 || e.button !== 0) return;
  if (state.pickingOn) {
    const p = view.pointAt(e.clientX, e.clientY);
    if (p) pick(p);
    return;
  }
  select(view.objectAt(e.clientX, e.clientY));
});
let hover = null;  // the latest pointer position, handled once per frame (a raycast each)
canvas.addEventListener('pointermove', (e) => {
  if (!state.loaded || e.buttons !== 0) return;
  if (hover === null) requestAnimationFrame(showHover);
  hover = {clientX: e.clientX, clientY: e.clientY};
});
function showHover() {
  const e = hover;
  hover = null;
  if (!e || !state.loaded) return;
  const label = view.objectAt(e.clientX, e.clientY);
  const tip = $('tooltip');
  tip.hidden = label === null;
  if (label !== null) {
    const r = $('view').getBoundingClientRect();
    tip.style.left = `${e.clientX - r.left}px`;
    tip.style.top = `${e.clientY - r.top}px`;
    tip.textContent = label;
  }
}
canvas.addEventListener('pointerleave', () => {
  hover = null;
  $('tooltip').hidden = true;
});

// ---- files: choose or drop -------------------------------------------------------------------

$('files').addEventListener('change', (e) => {
  submit(e.target.files);
  e.target.value = '';
});
let dragDepth = 0;
window.addEventListener('dragenter', (e) => {
  e.preventDefault();
  dragDepth++;
  document.body.classList.add('dragging');
});
window.addEventListener('dragleave', () => {
  if (--dragDepth <= 0) document.body.classList.remove('dragging');
});
window.addEventListener('dragover', (e) => e.preventDefault());
window.addEventListener('drop', (e) => {
  e.preventDefault();
  dragDepth = 0;
  document.body.classList.remove('dragging');
  submit(e.dataTransfer.files);
});

// ---- previous jobs ---------------------------------------------------------------------------

async function listJobs() {
  try {
    const list = await getJSON('/v1/jobs');
    const select = $('jobs');
    const done = list.jobs.filter((j) => j.status === 'done').slice(0, 50);
    select.replaceChildren(new Option(done.length ? '… or open a previous job' : 'no previous jobs', ''),
                           ...done.map((j) => new Option(`${j.id.slice(0, 12)} · ${j.submitted_at ?? ''}`, j.id)));
  } catch {
    // the list is a convenience
  }
}
$('jobs').addEventListener('change', (e) => {
  if (e.target.value) run(() => openJob(e.target.value));
});
$('jobs').addEventListener('focus', listJobs);

/** `#job=<id>` in the address opens that job (on load, and when the address changes). */
function openFromHash() {
  const m = /^#job=([0-9a-zA-Z_-]+)$/.exec(location.hash);
  if (m && m[1] !== state.jobId) {
    clearError();
    run(async () => openJob(m[1], await getJSON(`/v1/jobs/${m[1]}`)));
  }
}
window.addEventListener('hashchange', openFromHash);
listJobs();
openFromHash();

// ---- the hook the browser test drives (tests/js/viewer_browser_test.mjs) ------------------------

window.gvdViewer = {
  state,
  view,
  /** Window coordinates where clicking hits the object `label`, or null. */
  screenPointOf: (label) => view.screenPointOf(label),
  /** Window coordinates where clicking hits the GVD surface between two objects. */
  screenPointOnGvd: (label, other) => view.screenPointOnGvd(label, other),
  /** The colour an object is drawn in, as 'rrggbb'. */
  colorOf: (label) => view.byLabel.get(label)?.parts[0]?.material.color.getHexString() ?? null,
  /** Fraction of the canvas's pixels that are not background: something is drawn. */
  coverage: () => view.coverage(),
};
