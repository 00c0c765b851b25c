// SPDX-License-Identifier: Apache-2.0
// The <osteon-viewer> element on a page of its own: a page outside the package folders (embed/),
// importing the built element from a folder of its own (lib/, a copy of build/viewer without its
// index.html), embeds two viewers side by side on two different packages (the phantom packed
// without levels and with repeats; a finer phantom of another seed, with levels and without
// repeats). Both must load and draw in their own boxes, report their own counts, answer a click
// with a 'select' event of their own, and the methods of one must leave the other as it was. The
// page holds no viewer globals.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/element.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { cpSync, mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import { countForeground, launchBrowser, missingPrerequisite, osteon, pack, serve, viewerDir } from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# element browser tests skipped: ${skip}`);

const kPage = `<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>two viewers</title>
<link rel="icon" href="data:,">
<style>
  body { margin: 0; display: flex; gap: 20px; padding: 20px; background: #fff; }
  osteon-viewer { width: 600px; height: 560px; }
</style>
<script type="module">
  import '../lib/osteon-viewer.mjs';
  window.__events = [];
  for (const el of document.querySelectorAll('osteon-viewer')) {
    for (const type of ['load', 'progress', 'select']) {
      el.addEventListener(type, (e) => window.__events.push({ viewer: el.id, type, detail: e.detail }));
    }
  }
</script>
</head>
<body>
<osteon-viewer id="a" src="../a/"></osteon-viewer>
<osteon-viewer id="b" src="../b/manifest.json" background="#304050" panel="off" budget-mb="64"></osteon-viewer>
</body>
</html>
`;

/// The plain fields of viewer `id`'s report.
function reportOf(page, id) {
  return page.evaluate((i) => JSON.parse(JSON.stringify(document.getElementById(i).report)), id);
}

/// Waits until viewer `id` has drawn every change asked of it and its frame counter stops moving
/// over two animation frames (browser_helpers.mjs settle, for an element's report).
async function settleViewer(page, id) {
  let frames = -1;
  for (let i = 0; i < 50; ++i) {
    await page.waitForFunction((v) => !document.getElementById(v).report.framePending, id, { timeout: 10000 });
    const now = await page.evaluate((v) => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(() => {
      const r = document.getElementById(v).report;
      resolve(r.framePending ? -1 : r.frames);
    }))), id);
    if (now === frames && now >= 0) return;
    frames = now;
  }
}

describe('<osteon-viewer> elements, two on a page', { skip: skip ?? false }, () => {
  let work;
  let server;
  let browser;
  let a;
  let b;

  before(async () => {
    work = mkdtempSync(path.join(tmpdir(), 'osteon-element-'));
    const site = path.join(work, 'site');
    osteon('phantom', '-o', path.join(work, 'phantom-a'));
    osteon('phantom', '--detail', '2', '--seed', '7', '-o', path.join(work, 'phantom-b'));
    a = pack([path.join(work, 'phantom-a')], path.join(site, 'a'), ['--chunk-bytes', '6000', '--no-lod']);
    b = pack([path.join(work, 'phantom-b')], path.join(site, 'b'), ['--no-repeats']);
    // The element's files, apart from the packages and their pages.
    cpSync(viewerDir, path.join(site, 'lib'), { recursive: true, filter: (f) => !/index\.html/.test(path.basename(f)) });
    mkdirSync(path.join(site, 'embed'));
    writeFileSync(path.join(site, 'embed', 'index.html'), kPage);
    server = await serve(site);
    browser = await launchBrowser();
  });

  after(async () => {
    await browser?.close();
    await server?.close();
    if (work) rmSync(work, { recursive: true, force: true });
  });

  test('both load their own package, draw in their own box and answer their own clicks and methods', async () => {
    assert.notEqual(a.components.length, b.components.length, 'the two packages differ');
    const context = await browser.newContext({ viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 });
    const page = await context.newPage();
    const problems = [];
    page.on('pageerror', (e) => problems.push(`pageerror: ${e.message}`));
    page.on('console', (m) => m.type() === 'error' && problems.push(`console: ${m.text()}`));
    await page.goto(`${server.url}embed/`);
    await page.waitForFunction(() => [...document.querySelectorAll('osteon-viewer')].every((el) => el.report?.done === true), null, { timeout: 60000 });
    for (const id of ['a', 'b']) await settleViewer(page, id);

    const ra = await reportOf(page, 'a');
    const rb = await reportOf(page, 'b');
    for (const [r, m, name] of [[ra, a, 'a'], [rb, b, 'b']]) {
      assert.deepEqual(r.errors, [], name);
      assert.equal(r.renderer, 'worker', name);
      assert.equal(r.componentsTotal, m.components.length, name);
      assert.equal(r.componentsLoaded, m.components.length, name);
      assert.equal(r.instancesTotal, m.instances.length, name);
      assert.equal(r.instancesDrawn, m.instances.length, name);
      assert.equal(r.chunksTotal, m.chunks.length, name);
      assert.ok(r.firstFrameMs > 0, name);
    }
    assert.equal(ra.background, '#1c2027');
    assert.equal(rb.background, '#304050');
    assert.equal(rb.budget.bytes, 64e6, 'budget-mb');
    // Each element's own load event, and progress events with its own counts.
    const events = await page.evaluate(() => window.__events);
    for (const [id, m] of [['a', a], ['b', b]]) {
      const loads = events.filter((e) => e.viewer === id && e.type === 'load');
      assert.equal(loads.length, 1, `${id}: one load event`);
      assert.equal(loads[0].detail.componentsLoaded, m.components.length);
      const progress = events.filter((e) => e.viewer === id && e.type === 'progress');
      assert.ok(progress.length >= 1 && progress.every((e) => e.detail.componentsTotal === m.components.length), `${id}: progress events`);
    }
    // No page globals: each viewer is reached through its element only.
    assert.deepEqual(await page.evaluate(() => [typeof window.osteon, typeof window.osteonBoot]), ['undefined', 'undefined']);

    // Side by side, each drawn inside its own box.
    const boxA = await page.locator('#a').boundingBox();
    const boxB = await page.locator('#b').boundingBox();
    assert.ok(boxA.x + boxA.width <= boxB.x, JSON.stringify({ boxA, boxB }));
    const shot = await page.screenshot();
    const origin = { x: 0, y: 0 };
    const canvasOf = async (id) => page.locator(`#${id}`).locator('#canvas').boundingBox();
    const [canvasA, canvasB] = [await canvasOf('a'), await canvasOf('b')];
    const boundsA = await page.evaluate(() => document.getElementById('a').report.screenBoundsOf());
    const boundsB = await page.evaluate(() => document.getElementById('b').report.screenBoundsOf());
    for (const [bounds, canvas] of [[boundsA, canvasA], [boundsB, canvasB]]) {
      assert.ok(bounds.left >= canvas.x - 1 && bounds.right <= canvas.x + canvas.width + 1, JSON.stringify({ bounds, canvas }));
    }
    const [inA, inB] = await countForeground(context, shot, origin, [boundsA, boundsB], '#1c2027');
    const [inB2] = await countForeground(context, shot, origin, [boundsB], '#304050');
    console.log(`# two viewers: ${(100 * inA.fraction).toFixed(1)}% and ${(100 * inB2.fraction).toFixed(1)}% of their skeletons' boxes are bone`);
    assert.ok(inA.fraction > 0.08, `a: ${(100 * inA.fraction).toFixed(1)}% bone`);
    assert.ok(inB2.fraction > 0.08, `b: ${(100 * inB2.fraction).toFixed(1)}% bone`);
    assert.ok(inB.fraction > 0.9, 'b is drawn on its own background colour, not a\'s');
    // b's panel is off: its view takes the whole element. a is narrower than 720 px: its panel
    // is under its view (the layout follows the element's width, not the window's).
    assert.equal(await page.locator('#b').locator('#panel').isVisible(), false);
    assert.ok(Math.abs(canvasB.width - boxB.width) <= 1 && Math.abs(canvasB.height - boxB.height) <= 1, JSON.stringify({ canvasB, boxB }));
    const panelA = await page.locator('#a').locator('#panel').boundingBox();
    assert.ok(canvasA.width === boxA.width && panelA.y >= canvasA.y + canvasA.height - 1, JSON.stringify({ canvasA, panelA }));

    // A click on each skull selects it in that viewer alone, with its own 'select' event.
    for (const [id, other] of [['a', 'b'], ['b', 'a']]) {
      const at = await page.evaluate((i) => document.getElementById(i).report.screenPositionOf('skull'), id);
      await page.evaluate(() => { window.__events = []; });
      await page.mouse.click(at.x, at.y);
      await page.waitForFunction((i) => document.getElementById(i).report.selected === 'skull', id);
      const selects = (await page.evaluate(() => window.__events)).filter((e) => e.type === 'select');
      assert.deepEqual(selects.map((e) => [e.viewer, e.detail.name]), [[id, 'skull']]);
      assert.equal(typeof selects[0].detail.part, 'number');
      assert.equal(await page.locator(`#${id}`).locator('#info-name').textContent(), 'skull');
      if (id === 'a') assert.equal((await reportOf(page, other)).selected, null, 'the other viewer is not selected');
    }

    // Methods act on their own element.
    const femurA = a.parts.find((p) => p.display_name === 'femur_l');
    assert.equal(await page.evaluate(() => document.getElementById('a').hide('femur_l')), true);
    assert.equal((await reportOf(page, 'a')).instancesDrawn, a.instances.length - 1);
    assert.equal((await reportOf(page, 'a')).trianglesDrawn, ra.trianglesDrawn - femurA.triangles);
    assert.equal((await reportOf(page, 'b')).instancesDrawn, b.instances.length);
    assert.equal(await page.evaluate(() => document.getElementById('b').isolate('pelvis')), true);
    assert.equal((await reportOf(page, 'b')).instancesDrawn, 1);
    assert.equal((await reportOf(page, 'a')).instancesDrawn, a.instances.length - 1);
    assert.equal(await page.evaluate(() => document.getElementById('a').select(null)), true);
    assert.equal((await reportOf(page, 'a')).selected, null);
    assert.equal((await reportOf(page, 'b')).selected, 'skull');
    assert.equal(await page.evaluate(() => document.getElementById('a').hide('no such bone')), false);
    await page.evaluate(() => document.getElementById('a').showAll());
    assert.equal((await reportOf(page, 'a')).instancesDrawn, a.instances.length);
    assert.equal((await reportOf(page, 'b')).instancesDrawn, 1);
    await page.evaluate(() => document.getElementById('b').show('skull'));
    assert.equal((await reportOf(page, 'b')).instancesDrawn, 2);

    // The camera attribute moves that viewer's camera alone; a bad one is named, not applied.
    // (The orbit controls' update moves the camera by a rounding error.)
    const near = (u, v) => u.every((x, i) => Math.abs(x - v[i]) < 1e-6);
    const cameraB = await page.evaluate(() => document.getElementById('b').report.cameraState());
    await page.evaluate(() => document.getElementById('a').setAttribute('camera', '10,-2000,900,5,0,950'));
    const cameraA = await page.evaluate(() => document.getElementById('a').report.cameraState());
    assert.ok(near(cameraA.position, [10, -2000, 900]) && near(cameraA.target, [5, 0, 950]), JSON.stringify(cameraA));
    const cameraB2 = await page.evaluate(() => document.getElementById('b').report.cameraState());
    assert.ok(near(cameraB2.position, cameraB.position) && near(cameraB2.target, cameraB.target), 'b\'s camera stays');
    await page.evaluate(() => document.getElementById('a').setAttribute('camera', '1,2,3'));
    assert.ok(near((await page.evaluate(() => document.getElementById('a').report.cameraState())).position, [10, -2000, 900]));
    assert.match((await reportOf(page, 'a')).errors.join('\n'), /^osteon: view: camera "1,2,3": expected 6, 9 or 10/);

    // A new src starts that element over on the other package; the first keeps its own.
    await page.evaluate(() => document.getElementById('b').setAttribute('src', '../a/'));
    await page.waitForFunction(() => document.getElementById('b').report?.done === true && document.getElementById('b').report.componentsTotal > 0, null, { timeout: 60000 });
    const rb2 = await reportOf(page, 'b');
    assert.equal(rb2.componentsLoaded, a.components.length);
    assert.deepEqual(rb2.errors, []);
    assert.equal((await reportOf(page, 'a')).instancesDrawn, a.instances.length);
    assert.deepEqual(problems, []);
    await context.close();
  });
});
