// The gvd web viewer: submit a scene, follow the job, show the objects and the GVD, and ask
// the API for neighbours, nearest objects, tight places, paths and the exploded view. Talks
// only to the HTTP API (api.js).
import {ApiError, cancelJob, getBytes, getJSON, postJSON, submitFiles, watchJob} from './api.js';
import {GvdView, ramp, rampPosition} from './view.js';

const $ = (id) => document.getElementById(id);
const enc = encodeURIComponent;

const state = {
  jobId: null,
  status: null,       // the job's status as last seen
  loaded: false,      // objects and GVD are on screen
  dimension: 3,
  units: null,        // the scene's length unit ("mm", ...) when it declares one
  labels: [],
  selected: null,     // label of the clicked object
  highlighted: [],    // labels of its k-ring neighbours (what the view colours)
  picking: [],        // path points picked so far
  path: null,         // {from, to, found, length, min_clearance, reason}
  measuring: [],      // measure points picked so far
  measure: null,      // {points: [a, b], distance}
  hover: null,        // {point, label, onGvd, other, nearest (the API's answer), error}
  tight: null,        // {below, pairs (the API's)}
  scaleBar: null,     // {length, pixels}
  explode: 0,
  anchor: null,
  error: null,
  notice: null,
  busy: 0,            // requests in flight
  updates: {events: 0, poll: 0},  // job updates received by server-sent events / polling
};

let view;
try {
  view = new GvdView($('canvas'));
  view.onChange = updateScaleBar;
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

function showNotice(message) {
  state.notice = message;
  $('notice').textContent = message ?? '';
  $('notice').hidden = !message;
}

$('error-close').addEventListener('click', clearError);
window.addEventListener('unhandledrejection', (e) => showError(e.reason?.message ?? e.reason));
window.addEventListener('error', (e) => showError(e.message));

/** Runs an async action, counting it as busy and showing its failure (prefixed with `what`). */
async function run(action, what) {
  state.busy++;
  try {
    return await action();
  } catch (e) {
    const message = e.message ?? String(e);
    showError(what ? `${what}: ${message}` : message);
    return undefined;
  } finally {
    state.busy--;
  }
}

const fmt = (x, digits = 4) => (x === null || x === undefined ? '—'
  : typeof x === 'number' ? (Number.isInteger(x) ? x.toLocaleString('en') : x.toPrecision(digits)) : String(x));
/** A length with the scene's unit when it declares one. */
const len = (x, digits = 4) => (x === null || x === undefined ? '—' : state.units ? `${fmt(x, digits)} ${state.units}` : fmt(x, digits));
const coords = (p) => p.map((x) => fmt(x, 4)).join(', ');
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

// ---- the names of submitted files, by job id (this browser's own) --------------------------

const kNamesKey = 'gvd.jobNames';

function jobNames() {
  try {
    return JSON.parse(localStorage.getItem(kNamesKey) ?? '{}');
  } catch {
    return {};
  }
}

function rememberName(id, name) {
  try {
    const names = jobNames();
    names[id] = name;
    localStorage.setItem(kNamesKey, JSON.stringify(names));
  } catch {
    // private mode: the list just shows ids
  }
}

// ---- submitting and following a job --------------------------------------------------------

async function submit(files) {
  clearError();
  if (files.length === 0) return;
  const name = [...files].map((f) => f.name).join(', ');
  await run(async () => {
    const params = {max_depth: $('max-depth').value};
    $('job-status').textContent = `uploading ${files.length === 1 ? files[0].name : files.length + ' files'}…`;
    $('job').hidden = false;
    const doc = await submitFiles([...files], params);
    rememberName(doc.id, name);
    await openJob(doc.id, doc);
  }, name);
}

/** The bundled example scenes (copied into the web root at build time). */
async function tryExample(file) {
  clearError();
  await run(async () => {
    const blob = await (await fetchOk(`/viewer/examples/${enc(file)}`)).blob();
    await submit([new File([blob], file, {type: 'application/json'})]);
  }, file);
}

async function fetchOk(url) {
  const res = await fetch(url);
  if (!res.ok) throw new Error(`cannot load ${url} (HTTP ${res.status})`);
  return res;
}

for (const b of document.querySelectorAll('button.example')) b.addEventListener('click', () => tryExample(b.dataset.file));

let watching = null;  // aborts following the previous job when another is opened

async function openJob(id, doc) {
  watching?.abort();
  watching = new AbortController();
  const signal = watching.signal;
  resetResult();
  state.jobId = id;
  history.replaceState(null, '', `#job=${id}`);
  $('job').hidden = false;
  $('job-id').textContent = id;
  $('hint-text').textContent = 'Computing…';
  $('hint-example').hidden = true;
  const final = doc && doc.status === 'done' ? doc : await watchJob(id, showStatus, signal);
  if (final === null || signal.aborted) return;  // another job was opened meanwhile
  showStatus(final);
  if (final.status === 'done') {
    await loadResult(final, signal);
  } else {
    const p = final.error;
    const name = jobNames()[id] ?? `job ${id}`;
    showError(`${name}: ${p ? `${p.title ?? 'Job ' + final.status}: ${p.detail ?? ''}` : `the job ${final.status}.`}`);
    $('hint-text').textContent = '';
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

$('copy-id').addEventListener('click', async () => {
  const id = state.jobId;
  if (!id) return;
  try {
    await navigator.clipboard.writeText(id);
  } catch {
    // no clipboard permission (or an insecure origin): copy the selected text the old way
    const range = document.createRange();
    range.selectNodeContents($('job-id'));
    getSelection().removeAllRanges();
    getSelection().addRange(range);
    document.execCommand('copy');
  }
  $('copy-id').textContent = 'Copied';
  setTimeout(() => ($('copy-id').textContent = 'Copy'), 1500);
});

window.addEventListener('keydown', (e) => {
  if (e.key !== 'Escape') return;
  if (state.pickingOn) {
    setPicking(false);
    $('path-result').textContent = 'Picking cancelled.';
  }
  if (state.measuringOn) setMeasuring(false);
});

function resetResult() {
  state.loaded = false;
  state.selected = null;
  state.highlighted = [];
  state.picking = [];
  state.path = null;
  state.measure = null;
  state.measuring = [];
  state.hover = null;
  state.tight = null;
  state.units = null;
  state.explode = 0;
  $('explode-slider').value = 0;
  for (const id of ['info', 'objects', 'neighbors', 'path', 'tight', 'measure', 'explode', 'display', 'downloads']) $(id).hidden = true;
  $('selected').textContent = 'Click an object.';
  $('neighbor-list').replaceChildren();
  $('tight-list').replaceChildren();
  $('object-list').replaceChildren();
  $('path-result').textContent = 'Click Pick two points, then two places in the view, or type the two points.';
  $('path-from').value = '';
  $('path-to').value = '';
  $('measure-result').textContent = '';
  $('readout').hidden = true;
  $('scalebar').hidden = true;
  showNotice(null);
  if (state.pickingOn) setPicking(false);
  if (state.measuringOn) setMeasuring(false);
  view?.clear();
}

/**
 * The default anchor of the exploded view: the object whose interfaces with its neighbours
 * have the largest total area (the frame, the plate), not merely the most neighbours.
 */
function defaultAnchor(graph) {
  const area = new Map(graph.nodes.map((n) => [n.object, 0]));
  for (const e of graph.edges) {
    area.set(e.a, area.get(e.a) + (e.area ?? 0));
    area.set(e.b, area.get(e.b) + (e.area ?? 0));
  }
  let anchor = graph.nodes[0];
  for (const n of graph.nodes) if (area.get(n.object) > area.get(anchor.object)) anchor = n;
  return anchor.label;
}

async function loadResult(job, signal) {
  const r = job.result ?? {};
  state.dimension = r.dimension ?? job.scene?.dimension ?? 3;
  $('hint-text').textContent = 'Loading the GVD…';
  const base = `/v1/jobs/${enc(job.id)}`;
  const graph = await getJSON(`${base}/graph`);
  if (signal.aborted) return;
  state.units = graph.units ?? job.units ?? null;
  showInfo(job);
  state.labels = graph.nodes.map((n) => n.label);
  state.anchor = defaultAnchor(graph);
  $('anchor').replaceChildren(...state.labels.map((l) => new Option(l, l, false, l === state.anchor)));
  showDownloads(job.id);

  const [objectsGlb, gvdGlb] = await Promise.all([
    getBytes(`${base}/explode?anchor=${enc(state.anchor)}&format=glb`),
    getBytes(`${base}/gvd.glb`),
  ]);
  if (!view || signal.aborted) return;
  await view.show({dimension: state.dimension, objectCount: graph.nodes.length, domain: r.domain,
                   objectsGlb, gvdGlb});
  if (signal.aborted) return;
  $('hint-text').textContent = '';
  for (const id of ['objects', 'neighbors', 'path', 'tight', 'measure', 'explode', 'display']) $(id).hidden = false;
  for (const el of document.querySelectorAll('.view3d')) el.hidden = state.dimension === 2;
  $('path-from').placeholder = $('path-to').placeholder = state.dimension === 2 ? 'x, y' : 'x, y, z';
  showObjectList(graph);
  resetDisplay();
  if (graph.nodes.length < 2) {
    showNotice(`This scene has ${graph.nodes.length === 1 ? `one object (${graph.nodes[0].label})` : 'no object'}: ` +
               'a GVD needs at least two objects, since it is where two objects are equally near. ' +
               'Add another object to the scene (several files, or several groups or nodes in one file).');
  }
  state.loaded = true;
  listJobs();
  if (graph.edges.length > 0) await listTight(defaultBelow(graph));
}

function showDownloads(id) {
  const base = `/v1/jobs/${enc(id)}`;
  const name = (jobNames()[id] ?? id).split(',')[0].trim().replace(/\.[^.]*$/, '').replace(/[^\w.-]+/g, '_') || id;
  const set = (el, href, file) => {
    $(el).href = href;
    $(el).download = file;
  };
  set('dl-glb', `${base}/gvd.glb`, `${name}.gvd.glb`);
  set('dl-graph', `${base}/graph`, `${name}.graph.json`);
  set('dl-json', `${base}/gvd.json`, `${name}.gvd.json`);
  set('dl-result', `${base}/result.gvd`, `${name}.gvd`);
  $('downloads').hidden = false;
}

function showInfo(job) {
  const r = job.result ?? {};
  const s = job.scene ?? {};
  rows($('info-table'), [
    ['dimension', `${r.dimension ?? s.dimension}D`],
    ['objects', fmt(r.objects ?? s.objects)],
    ['simplices', fmt(r.simplices ?? s.simplices)],
    ['domain side', len(r.domain?.side)],
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

$('info-toggle').addEventListener('click', () => $('info').classList.toggle('folded'));

// ---- the object list -------------------------------------------------------------------------

function showObjectList(graph) {
  const trs = graph.nodes.map((n) => {
    const tr = document.createElement('tr');
    tr.dataset.label = n.label;
    const sw = document.createElement('span');
    sw.className = 'swatch';
    sw.style.background = `#${view.byLabel.get(n.label)?.baseColor.getHexString() ?? '888888'}`;
    const shown = Object.assign(document.createElement('input'), {type: 'checkbox', checked: true, className: 'obj-visible',
                                                                  title: `show ${n.label}`});
    shown.addEventListener('change', () => view.setObjectVisible(n.label, shown.checked));
    const name = document.createElement('td');
    name.className = 'name';
    name.textContent = n.label;
    name.title = `${n.label}: click for its neighbours`;
    name.addEventListener('click', () => select(n.label));
    const opacity = Object.assign(document.createElement('input'), {type: 'range', min: 0, max: 1, step: 0.05, value: 1,
                                                                     className: 'obj-opacity', title: `opacity of ${n.label}`});
    opacity.addEventListener('input', () => view.setObjectOpacity(n.label, Number(opacity.value)));
    const cell = Object.assign(document.createElement('button'), {textContent: 'cell', className: 'obj-cell',
                                                                  title: `show only the GVD cell of ${n.label}`});
    cell.addEventListener('click', () => {
      const on = view.soloCell !== n.label;
      view.setSoloCell(on ? n.label : null);
      for (const b of document.querySelectorAll('#object-list .obj-cell')) b.classList.remove('active');
      cell.classList.toggle('active', on);
    });
    const td = (...els) => {
      const cellTd = document.createElement('td');
      cellTd.append(...els);
      return cellTd;
    };
    tr.append(td(sw, shown), name, td(opacity), td(cell));
    return tr;
  });
  $('object-list').replaceChildren(...trs);
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
      name.append(sw, ` ${n.label}`);
      const info = document.createElement('span');
      info.className = 'muted';
      // Clearance: interface to objects; gap: between the two objects (via and this one).
      const gap = n.gap == null ? '' : ` · gap ${len(n.gap, 3)}`;
      info.textContent = n.touching
        ? `ring ${n.ring} · touching (clearance 0)${gap}`
        : `ring ${n.ring} · clearance ${len(n.min_clearance, 3)}${gap}`;
      li.append(name, info);
      li.dataset.label = n.label;
      return li;
    }));
  });
}

$('ring').addEventListener('change', () => state.selected !== null && select(state.selected));

// ---- paths ---------------------------------------------------------------------------------

function setPicking(on) {
  if (on && state.measuringOn) setMeasuring(false);
  state.pickingOn = on;
  state.picking = [];
  $('pick-path').classList.toggle('active', on);
  $('view').classList.toggle('picking', on || state.measuringOn);
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
  $(state.picking.length === 1 ? 'path-from' : 'path-to').value = coords(point);
  if (state.picking.length === 1) {
    $('path-result').textContent = 'Now click the goal.';
    return;
  }
  const [from, to] = state.picking;
  setPicking(false);
  await findPath(from, to);
}

/** "x, y[, z]" -> numbers, exactly the scene's dimension of them. */
function parsePoint(text, what) {
  const parts = text.split(/[\s,;]+/).filter((s) => s !== '');
  const p = parts.map(Number);
  if (p.length !== state.dimension || p.some((x) => !Number.isFinite(x))) {
    throw new Error(`"${what}" needs ${state.dimension} numbers (x, y${state.dimension === 3 ? ', z' : ''}), got "${text}"`);
  }
  return p;
}

$('path-go').addEventListener('click', () => run(async () => {
  const from = parsePoint($('path-from').value, 'from');
  const to = parsePoint($('path-to').value, 'to');
  if (state.pickingOn) setPicking(false);
  await findPath(from, to);
}));

async function findPath(from, to) {
  view.showMarkers([from, to]);
  view.clearOverlay('path');
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
          `length ${len(answer.length)}, min clearance ${len(answer.min_clearance, 3)} (${answer.points.length} points)`;
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

// ---- tightest places -----------------------------------------------------------------------

/** A bound that lists the (up to) eight tightest neighbouring pairs of the graph. */
function defaultBelow(graph) {
  const c = graph.edges.map((e) => e.min_clearance).filter((x) => Number.isFinite(x)).sort((a, b) => a - b);
  if (c.length === 0) return 0;
  const v = c[Math.min(7, c.length - 1)];
  const positive = c.find((x) => x > 0);
  return v > 0 ? v * 1.001 : (positive ?? 1) / 2;
}

async function listTight(below) {
  $('tight-below').value = String(below);
  await run(async () => {
    const answer = await getJSON(`/v1/jobs/${enc(state.jobId)}/tight?below=${below}`);
    state.tight = {below, pairs: answer.pairs};
    view.showTight(answer.pairs.filter((p) => p.point).map((p) => p.point));
    $('tight-list').replaceChildren(...answer.pairs.map((p) => {
      const li = document.createElement('li');
      li.textContent = `${p.label_a} – ${p.label_b}: ${p.touching ? 'touching (clearance 0)' : `clearance ${len(p.min_clearance, 3)}`}` +
                       (p.gap == null ? '' : ` · gap ${len(p.gap, 3)}`);
      li.title = p.point ? `at ${coords(p.point)}: click to centre the view there` : '';
      if (p.point) li.addEventListener('click', () => view.lookAt(p.point));
      return li;
    }));
    if (answer.pairs.length === 0) $('tight-list').textContent = 'No neighbouring pair is that tight.';
  }, 'tight places');
}

$('tight-go').addEventListener('click', () => {
  const below = Number($('tight-below').value);
  if (!(below >= 0)) return showError('tight places: the bound must be a number ≥ 0');
  return listTight(below);
});

// ---- measuring ---------------------------------------------------------------------------------

function setMeasuring(on) {
  if (on && state.pickingOn) setPicking(false);
  state.measuringOn = on;
  state.measuring = [];
  $('measure-go').classList.toggle('active', on);
  $('view').classList.toggle('picking', on || state.pickingOn);
  if (on) {
    view.clearOverlay('measure');
    state.measure = null;
    $('measure-result').textContent = 'Click the first point.';
  } else if (!state.measure) {
    $('measure-result').textContent = '';
  }
}

$('measure-go').addEventListener('click', () => setMeasuring(!state.measuringOn));

function measurePoint(point) {
  state.measuring.push(point);
  view.showMeasure(state.measuring);
  if (state.measuring.length === 1) {
    $('measure-result').textContent = 'Now the second point.';
    return;
  }
  const [a, b] = state.measuring;
  const d = a.map((x, k) => b[k] - x);
  const distance = Math.hypot(...d);
  state.measure = {points: [a, b], distance};
  setMeasuring(false);
  view.showMeasure([a, b]);
  $('measure-result').textContent = `${len(distance)} (Δ ${d.map((x) => fmt(x, 3)).join(', ')})`;
  $('measure-result').title = `from ${coords(a)} to ${coords(b)}`;
}

// ---- exploded view ---------------------------------------------------------------------------

function setExplode(t) {
  state.explode = t;
  $('explode-slider').value = t;
  view.setExplode(t);
  if (t > 0) $('readout').hidden = true;
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
$('show-axes').addEventListener('change', (e) => {
  view.setVisible({axes: e.target.checked});
  updateScaleBar();
});
$('view-reset').addEventListener('click', () => view.resetView());
// The up axis is a property of where the user's meshes come from: kept across jobs and visits.
try {
  $('up-axis').value = localStorage.getItem('gvd.up') === 'y' ? 'y' : 'z';
} catch {
  // no storage: z up
}
$('up-axis').addEventListener('change', (e) => {
  view.setUp(e.target.value);
  try {
    localStorage.setItem('gvd.up', e.target.value);
  } catch {
    // not kept
  }
});

function applyClip() {
  const axis = $('clip-axis').value || null;
  $('clip-pos').disabled = axis === null;
  view.setClip(axis, Number($('clip-pos').value), $('clip-flip').checked);
}
for (const id of ['clip-axis', 'clip-pos', 'clip-flip']) $(id).addEventListener('input', applyClip);

/** Display settings back to their defaults for a newly shown result (the up axis stays). */
function resetDisplay() {
  $('clip-axis').value = '';
  $('clip-pos').value = 0.5;
  applyClip();
  view.setUp($('up-axis').value);
  $('ramp-scale').value = 'linear';
  $('ramp-min').value = 0;
  $('ramp-max').value = fmt(view.clearanceMax > 0 ? view.clearanceMax : 1, 4);
  applyRamp();
  for (const id of ['show-objects', 'show-gvd', 'show-axes']) $(id).checked = true;
  $('cell-only').checked = false;
  view.setVisible({objects: true, gvd: true, axes: true, opacity: Number($('gvd-opacity').value)});
}

// ---- the clearance legend ------------------------------------------------------------------------

function applyRamp() {
  const scale = $('ramp-scale').value;
  let min = Number($('ramp-min').value);
  let max = Number($('ramp-max').value);
  if (!(max > 0)) max = view.clearanceMax > 0 ? view.clearanceMax : 1;
  if (scale === 'log' && !(min > 0)) {
    // a log scale cannot start at 0: three decades below the widest, or the least clearance
    min = Math.max(view.clearanceMinPositive || 0, max / 1000);
    $('ramp-min').value = fmt(min, 3);
    min = Number($('ramp-min').value);
  }
  if (!(min >= 0) || min >= max) min = scale === 'log' ? max / 1000 : 0;
  view.setRamp({scale, min, max});
  drawLegend({scale, min, max});
}

for (const id of ['ramp-scale', 'ramp-min', 'ramp-max']) {
  $(id).addEventListener('change', () => {
    if (id === 'ramp-scale' && $('ramp-scale').value === 'linear') $('ramp-min').value = 0;
    applyRamp();
  });
}

/** Ticks of a scale: its ends and, on a log scale, the powers of ten between them. */
function ticks({scale, min, max}) {
  const t = [min];
  if (scale === 'log') {
    for (let k = Math.ceil(Math.log10(min)); 10 ** k < max; k++) if (10 ** k > min * 1.3 && 10 ** k < max / 1.3) t.push(10 ** k);
  } else {
    t.push((min + max) / 2);
  }
  t.push(max);
  return t;
}

function drawLegend(rampScale) {
  const canvas = $('legend-ramp');
  const g = canvas.getContext('2d');
  for (let x = 0; x < canvas.width; x++) {
    const [r, gg, b] = ramp(x / (canvas.width - 1));
    g.fillStyle = `rgb(${Math.round(r * 255)}, ${Math.round(gg * 255)}, ${Math.round(b * 255)})`;
    g.fillRect(x, 0, 1, canvas.height);
  }
  const spans = ticks(rampScale).map((v) => {
    const s = document.createElement('span');
    s.style.left = `${rampPosition(v, rampScale) * 100}%`;
    s.textContent = fmt(v, 3);
    return s;
  });
  $('legend-ticks').replaceChildren(...spans);
  const unit = state.units ? state.units : 'scene units';
  const low = rampScale.scale === 'log' || rampScale.min > 0
    ? `0 (touching) and up to ${fmt(rampScale.min, 3)}: red` : '0 = touching: red';
  $('legend-note').textContent = `${rampScale.scale} scale, ${unit}; ${low}; ${fmt(rampScale.max, 3)} and wider: blue` +
                                 ` (widest ${len(view.clearanceMax, 3)})`;
  state.ramp = rampScale;
}

// ---- the scale bar ---------------------------------------------------------------------------------

/** A bar of a round length (1, 2 or 5 x 10^k) about 100 pixels long, at the centre of rotation. */
function updateScaleBar() {
  const bar = $('scalebar');
  if (!view || view.byLabel.size === 0 || !$('show-axes').checked) {
    bar.hidden = true;
    return;
  }
  const upp = view.unitsPerPixel();
  const raw = upp * 100;
  const p = 10 ** Math.floor(Math.log10(raw));
  const length = [5, 2, 1].map((m) => m * p).find((v) => v <= raw) ?? p;
  const pixels = length / upp;
  $('scalebar-bar').style.width = `${pixels}px`;
  $('scalebar-label').textContent = len(length, 3);
  bar.title = state.dimension === 3 ? 'at the depth of the centre of rotation' : '';
  bar.hidden = false;
  state.scaleBar = {length, pixels};
}

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
  if (state.measuringOn) {
    const p = view.measurePointAt(e.clientX, e.clientY);
    if (p) measurePoint(p);
    return;
  }
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
  const r = $('view').getBoundingClientRect();
  if (label !== null) {
    tip.style.left = `${e.clientX - r.left}px`;
    tip.style.top = `${e.clientY - r.top}px`;
    tip.textContent = label;
  }
  if (state.explode > 0) return;  // the readout is for the assembled scene
  const at = view.surfaceAt(e.clientX, e.clientY);
  if (!at) {
    $('readout').hidden = true;
    return;
  }
  askNearest({...at, screen: {x: e.clientX, y: e.clientY}});
}

let nearestBusy = false;
let nearestNext = null;
/** The readout under the pointer: one request at a time, the latest position wins. */
async function askNearest(at) {
  if (nearestBusy) {
    nearestNext = at;
    return;
  }
  nearestBusy = true;
  state.busy++;
  try {
    const answer = await getJSON(`/v1/jobs/${enc(state.jobId)}/nearest?point=${at.point.join(',')}`);
    state.hover = {...at, nearest: answer};
  } catch (err) {
    state.hover = {...at, nearest: null, error: err.problem?.title ?? err.message};
  } finally {
    nearestBusy = false;
    state.busy--;
  }
  showReadout(state.hover);
  if (nearestNext) {
    const next = nearestNext;
    nearestNext = null;
    askNearest(next);
  }
}

function showReadout(h) {
  const box = $('readout');
  if (!h || state.explode > 0) {
    box.hidden = true;
    return;
  }
  const lines = [`at ${coords(h.point)}`];
  if (h.nearest) {
    const n = h.nearest;
    lines.push(`nearest ${n.label} · signed distance ${len(n.signed_distance)}${n.inside ? ' (inside)' : ''}`);
    // 3D: the point is on the surface hit; 2D: lines are picked within a few pixels.
    const on = state.dimension === 2 ? 'near' : 'on';
    if (h.onGvd) {
      lines.push(`${on} the GVD of ${h.label}${h.other ? ' | ' + h.other : ''} · clearance ${len(n.distance)}`);
    } else if (h.label && state.dimension === 3) {
      lines.push(`on ${h.label}`);
    }
  } else {
    lines.push(h.error ?? 'no answer');
  }
  box.textContent = lines.join('\n');
  box.hidden = false;
}

canvas.addEventListener('pointerleave', () => {
  hover = null;
  $('tooltip').hidden = true;
  $('readout').hidden = true;
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

// ---- earlier jobs ------------------------------------------------------------------------------

async function listJobs() {
  try {
    const list = await getJSON('/v1/jobs');
    const names = jobNames();
    const select = $('jobs');
    const done = list.jobs.filter((j) => j.status === 'done').slice(0, 50);
    const when = (j) => (j.submitted_at ?? '').replace('T', ' ').replace(/\.\d+Z$/, ' UTC');
    select.replaceChildren(new Option(done.length ? '… or open an earlier job' : 'no earlier jobs', ''),
                           ...done.map((j) => new Option(`${names[j.id] ?? '(submitted elsewhere)'} · ${when(j)} · ${j.id}`, j.id)));
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
  /** Window coordinates of a point of the assembled scene. */
  toScreen: (p) => view.toScreen(p),
  /** The colour an object is drawn in, as 'rrggbb'. */
  colorOf: (label) => view.byLabel.get(label)?.parts[0]?.material.color.getHexString() ?? null,
  /** Fraction of the canvas's pixels that are not background: something is drawn. */
  coverage: () => view.coverage(),
  /** The legend's colour (0..255 RGB) at a fraction t of its width. */
  legendColorAt: (t) => {
    const c = $('legend-ramp');
    const x = Math.round(t * (c.width - 1));
    return [...c.getContext('2d').getImageData(x, c.height >> 1, 1, 1).data.slice(0, 3)];
  },
};
