// SPDX-License-Identifier: Apache-2.0
// The viewer in a real browser: packages made by the real `osteon pack`, served by the real
// `osteon serve` under a path prefix (/phantom/, /bodyparts3d/, ...), loaded by Debian's Chromium
// headless with WebGL on SwiftShader. Each test reads window.osteon (the viewer's state), clicks
// and taps like a person, and checks screenshots pixel by pixel. Screenshots are kept in
// build/test-artifacts/viewer/ for a person to look at.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon npm run test:browser
//
// Environment: see browser_helpers.mjs (OSTEON_CLI, OSTEON_VIEWER_DIR, OSTEON_SHARED_DATA,
// OSTEON_CHROMIUM). The BodyParts3D test skips when the real data is absent; everything else runs
// on the generated phantom skeleton (`osteon phantom`): packed without levels of detail and
// rewritten as version 2 (the format before levels) for the loading, renderer and phone tests,
// which must work as they always did; packed denser and with levels for the refinement tests.

import assert from 'node:assert/strict';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, unlinkSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import {
  artifacts,
  asVersion2,
  chunkFiles,
  corruptRange,
  countDiffering,
  countForeground,
  dataDir,
  launchBrowser,
  missingPrerequisite,
  observeLongTasks,
  openViewer,
  osteon,
  pack,
  serve,
  settle,
  shootCanvas,
  totalBlockingTime,
  waitLoaded,
  waitRefined,
} from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# viewer browser tests skipped: ${skip}`);
const bonesDir = path.join(dataDir, 'aHer-dev__3DAnatomy', 'models', 'bones');
const metaJson = path.join(dataDir, 'aHer-dev__3DAnatomy', 'meta.json');
const ontologyDir = path.join(dataDir, 'BodyParts3D-FMA');
const ctSeg = path.join(dataDir, 'wasserth__TotalSegmentator', 'tests', 'reference_files', 'example_seg.nii.gz');
const kDesktop = { viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 };
const kPhone = { viewport: { width: 390, height: 844 }, deviceScaleFactor: 1, isMobile: true, hasTouch: true };

/// Reads window.osteon's plain fields.
function readState(page) {
  return page.evaluate(() => {
    const { screenPositionOf, screenBoundsOf, select, frame, ...plain } = window.osteon;
    return JSON.parse(JSON.stringify(plain));
  });
}

/// The triangles drawn when every instance of `m` (a manifest.json) whose part `shown(part)` is
/// drawn at the level `levelDrawn` (window.osteon's) names for its component.
/// Holds three.js's code (which the render worker fetches) back on its way in `context` until the
/// returned function is called: the first frames draw meanwhile.
async function holdThree(context) {
  let release;
  const held = new Promise((resolve) => { release = resolve; });
  await context.route(/\/render-three-[0-9a-f]+\.js$/, async (route) => {
    await held;
    await route.continue();
  });
  return release;
}

function trianglesAtLevels(m, levelDrawn, shown = () => true) {
  const byId = new Map(m.components.map((c) => [c.id, c]));
  return m.instances.filter((i) => shown(i.part)).reduce((sum, i) => {
    const c = byId.get(i.component);
    const levels = [...(c.levels ?? []), { triangles: c.triangles }];
    return sum + levels[levelDrawn[i.component] ?? 0].triangles;
  }, 0);
}

/// Each chunk's fetch as [start, end], from the viewer's per-component fetch log (a chunk's fetch
/// starts once for all its components and ends with its last component's bytes).
function chunkFetches(log) {
  const chunks = new Map();
  for (const e of log) {
    const [start, end] = chunks.get(e.chunk) ?? [e.fetchStart, e.fetchEnd];
    chunks.set(e.chunk, [Math.min(start, e.fetchStart), Math.max(end, e.fetchEnd)]);
  }
  return [...chunks.values()];
}

/// The most chunk fetches that were in flight at once.
function maxInFlight(log) {
  const fetches = chunkFetches(log);
  return Math.max(...fetches.map(([s]) => fetches.filter(([a, b]) => a <= s && s < b).length));
}

describe('osteon viewer in Chromium', { skip: skip ?? false }, () => {
  let work;
  let site;
  let server;
  let browser;
  let phantomManifest;
  let lodManifest;

  /// The dense phantom (detail 4: 16,000 triangles a bone, up to four levels each), packed with
  /// levels of detail in 20 KB chunks, served at lod/; made once, for the tests that need it.
  /// Every level of the chain is kept (`--level-share 100`): the phantom's smooth bones cost so
  /// little at full resolution that the default share keeps only their coarsest, and these tests
  /// refine through the levels between.
  function lodPackage() {
    if (!lodManifest) {
      osteon('phantom', '--detail', '4', '-o', path.join(work, 'phantom-dense'));
      lodManifest = pack([path.join(work, 'phantom-dense')], path.join(site, 'lod'), ['--chunk-bytes', '20000', '--level-share', '100']);
    }
    return lodManifest;
  }

  before(async () => {
    work = mkdtempSync(path.join(tmpdir(), 'osteon-viewer-'));
    site = path.join(work, 'site');
    mkdirSync(site);
    osteon('phantom', '-o', path.join(work, 'phantom-src'));
    // Chunks of at most 6 KB: the phantom's 18 KB come in several. No levels, and version 2: the
    // format as it was before levels of detail loads as it did.
    pack([path.join(work, 'phantom-src')], path.join(site, 'phantom'), ['--chunk-bytes', '6000', '--no-lod']);
    phantomManifest = asVersion2(path.join(site, 'phantom'));
    server = await serve(site);
    browser = await launchBrowser();
  });

  after(async () => {
    await browser?.close();
    await server?.close();
    if (work) rmSync(work, { recursive: true, force: true });
  });

  test('the phantom skeleton streams in component by component, fills the view and picks bones', async () => {
    const context = await browser.newContext(kDesktop);
    await observeLongTasks(context);
    // A slow connection (100 kB/s, 20 ms latency), so that streaming shows: the first bone must be
    // on screen while later chunks are still downloading.
    // The last chunk is held back until the first bone is on screen, so that whatever the speed of
    // this machine, the test sees the skeleton drawn while a chunk is still on its way.
    const m = phantomManifest;
    const lastChunk = m.chunks[m.chunks.length - 1].file;
    const { page, problems } = await openViewer(context, `${server.url}phantom/`, async (p) => {
      const cdp = await context.newCDPSession(p);
      await cdp.send('Network.enable');
      await cdp.send('Network.emulateNetworkConditions', {
        offline: false, latency: 20, downloadThroughput: 100_000, uploadThroughput: 100_000,
      });
      await p.route(`**/phantom/${lastChunk}`, async (route) => {
        await p.waitForFunction(() => window.osteon?.firstComponentMs !== null, null, { timeout: 30000 }).catch(() => {});
        await route.continue();
      });
    });
    const state = await waitLoaded(page);

    assert.deepEqual(state.errors, []);
    assert.equal(state.componentsTotal, m.components.length);
    assert.equal(state.componentsLoaded, m.components.length);
    assert.equal(state.componentsFailed, 0);
    assert.equal(state.instancesDrawn, m.instances.length);
    assert.equal(state.trianglesDrawn, m.parts.reduce((s, p) => s + p.triangles, 0));
    assert.ok(m.instances.length > m.components.length, 'the phantom has repeated bones (instances)');
    assert.ok(state.drawCalls < m.instances.length, `${state.drawCalls} draw calls for ${m.instances.length} instances: repeats are GPU-instanced`);

    // Drawn by the render worker; the chunks fetched in order, at most 2 at a time, each file
    // once; every component's log in stream_order; drawn progressively.
    assert.equal(state.renderer, 'worker');
    assert.ok(m.chunks.length >= 3, `${m.chunks.length} chunks`);
    const log = state.fetchLog;
    assert.deepEqual(log.map((e) => e.id), m.stream_order);
    const byId = new Map(m.components.map((c) => [c.id, c]));
    for (const e of log) {
      assert.equal(e.chunk, byId.get(e.id).chunk);
      assert.equal(e.file, m.chunks[e.chunk].file);
      assert.ok(e.fetchStart <= e.fetchEnd && e.fetchEnd <= e.decodedAt && e.decodedAt <= e.addedAt, JSON.stringify(e));
    }
    const starts = chunkFetches(log).map(([start]) => start);
    assert.deepEqual([...starts].sort((a, b) => a - b), starts, 'chunks fetched in the manifest\'s order');
    assert.ok(maxInFlight(log) <= 2, `${maxInFlight(log)} chunk fetches in flight`);
    const served = server.requests.filter((r) => /^GET \/phantom\/c\/[0-9a-f]{24}\.ostc 200/.test(r));
    assert.equal(served.length, m.chunks.length, served.join('\n'));
    const firstAdded = Math.min(...log.map((e) => e.addedAt));
    const lastFetched = Math.max(...log.map((e) => e.fetchEnd));
    assert.ok(state.firstComponentMs < state.allLoadedMs, `first ${state.firstComponentMs} ms, all ${state.allLoadedMs} ms`);
    assert.equal(firstAdded, state.firstComponentMs);
    assert.ok(firstAdded < lastFetched, `first component drawn at ${firstAdded} ms, last chunk ended ${lastFetched} ms`);
    const tbt = await totalBlockingTime(page, state.allLoadedMs);
    console.log(`# phantom at 100 kB/s: first component ${state.firstComponentMs.toFixed(0)} ms, all ${state.allLoadedMs.toFixed(0)} ms ` +
      `after navigation; main-thread blocking ${tbt.toFixed(0)} ms; renderer ${JSON.stringify(state.timings)}`);

    // Fitted to view: the package's box projects inside the canvas and fills most of its height.
    const { png, box } = await shootCanvas(page, 'phantom');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    assert.ok(bounds.left >= box.x - 1 && bounds.right <= box.x + box.width + 1, JSON.stringify({ bounds, box }));
    assert.ok(bounds.top >= box.y - 1 && bounds.bottom <= box.y + box.height + 1, JSON.stringify({ bounds, box }));
    assert.ok(bounds.bottom - bounds.top > 0.7 * box.height, 'the skeleton fills the view\'s height');
    const inside = await countForeground(context, png, box, bounds, state.background);
    const all = await countForeground(context, png, box, { left: box.x, top: box.y, right: box.x + box.width, bottom: box.y + box.height }, state.background);
    console.log(`# phantom screenshot: ${(100 * inside.fraction).toFixed(1)}% of the skeleton's box is bone`);
    assert.ok(inside.fraction > 0.08, `only ${(100 * inside.fraction).toFixed(1)}% of the box differs from the background`);
    // Nothing drawn outside the box (the overlays are hidden in the screenshot).
    assert.ok(all.differing - inside.differing < 0.01 * (all.pixels - inside.pixels), 'bone drawn outside the package bounds');

    // Upright: the skull above the pelvis above the femurs.
    const at = (name) => page.evaluate((n) => window.osteon.screenPositionOf(n), name);
    const skull = await at('skull');
    assert.ok(skull.y < (await at('pelvis')).y && (await at('pelvis')).y < (await at('femur_r')).y, 'the skeleton is upright');

    // Click the skull.
    await page.mouse.click(skull.x, skull.y);
    await page.waitForFunction(() => document.querySelector('osteon-viewer').shadowRoot.querySelector('#info-name').textContent === 'skull');
    assert.equal((await readState(page)).selected, 'skull');
    assert.match(await page.locator('#info-drawn').textContent(), /its own mesh/);
    assert.match(await page.locator('#info-error').textContent(), / mm$/);

    // Click the left femur: a mirrored copy of the right one, drawn by the mirrored InstancedMesh.
    const femur = await at('femur_l');
    await page.mouse.click(femur.x, femur.y);
    await page.waitForFunction(() => document.querySelector('osteon-viewer').shadowRoot.querySelector('#info-name').textContent === 'femur_l');
    assert.equal(await page.locator('#info').getAttribute('data-instance'), 'true');
    assert.equal(await page.locator('#info').getAttribute('data-gpu-instanced'), 'true');
    assert.match(await page.locator('#info-drawn').textContent(), /instance of femur_r, mirrored/);
    await settle(page);
    await shootCanvas(page, 'phantom-femur-selected');

    // Click the background: nothing selected.
    await page.mouse.click(box.x + 10, box.y + box.height - 10);
    await page.waitForFunction(() => window.osteon.selected === null);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('the BodyParts3D skeleton (235 bones) loads, renders upright and a click on the head names a skull bone', {
    skip: existsSync(bonesDir) ? false : `no real data at ${bonesDir}`,
  }, async () => {
    const out = path.join(site, 'bodyparts3d');
    const regions = existsSync(path.join(ontologyDir, 'conventional_part_of.txt')) ? ['--regions', `fma:${ontologyDir}`] : [];
    const m = pack([bonesDir], out, ['--names', metaJson, ...regions]);
    assert.equal(m.version, 3);
    const firstChunks = new Set(m.components.map((c) => (c.levels ? c.levels[0].chunk : c.chunk)));
    const firstBytes = [...firstChunks].reduce((sum, k) => sum + m.chunks[k].bytes, 0);
    assert.equal(m.parts.length, 235);
    const skullBones = new Set(JSON.parse(readFileSync(metaJson, 'utf8'))
      .map((e) => e.label)
      .filter((l) => /frontal|parietal|occipital|temporal|sphenoid|ethmoid|nasal|lacrimal|zygomatic|maxilla|palatine|vomer|mandible/i.test(l)));
    assert.ok(skullBones.has('Frontal bone') && skullBones.has('Occipital bone'));

    const context = await browser.newContext(kDesktop);
    await observeLongTasks(context);
    const { page, problems } = await openViewer(context, `${server.url}bodyparts3d/`);
    await waitLoaded(page);
    // Every bone at its coarsest level first, from the first chunks alone; then refined for the view.
    const state = await waitRefined(page);
    assert.deepEqual(state.errors, []);
    assert.equal(state.renderer, 'worker');
    assert.equal(state.componentsLoaded, m.components.length);
    assert.equal(state.componentsTotal, m.components.length);
    assert.equal(state.instancesDrawn, m.instances.length);
    assert.equal(state.trianglesDrawn, trianglesAtLevels(m, state.levelDrawn));
    assert.equal(state.bytesAtSkeletonComplete, firstBytes);
    assert.ok(state.refinedMs !== null && state.firstRefinedMs >= state.skeletonCompleteMs, JSON.stringify([state.skeletonCompleteMs, state.refinedMs]));
    const levelsDrawn = Object.values(state.levelDrawn);
    console.log(`# BodyParts3D with levels: skeleton complete at ${state.skeletonCompleteMs.toFixed(0)} ms after ${firstBytes} of ${state.bytesTotal} bytes ` +
      `(${(100 * firstBytes / state.bytesTotal).toFixed(0)}%); refined at ${state.firstRefinedMs.toFixed(0)} ms after ${state.bytesLoaded} bytes, ` +
      `${state.levelLog.length} level fetches; ${state.trianglesDrawn} of ${m.parts.reduce((s, p) => s + p.triangles, 0)} triangles drawn; ` +
      `${levelsDrawn.filter((l) => l > 0).length} of ${levelsDrawn.length} components above their coarsest level; GPU ${(state.gpuBytes / 1e6).toFixed(1)} MB`);
    assert.equal(await page.locator('#part-list li').count(), 235);
    if (regions.length) {
      // The regions from BodyParts3D's ontology: the tree's regions, with counts adding up to 235.
      const items = await page.locator('#region-tree [role="treeitem"][aria-level="2"]').evaluateAll((lis) =>
        lis.map((li) => ({ name: li.querySelector('.node-name')?.textContent ?? li.textContent, count: Number(li.dataset.count) })));
      assert.ok(items.length >= 6, JSON.stringify(items));
      assert.equal(items.reduce((sum, i) => sum + i.count, 0), 235, JSON.stringify(items));
      await page.locator('#color-by').selectOption('region');
      await settle(page);
      await shootCanvas(page, 'bodyparts3d-colour-by-region');
      await page.locator('#color-by').selectOption('part');
      await settle(page);
    }
    const tbt = await totalBlockingTime(page, state.allLoadedMs);
    console.log(`# BodyParts3D (${m.components.length} components in ${m.chunks.length} chunks, ${(state.bytesTotal / 1e6).toFixed(2)} MB) from localhost: ` +
      `manifest ${state.manifestMs.toFixed(0)} ms, first component ${state.firstComponentMs.toFixed(0)} ms, all ${state.allLoadedMs.toFixed(0)} ms after navigation; ` +
      `main-thread blocking ${tbt.toFixed(0)} ms`);

    const { png, box } = await shootCanvas(page, 'bodyparts3d');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    assert.ok(bounds.bottom - bounds.top > 0.7 * box.height, 'the skeleton fills the view\'s height');
    const inside = await countForeground(context, png, box, bounds, state.background);
    console.log(`# BodyParts3D screenshot: ${(100 * inside.fraction).toFixed(1)}% of the skeleton's box is bone`);
    assert.ok(inside.fraction > 0.05, `only ${(100 * inside.fraction).toFixed(1)}% of the box differs from the background`);

    const at = (name) => page.evaluate((n) => window.osteon.screenPositionOf(n), name);
    const frontal = await at('Frontal bone');
    assert.ok(frontal.y < (await at('Left hip bone')).y && (await at('Left hip bone')).y < (await at('Left femur')).y, 'upright');
    await page.mouse.click(frontal.x, frontal.y);
    await page.waitForFunction(() => window.osteon.selected !== null);
    const name = await page.locator('#info-name').textContent();
    assert.ok(skullBones.has(name), `clicked the head, got "${name}"`);
    assert.match(await page.locator('#info-group').textContent(), regions.length ? /Skull/ : /bones/);
    await settle(page);
    await shootCanvas(page, 'bodyparts3d-skull-selected');
    await page.screenshot({ path: path.join(artifacts, 'bodyparts3d-page.png') });
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('a CT segmentation (TotalSegmentator, --labels bones) shows 17 named, coloured bones upright and from the front', {
    skip: existsSync(ctSeg) ? false : `no real data at ${ctSeg}`,
  }, async () => {
    const m = pack([ctSeg], path.join(site, 'ct'), ['--labels', 'bones', '--regions', 'names']);
    assert.equal(m.parts.length, 17);
    // TotalSegmentator's class names place the bones: T11-L2 in the vertebral column, the ribs
    // and cartilages in the thorax, by side.
    const groupOf = new Map(m.parts.map((p) => [p.name, p.group]));
    assert.equal(groupOf.get('vertebrae_T11'), 'Skeleton / Vertebral column / Thoracic');
    assert.equal(groupOf.get('rib_left_7'), 'Skeleton / Thorax / Left / Ribs');
    assert.equal(groupOf.get('costal_cartilages'), 'Skeleton / Thorax / Costal cartilages');
    assert.ok(m.parts.every((p) => p.color.length === 3), 'every bone has its colour from the file');
    const context = await browser.newContext(kDesktop);
    const { page, problems } = await openViewer(context, `${server.url}ct/`);
    const state = await waitLoaded(page);
    assert.deepEqual(state.errors, []);
    assert.equal(state.componentsLoaded, 17);
    const names = await page.locator('#part-list li').allTextContents();
    for (const bone of ['vertebrae_T11', 'vertebrae_L2', 'rib_left_7', 'costal_cartilages']) {
      assert.ok(names.some((n) => n.includes(bone)), `${bone} is listed`);
    }
    const regions = await page.locator('#region-tree [role="treeitem"][aria-level="2"]').evaluateAll((lis) =>
      lis.map((li) => [li.querySelector('.node-name').textContent, Number(li.dataset.count)]));
    assert.deepEqual(regions, [['Vertebral column', 4], ['Thorax', 13]]);
    // Upright: T11 above L2 on screen; from the front: the patient's left ribs on screen right.
    const at = (name) => page.evaluate((n) => window.osteon.screenPositionOf(n), name);
    assert.ok((await at('vertebrae_T11')).y < (await at('vertebrae_L2')).y, 'upright');
    assert.ok((await at('rib_left_9')).x > (await at('rib_right_9')).x, 'seen from the front');
    await shootCanvas(page, 'ct-segmentation');
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('a corrupted component fails alone, a missing chunk fails its components, each named in the page; the rest loads', async () => {
    const out = path.join(site, 'corrupt');
    const m = pack([path.join(work, 'phantom-src')], out, ['--chunk-bytes', '9000', '--no-lod']);
    assert.deepEqual(chunkFiles(out), m.chunks.map((c) => path.basename(c.file)).sort());
    // The corrupted component: the first of a chunk that holds others too, so they show that the
    // damage stays with it. The deleted chunk: the last one.
    const inChunk = (k) => m.components.filter((c) => c.chunk === k);
    const bad = m.chunks.findIndex((c, k) => k < m.chunks.length - 1 && new Set(inChunk(k).map((x) => x.offset)).size >= 2);
    assert.ok(bad >= 0, 'a chunk with two components');
    const victim = inChunk(bad).reduce((a, b) => (b.offset < a.offset ? b : a));
    const victims = inChunk(bad).filter((c) => c.offset === victim.offset).map((c) => c.id);  // byte-identical twins too
    corruptRange(path.join(out, m.chunks[bad].file), victim.offset, victim.bytes);
    const lost = m.chunks.length - 1;
    const lostIds = inChunk(lost).map((c) => c.id);
    const lostRanges = new Set(inChunk(lost).map((c) => c.offset)).size;
    unlinkSync(path.join(out, m.chunks[lost].file));

    const context = await browser.newContext(kDesktop);
    const { page, problems } = await openViewer(context, `${server.url}corrupt/`);
    const state = await waitLoaded(page);
    const all = state.errors.join('\n');
    assert.equal(state.errors.length, 1 + lostRanges, all);
    assert.ok(state.errors.every((e) => e.startsWith('osteon:')), all);
    const corrupt = state.errors.filter((e) => e.includes(m.chunks[bad].file));
    assert.equal(corrupt.length, 1, all);
    assert.match(corrupt[0], /corrupt|checksum/i);
    assert.ok(victims.every((id) => corrupt[0].includes(id)), corrupt[0]);
    const missing = state.errors.filter((e) => e.includes(m.chunks[lost].file));
    assert.equal(missing.length, lostRanges, all);
    assert.ok(missing.every((e) => /HTTP 404/.test(e)), all);
    assert.ok(lostIds.every((id) => missing.some((e) => e.includes(`${id},`) || e.includes(`${id} `))), all);
    const errorBox = page.locator('#errors');
    assert.ok(await errorBox.isVisible());
    const text = await errorBox.textContent();
    assert.ok(text.includes(m.chunks[bad].file) && text.includes(m.chunks[lost].file), text);

    const failed = new Set([...victims, ...lostIds]);
    assert.deepEqual(state.fetchLog.filter((e) => e.error).map((e) => e.id).sort(), [...failed].sort());
    assert.equal(state.componentsFailed, failed.size);
    assert.equal(state.componentsLoaded, m.components.length - failed.size);
    assert.equal(state.instancesDrawn, m.instances.filter((i) => !failed.has(i.component)).length);
    const { png, box } = await shootCanvas(page, 'corrupt');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    assert.ok((await countForeground(context, png, box, bounds, state.background)).fraction > 0.04, 'the other bones are drawn');
    // The only console error is the browser's own line for the 404.
    assert.deepEqual(problems.filter((p) => !/404/.test(p)), []);

    // A missing manifest: named in the page, and loading ends.
    const lostManifest = await openViewer(context, `${server.url}corrupt/?manifest=missing.json`);
    const lostState = await waitLoaded(lostManifest.page);
    assert.deepEqual(lostState.errors, ['osteon: missing.json: HTTP 404']);
    assert.equal(lostState.componentsTotal, 0);
    assert.match(await lostManifest.page.locator('#errors').textContent(), /missing\.json: HTTP 404/);
    await context.close();
  });

  test('levels of detail: every bone coarse first, then refined for the view by byte range; zooming in refines what is seen; picks, isolation and the mirrored femur at every level; a budget evicts and holds', async () => {
    const m = lodPackage();
    assert.equal(m.version, 3);
    const byId = new Map(m.components.map((c) => [c.id, c]));
    const levelsOf = (id) => [...(byId.get(id).levels ?? []), byId.get(id)];
    const componentsOf = (name) => {
      const part = m.parts.find((p) => p.name === name);
      return [...new Set(m.instances.filter((i) => i.part === part.id).map((i) => i.component))];
    };
    const copies = (id) => {
      const uses = m.instances.filter((i) => i.component === id);
      const mirrored = uses.filter((i) => i.mirror).length;
      return uses.length === 1 ? 1 : (mirrored > 0) + (mirrored < uses.length);
    };
    // Float positions and normals; 16-bit indices where they fit (the decodes' kDecodeOptions).
    const gpuOf = ({ vertices, triangles }, id) => vertices * 24 + triangles * 3 * (vertices <= 65536 ? 2 : 4) * copies(id);
    const firstGpu = m.components.reduce((sum, c) => sum + gpuOf(levelsOf(c.id)[0], c.id), 0);
    const firstChunks = new Set(m.components.map((c) => (c.levels ? c.levels[0].chunk : c.chunk)));
    const firstBytes = [...firstChunks].reduce((sum, k) => sum + m.chunks[k].bytes, 0);
    assert.ok(m.components.filter((c) => c.levels?.length >= 2).length >= 5, 'most bones have three levels or more');
    assert.ok(firstChunks.size < m.chunks.length);

    const context = await browser.newContext(kDesktop);
    const { page, problems } = await openViewer(context, `${server.url}lod/`);
    const loaded = await waitLoaded(page);
    assert.deepEqual(loaded.errors, []);
    assert.equal(loaded.componentsLoaded, m.components.length);
    assert.equal(loaded.levelsTotal, m.components.reduce((n, c) => n + levelsOf(c.id).length, 0));
    // The whole skeleton, at its coarsest, from the first chunks alone, before any finer level
    // (which may come while the renderer is still busy with the first ones).
    assert.ok(loaded.skeletonCompleteMs !== null && loaded.firstFrameMs <= loaded.skeletonCompleteMs);
    assert.ok(loaded.fetchLog.every((e) => firstChunks.has(e.chunk)));
    assert.equal(loaded.bytesAtSkeletonComplete, firstBytes);
    let state = await waitRefined(page);
    const firstInHand = Math.max(...state.fetchLog.map((e) => e.decodedAt));
    assert.ok(state.levelLog.every((e) => e.fetchStart >= firstInHand), 'no level fetched before every first level was decoded');
    assert.ok(state.firstRefinedMs >= state.skeletonCompleteMs && state.refinedMs !== null);
    assert.deepEqual(state.errors, []);
    console.log(`# dense phantom: skeleton complete at ${state.skeletonCompleteMs.toFixed(0)} ms after ${firstBytes} of ${state.bytesTotal} bytes; ` +
      `refined for the whole view at ${state.firstRefinedMs.toFixed(0)} ms after ${state.bytesLoaded} bytes (${state.levelLog.length} level fetches); ` +
      `levels ${JSON.stringify(state.levelDrawn)}`);

    // Zoom into the pelvis: its levels rise; what left the view drops to its coarsest; only
    // components on screen are above it.
    const before = state.levelDrawn;
    await page.evaluate(() => window.osteon.frame('pelvis'));
    state = await waitRefined(page);
    const raised = Object.keys(state.levelDrawn).filter((id) => state.levelDrawn[id] > before[id]);
    const pelvis = componentsOf('pelvis');
    assert.ok(pelvis.every((id) => raised.includes(id)), `raised ${raised}, pelvis ${pelvis}`);
    assert.ok(componentsOf('skull').every((id) => state.levelDrawn[id] === 0), 'the skull, off screen, at its coarsest');
    for (const id of Object.keys(state.levelDrawn)) {
      if (state.levelDrawn[id] > 0) assert.ok(id in state.levelWanted, `${id} is refined off screen`);
    }
    const raisedParts = m.parts.filter((p) => componentsOf(p.name).some((id) => raised.includes(id))).map((p) => p.name);
    console.log(`# zoomed to the pelvis: raised ${raisedParts.join(', ')}; on screen ${Object.keys(state.levelWanted).length} of ${m.components.length} components; ` +
      `refined at ${state.refinedMs.toFixed(0)} ms`);
    assert.ok(state.levelLog.length > 0 && state.levelLog.every((e) => e.status === 206 && e.received === e.bytes), JSON.stringify(state.levelLog.slice(0, 3)));
    const ranged = server.requests.filter((r) => /^GET \/lod\/c\/[0-9a-f]{24}\.ostc 206/.test(r));
    // One request a level (more only where an answer came short and was continued).
    assert.equal(ranged.length, state.levelLog.reduce((n, e) => n + e.requests, 0), ranged.join('\n'));

    // The panel names the level drawn; isolating the pelvis draws it alone, at that level.
    await page.evaluate(() => window.osteon.select('pelvis'));
    const pelvisLevel = state.levelDrawn[pelvis[0]];
    const pelvisLevels = levelsOf(pelvis[0]).length;
    assert.match(await page.locator('#info-level').textContent(), new RegExp(`^level ${pelvisLevel + 1} of ${pelvisLevels}(?: \\(full resolution\\))?, error [0-9.]+ mm$`));
    await page.locator('#isolate').click();
    state = await readState(page);
    const pelvisPart = m.parts.find((p) => p.name === 'pelvis').id;
    assert.equal(state.instancesDrawn, pelvis.length);
    assert.equal(state.trianglesDrawn, trianglesAtLevels(m, state.levelDrawn, (part) => part === pelvisPart));
    await page.locator('#show-all').click();
    await page.locator('#canvas').press('Escape');

    // The left femur, a mirrored instance of the right one's component: a pick names it at every level.
    await page.evaluate(() => window.osteon.frame('femur_l'));
    await waitRefined(page);
    const femur = componentsOf('femur_l')[0];
    assert.deepEqual(componentsOf('femur_r'), [femur]);
    assert.ok(m.instances.some((i) => i.component === femur && i.mirror));
    const femurLevels = levelsOf(femur).length;
    const pixels = await page.evaluate((id) => window.osteon.levelPixels(id), femur);
    // Nothing finer held (a budget of nothing evicts every fine level), so that each level is
    // fetched and drawn in turn.
    await page.evaluate(() => window.osteon.setBudget({ bytes: 0 }));
    assert.deepEqual(Object.values((await waitRefined(page)).levelDrawn).filter((l) => l > 0), []);
    await page.evaluate(() => window.osteon.setBudget({ bytes: 256e6 }));
    for (let k = 0; k < femurLevels; ++k) {
      // The pixel target that makes level k the one needed: between its error and the next coarser one's.
      const target = k === 0 ? pixels[0] * 2 : Math.sqrt(pixels[k] * pixels[k - 1]);
      await page.evaluate((px) => window.osteon.setMaxPixelError(px), target);
      state = await waitRefined(page);
      assert.equal(state.levelDrawn[femur], k, `femur at level ${k} for ${target} px (${pixels})`);
      const at = await page.evaluate(() => window.osteon.screenPositionOf('femur_l'));
      await page.mouse.click(at.x, at.y);
      await page.waitForFunction(() => window.osteon.selected === 'femur_l');
      assert.match(await page.locator('#info-level').textContent(), new RegExp(`^level ${k + 1} of ${femurLevels}`));
      await page.locator('#canvas').press('Escape');
      await page.waitForFunction(() => window.osteon.selected === null);
    }

    // Both femurs at their coarsest, then at full resolution, seen whole: the mirrored one is
    // drawn as large and lit as brightly as the other (inside out it would be dark).
    await page.locator('#fit').click();
    const shots = {};
    for (const [name, px] of [['coarse', 1e9], ['fine', 1e-6]]) {
      await page.evaluate((p) => window.osteon.setMaxPixelError(p), px);
      state = await waitRefined(page);
      assert.equal(state.levelDrawn[femur], name === 'coarse' ? 0 : femurLevels - 1);
      const { png, box } = await shootCanvas(page, `lod-femurs-${name}`);
      const rects = await page.evaluate(() => ['femur_l', 'femur_r'].map((n) => window.osteon.screenBoundsOf(n)));
      const [left, right] = await countForeground(context, png, box, rects, state.background);
      shots[name] = { left, right };
      assert.ok(left.differing > 0.7 * right.differing && left.differing < 1.4 * right.differing, `${name}: ${JSON.stringify(shots[name])}`);
      assert.ok(left.luminance > 0.75 * right.luminance && left.luminance < 1.33 * right.luminance, `${name}: ${JSON.stringify(shots[name])}`);
    }
    console.log(`# femurs (left mirrored): ${Object.entries(shots).map(([k, v]) => `${k} ${v.left.differing}/${v.right.differing} px, ` +
      `luminance ${v.left.luminance.toFixed(0)}/${v.right.luminance.toFixed(0)}`).join('; ')}`);

    // A budget between the coarsest levels and what is held now evicts at once, and holds as
    // the view moves on.
    const held = { gpu: state.gpuBytes, levels: state.levelsLoaded, evictions: state.evictions };
    assert.ok(held.gpu > firstGpu * 1.5, `${held.gpu} bytes held, ${firstGpu} at the coarsest`);
    const budget = Math.round(firstGpu + (held.gpu - firstGpu) / 3);
    const now = await page.evaluate((b) => {
      window.osteon.setBudget({ bytes: b });
      return { gpu: window.osteon.gpuBytes, levels: window.osteon.levelsLoaded, evictions: window.osteon.evictions, budget: window.osteon.budget };
    }, budget);
    assert.deepEqual(now.budget, { bytes: budget, triangles: 4e6 });
    assert.ok(now.gpu <= budget && now.levels < held.levels && now.evictions > held.evictions, JSON.stringify({ held, now, budget }));
    await page.evaluate(() => window.osteon.setMaxPixelError(1));
    const fetched = (await readState(page)).levelLog.length;
    for (const bone of ['skull', 'pelvis']) {
      await page.evaluate((b) => window.osteon.frame(b), bone);
      state = await waitRefined(page);
      assert.ok(state.gpuBytesPeak <= budget, `${bone}: peak ${state.gpuBytesPeak} over the budget ${budget}`);
    }
    assert.ok(state.levelLog.length > fetched, 'levels are fetched again within the budget');
    // A triangle budget below the coarsest levels: those alone are drawn.
    const coarse = trianglesAtLevels(m, {});
    await page.evaluate(() => window.osteon.setBudget({ bytes: 256e6, triangles: 1000 }));
    state = await waitRefined(page);
    assert.equal(state.gpuTriangles, coarse);
    assert.ok(Object.values(state.levelDrawn).every((l) => l === 0));
    assert.deepEqual(state.errors, []);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('a corrupt level fails alone: named in the page, the next coarser one drawn and picked; the budget comes from the URL', async () => {
    const m = lodPackage();
    const part = m.parts.find((p) => p.name === 'pelvis');
    const id = m.instances.find((i) => i.part === part.id).component;
    const c = m.components.find((x) => x.id === id);
    const levels = (c.levels?.length ?? 0) + 1;
    assert.ok(levels >= 3, `the pelvis has ${levels} levels`);
    const file = m.chunks[c.chunk].file;  // its full level's chunk
    const range = `bytes=${c.offset}-${c.offset + c.bytes - 1}`;
    const context = await browser.newContext(kDesktop);
    let corrupted = 0;
    const { page, problems } = await openViewer(context, `${server.url}lod/?budgetMB=100&budgetTriangles=3000000`, async (p) => {
      await p.route(`**/lod/${file}`, async (route) => {
        if (route.request().headers().range !== range) return route.continue();
        const response = await route.fetch();
        const body = Buffer.from(await response.body());
        const middle = Math.floor(body.length / 2);  // an odd length's half is no byte index
        for (let i = middle - 8; i < middle + 8; ++i) body[i] ^= 0xff;
        corrupted++;
        return route.fulfill({ response, body });
      });
    });
    await waitLoaded(page);
    assert.deepEqual((await readState(page)).budget, { bytes: 100e6, triangles: 3e6 });
    await page.evaluate(() => window.osteon.frame('pelvis'));
    await page.evaluate(() => window.osteon.setMaxPixelError(1e-6));  // everything on screen at full resolution
    // The opening view may already be refined (its coarse levels within a pixel): wait for the
    // new plan's fetch of the full level before waiting for the refinement to settle again.
    for (const start = Date.now(); corrupted === 0 && Date.now() - start < 30000;) {
      await new Promise((resolve) => setTimeout(resolve, 100));
    }
    const state = await waitRefined(page);
    assert.equal(corrupted, 1);
    assert.equal(state.errors.length, 1, state.errors.join('\n'));
    assert.ok(state.errors[0].startsWith(`osteon: ${file} (component ${id}, level ${levels} of ${levels}, bytes ${c.offset}-${c.offset + c.bytes})`), state.errors[0]);
    assert.match(state.errors[0], /corrupt|checksum/i);
    assert.match(await page.locator('#errors').textContent(), new RegExp(`component ${id}, level ${levels} of ${levels}`));
    assert.equal(state.levelsFailed, 1);
    assert.equal(state.componentsFailed, 0);
    assert.equal(state.levelDrawn[id], levels - 2, 'the next coarser level is drawn');
    assert.ok(state.refinedMs !== null, 'as refined as it can be');
    // Every other component on screen is at its full level.
    for (const other of Object.keys(state.levelWanted)) {
      if (other !== id) assert.equal(state.levelDrawn[other], (m.components.find((x) => x.id === other).levels?.length ?? 0), other);
    }
    const at = await page.evaluate(() => window.osteon.screenPositionOf('pelvis'));
    await page.mouse.click(at.x, at.y);
    await page.waitForFunction(() => window.osteon.selected === 'pelvis');
    assert.match(await page.locator('#info-level').textContent(), new RegExp(`^level ${levels - 1} of ${levels}`));
    await page.locator('#canvas').press('Escape');
    await settle(page);
    const { png, box } = await shootCanvas(page, 'lod-corrupt-level');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf('pelvis'));
    assert.ok((await countForeground(context, png, box, bounds, state.background)).fraction > 0.1, 'the pelvis is drawn');
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('before three.js is ready, the first frames draw every bone as three.js then draws it; picks wait for three.js', async () => {
    const m = phantomManifest;
    const context = await browser.newContext(kDesktop);
    const releaseThree = await holdThree(context);
    const { page, problems } = await openViewer(context, `${server.url}phantom/`);
    const early = await waitLoaded(page);
    assert.deepEqual(early.errors, []);
    assert.equal(early.componentsLoaded, m.components.length);
    assert.equal(early.instancesDrawn, m.instances.length);
    assert.ok(early.timings.firstFrames > early.timings.context, JSON.stringify(early.timings));
    assert.equal(early.timings.three, undefined, 'three.js has not been loaded');
    assert.ok(early.firstFrameMs >= early.timings.firstFrames && early.skeletonCompleteMs >= early.firstFrameMs);
    const before = await shootCanvas(page, 'phantom-first-frames');
    // A click waits for three.js's view (picking is its raycaster).
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    await page.mouse.click(skull.x, skull.y);
    await page.waitForTimeout(200);
    assert.equal(await page.evaluate(() => window.osteon.selected), null);

    releaseThree();
    await page.waitForFunction(() => window.osteon.timings.compiled !== undefined && window.osteon.selected === 'skull');
    await settle(page);
    // Deselected, so both pictures show the same bones in the same colours.
    await page.locator('#canvas').press('Escape');
    await page.waitForFunction(() => window.osteon.selected === null);
    await settle(page);
    const after = await shootCanvas(page, 'phantom-three');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    const drawn = await countForeground(context, after.png, after.box, bounds, early.background);
    const firstDrawn = await countForeground(context, before.png, before.box, bounds, early.background);
    const diff = await countDiffering(context, before.png, after.png);
    console.log(`# first frames: ${firstDrawn.differing} bone pixels, three.js ${drawn.differing}; ${diff.differing} pixels differ between them`);
    assert.ok(drawn.fraction > 0.08, 'three.js draws the skeleton');
    assert.ok(Math.abs(firstDrawn.differing - drawn.differing) < 0.02 * drawn.differing, 'the first frames cover what three.js covers');
    assert.ok(diff.differing < 0.05 * drawn.differing, `${diff.differing} pixels differ from three.js's frame`);
    assert.ok(Math.abs(firstDrawn.luminance - drawn.luminance) < 8, `lit alike: ${firstDrawn.luminance.toFixed(1)} against ${drawn.luminance.toFixed(1)}`);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('before three.js is ready, the first frames also draw the finer levels the view needs, and three.js takes over at those levels', async () => {
    const m = lodPackage();
    const context = await browser.newContext(kDesktop);
    const releaseThree = await holdThree(context);
    const { page, problems } = await openViewer(context, `${server.url}lod/`);
    await waitLoaded(page);
    const early = await waitRefined(page);
    assert.deepEqual(early.errors, []);
    assert.equal(early.timings.three, undefined, 'three.js has not been loaded');
    assert.ok(early.refinedMs !== null, 'refined by the first frames');
    const raised = Object.keys(early.levelDrawn).filter((id) => early.levelDrawn[id] > 0);
    assert.ok(raised.length > 0, `some bones above their coarsest level: ${JSON.stringify(early.levelDrawn)}`);
    assert.ok(early.levelLog.every((e) => e.shownAt !== null || e.dropped || e.evictedAt !== null), 'every level fetched is drawn');
    assert.equal(early.trianglesDrawn, trianglesAtLevels(m, early.levelDrawn));
    const before = await shootCanvas(page, 'lod-first-frames');

    releaseThree();
    await page.waitForFunction(() => window.osteon.timings.compiled !== undefined);
    const after = await waitRefined(page);
    assert.deepEqual(after.levelDrawn, early.levelDrawn, 'three.js draws the levels the first frames drew');
    assert.deepEqual(after.errors, []);
    const shot = await shootCanvas(page, 'lod-three');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    const drawn = await countForeground(context, shot.png, shot.box, bounds, after.background);
    const diff = await countDiffering(context, before.png, shot.png);
    console.log(`# first frames refined ${raised.length} of ${m.components.length} components at ${early.refinedMs.toFixed(0)} ms; ${diff.differing} of ${drawn.differing} bone pixels differ from three.js's frame`);
    assert.ok(drawn.fraction > 0.05, 'three.js draws the skeleton');
    assert.ok(diff.differing < 0.05 * drawn.differing, `${diff.differing} pixels differ from three.js's frame`);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('without OffscreenCanvas the renderer runs on the page, and draws and picks the same', async () => {
    const m = phantomManifest;
    const context = await browser.newContext(kDesktop);
    // A browser that cannot hand a canvas to a worker.
    await context.addInitScript(() => {
      delete HTMLCanvasElement.prototype.transferControlToOffscreen;
    });
    const { page, problems } = await openViewer(context, `${server.url}phantom/`);
    const state = await waitLoaded(page);
    assert.equal(state.renderer, 'page');
    assert.deepEqual(state.errors, []);
    assert.equal(state.componentsLoaded, m.components.length);
    assert.equal(state.instancesDrawn, m.instances.length);
    const { png, box } = await shootCanvas(page, 'phantom-on-page');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    assert.ok((await countForeground(context, png, box, bounds, state.background)).fraction > 0.08, 'the skeleton is drawn');
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    await page.mouse.click(skull.x, skull.y);
    await page.waitForFunction(() => window.osteon.selected === 'skull');
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('on a phone: search selects a bone; hide, isolate, groups and show all change what is drawn; tap picks; the plane clips', async () => {
    const m = phantomManifest;
    const context = await browser.newContext(kPhone);
    const { page, problems } = await openViewer(context, `${server.url}phantom/`);
    const full = await waitLoaded(page);
    const all = { instances: full.instancesDrawn, triangles: full.trianglesDrawn };
    const femur = m.parts.find((p) => p.display_name === 'femur_l');

    // The panel sits under the view on a narrow screen.
    const view = await page.locator('#view').boundingBox();
    const panel = await page.locator('#panel').boundingBox();
    assert.ok(panel.y >= view.y + view.height - 1 && view.width === 390, JSON.stringify({ view, panel }));

    await page.locator('#search').fill('femur');
    const rows = page.locator('#part-list li:not([hidden]) button');
    assert.deepEqual(await rows.allTextContents(), ['femur_l', 'femur_r']);
    await rows.filter({ hasText: 'femur_l' }).tap();
    await page.waitForFunction(() => window.osteon.selected === 'femur_l');
    assert.equal(await page.locator('#info-name').textContent(), 'femur_l');
    assert.equal(await page.locator('#info-triangles').textContent(), femur.triangles.toLocaleString('en'));

    const drawn = async () => {
      const s = await readState(page);
      return { instances: s.instancesDrawn, triangles: s.trianglesDrawn };
    };
    await page.locator('#hide').tap();
    assert.deepEqual(await drawn(), { instances: all.instances - 1, triangles: all.triangles - femur.triangles });
    assert.ok(await page.locator('#part-list li.hidden-part').filter({ hasText: 'femur_l' }).count() === 1);
    await page.locator('#isolate').tap();
    assert.deepEqual(await drawn(), { instances: 1, triangles: femur.triangles });
    await settle(page);
    await shootCanvas(page, 'phone-isolated');
    await page.locator('#show-all').tap();
    assert.deepEqual(await drawn(), all);

    const group = page.locator('#group-list input');
    await group.first().uncheck();
    assert.deepEqual(await drawn(), { instances: 0, triangles: 0 });
    await group.first().check();
    assert.deepEqual(await drawn(), all);

    // Fit, then tap the skull.
    await page.locator('#search').fill('');
    await page.locator('#fit').tap();
    await settle(page);
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    await page.touchscreen.tap(skull.x, skull.y);
    await page.waitForFunction(() => window.osteon.selected === 'skull');
    await settle(page);
    await page.screenshot({ path: path.join(artifacts, 'phone-page.png') });

    // The clipping plane at the middle of Z keeps the upper half: the lower half of the view empties.
    const before = await shootCanvas(page, 'phone');
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    const lower = { ...bounds, top: (bounds.top + bounds.bottom) / 2 + 4 };
    const lowerBefore = await countForeground(context, before.png, before.box, lower, full.background);
    await page.locator('#clip-on').check();
    await settle(page);
    const clipped = await shootCanvas(page, 'phone-clipped');
    const lowerAfter = await countForeground(context, clipped.png, clipped.box, lower, full.background);
    assert.ok(lowerBefore.differing > 1000, `${lowerBefore.differing} bone pixels below the middle`);
    assert.ok(lowerAfter.differing < 0.1 * lowerBefore.differing, `clipping left ${lowerAfter.differing} of ${lowerBefore.differing} pixels`);
    assert.deepEqual(problems, []);
    await context.close();
  });
});
