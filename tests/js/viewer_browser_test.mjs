// The web viewer in a real browser (Debian's chromium, headless, driven by playwright-core):
// starts gvd-server on a free port with a fresh store, loads `/` and drives every panel with
// real mouse events, checking what the page shows against the API: the example button (its
// job id = the API's for the same file), the full job id and its copy, downloads (= the API's
// bytes), the object list (palette, visibility, opacity, one cell), the clearance legend (linear
// and log, colours of GVD vertices = the legend at their clearance; vertex clearances = the
// API's distance there), the hover readout (= /nearest at the point under the pointer), the
// measure tool, tight places (= /tight), neighbours, picked and typed paths (= /paths), the
// explode slider (paths hide), the default anchor (largest interface area), clipping, the up
// axis, the axes inset, the scale bar, the view reset, a 2D scene, units, earlier jobs by file
// name, several STL files, a part inside a box (clipping), a one-object scene, a bad file.
// Every request must stay on the server: the page works offline. Screenshots of a 3D and a 2D
// scene go to --out, and to --docs DIR (docs/viewer-3d.png, docs/viewer-2d.png) when given.
//
//   node viewer_browser_test.mjs --server build/server/gvd-server --data tests/data
//        --out build/test-output/browser [--docs docs]
import {spawn} from 'node:child_process';
import {copyFileSync, existsSync, mkdirSync, readFileSync, rmSync, writeFileSync} from 'node:fs';
import {join} from 'node:path';
import {chromium} from 'playwright-core';

const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) => {
  if (a.startsWith('--')) acc.push([a.slice(2), all[i + 1]]);
  return acc;
}, []));
const chromiumPath = process.env.GVD_CHROMIUM ?? '/usr/bin/chromium';
const out = args.out ?? 'browser-test-output';
const started = Date.now();
const log = (msg) => console.log(`[${((Date.now() - started) / 1000).toFixed(1)} s] ${msg}`);

function check(cond, msg) {
  if (!cond) throw new Error(`check failed: ${msg}`);
}

function startServer(binary, store) {
  return new Promise((resolve, reject) => {
    const proc = spawn(binary, ['--port', '0', '--store', store, '--quiet', '--workers', '1'],
                       {stdio: ['ignore', 'pipe', 'inherit']});
    let text = '';
    const timer = setTimeout(() => reject(new Error(`gvd-server did not start: "${text}"`)), 10000);
    proc.on('error', reject);
    proc.on('exit', (code) => reject(new Error(`gvd-server exited (${code}): "${text}"`)));
    proc.stdout.on('data', (d) => {
      text += d;
      const m = /http:\/\/[^:]+:(\d+)/.exec(text);
      if (m) {
        clearTimeout(timer);
        resolve({proc, port: Number(m[1])});
      }
    });
  });
}

/** An ASCII STL of the cube of side `s` at `o` (12 triangles, outward normals). */
function cubeStl(name, o, s = 1) {
  const v = (x, y, z) => `      vertex ${o[0] + s * x} ${o[1] + s * y} ${o[2] + s * z}`;
  const quads = [[[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]], [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
                 [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], [[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]],
                 [[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]]];
  const facets = [];
  for (const q of quads) {
    for (const t of [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]) {
      facets.push(`  facet normal 0 0 0\n    outer loop\n${t.map((p) => v(...p)).join('\n')}\n    endloop\n  endfacet`);
    }
  }
  return `solid ${name}\n${facets.join('\n')}\nendsolid ${name}\n`;
}

async function api(base, path, options) {
  const res = await fetch(base + path, options);
  return {status: res.status, body: await res.json()};
}

async function post(base, path, body, type = 'application/json') {
  const res = await fetch(base + path, {method: 'POST', headers: {'Content-Type': type}, body});
  return {status: res.status, body: await res.json()};
}

const sub = (a, b) => a.map((x, k) => x - b[k]);
const norm = (v) => Math.hypot(...v);
const near = (a, b, tol) => Math.abs(a - b) <= tol;

/** The axis-aligned box of the job's domain cube (its axes turned when the octree was). */
function domainBox(domain, dimension) {
  const axes = domain.axes ?? [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let c = 0; c < 8; c++) {
    const w = [c & 1, (c >> 1) & 1, dimension === 2 ? 0 : (c >> 2) & 1];
    for (let k = 0; k < 3; k++) {
      const v = (domain.origin[k] ?? 0) + domain.side * (w[0] * axes[0][k] + w[1] * axes[1][k] + w[2] * axes[2][k]);
      lo[k] = Math.min(lo[k], v);
      hi[k] = Math.max(hi[k], v);
    }
  }
  return {lo, hi};
}

async function main() {
  check(args.server && args.data, 'usage: --server BIN --data DIR --out DIR [--docs DIR]');
  if (!existsSync(chromiumPath)) {
    throw new Error(`${chromiumPath} is missing: install Debian's chromium (docker/install-deps.sh)`);
  }
  mkdirSync(out, {recursive: true});
  const store = join(out, 'store');
  rmSync(store, {recursive: true, force: true});
  const {proc, port} = await startServer(args.server, store);
  const base = `http://127.0.0.1:${port}`;
  log(`gvd-server on ${base}`);
  let browser;
  let page;
  /**
   * A screenshot with nothing selected (the objects in their own colours), hovering `at`, the
   * side panel scrolled to the section `panelAt`.
   */
  const shoot = async (name, at, panelAt) => {
    const corner = await page.evaluate(() => {
      const r = document.getElementById('canvas').getBoundingClientRect();
      return {x: r.left + 8, y: r.top + 8};
    });
    await page.mouse.click(corner.x, corner.y);  // on no object: deselects
    await page.waitForFunction(() => window.gvdViewer.state.selected === null && window.gvdViewer.state.busy === 0);
    await page.evaluate((id) => document.getElementById('panel').scrollTo(0, id ? document.getElementById(id).offsetTop - 10 : 0), panelAt);
    if (at) {
      const p = await page.evaluate(at);
      await page.mouse.move(p.x, p.y);
      await page.waitForFunction(() => window.gvdViewer.state.hover !== null && window.gvdViewer.state.busy === 0);
    } else {
      await page.mouse.move(5, 5);
    }
    await page.waitForTimeout(300);
    const file = join(out, name);
    await page.screenshot({path: file});
    if (args.docs) copyFileSync(file, join(args.docs, name));
    log(`screenshot ${file}`);
  };
  const viewer = (fn, arg) => page.evaluate(fn, arg);
  try {
    browser = await chromium.launch({
      executablePath: chromiumPath,
      args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update',
             '--disable-sync', '--no-first-run', '--disable-quic', '--disable-dev-shm-usage'],
    });
    // 1000 x 700: the size of the screenshots in docs/.
    const context = await browser.newContext({viewport: {width: 1000, height: 700}, acceptDownloads: true});
    await context.grantPermissions(['clipboard-read', 'clipboard-write'], {origin: base});
    page = await context.newPage();
    const problems = [];
    page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
    page.on('console', (m) => {
      // The browser logs every failed request; 422 is the answer the page expects (no path, bad file).
      if (m.type() === 'error' && !/status of 422/.test(m.text())) problems.push(`console error: ${m.text()}`);
    });
    // Offline: anything not asked of this server is refused and reported.
    const foreign = [];
    await page.route('**/*', (route) => {
      const url = new URL(route.request().url());
      if (url.origin === base) return route.continue();
      foreign.push(url.href);
      return route.abort();
    });

    // The page, its modules and three.js, from the server.
    const index = await fetch(`${base}/`);
    check(index.headers.get('content-type').startsWith('text/html'), '/ is HTML');
    const three = await fetch(`${base}/vendor/three/build/three.module.js`);
    check(three.status === 200, `three.js is served (${three.status}): is clients/web/node_modules installed?`);
    check(three.headers.get('content-type').startsWith('text/javascript'), 'modules are text/javascript');
    const etag = three.headers.get('etag');
    check(etag, 'static files carry an ETag');
    const again = await fetch(`${base}/vendor/three/build/three.module.js`, {headers: {'If-None-Match': etag}});
    check(again.status === 304, `If-None-Match answers 304 (got ${again.status})`);
    check((await fetch(`${base}/viewer/..%2f..%2fCMakeCache.txt`)).status === 404, 'no path escapes the web root');

    await page.goto(`${base}/`);
    await page.waitForFunction(() => window.gvdViewer !== undefined, null, {timeout: 10000});
    log('viewer loaded');

    // 1. "Try an example" on the empty page: the bundled balls_on_plate scene. Its job id must
    //    be the API's for the same file (ids are content addresses).
    check(await page.isVisible('#hint-example'), 'the empty page offers an example');
    await page.click('#hint-example');
    await page.waitForFunction(() => window.gvdViewer.state.loaded || window.gvdViewer.state.error,
                               null, {timeout: 45000});
    let state = await viewer(() => window.gvdViewer.state);
    check(!state.error, `no error after submitting (${state.error})`);
    check(state.status === 'done', 'the job is done');
    check(state.updates.events >= 1, `progress came as server-sent events (${JSON.stringify(state.updates)})`);
    const sceneText = readFileSync(join(args.data, 'scenes', 'balls_on_plate.json'));
    const direct = await post(base, '/v1/jobs', sceneText);
    check(direct.body.id === state.jobId, `the example's job is the API's for balls_on_plate.json (${direct.body.id} vs ${state.jobId})`);
    const scene = JSON.parse(sceneText);
    const job = `/v1/jobs/${state.jobId}`;
    const doc = (await api(base, job)).body;
    check(doc.status === 'done', 'the API agrees the job is done');
    const side = doc.result.domain.side;
    const info = await page.textContent('#info-table');
    check(info.includes(String(doc.result.leaves.toLocaleString('en'))), 'the panel states the leaf count');
    check(info.includes('octree depth'), 'the panel states the octree depth');
    const stages = await page.$$eval('#stages-table td', (tds) => tds.length / 2);
    check(stages >= 4, `the panel lists stage timings (${stages})`);
    const gvdMeshes = await viewer(() => [...window.gvdViewer.view.byLabel.values()]
      .reduce((n, e) => n + e.gvdParts.length, 0));
    check(gvdMeshes === doc.result.objects, `one GVD cell per object is shown (${gvdMeshes})`);
    const coverage = await viewer(() => window.gvdViewer.coverage());
    check(coverage > 0.15, `the canvas shows the scene (${(coverage * 100).toFixed(0)} % of it drawn)`);
    // The stats panel does not cover the scene.
    const overlap = await viewer(() => {
      const a = document.getElementById('info').getBoundingClientRect();
      const c = document.getElementById('canvas').getBoundingClientRect();
      return Math.max(0, Math.min(a.right, c.right) - Math.max(a.left, c.left)) *
             Math.max(0, Math.min(a.bottom, c.bottom) - Math.max(a.top, c.top));
    });
    check(overlap === 0, `the stats panel does not cover the view (${overlap} px²)`);
    log(`example job ${state.jobId} shown: ${doc.result.objects} objects, ${doc.result.leaves} leaves`);

    // 2. The full job id, as the API writes it, and its copy.
    const shownId = await page.innerText('#job-id');
    check(shownId === state.jobId, `the whole job id is shown as is ("${shownId}")`);
    await page.click('#copy-id');
    const copied = await viewer(() => navigator.clipboard.readText());
    check(copied === state.jobId, `Copy puts the job id on the clipboard ("${copied}")`);
    check((await fetch(`${base}/v1/jobs/${copied}`)).status === 200, 'the API accepts the copied id');

    // 3. Downloads: the API's bytes.
    for (const [link, route] of [['#dl-glb', 'gvd.glb'], ['#dl-graph', 'graph'], ['#dl-json', 'gvd.json'],
                                 ['#dl-result', 'result.gvd']]) {
      const [download] = await Promise.all([page.waitForEvent('download'), page.click(link)]);
      const got = readFileSync(await download.path());
      const want = Buffer.from(await (await fetch(`${base}${job}/${route}`)).arrayBuffer());
      check(got.length > 0 && got.equals(want), `${link} downloads the bytes of ${route} (${got.length} vs ${want.length})`);
      // (result.gvd comes with the server's own Content-Disposition name, which wins)
      check(route === 'result.gvd' || download.suggestedFilename().startsWith('balls_on_plate'),
            `named after the file (${download.suggestedFilename()})`);
    }
    log('job id, copy and downloads');

    // 4. The object list, the palette and the default anchor.
    const graph = (await api(base, `${job}/graph`)).body;
    const listed = await page.$$eval('#object-list tr', (trs) => trs.map((tr) => tr.dataset.label));
    check(JSON.stringify(listed) === JSON.stringify(graph.nodes.map((n) => n.label)), `the list holds the graph's objects (${listed})`);
    const colors = await viewer((ls) => ls.map((l) => window.gvdViewer.colorOf(l)), listed);
    check(new Set(colors).size === colors.length, `every object has its own colour (${colors})`);
    const swatches = await page.$$eval('#object-list .swatch', (s) => s.map((e) => getComputedStyle(e).backgroundColor));
    swatches.forEach((sw, i) => {
      const hex = sw.match(/\d+/g).map((x) => Number(x).toString(16).padStart(2, '0')).join('');
      check(hex === colors[i], `the list's swatch of ${listed[i]} is its colour (${hex} vs ${colors[i]})`);
    });
    const areaOf = new Map(graph.nodes.map((n) => [n.label, 0]));
    for (const e of graph.edges) {
      areaOf.set(e.label_a, areaOf.get(e.label_a) + e.area);
      areaOf.set(e.label_b, areaOf.get(e.label_b) + e.area);
    }
    const largest = [...areaOf].sort((a, b) => b[1] - a[1])[0][0];
    check(state.anchor === largest && (await page.inputValue('#anchor')) === largest,
          `the default anchor has the largest interface area (${state.anchor} vs ${largest})`);
    // Visibility: a hidden object is not drawn there nor picked.
    const b0 = await viewer(() => window.gvdViewer.screenPointOf('ball_0'));
    check(b0, 'ball_0 is visible somewhere on the canvas');
    await page.uncheck('#object-list tr[data-label="ball_0"] .obj-visible');
    check(await viewer((p) => window.gvdViewer.view.objectAt(p.x, p.y) !== 'ball_0', b0), 'a hidden object is not picked');
    check(await viewer(() => window.gvdViewer.screenPointOf('ball_0')) === null, 'a hidden object is nowhere on screen');
    await page.check('#object-list tr[data-label="ball_0"] .obj-visible');
    await page.locator('#object-list tr[data-label="plate"] .obj-opacity').fill('0.3');
    const plateOpacity = await viewer(() => window.gvdViewer.view.byLabel.get('plate').parts
      .map((p) => p.material.transparent && p.material.opacity));
    check(plateOpacity.every((o) => o === 0.3), `the plate's opacity follows its slider (${plateOpacity})`);
    await page.locator('#object-list tr[data-label="plate"] .obj-opacity').fill('1');
    await page.click('#object-list tr[data-label="ball_2"] .obj-cell');
    let cells = await viewer(() => [...window.gvdViewer.view.byLabel.values()].filter((e) => e.gvdNode.visible).map((e) => e.label));
    check(JSON.stringify(cells) === '["ball_2"]', `"cell" shows only that object's cell (${cells})`);
    await page.click('#object-list tr[data-label="ball_2"] .obj-cell');
    cells = await viewer(() => [...window.gvdViewer.view.byLabel.values()].filter((e) => e.gvdNode.visible).length);
    check(cells === graph.nodes.length, 'clicking "cell" again shows every cell');
    log('object list, palette, default anchor');

    // 5. The clearance legend. Vertex clearances are the API's distances there; vertex colours
    //    are the legend's colour at the clearance's place on the scale the test sets.
    const samples = await viewer(() => ['ball_0', 'ball_3', 'plate'].flatMap((l) => window.gvdViewer.view.gvdVertexSample(l, 6)));
    const answers = (await post(base, `${job}/nearest`, JSON.stringify({points: samples.map((s) => s.position)}))).body.answers;
    samples.forEach((s, i) => check(near(answers[i].distance, s.clearance, 1e-4 * side),
                                    `a GVD vertex's clearance ${s.clearance} = the API's distance ${answers[i].distance}`));
    const defaultMax = await page.inputValue('#ramp-max');
    const cs = samples.map((s) => s.clearance).filter((c) => c > 0).sort((a, b) => a - b);
    for (const scale of [{scale: 'linear', min: 0, max: cs[Math.floor(cs.length * 0.7)]},
                         {scale: 'log', min: cs[0] * 1.5, max: cs[cs.length - 2]}]) {
      await page.selectOption('#ramp-scale', scale.scale);
      await page.fill('#ramp-min', String(scale.min));
      await page.dispatchEvent('#ramp-min', 'change');
      await page.fill('#ramp-max', String(scale.max));
      await page.dispatchEvent('#ramp-max', 'change');
      const drawn = await viewer(() => ['ball_0', 'ball_3', 'plate'].flatMap((l) => window.gvdViewer.view.gvdVertexSample(l, 6)));
      const ts = drawn.map((s) => Math.min(1, Math.max(0, scale.scale === 'log'
        ? (Math.log(Math.max(s.clearance, scale.min)) - Math.log(scale.min)) / (Math.log(scale.max) - Math.log(scale.min))
        : s.clearance / scale.max)));
      const legend = await viewer((us) => us.map((u) => window.gvdViewer.legendColorAt(u)), ts);
      drawn.forEach((s, i) => check(s.rgb.every((v, k) => Math.abs(v - legend[i][k]) <= 8),
        `${scale.scale}: clearance ${s.clearance} drawn ${s.rgb.map(Math.round)} = legend ${legend[i]} at ${ts[i].toFixed(3)}`));
      const ticks = await page.$$eval('#legend-ticks span', (s) => s.map((e) => Number(e.textContent)));
      check(near(ticks[0], scale.min, 1e-3 * scale.max) && near(ticks[ticks.length - 1], scale.max, 1e-3 * scale.max),
            `${scale.scale}: the legend shows the range (${ticks})`);
      const note = await page.textContent('#legend-note');
      check(note.includes(scale.scale) && note.includes('0'), `the legend says the scale and 0 ("${note}")`);
    }
    await page.selectOption('#ramp-scale', 'linear');
    await page.fill('#ramp-max', defaultMax);
    await page.dispatchEvent('#ramp-max', 'change');
    log('clearance legend, linear and log');

    // 6. Neighbours: click an object in the canvas; its ring-1/2 neighbours must be the API's.
    const label = 'ball_0';
    const spot = await viewer((l) => window.gvdViewer.screenPointOf(l), label);
    check(spot, `${label} is visible somewhere on the canvas`);
    await page.mouse.click(spot.x, spot.y);
    await page.waitForFunction((l) => window.gvdViewer.state.selected === l && window.gvdViewer.state.busy === 0 &&
                               document.querySelectorAll('#neighbor-list li').length > 0, label, {timeout: 10000});
    for (const ring of [1, 2]) {
      if (ring === 2) {
        await page.selectOption('#ring', '2');
        await page.waitForFunction(() => window.gvdViewer.state.busy === 0 &&
                                   document.querySelector('#selected').textContent.includes('2 rings'));
      }
      state = await viewer(() => window.gvdViewer.state);
      const expected = (await api(base, `${job}/objects/${label}/neighbors?ring=${ring}`)).body.neighbors
        .map((n) => n.label).sort();
      const shown = [...state.highlighted].sort();
      const items = (await page.$$eval('#neighbor-list li', (lis) => lis.map((li) => li.dataset.label))).sort();
      check(JSON.stringify(shown) === JSON.stringify(expected),
            `ring ${ring} highlighted ${JSON.stringify(shown)} = API ${JSON.stringify(expected)}`);
      check(JSON.stringify(items) === JSON.stringify(expected), `ring ${ring} list = API`);
      const drawn = await viewer((ls) => Object.fromEntries(ls.map((l) => [l, window.gvdViewer.colorOf(l)])), state.labels);
      for (const l of state.labels) {
        const want = l === label ? 'ffffff' : expected.includes(l) ? null : '5a5f66';
        if (want) check(drawn[l] === want, `${l} drawn ${drawn[l]}, expected ${want}`);
        else check(drawn[l] !== 'ffffff' && drawn[l] !== '5a5f66', `${l} drawn as a neighbour (${drawn[l]})`);
      }
      log(`ring ${ring} of ${label}: ${shown.join(', ')}`);
    }
    await page.check('#cell-only');
    cells = await viewer(() => [...window.gvdViewer.view.byLabel.values()].filter((e) => e.gvdNode.visible).map((e) => e.label));
    check(JSON.stringify(cells) === JSON.stringify([label]), `only the selected cell is drawn (${cells})`);
    await page.uncheck('#cell-only');
    await page.selectOption('#ring', '1');
    await page.waitForFunction(() => window.gvdViewer.state.busy === 0 &&
                               !document.querySelector('#selected').textContent.includes('rings'));

    // 7. Tight places: the list and the marks are /tight's answer for the bound shown.
    const below = Number(await page.inputValue('#tight-below'));
    const tight = (await api(base, `${job}/tight?below=${below}`)).body.pairs;
    const tightItems = await page.$$eval('#tight-list li', (lis) => lis.map((li) => li.textContent));
    check(tight.length > 0 && tightItems.length === tight.length, `tight places listed: ${tightItems.length} = API ${tight.length}`);
    tight.forEach((p, i) => check(tightItems[i].startsWith(`${p.label_a} – ${p.label_b}`), `tight place ${i + 1} = API (${tightItems[i]})`));
    const marks = await viewer(() => window.gvdViewer.view.overlays('tight').map((m) => m.position.toArray()));
    check(marks.length === tight.filter((p) => p.point).length, `one mark per tight place (${marks.length})`);
    tight.filter((p) => p.point).forEach((p, i) => check(norm(sub(marks[i], p.point)) < 1e-6 * side, `mark ${i + 1} at the API's point`));
    log(`tight places: ${tight.length} below ${below}`);

    // 8. The hover readout = /nearest at the point under the pointer: on an object (distance ~0
    //    to it) and on the GVD between two objects (nearest is one of them).
    //    (The GVD is hidden for the first: drawn in front of the objects, it is hit first.)
    const hoverAt = async (p) => {
      await page.mouse.move(p.x, p.y);
      await page.waitForFunction((q) => {
        const h = window.gvdViewer.state.hover;  // pointer coordinates come as float32
        return h && Math.abs(h.screen.x - q.x) < 0.01 && Math.abs(h.screen.y - q.y) < 0.01 &&
               window.gvdViewer.state.busy === 0;
      }, p, {timeout: 10000});
    };
    for (const [what, where] of [['object', () => window.gvdViewer.screenPointOf('ball_1')],
                                 ['GVD', () => window.gvdViewer.screenPointOnGvd('ball_0', 'ball_2')]]) {
      if (what === 'object') await page.uncheck('#show-gvd');
      else await page.check('#show-gvd');
      const p = await viewer(where);
      check(p, `a point on the ${what} is visible`);
      await hoverAt(p);
      const hover = await viewer(() => window.gvdViewer.state.hover);
      const under = await viewer((q) => window.gvdViewer.toScreen(q), hover.point);
      check(Math.hypot(under.x - p.x, under.y - p.y) < 1.5, `the readout's point is under the pointer (${JSON.stringify(under)} vs ${JSON.stringify(p)})`);
      const answer = (await api(base, `${job}/nearest?point=${hover.point.join(',')}`)).body;
      const text = await page.innerText('#readout');
      check(await page.isVisible('#readout'), 'the readout is shown');
      check(text.includes(`nearest ${answer.label}`) && text.includes(`signed distance ${answer.signed_distance.toPrecision(4)}`),
            `the readout = the API (${answer.label}, ${answer.signed_distance}): "${text}"`);
      if (what === 'object') {
        check(answer.label === 'ball_1' && Math.abs(answer.distance) < 1e-3 * side, `on ball_1's surface (${answer.label}, ${answer.distance})`);
      } else {
        check(hover.onGvd && hover.label === 'ball_0' && hover.other === 'ball_2', `on the GVD of ball_0 | ball_2 (${hover.label} | ${hover.other})`);
        check(['ball_0', 'ball_2'].includes(answer.label), `nearest is one of the two (${answer.label})`);
        check(text.includes(`clearance ${answer.distance.toPrecision(4)}`), `the readout gives the clearance there: "${text}"`);
      }
      log(`hover on the ${what}: ${text.replace(/\n/g, ' / ')}`);
    }

    // 9. Measure: two points picked on two balls; the distance is theirs, and they lie on them.
    await page.click('#measure-go');
    const ends = [];
    for (const l of ['ball_0', 'ball_3']) {
      const p = await viewer((x) => window.gvdViewer.screenPointOf(x), l);
      await page.mouse.click(p.x, p.y);
      ends.push(l);
    }
    await page.waitForFunction(() => window.gvdViewer.state.measure !== null);
    const measure = await viewer(() => window.gvdViewer.state.measure);
    check(near(measure.distance, norm(sub(measure.points[1], measure.points[0])), 1e-12 * side), 'measure = |b - a|');
    const onBalls = (await post(base, `${job}/nearest`, JSON.stringify({points: measure.points}))).body.answers;
    onBalls.forEach((a, i) => check(a.label === ends[i] && a.distance < 1e-3 * side, `measure point ${i + 1} on ${ends[i]} (${a.label}, ${a.distance})`));
    const measured = await page.textContent('#measure-result');
    check(measured.startsWith(measure.distance.toPrecision(4)), `the distance is shown ("${measured}")`);
    log(`measured ${measure.distance.toFixed(4)} between ball_0 and ball_3`);

    // 10. A path between two points picked on the GVD; the answer must be the API's; the points
    //     are written into the from/to fields.
    await page.click('#pick-path');
    for (const [a, b] of [['ball_0', 'ball_2'], ['ball_1', 'ball_3']]) {
      const p = await viewer(([x, y]) => window.gvdViewer.screenPointOnGvd(x, y), [a, b]);
      check(p, `the GVD between ${a} and ${b} is visible`);
      await page.mouse.click(p.x, p.y);
      await page.waitForTimeout(100);
    }
    await page.waitForFunction(() => window.gvdViewer.state.path !== null && window.gvdViewer.state.busy === 0,
                               null, {timeout: 10000});
    state = await viewer(() => window.gvdViewer.state);
    const path = await post(base, `${job}/paths`, JSON.stringify({from: state.path.from, to: state.path.to}));
    check(state.path.found === (path.status === 200), `path found in the viewer = API (${path.status})`);
    if (state.path.found) {
      check(Math.abs(state.path.length - path.body.length) <= 1e-9 * Math.max(1, path.body.length), 'path length = API');
      log(`path of length ${state.path.length.toFixed(4)}, ${state.path.points} points`);
    } else {
      const text = await page.textContent('#path-result');
      check(text.startsWith('No path:') && text.includes(path.body.path.reason), 'the no-path reason is shown');
      log(`no path: ${state.path.reason}`);
    }
    const typedFrom = (await page.inputValue('#path-from')).split(',').map(Number);
    check(typedFrom.length === 3 && norm(sub(typedFrom, state.path.from)) < 1e-3 * side, `the picked start is written out (${typedFrom})`);

    // 11. The screenshot of the 3D scene: a path, tight places, a measurement, the readout.
    await shoot('viewer-3d.png', () => window.gvdViewer.screenPointOnGvd('ball_1', 'ball_3'));

    // 12. The explode slider moves the objects (and their cells) apart; the path hides meanwhile.
    await page.locator('#explode-slider').fill('0.5');
    state = await viewer(() => window.gvdViewer.state);
    check(Math.abs(state.explode - 0.5) < 1e-9, 'the slider sets the explode fraction');
    const moved = await viewer(() => [...window.gvdViewer.view.byLabel.values()]
      .filter((e) => e.node && e.node.position.length() > 0 && e.gvdNode.position.equals(e.node.position)).length);
    check(moved >= 1, `objects moved apart with their cells (${moved})`);
    const hidden = await viewer(() => ['path', 'marker', 'measure', 'tight']
      .flatMap((k) => window.gvdViewer.view.overlays(k)).filter((o) => o.visible).length);
    check(hidden === 0, `paths, measurements and marks hide while exploded (${hidden} shown)`);
    await page.screenshot({path: join(out, 'viewer-exploded.png')});
    await page.locator('#explode-slider').fill('0');
    check(await viewer(() => window.gvdViewer.view.overlays('path').every((o) => o.visible)), 'the path is back when assembled');
    await page.locator('#explode-slider').fill('0.5');
    // Another anchor: the vectors of /explode?anchor=ball_0, and the anchor stays in place.
    await page.selectOption('#anchor', 'ball_0');
    await page.waitForFunction(() => window.gvdViewer.state.anchor === 'ball_0' && window.gvdViewer.state.busy === 0);
    const anchored = await viewer(() => window.gvdViewer.view.byLabel.get('ball_0').node.position.length());
    check(anchored === 0, `the anchor does not move (${anchored})`);
    await page.locator('#explode-slider').fill('0');
    log('explode slider and anchor');

    // 13. Clipping: keep x <= 0 (the test's own plane through the domain): ball_2 and ball_3
    //     (x >= 0.502 in the scene file) vanish and cannot be picked; ball_0 (across) stays.
    const box = domainBox(doc.result.domain, 3);
    const fraction = (0 - box.lo[0]) / (box.hi[0] - box.lo[0]);
    await page.selectOption('#clip-axis', 'x');
    await page.locator('#clip-pos').fill(String(fraction));
    const plane = box.lo[0] + (box.hi[0] - box.lo[0]) * Number(await page.inputValue('#clip-pos'));
    const beyond = scene.objects.filter((o) => Math.min(...o.vertices.map((v) => v[0])) > plane).map((o) => o.label);
    check(beyond.includes('ball_2') && beyond.includes('ball_3'), `objects beyond the plane x = ${plane}: ${beyond}`);
    for (const l of beyond) check(await viewer((x) => window.gvdViewer.screenPointOf(x), l) === null, `${l} is clipped away`);
    const kept = await viewer(() => window.gvdViewer.screenPointOf('ball_0'));
    check(kept, 'ball_0, across the plane, is still drawn');
    const keptHit = await viewer((p) => window.gvdViewer.view.surfaceAt(p.x, p.y), kept);
    check(keptHit.point[0] <= plane + 1e-9, `what is picked lies on the kept side (${keptHit.point[0]} <= ${plane})`);
    await page.selectOption('#clip-axis', '');
    check(await viewer(() => window.gvdViewer.screenPointOf('ball_2')) !== null, 'clipping off: ball_2 is back');
    log(`clipping plane x = ${plane.toFixed(3)}`);

    // 14. The axes inset points where the view's axes do; y up turns the view; the scale bar
    //     is as long on screen as its length at the centre of rotation; the view resets.
    const axesAgree = async () => {
      const dirs = await viewer(() => window.gvdViewer.view.gizmoDirections());
      const f = await viewer(() => window.gvdViewer.view.cameraFrame());
      const o = await viewer((t) => window.gvdViewer.toScreen(t), f.target);
      for (const [k, axis] of [[0, 'x'], [1, 'y'], [2, 'z']]) {
        const tip = [...f.target];
        tip[k] += 0.05 * side;
        const s = await viewer((t) => window.gvdViewer.toScreen(t), tip);
        const d = [s.x - o.x, s.y - o.y];
        const l = Math.hypot(...d);
        if (l < 5 || !dirs[axis]) continue;  // seen end-on
        const cos = (d[0] * dirs[axis].x + d[1] * dirs[axis].y) / l;
        check(cos > 0.98, `the inset's ${axis} axis points as the view's (cos ${cos.toFixed(3)})`);
      }
      return f;
    };
    const upOnScreen = async (k) => {
      const f = await viewer(() => window.gvdViewer.view.cameraFrame());
      const tip = [...f.target];
      tip[k] += 0.1 * side;
      const [a, b] = await viewer(([t, u]) => [window.gvdViewer.toScreen(t), window.gvdViewer.toScreen(u)], [f.target, tip]);
      return (a.y - b.y) / Math.hypot(b.x - a.x, b.y - a.y);  // 1 = straight up
    };
    const first = await axesAgree();
    check(await upOnScreen(2) > 0.9, 'z points up on the screen by default');
    await page.selectOption('#up-axis', 'y');
    check(await upOnScreen(1) > 0.9, 'with "y up", y points up on the screen');
    await axesAgree();
    await page.selectOption('#up-axis', 'z');
    const bar = await viewer(() => ({...window.gvdViewer.state.scaleBar,
                                     width: document.getElementById('scalebar-bar').getBoundingClientRect().width,
                                     label: document.getElementById('scalebar-label').textContent}));
    const f0 = await viewer(() => window.gvdViewer.view.cameraFrame());
    const barEnds = await viewer(([t, u]) => [window.gvdViewer.toScreen(t), window.gvdViewer.toScreen(u)],
                                 [f0.target, f0.target.map((x, k) => x + bar.length * f0.right[k])]);
    const barPixels = Math.hypot(barEnds[1].x - barEnds[0].x, barEnds[1].y - barEnds[0].y);
    check(Math.abs(bar.width - barPixels) < 1.5, `the scale bar (${bar.label}, ${bar.width} px) = ${barPixels.toFixed(1)} px on screen`);
    check(Number(bar.label) === bar.length, `the bar's label is its length ("${bar.label}")`);
    const c = await viewer(() => {
      const r = document.getElementById('canvas').getBoundingClientRect();
      return {x: r.left + r.width / 2, y: r.top + r.height / 2};
    });
    await page.mouse.move(c.x, c.y);
    await page.mouse.down();
    await page.mouse.move(c.x + 90, c.y + 40, {steps: 6});
    await page.mouse.up();
    await page.mouse.wheel(0, -300);
    await page.waitForTimeout(200);
    const turned = await viewer(() => window.gvdViewer.view.cameraFrame());
    check(norm(sub(turned.position, first.position)) > 0.05 * side, 'dragging turns the view');
    await page.click('#view-reset');
    const back = await viewer(() => window.gvdViewer.view.cameraFrame());
    check(norm(sub(back.position, first.position)) < 1e-9 * side && norm(sub(back.target, first.target)) < 1e-9 * side,
          'Reset view brings the first view back');
    log('axes inset, up axis, scale bar, view reset');

    // 15. A 2D scene through the file input: lines at z = 0 in an orthographic view.
    await page.setInputFiles('#files', join(args.data, 'scenes', 'gears2d.json'));
    await page.waitForFunction(() => (window.gvdViewer.state.loaded && window.gvdViewer.state.dimension === 2) ||
                               window.gvdViewer.state.error, null, {timeout: 45000});
    state = await viewer(() => window.gvdViewer.state);
    check(!state.error, `no error on the 2D scene (${state.error})`);
    check(await viewer(() => window.gvdViewer.view.camera.isOrthographicCamera), '2D uses an orthographic view');
    const job2 = `/v1/jobs/${state.jobId}`;
    const gear = await viewer(() => window.gvdViewer.screenPointOf('gear_a'));
    check(gear, 'gear_a is visible');
    await page.mouse.click(gear.x, gear.y);
    await page.waitForFunction(() => window.gvdViewer.state.selected === 'gear_a' && window.gvdViewer.state.busy === 0);
    state = await viewer(() => window.gvdViewer.state);
    const gearNeighbors = (await api(base, `${job2}/objects/gear_a/neighbors?ring=1`)).body.neighbors
      .map((n) => n.label).sort();
    check(JSON.stringify([...state.highlighted].sort()) === JSON.stringify(gearNeighbors), '2D neighbours = API');
    // A typed path (inside the frame, around the gears) = the API's.
    await page.fill('#path-from', '-1.1, 1.1');
    await page.fill('#path-to', '3.1 -1.1');
    await page.click('#path-go');
    await page.waitForFunction(() => window.gvdViewer.state.path !== null && window.gvdViewer.state.busy === 0);
    state = await viewer(() => window.gvdViewer.state);
    const typed = await post(base, `${job2}/paths`, JSON.stringify({from: [-1.1, 1.1], to: [3.1, -1.1]}));
    check(JSON.stringify(state.path.from) === '[-1.1,1.1]' && JSON.stringify(state.path.to) === '[3.1,-1.1]', 'the typed points are asked');
    check(state.path.found === (typed.status === 200) &&
          (!state.path.found || Math.abs(state.path.length - typed.body.length) <= 1e-9 * typed.body.length),
          `the typed path = API (${state.path.length} vs ${typed.body.length})`);
    // A measure across the plane: 200 pixels to the right is 200 x (bar length / bar pixels).
    const bar2 = await viewer(() => window.gvdViewer.state.scaleBar);
    await page.click('#measure-go');
    const m0 = {x: gear.x - 100, y: gear.y + 10};
    await page.mouse.click(m0.x, m0.y);
    await page.mouse.click(m0.x + 200, m0.y);
    await page.waitForFunction(() => window.gvdViewer.state.measure !== null);
    const m2 = await viewer(() => window.gvdViewer.state.measure);
    const expected2 = 200 * bar2.length / bar2.pixels;
    check(near(m2.distance, expected2, 1e-3 * expected2), `a 200-pixel measure is ${expected2} (${m2.distance})`);
    // The readout in 2D: anywhere in the plane.
    await hoverAt({x: m0.x + 50, y: m0.y - 30});
    const hover2 = await viewer(() => window.gvdViewer.state.hover);
    const answer2 = (await api(base, `${job2}/nearest?point=${hover2.point.join(',')}`)).body;
    check(hover2.nearest.label === answer2.label && hover2.nearest.signed_distance === answer2.signed_distance,
          `2D readout = API (${answer2.label}, ${answer2.signed_distance})`);
    await hoverAt(await viewer(() => window.gvdViewer.screenPointOnGvd('gear_a', 'gear_b')));
    const onGvd2 = await viewer(() => window.gvdViewer.state.hover);
    check(onGvd2.onGvd && onGvd2.label === 'gear_a' && onGvd2.other === 'gear_b', `2D: near the GVD of gear_a | gear_b (${onGvd2.label} | ${onGvd2.other})`);
    check(await page.isHidden('#clip-axis'), '2D: no clipping plane to set');
    await shoot('viewer-2d.png', () => window.gvdViewer.screenPointOnGvd('gear_a', 'gear_b'), 'measure');
    log('2D scene: neighbours, typed path, measure, readout');

    // 16. Units: a graph that declares "units" (as the server writes it when the scene does;
    //     served here through a route) puts them on every length; earlier jobs are listed by
    //     file name, and opening one from the list shows it.
    await page.route('**/v1/jobs/*/graph', async (route) => {
      const res = await route.fetch();
      const g = await res.json();
      g.units = g.units ?? 'mm';
      await route.fulfill({response: res, json: g});
    });
    await page.focus('#jobs');
    await page.waitForFunction(() => [...document.querySelectorAll('#jobs option')].some((o) => o.textContent.includes('gears2d.json')));
    const options = await page.$$eval('#jobs option', (os) => os.map((o) => [o.value, o.textContent]));
    const jobIds = (await api(base, '/v1/jobs')).body.jobs.map((j) => j.id);
    const ballsOption = options.find(([, t]) => t.startsWith('balls_on_plate.json'));
    check(ballsOption && ballsOption[0] === direct.body.id && jobIds.includes(ballsOption[0]), `balls_on_plate.json is listed with its id (${JSON.stringify(options)})`);
    await page.selectOption('#jobs', ballsOption[0]);
    await page.waitForFunction((id) => window.gvdViewer.state.loaded && window.gvdViewer.state.jobId === id && window.gvdViewer.state.busy === 0, ballsOption[0]);
    check(await viewer(() => window.gvdViewer.state.units) === 'mm', 'the units are read from the graph');
    const withUnits = [await page.textContent('#legend-note'), await page.textContent('#scalebar-label'),
                       await page.textContent('#tight-list')];
    check(withUnits.every((t) => t.includes('mm')), `lengths carry the units: ${JSON.stringify(withUnits)}`);
    await page.unroute('**/v1/jobs/*/graph');
    log('units, earlier jobs by file name');

    // 17. Several STL files: one multipart submission, one object per file named after it.
    const stls = ['cube_a', 'cube_b', 'cube_c'].map((name, i) => {
      const file = join(out, `${name}.stl`);
      writeFileSync(file, cubeStl(name, [1.5 * i, 0, 0]));
      return file;
    });
    let previous = await viewer(() => window.gvdViewer.state.jobId);
    await page.setInputFiles('#files', stls);
    await page.waitForFunction((prev) => (window.gvdViewer.state.loaded && window.gvdViewer.state.jobId !== prev) ||
                               window.gvdViewer.state.error, previous, {timeout: 45000});
    state = await viewer(() => window.gvdViewer.state);
    check(!state.error, `no error on the STL files (${state.error})`);
    check(JSON.stringify([...state.labels].sort()) === '["cube_a","cube_b","cube_c"]', `labels from file names (${state.labels})`);
    check(state.units === null && !(await page.textContent('#scalebar-label')).includes('mm'), 'no units when the scene has none');
    log(`3 STL files as one job: ${state.labels.join(', ')}`);

    // 18. A part inside a closed box (the teapot in a box): hidden until the
    //     clipping plane cuts the box open or the box is hidden.
    const nested = [['box', [-1, -1, -1], 3], ['part', [0, 0, 0], 1]].map(([name, o, size]) => {
      const file = join(out, `${name}.stl`);
      writeFileSync(file, cubeStl(name, o, size));
      return file;
    });
    previous = state.jobId;
    await page.setInputFiles('#files', nested);
    await page.waitForFunction((prev) => (window.gvdViewer.state.loaded && window.gvdViewer.state.jobId !== prev) ||
                               window.gvdViewer.state.error, previous, {timeout: 45000});
    state = await viewer(() => window.gvdViewer.state);
    check(!state.error && state.labels.includes('part'), `the box and the part are shown (${state.error ?? state.labels})`);
    check(await viewer(() => window.gvdViewer.screenPointOf('part')) === null, 'the part is hidden inside the box');
    await page.selectOption('#clip-axis', 'x');
    await page.locator('#clip-pos').fill('0.5');
    check(await viewer(() => window.gvdViewer.screenPointOf('part')) !== null, 'the clipping plane opens the box: the part is seen');
    await page.selectOption('#clip-axis', '');
    await page.uncheck('#object-list tr[data-label="box"] .obj-visible');
    check(await viewer(() => window.gvdViewer.screenPointOf('part')) !== null, 'hiding the box shows the part');
    log('a part inside a box: seen through the clipping plane or with the box hidden');

    // 19. One object: the page says a GVD needs two.
    previous = state.jobId;
    await page.setInputFiles('#files', {name: 'lonely.stl', mimeType: 'model/stl', buffer: Buffer.from(cubeStl('lonely', [0, 0, 0]))});
    await page.waitForFunction((prev) => (window.gvdViewer.state.loaded && window.gvdViewer.state.jobId !== prev) ||
                               window.gvdViewer.state.error, previous, {timeout: 45000});
    const notice = await page.textContent('#notice');
    check(await page.isVisible('#notice') && notice.includes('two objects') && notice.includes('lonely'),
          `a one-object scene says a GVD needs two objects ("${notice}")`);
    log(`one object: "${notice}"`);

    // 20. A bad file: a readable message that names the file, not a broken page.
    await page.setInputFiles('#files', {name: 'broken.stl', mimeType: 'model/stl', buffer: Buffer.from('solid x\nfacet')});
    await page.waitForFunction(() => window.gvdViewer.state.error !== null, null, {timeout: 10000});
    const message = await page.textContent('#error-text');
    check(await page.isVisible('#error'), 'the error is shown');
    check(message.startsWith('broken.stl: ') && /Invalid scene|Unsupported/.test(message), `the message names the file and the problem: "${message}"`);
    log(`bad file: "${message}"`);

    check(foreign.length === 0, `no request left the server: ${foreign.join(', ')}`);
    check(problems.length === 0, `no errors in the page:\n${problems.join('\n')}`);
    log('ok');
  } catch (e) {
    // What the page showed and knew when it failed.
    if (page) {
      await page.screenshot({path: join(out, 'failure.png')}).catch(() => {});
      const seen = await page.evaluate(() => JSON.stringify({state: window.gvdViewer?.state,
        error: document.querySelector('#error-text')?.textContent,
        path: document.querySelector('#path-result')?.textContent})).catch(() => '');
      e.message += `\npage: ${seen}\nscreenshot: ${join(out, 'failure.png')}`;
    }
    throw e;
  } finally {
    await browser?.close();
    proc.kill('SIGKILL');
  }
}

main().then(() => process.exit(0), (e) => {
  console.error(`FAIL: ${e.message}`);
  process.exit(1);
});
