// The web viewer in a real browser (Debian's chromium, headless, driven by playwright-core):
// starts gvd-server on a free port with a fresh store, loads `/`, submits a scene through the
// file input, waits for the GVD on screen, clicks an object and checks the highlighted
// neighbours against the API, picks a path and checks it against the API, moves the explode
// slider, saves a screenshot, shows a 2D scene, and checks that a bad file gives a readable
// message, and several STL files as one job. Every request must stay on the server: the page works offline.
//
//   node viewer_browser_test.mjs --server build/server/gvd-server --data tests/data
//        --out build/test-output/browser [--screenshot docs/viewer.png]
import {spawn} from 'node:child_process';
import {copyFileSync, existsSync, mkdirSync, rmSync, writeFileSync} from 'node:fs';
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

/** An ASCII STL of the unit cube at `o` (12 triangles, outward normals). */
function cubeStl(name, o) {
  const v = (x, y, z) => `      vertex ${o[0] + x} ${o[1] + y} ${o[2] + z}`;
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

async function main() {
  check(args.server && args.data, 'usage: --server BIN --data DIR --out DIR [--screenshot FILE]');
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
  try {
    browser = await chromium.launch({
      executablePath: chromiumPath,
      args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update',
             '--disable-sync', '--no-first-run', '--disable-quic', '--disable-dev-shm-usage'],
    });
    page = await browser.newPage({viewport: {width: 1280, height: 800}});
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

    // 1. Submit a 3D scene through the file input and wait for the GVD on screen.
    await page.setInputFiles('#files', join(args.data, 'scenes', 'balls_on_plate.json'));
    await page.waitForFunction(() => window.gvdViewer.state.loaded || window.gvdViewer.state.error,
                               null, {timeout: 45000});
    let state = await page.evaluate(() => window.gvdViewer.state);
    check(!state.error, `no error after submitting (${state.error})`);
    check(state.status === 'done', 'the job is done');
    check(state.updates.events >= 1, `progress came as server-sent events (${JSON.stringify(state.updates)})`);
    const job = `/v1/jobs/${state.jobId}`;
    const doc = (await api(base, job)).body;
    check(doc.status === 'done', 'the API agrees the job is done');
    const info = await page.textContent('#info-table');
    check(info.includes(String(doc.result.leaves.toLocaleString('en'))), 'the panel states the leaf count');
    check(info.includes('octree depth'), 'the panel states the octree depth');
    const stages = await page.$$eval('#stages-table td', (tds) => tds.length / 2);
    check(stages >= 4, `the panel lists stage timings (${stages})`);
    const gvdMeshes = await page.evaluate(() => [...window.gvdViewer.view.byLabel.values()]
      .reduce((n, e) => n + e.gvdParts.length, 0));
    check(gvdMeshes === doc.result.objects, `one GVD cell per object is shown (${gvdMeshes})`);
    const coverage = await page.evaluate(() => window.gvdViewer.coverage());
    check(coverage > 0.15, `the canvas shows the scene (${(coverage * 100).toFixed(0)} % of it drawn)`);
    log(`job ${state.jobId} shown: ${doc.result.objects} objects, ${doc.result.leaves} leaves`);

    // 2. Click an object in the canvas; its ring-1 neighbours must be those of the API.
    const label = 'ball_0';
    const spot = await page.evaluate((l) => window.gvdViewer.screenPointOf(l), label);
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
      state = await page.evaluate(() => window.gvdViewer.state);
      const expected = (await api(base, `${job}/objects/${label}/neighbors?ring=${ring}`)).body.neighbors
        .map((n) => n.label).sort();
      const shown = [...state.highlighted].sort();
      const listed = (await page.$$eval('#neighbor-list li', (lis) => lis.map((li) => li.dataset.label))).sort();
      check(JSON.stringify(shown) === JSON.stringify(expected),
            `ring ${ring} highlighted ${JSON.stringify(shown)} = API ${JSON.stringify(expected)}`);
      check(JSON.stringify(listed) === JSON.stringify(expected), `ring ${ring} list = API`);
      const colors = await page.evaluate((ls) => Object.fromEntries(ls.map((l) => [l, window.gvdViewer.colorOf(l)])),
                                         state.labels);
      for (const l of state.labels) {
        const want = l === label ? 'ffffff' : expected.includes(l) ? null : '5a5f66';
        if (want) check(colors[l] === want, `${l} drawn ${colors[l]}, expected ${want}`);
        else check(colors[l] !== 'ffffff' && colors[l] !== '5a5f66', `${l} drawn as a neighbour (${colors[l]})`);
      }
      log(`ring ${ring} of ${label}: ${shown.join(', ')}`);
    }
    await page.check('#cell-only');
    const cells = await page.evaluate(() => [...window.gvdViewer.view.byLabel.values()]
      .filter((e) => e.gvdNode.visible).map((e) => e.label));
    check(JSON.stringify(cells) === JSON.stringify([label]), `only the selected cell is drawn (${cells})`);
    await page.uncheck('#cell-only');
    await page.selectOption('#ring', '1');
    await page.waitForFunction(() => window.gvdViewer.state.busy === 0 &&
                               !document.querySelector('#selected').textContent.includes('rings'));

    // 3. A path between two points picked on the GVD; the answer must be the API's.
    await page.click('#pick-path');
    for (const [a, b] of [['ball_0', 'ball_2'], ['ball_1', 'ball_3']]) {
      const p = await page.evaluate(([x, y]) => window.gvdViewer.screenPointOnGvd(x, y), [a, b]);
      check(p, `the GVD between ${a} and ${b} is visible`);
      log(`GVD point between ${a} and ${b}`);
      await page.mouse.click(p.x, p.y);
      await page.waitForTimeout(100);
    }
    await page.waitForFunction(() => window.gvdViewer.state.path !== null && window.gvdViewer.state.busy === 0,
                               null, {timeout: 10000});
    state = await page.evaluate(() => window.gvdViewer.state);
    const path = await api(base, `${job}/paths`, {
      method: 'POST', headers: {'Content-Type': 'application/json'},
      body: JSON.stringify({from: state.path.from, to: state.path.to}),
    });
    check(state.path.found === (path.status === 200), `path found in the viewer = API (${path.status})`);
    if (state.path.found) {
      check(Math.abs(state.path.length - path.body.length) <= 1e-9 * Math.max(1, path.body.length),
            'path length = API');
      log(`path of length ${state.path.length.toFixed(4)}, ${state.path.points} points`);
    } else {
      const text = await page.textContent('#path-result');
      check(text.startsWith('No path:') && text.includes(path.body.path.reason), 'the no-path reason is shown');
      log(`no path: ${state.path.reason}`);
    }

    // 4. The screenshot (the README's picture when --screenshot is given).
    await page.mouse.move(5, 5);
    await page.evaluate(() => document.getElementById('panel').scrollTo(0, 0));
    await page.waitForTimeout(300);
    const shot = join(out, 'viewer.png');
    await page.screenshot({path: shot});
    if (args.screenshot) copyFileSync(shot, args.screenshot);
    log(`screenshot ${shot}`);

    // 5. The explode slider moves the objects (and their cells) apart.
    await page.locator('#explode-slider').fill('0.5');
    state = await page.evaluate(() => window.gvdViewer.state);
    check(Math.abs(state.explode - 0.5) < 1e-9, 'the slider sets the explode fraction');
    const moved = await page.evaluate(() => [...window.gvdViewer.view.byLabel.values()]
      .filter((e) => e.node && e.node.position.length() > 0 && e.gvdNode.position.equals(e.node.position)).length);
    check(moved >= 1, `objects moved apart with their cells (${moved})`);

    await page.screenshot({path: join(out, 'viewer-exploded.png')});
    // Another anchor: the vectors of /explode?anchor=ball_0, and the anchor stays in place.
    await page.selectOption('#anchor', 'ball_0');
    await page.waitForFunction(() => window.gvdViewer.state.anchor === 'ball_0' && window.gvdViewer.state.busy === 0);
    const anchored = await page.evaluate(() => window.gvdViewer.view.byLabel.get('ball_0').node.position.length());
    check(anchored === 0, `the anchor does not move (${anchored})`);
    log('explode slider and anchor');

    // 6. A 2D scene: lines at z = 0 in an orthographic view.
    await page.setInputFiles('#files', join(args.data, 'scenes', 'gears2d.json'));
    await page.waitForFunction(() => (window.gvdViewer.state.loaded && window.gvdViewer.state.dimension === 2) ||
                               window.gvdViewer.state.error, null, {timeout: 45000});
    state = await page.evaluate(() => window.gvdViewer.state);
    check(!state.error, `no error on the 2D scene (${state.error})`);
    check(await page.evaluate(() => window.gvdViewer.view.camera.isOrthographicCamera), '2D uses an orthographic view');
    const gear = await page.evaluate(() => window.gvdViewer.screenPointOf('gear_a'));
    check(gear, 'gear_a is visible');
    await page.mouse.click(gear.x, gear.y);
    await page.waitForFunction(() => window.gvdViewer.state.selected === 'gear_a' && window.gvdViewer.state.busy === 0);
    state = await page.evaluate(() => window.gvdViewer.state);
    const gearNeighbors = (await api(base, `/v1/jobs/${state.jobId}/objects/gear_a/neighbors?ring=1`)).body.neighbors
      .map((n) => n.label).sort();
    check(JSON.stringify([...state.highlighted].sort()) === JSON.stringify(gearNeighbors), '2D neighbours = API');
    await page.screenshot({path: join(out, 'viewer-2d.png')});
    log('2D scene shown');

    // 7. Several STL files: one multipart submission, one object per file named after it.
    const stls = ['cube_a', 'cube_b', 'cube_c'].map((name, i) => {
      const file = join(out, `${name}.stl`);
      writeFileSync(file, cubeStl(name, [1.5 * i, 0, 0]));
      return file;
    });
    const previous = state.jobId;
    await page.setInputFiles('#files', stls);
    await page.waitForFunction((prev) => (window.gvdViewer.state.loaded && window.gvdViewer.state.jobId !== prev) ||
                               window.gvdViewer.state.error, previous, {timeout: 45000});
    state = await page.evaluate(() => window.gvdViewer.state);
    check(!state.error, `no error on the STL files (${state.error})`);
    check(JSON.stringify([...state.labels].sort()) === '["cube_a","cube_b","cube_c"]', `labels from file names (${state.labels})`);
    log(`3 STL files as one job: ${state.labels.join(', ')}`);

    // 8. A bad file: a readable message, not a broken page.
    await page.setInputFiles('#files', {name: 'broken.stl', mimeType: 'model/stl', buffer: Buffer.from('solid x\nfacet')});
    await page.waitForFunction(() => window.gvdViewer.state.error !== null, null, {timeout: 10000});
    const message = await page.textContent('#error-text');
    check(await page.isVisible('#error'), 'the error is shown');
    check(/Invalid scene|Unsupported/.test(message), `the message names the problem: "${message}"`);
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
