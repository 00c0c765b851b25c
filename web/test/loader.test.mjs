// SPDX-License-Identifier: Apache-2.0
// OsteonLoader as an application uses it: web/ is packed with `npm pack` (which builds dist/),
// the tarball is installed with three 0.187 into a page in a temporary folder outside the
// package, the page (test/loader_page.mjs) is bundled by esbuild (decoder files copied beside
// it, setDecoderPath) and also served unbundled under an import map (default decoder path), and
// headless Chromium loads packages made by the real `osteon pack` into the page's own three.js
// scene: the phantom (mirrored and repeated parts, levels of detail) and BodyParts3D (skipped
// without ../shared/data). Then the bad packages: each load must reject with an Error naming
// the file and the field, within its time-out, with every decoder worker terminated.
//
//   cd web && OSTEON_CLI=../build/release/osteon node --test test/loader.test.mjs
//
// Needs build/wasm (npm run build:decoder), the CLI, /usr/bin/chromium and the npm cache or
// registry (three 0.187.0). Environment: as browser_helpers.mjs (OSTEON_CLI, OSTEON_SHARED_DATA,
// OSTEON_CHROMIUM), OSTEON_WASM_DIR.

import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import http from 'node:http';
import { copyFileSync, cpSync, existsSync, mkdirSync, mkdtempSync, readFileSync, readdirSync, rmSync, unlinkSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';
import { fileURLToPath } from 'node:url';

import * as esbuild from 'esbuild';

import { chromiumPath, cli, corruptRange, dataDir, launchBrowser, osteon, repo, serve } from './browser_helpers.mjs';
import { planSpans } from '../viewer/stream.mjs';

const web = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const wasmDir = path.resolve(process.env.OSTEON_WASM_DIR ?? path.join(repo, 'build', 'wasm'));
const bonesDir = path.join(dataDir, 'aHer-dev__3DAnatomy', 'models', 'bones');
const metaJson = path.join(dataDir, 'aHer-dev__3DAnatomy', 'meta.json');

function missing() {
  if (!cli || !existsSync(cli)) return 'the osteon CLI is not built (set OSTEON_CLI or build build/release)';
  if (!existsSync(path.join(wasmDir, 'osteon_decoder.wasm'))) return `${wasmDir}/osteon_decoder.wasm is missing: run npm run build:decoder`;
  if (!existsSync(chromiumPath)) return `no browser at ${chromiumPath} (apt-get install chromium, or set OSTEON_CHROMIUM)`;
  return null;
}
const skip = missing();
if (skip) console.log(`# loader tests skipped: ${skip}`);

/// Packs `src` into site/<name> with the real CLI, data only; returns manifest.json parsed.
function packInto(site, name, inputs, extra = []) {
  const out = path.join(site, name);
  osteon('pack', ...inputs, '-o', out, '--no-viewer', ...extra);
  return JSON.parse(readFileSync(path.join(out, 'manifest.json'), 'utf8'));
}

/// A copy of package `from` as `to`, its manifest.json rewritten by `edit(json)` (the .gz copy
/// removed, so the host sends the edited text).
function editedCopy(site, from, to, edit) {
  cpSync(path.join(site, from), path.join(site, to), { recursive: true });
  const file = path.join(site, to, 'manifest.json');
  const json = JSON.parse(readFileSync(file, 'utf8'));
  edit(json);
  writeFileSync(file, typeof json === 'string' ? json : JSON.stringify(json));
  rmSync(`${file}.gz`, { force: true });
  return json;
}

/// What every load of `m` (a manifest.json) must give: per component, its instances split into
/// kept and mirrored batches (one Mesh when one instance uses it).
function expectedBatches(m) {
  const out = [];
  for (const c of m.components) {
    const uses = m.instances.filter((i) => i.component === c.id);
    if (uses.length === 1) {
      out.push({ component: c.id, type: 'Mesh', count: 1, mirror: uses[0].mirror, parts: [m.parts[uses[0].part].name] });
      continue;
    }
    for (const mirror of [false, true]) {
      const batch = uses.filter((i) => i.mirror === mirror);
      if (batch.length) out.push({ component: c.id, type: 'InstancedMesh', count: batch.length, mirror, parts: batch.map((i) => m.parts[i.part].name) });
    }
  }
  const key = (b) => `${b.component}:${b.mirror}`;
  return out.sort((a, b) => key(a).localeCompare(key(b)));
}

function batchesOf(summary) {
  const key = (b) => `${b.component}:${b.mirror}`;
  return summary.objects.map(({ component, type, count, mirror, parts }) => ({ component, type, count, mirror, parts }))
    .sort((a, b) => key(a).localeCompare(key(b)));
}

const fullTriangles = (m, id) => m.components.find((c) => c.id === id).triangles;
const coarsestTriangles = (m, id) => {
  const c = m.components.find((x) => x.id === id);
  return c.levels ? c.levels[0].triangles : c.triangles;
};

test('planSpans: one request per run of close ranges, offsets relative to the span, labels with absolute bytes', () => {
  const level = (chunk, offset, bytes, n) => ({ chunk, offset, bytes, level: n });
  const component = (id, levels) => ({ id, levels: levels.map((l, n) => ({ ...l, level: n })) });
  const manifest = {
    chunks: [{ index: 0, file: 'c/000000000000000000000000.ostc', bytes: 300 }, { index: 1, file: 'c/111111111111111111111111.ostc', bytes: 500000 }],
    components: [],
  };
  const a = component('c0', [level(0, 0, 100), level(1, 0, 1000)]);
  const b = component('c1', [level(0, 100, 200), level(1, 1100, 2000)]);
  const c = component('c2', [level(1, 400000, 50000)]);
  const d = component('c3', [level(1, 400000, 50000)]);  // the same bytes as c2: decoded once
  const first = planSpans(manifest, 'http://h/p/manifest.json', [a, b], (x) => x.levels[0]);
  assert.equal(first.length, 1);
  assert.deepEqual([first[0].start, first[0].bytes, first[0].whole, first[0].url], [0, 300, true, 'http://h/p/c/000000000000000000000000.ostc']);
  const fine = planSpans(manifest, 'http://h/p/manifest.json', [a, b, c, d], (x) => x.levels[x.levels.length - 1], 65536);
  assert.deepEqual(fine.map((s) => [s.start, s.bytes, s.whole]), [[0, 3100, false], [400000, 50000, false]]);
  assert.deepEqual(fine[0].ranges.map((r) => [r.offset, r.end]), [[0, 1000], [1100, 3100]]);
  assert.equal(fine[0].ranges[1].label, 'c/111111111111111111111111.ostc (component c1, level 2 of 2, bytes 1100-3100)');
  assert.deepEqual(fine[1].ranges.map((r) => [r.offset, r.end, r.components.map((x) => x.id)]), [[0, 50000, ['c2', 'c3']]]);
  assert.equal(fine[1].ranges[0].label, 'c/111111111111111111111111.ostc (components c2, c3, bytes 400000-450000)');
  // A smaller gap splits the first span in two.
  assert.equal(planSpans(manifest, undefined, [a, b], (x) => x.levels[1], 50).length, 2);
});

describe('OsteonLoader from the npm tarball in Chromium', { skip: skip ?? false }, () => {
  let work;
  let site;
  let server;
  let browser;
  let page;
  let phantom;      // manifest.json of site/phantom (levels of detail, small chunks)
  const problems = [];

  before(async () => {
    const t0 = performance.now();
    work = mkdtempSync(path.join(tmpdir(), 'osteon-loader-'));
    site = path.join(work, 'site');
    mkdirSync(site);
    // The package as it would be published: npm pack runs the prepack build (dist/).
    const tarball = execFileSync('npm', ['pack', '--silent', '--pack-destination', work], { cwd: web, encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] })
      .trim().split('\n').pop();
    writeFileSync(path.join(site, 'package.json'), JSON.stringify({ name: 'osteon-loader-test-page', private: true, type: 'module' }));
    execFileSync('npm', ['install', '--prefer-offline', '--no-audit', '--no-fund', '--no-package-lock', path.join(work, tarball), 'three@0.187.0'],
      { cwd: site, stdio: ['ignore', 'pipe', 'pipe'] });
    const installed = JSON.parse(readFileSync(path.join(site, 'node_modules', 'osteon', 'package.json'), 'utf8'));
    assert.equal(installed.name, 'osteon');
    const dist = path.join(site, 'node_modules', 'osteon', 'dist');
    const files = readdirSync(dist).sort();
    assert.deepEqual(files.filter((f) => !/^(element-|render-|osteon-viewer\.|decoder-worker-|sw\.js$)/.test(f)),
      ['decoder-worker.js', 'loader.d.ts', 'loader.js', 'osteon_decoder.wasm']);
    // osteon/element: its entry, and every file its bundle starts, beside it.
    assert.equal(installed.exports['./element'].import, './dist/osteon-viewer.mjs');
    const element = readFileSync(path.join(dist, 'osteon-viewer.mjs'), 'utf8').match(/element-[0-9a-f]{24}\.js/)?.[0];
    assert.ok(element && files.includes(element), `osteon-viewer.mjs re-exports ${element}`);
    const named = readFileSync(path.join(dist, element), 'utf8').match(/(render-worker|render-three|decoder-worker)-[0-9a-f]{24}\.js/g);
    assert.deepEqual([...new Set(named.map((f) => f.replace(/-[0-9a-f]+\.js$/, '')))].sort(), ['decoder-worker', 'render-three', 'render-worker']);
    for (const f of named) assert.ok(files.includes(f), `${f} is in dist/ beside the element`);

    // The bundled page: three and osteon resolved from the page's node_modules; the decoder's
    // two files hosted in decoder/ (the page says so with setDecoderPath).
    copyFileSync(path.join(web, 'test', 'loader_page.mjs'), path.join(site, 'page.mjs'));
    await esbuild.build({
      entryPoints: [path.join(site, 'page.mjs')], bundle: true, format: 'esm', target: 'es2022',
      outfile: path.join(site, 'bundle', 'page.js'), absWorkingDir: site, logLevel: 'warning',
    });
    mkdirSync(path.join(site, 'decoder'));
    for (const f of ['decoder-worker.js', 'osteon_decoder.wasm']) copyFileSync(path.join(site, 'node_modules', 'osteon', 'dist', f), path.join(site, 'decoder', f));
    writeFileSync(path.join(site, 'index.html'), '<!doctype html><meta charset="utf-8"><title>loader test</title><body style="margin:0">' +
      '<script type="module" src="bundle/page.js"></script></body>');
    // The same page unbundled: bare imports through an import map, the decoder where the package has it.
    writeFileSync(path.join(site, 'importmap.html'), '<!doctype html><meta charset="utf-8"><title>loader test</title><body style="margin:0">' +
      '<script type="importmap">{"imports": {"three": "./node_modules/three/build/three.module.js", "osteon": "./node_modules/osteon/dist/loader.js"}}</script>' +
      '<script type="module" src="page.mjs"></script></body>');

    // The phantom, with levels of detail, in chunks of at most 6 KB: several chunks, so
    // components arrive while others are on the wire. Every level of the chain is kept
    // (`--level-share 100`; the default keeps only the phantom's coarsest): chunks that hold
    // levels the finest load skips, which it then asks for by Range.
    osteon('phantom', '-o', path.join(work, 'phantom-src'));
    phantom = packInto(site, 'phantom', [path.join(work, 'phantom-src')], ['--chunk-bytes', '4000', '--level-share', '100']);
    server = await serve(site);
    browser = await launchBrowser();
    page = await browser.newPage({ viewport: { width: 600, height: 700 } });
    page.on('pageerror', (e) => problems.push(`pageerror: ${e.message}`));
    await page.goto(`${server.url}index.html`);
    await page.waitForFunction(() => window.loaderTestReady === true, null, { timeout: 10000 });
    console.log(`# setup (npm pack, install, bundle, phantom, pack, serve, browser): ${(performance.now() - t0).toFixed(0)} ms`);
  });

  after(async () => {
    await browser?.close();
    await server?.close();
    if (work) rmSync(work, { recursive: true, force: true });
  });

  test('the phantom loads progressively: named meshes, instance counts, mirrored batches, full levels at the end', async () => {
    // Streaming: the last chunk of first streams is held back until a component has been added
    // from the earlier ones (a loader that waited for every chunk would never get it).
    const firstChunks = [...new Set(phantom.components.map((c) => (c.levels ? c.levels[0].chunk : c.chunk)))].sort((a, b) => a - b);
    assert.ok(firstChunks.length >= 2, 'the phantom\'s first streams span several chunks');
    const held = phantom.chunks[firstChunks.at(-1)].file;
    let eventsBeforeRelease = -1;
    await page.route(`**/phantom/${held}`, async (route) => {
      await page.waitForFunction(() => window.loaderEvents?.some((e) => e.type === 'component'), null, { timeout: 10000 });
      eventsBeforeRelease = await page.evaluate(() => window.loaderEvents.filter((e) => e.type === 'component').length);
      await route.continue();
    });
    const s = await page.evaluate(() => window.loaderTest.load('phantom/', { decoderPath: 'decoder/', workers: 2 }));
    await page.unroute(`**/phantom/${held}`);
    assert.ok(eventsBeforeRelease > 0 && eventsBeforeRelease < phantom.components.length, `${eventsBeforeRelease} components before the last first chunk`);
    assert.deepEqual(problems, []);
    assert.equal(s.name, 'phantom');
    assert.ok(s.url.endsWith('/phantom/manifest.json'), s.url);
    assert.deepEqual(batchesOf(s), expectedBatches(phantom));
    // Every part is named on some object; a Mesh is named after its part and carries its fields.
    const named = new Set(s.objects.flatMap((o) => o.parts));
    assert.deepEqual([...named].sort(), phantom.parts.map((p) => p.name).sort());
    for (const o of s.objects.filter((x) => x.type === 'Mesh')) {
      assert.equal(o.name, o.parts[0]);
      assert.equal(o.part.name, o.name);
      const p = phantom.parts.find((x) => x.name === o.name);
      assert.equal(o.part.source, p.source);
      assert.equal(o.part.triangles, p.triangles);
    }
    // Mirrored batches: negative determinants, the kept batch's positions, a flipped index.
    const mirrored = s.objects.filter((o) => o.mirror);
    assert.ok(mirrored.length >= 2, 'the phantom has mirrored instanced parts');
    for (const o of mirrored) {
      assert.equal(o.type, 'InstancedMesh');
      assert.ok(o.dets.every((d) => d < 0), JSON.stringify(o.dets));
      assert.equal(o.name, o.parts.join(', '));
      assert.equal(o.sharesPositions, true);
      const kept = s.objects.find((x) => x.component === o.component && !x.mirror);
      assert.deepEqual(o.indices, [kept.indices[0], kept.indices[2], kept.indices[1], kept.indices[3], kept.indices[5], kept.indices[4]]);
    }
    for (const o of s.objects.filter((x) => !x.mirror)) assert.ok(o.dets.every((d) => d > 0));
    for (const o of s.objects.filter((x) => x.type === 'InstancedMesh')) assert.equal(o.name, [...new Set(o.parts)].join(', '));
    // Progressive levels: each component's coarsest level first, in stream order, then the full
    // level of those that have finer ones; every object ends at its full level.
    const comps = s.events.filter((e) => e.type === 'component');
    const withLevels = phantom.components.filter((c) => c.levels);
    assert.ok(withLevels.length > 0);
    assert.equal(comps.length, phantom.components.length + withLevels.length);
    const firstRound = comps.slice(0, phantom.components.length);
    assert.deepEqual(firstRound.map((e) => e.level), firstRound.map(() => 0));
    assert.deepEqual(firstRound.map((e) => e.component).sort(), [...phantom.stream_order].sort());
    for (const e of comps.slice(phantom.components.length)) {
      const c = phantom.components.find((x) => x.id === e.component);
      assert.equal(e.level, c.levels.length);
      assert.equal(e.final, true);
    }
    assert.deepEqual(comps.filter((e) => e.final).map((e) => e.loaded), phantom.components.map((_, i) => i + 1));
    assert.equal(s.events[0].type, 'manifest');
    assert.equal(s.events.at(-1).type, 'load');
    for (const o of s.objects) {
      assert.equal(o.level, o.levels - 1);
      assert.equal(o.triangles, fullTriangles(phantom, o.component));
    }
    // Progress: chunk bytes, growing to the total.
    assert.ok(s.progress.length >= phantom.chunks.length, `${s.progress.length} progress calls`);
    assert.ok(s.progress.every(([, , isEvent]) => isEvent));
    assert.ok(s.progress.every(([loaded], i) => i === 0 || loaded >= s.progress[i - 1][0]));
    const [loaded, total] = s.progress.at(-1);
    assert.equal(loaded, total);
    console.log(`# phantom progressive: ${s.objects.length} objects, ${comps.length} component events, ${total} chunk bytes, ${s.ms.toFixed(0)} ms`);
  });

  test('a pick names the part: the skull (a Mesh), the left femur (a mirrored instance, front-facing), a vertebra', async () => {
    for (const name of ['skull', 'femur_l', 'femur_r', 'vertebra_l2']) {
      const hit = await page.evaluate((n) => window.loaderTest.pick(n), name);
      assert.equal(hit.part, name, JSON.stringify(hit));
      assert.equal(hit.userDataPart, name);
      assert.equal(hit.front, true, `${name}: the first triangle hit from outside faces the camera`);
    }
    const mirroredHit = await page.evaluate(() => window.loaderTest.pick('femur_l'));
    assert.equal(mirroredHit.instanced, true);
    assert.equal(mirroredHit.object, 'femur_l');  // its batch, named after the one part it draws
  });

  test('drawn with front faces only, the mirrored femur is as bright as the right one (and would not be from the unflipped index)', async () => {
    const { before, after } = await page.evaluate(() => window.loaderTest.lit(['femur_l', 'femur_r'], true));
    const [l, r] = [before.femur_l, before.femur_r];
    assert.ok(l.lit > 200 && r.lit > 200, JSON.stringify(before));
    assert.ok(Math.abs(l.lit - r.lit) / r.lit < 0.15, JSON.stringify(before));
    assert.ok(Math.abs(l.luminance - r.luminance) / r.luminance < 0.15, JSON.stringify(before));
    // The control: the same batch drawn from the unflipped index shows its inside, darker.
    assert.ok(after.femur_l.luminance < 0.8 * after.femur_r.luminance, JSON.stringify(after));
    console.log(`# front faces: left femur ${l.lit} px, luminance ${l.luminance.toFixed(0)}; right ${r.lit} px, ${r.luminance.toFixed(0)}; ` +
      `left from the unflipped index: luminance ${after.femur_l.luminance.toFixed(0)}`);
  });

  test('dispose() terminates the decoder workers', async () => {
    const workers = await page.evaluate(() => window.loaderTest.dispose());
    assert.equal(workers.made, 2);
    assert.equal(workers.terminated, workers.made);
  });

  test('levels: coarsest stops at the first level; finest loads only the full ones', async () => {
    const coarse = await page.evaluate(() => window.loaderTest.load('phantom/', { decoderPath: 'decoder/', levels: 'coarsest' }));
    assert.deepEqual(batchesOf(coarse), expectedBatches(phantom));
    for (const o of coarse.objects) {
      assert.equal(o.level, 0);
      assert.equal(o.triangles, coarsestTriangles(phantom, o.component));
    }
    const firstBytes = phantom.chunks.filter((c, k) => phantom.components.some((x) => (x.levels ? x.levels[0].chunk : x.chunk) === k))
      .reduce((sum, c) => sum + c.bytes, 0);
    assert.equal(coarse.progress.at(-1)[1], firstBytes);
    await page.evaluate(() => window.loaderTest.dispose());
    const fine = await page.evaluate(() => window.loaderTest.load('phantom/', { decoderPath: 'decoder/', levels: 'finest' }));
    const comps = fine.events.filter((e) => e.type === 'component');
    assert.equal(comps.length, phantom.components.length);
    assert.ok(comps.every((e) => e.final && e.level === e.levels - 1));
    for (const o of fine.objects) assert.equal(o.triangles, fullTriangles(phantom, o.component));
    assert.equal((await page.evaluate(() => window.loaderTest.pick('femur_l'))).part, 'femur_l');
    const workers = await page.evaluate(() => window.loaderTest.dispose());
    assert.equal(workers.terminated, workers.made);
  });

  test('a host that ignores Range (200, the whole chunk) loads the full levels the same', async () => {
    editedCopy(site, 'phantom', 'norange', () => {});
    let ranged = 0;
    await page.route('**/norange/c/**', async (route) => {
      const headers = { ...route.request().headers() };
      if (headers.range) ++ranged;
      delete headers.range;
      const response = await route.fetch({ headers });
      await route.fulfill({ status: 200, body: await response.body(), headers: { 'content-type': 'application/octet-stream' } });
    });
    const s = await page.evaluate(() => window.loaderTest.load('norange/', { decoderPath: 'decoder/' }));
    await page.unroute('**/norange/c/**');
    assert.ok(ranged > 0, 'the full levels were asked for by Range');
    assert.deepEqual(batchesOf(s), expectedBatches(phantom));
    for (const o of s.objects) assert.equal(o.triangles, fullTriangles(phantom, o.component));
    assert.equal(s.progress.at(-1)[0], s.progress.at(-1)[1]);
    await page.evaluate(() => window.loaderTest.dispose());
  });

  test('a decoder hosted on another origin (CORS): the worker starts through a blob: module', async () => {
    // A second host for site/decoder/, which allows any origin.
    const cdn = http.createServer((req, res) => {
      const file = path.join(site, 'decoder', path.basename(new URL(req.url, 'http://x').pathname));
      if (!existsSync(file)) return res.writeHead(404).end();
      res.writeHead(200, {
        'Content-Type': file.endsWith('.wasm') ? 'application/wasm' : 'text/javascript',
        'Access-Control-Allow-Origin': '*',
      }).end(readFileSync(file));
    });
    await new Promise((resolve) => cdn.listen(0, '127.0.0.1', resolve));
    try {
      const origin = `http://127.0.0.1:${cdn.address().port}`;
      assert.notEqual(new URL(server.url).origin, origin);
      const s = await page.evaluate((o) => window.loaderTest.load('phantom/', { decoderPath: `${o}/decoder/`, levels: 'coarsest' }), origin);
      assert.deepEqual(batchesOf(s), expectedBatches(phantom));
      const workers = await page.evaluate(() => window.loaderTest.dispose());
      assert.equal(workers.terminated, workers.made);
    } finally {
      await new Promise((resolve) => cdn.close(resolve));
    }
  });

  test('the unbundled page (import map, the decoder found beside the module) loads and picks the same', async () => {
    const other = await browser.newPage({ viewport: { width: 600, height: 700 } });
    const errors = [];
    other.on('pageerror', (e) => errors.push(e.message));
    await other.goto(`${server.url}importmap.html`);
    await other.waitForFunction(() => window.loaderTestReady === true, null, { timeout: 10000 });
    const s = await other.evaluate(() => window.loaderTest.load('phantom/manifest.json'));
    assert.deepEqual(batchesOf(s), expectedBatches(phantom));
    assert.equal((await other.evaluate(() => window.loaderTest.pick('femur_l'))).part, 'femur_l');
    assert.deepEqual(errors, []);
    await other.close();
  });

  test('BodyParts3D (235 bones) loads, names its bones, and a pick on the forehead names a skull bone', {
    skip: existsSync(bonesDir) ? false : `no real data at ${bonesDir}`,
  }, async () => {
    const m = packInto(site, 'bodyparts3d', [bonesDir], ['--names', metaJson]);
    const s = await page.evaluate(() => window.loaderTest.load('bodyparts3d/', { decoderPath: 'decoder/' }));
    assert.deepEqual(batchesOf(s), expectedBatches(m));
    assert.equal(new Set(s.objects.flatMap((o) => o.parts)).size, 235);
    const meshes = s.objects.filter((o) => o.part);
    assert.ok(meshes.some((o) => o.part.displayName === 'Frontal bone'));
    for (const o of s.objects) assert.equal(o.triangles, fullTriangles(m, o.component));
    const hit = await page.evaluate(() => window.loaderTest.pick('Frontal bone'));
    assert.match(hit.displayName, /frontal|parietal|nasal|ethmoid|sphenoid/i, JSON.stringify(hit));
    assert.equal(hit.front, true);
    console.log(`# BodyParts3D progressive: ${s.objects.length} objects, ${s.progress.at(-1)[1]} chunk bytes, ${s.ms.toFixed(0)} ms; pick: ${hit.displayName}`);
    await page.evaluate(() => window.loaderTest.dispose());
  });

  describe('bad packages reject with the file and the field, and free the workers', () => {
    /// Loads `url` in the page (expecting failure); checks the message and the workers.
    async function expectFailure(url, pattern, options = { decoderPath: 'decoder/' }, within = 10000) {
      const r = await page.evaluate(([u, o]) => window.loaderTest.fail(u, o), [url, options]);
      assert.ok(!r.loaded, `${url} loaded`);
      assert.equal(r.isError, true);
      assert.match(r.message, /^osteon: /);
      assert.match(r.message, pattern);
      assert.ok(r.ms < within, `${url}: failed after ${r.ms} ms`);
      assert.equal(r.workers.terminated, r.workers.made, `${url}: workers left running: ${JSON.stringify(r.workers)}`);
      console.log(`# ${r.message.replace(server.url, '/')} (after ${r.ms.toFixed(0)} ms)`);
      return r;
    }

    test('a wrong URL', async () => {
      await expectFailure('nowhere/', /nowhere\/manifest\.json: HTTP 404/);
    });

    test('a manifest that is not JSON', async () => {
      mkdirSync(path.join(site, 'notjson'));
      writeFileSync(path.join(site, 'notjson', 'manifest.json'), '{"format": "osteon-package", "version": 3,');
      await expectFailure('notjson/', /notjson\/manifest\.json: not JSON/);
    });

    test('hostile manifests: a bad field, a chunk outside the package, a stream too large to allocate', async () => {
      editedCopy(site, 'phantom', 'badproto', (j) => { j.parts[3].prototype = 99; });
      await expectFailure('badproto/', /badproto\/manifest\.json: parts\[3\]\.prototype: no part 99/);
      editedCopy(site, 'phantom', 'badfile', (j) => { j.chunks[0].file = '../../../etc/passwd'; });
      await expectFailure('badfile/', /badfile\/manifest\.json: chunks\[0\]\.file: expected "c\//);
      editedCopy(site, 'phantom', 'huge', (j) => {
        const c = j.components[0];
        const k = c.levels ? c.levels[0].chunk : c.chunk;
        j.chunks[k].bytes = 2 ** 40;
        (c.levels ? c.levels[0] : c).bytes = 2 ** 40 - (c.levels ? c.levels[0].offset : c.offset);
      });
      await expectFailure('huge/', /huge\/manifest\.json: components\[0\]\.(levels\[0\]\.)?bytes: \d+ bytes, more than/);
    });

    test('a corrupt chunk: the checksum names the chunk file, the component and its bytes', async () => {
      const m = editedCopy(site, 'phantom', 'corrupt', () => {});
      const c = m.components.find((x) => x.id === m.stream_order[1]);
      const first = c.levels ? c.levels[0] : c;
      corruptRange(path.join(site, 'corrupt', m.chunks[first.chunk].file), first.offset, first.bytes);
      const r = await expectFailure('corrupt/', new RegExp(`${m.chunks[first.chunk].file.replace('.', '\\.')} \\(components? [^)]*${c.id}[^)]*bytes ${first.offset}-${first.offset + first.bytes}\\)`));
      assert.match(r.message, /checksum/);
    });

    test('a missing chunk file', async () => {
      const m = editedCopy(site, 'phantom', 'nochunk', () => {});
      unlinkSync(path.join(site, 'nochunk', m.chunks[0].file));
      await expectFailure('nochunk/', new RegExp(`${m.chunks[0].file.replace('.', '\\.')} .*HTTP 404`));
    });

    test('a host that never answers: the time-out names the chunk', async () => {
      editedCopy(site, 'phantom', 'stall', () => {});
      const held = [];
      await page.route('**/stall/c/**', (route) => { held.push(route); });  // never answered
      const r = await expectFailure('stall/', /stall\/c\/[0-9a-f]{24}\.ostc: no data for 1 s \(timeout\)/, { decoderPath: 'decoder/', timeout: 1000 }, 5000);
      assert.ok(r.ms >= 1000, `${r.ms} ms`);
      await page.unroute('**/stall/c/**');
    });

    test('a wrong decoder path, and a decoder worker that is not there', async () => {
      await expectFailure('phantom/', /nodecoder\/osteon_decoder\.wasm: HTTP 404/, { decoderPath: 'nodecoder/' });
      mkdirSync(path.join(site, 'wasmonly'));
      copyFileSync(path.join(site, 'decoder', 'osteon_decoder.wasm'), path.join(site, 'wasmonly', 'osteon_decoder.wasm'));
      await expectFailure('phantom/', /wasmonly\/decoder-worker\.js: the decoder worker failed/, { decoderPath: 'wasmonly/' });
    });

    test('one loader, loads at once: a bad package fails alone, the good ones load; abort() ends a load', async () => {
      const r = await page.evaluate(() => window.loaderTest.concurrent(['phantom/', 'nochunk/', 'phantom/manifest.json'], { decoderPath: 'decoder/', workers: 2 }));
      assert.deepEqual(r.results.map((x) => x.ok), [true, false, true], JSON.stringify(r.results));
      assert.equal(r.results[0].parts, phantom.parts.length);
      assert.match(r.results[1].message, /nochunk\/c\/[0-9a-f]{24}\.ostc .*HTTP 404/);
      assert.equal(r.afterLoads.made, 2, 'the loads shared one pool of two workers');
      assert.equal(r.workers.terminated, r.workers.made);
      const a = await page.evaluate(() => window.loaderTest.abortAfterFirst('phantom/', { decoderPath: 'decoder/' }));
      assert.match(a.message, /phantom\/manifest\.json: aborted$/);
      assert.ok(a.objects > 0 && a.objects < 11, `${a.objects} objects when aborted`);
      assert.equal(a.workers.terminated, a.workers.made);
    });

    test('no page errors', () => {
      assert.deepEqual(problems, []);
    });
  });
});
