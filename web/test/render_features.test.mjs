// SPDX-License-Identifier: Apache-2.0
// Per-part colours, per-part opacity and x-ray picking in the render worker, in Chromium on the
// standalone page of the phantom: every part recoloured changes every part's pixels; a skull at
// opacity 0.3 shows the atlas beneath it, a pick through both returns the skull, an x-ray pick
// the atlas, each with a surface point inside the part's box and in depth order; a pick on an
// opaque bone (single, instanced, mirrored) returns a point in its box and a unit normal facing
// the camera. Prints what an opacity change and a pick cost.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/render_features.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { describe, test } from 'node:test';

import { BackSide, Color, Group, SRGBColorSpace } from 'three';

import { drawInfo, drawStats, parseManifest } from '../viewer/manifest.mjs';
import { createPackageScene } from '../viewer/scene.mjs';

import { missingPrerequisite, openViewer, phantomSite, settle, shootCanvas, waitLoaded, withPixels } from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# render feature browser tests skipped: ${skip}`);
const kDesktop = { viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 };
const kGreen = [0.1, 0.75, 0.2];
// OSTEON_PHANTOM_DETAIL=6: a phantom of 2.4 million triangles, for the costs printed.
const kDetail = process.env.OSTEON_PHANTOM_DETAIL;

/// Whether `point` lies in `box` ({ min, max }) grown by `slack` of its diagonal.
function inBox(point, box, slack = 1e-3) {
  const grow = slack * Math.hypot(...box.max.map((v, i) => v - box.min[i]));
  return point.every((v, i) => v >= box.min[i] - grow && v <= box.max[i] + grow);
}

const distance = (a, b) => Math.hypot(...a.map((v, i) => v - b[i]));

/// Decodes two screenshots of the canvas (PNGs, decoded by withPixels) and returns, per client
/// rectangle, { foreground (pixels of `a` off the background), changed (those that differ in
/// `b` by more than 24 in a channel), green (pixels of `b` off the background that are green) }.
function compareShots(context, a, b, box, background, rects) {
  return withPixels(context, [a, b], ([pa, pb], { origin, background, rects }) => {
    const bg = [1, 3, 5].map((i) => parseInt(background.slice(i, i + 2), 16));
    const off = (px, i) => [0, 1, 2].some((c) => Math.abs(px[i + c] - bg[c]) > 24);
    return rects.map((r) => {
      const out = { foreground: 0, changed: 0, green: 0 };
      for (let y = Math.max(0, Math.floor(r.top - origin.y)); y < Math.min(pa.height, Math.ceil(r.bottom - origin.y)); ++y) {
        for (let x = Math.max(0, Math.floor(r.left - origin.x)); x < Math.min(pa.width, Math.ceil(r.right - origin.x)); ++x) {
          const i = 4 * (y * pa.width + x);
          if (off(pa.data, i)) {
            ++out.foreground;
            if ([0, 1, 2].some((c) => Math.abs(pa.data[i + c] - pb.data[i + c]) > 24)) ++out.changed;
          }
          if (off(pb.data, i) && pb.data[i + 1] > pb.data[i] + 20 && pb.data[i + 1] > pb.data[i + 2] + 20) ++out.green;
        }
      }
      return out;
    });
  }, { origin: { x: box.x, y: box.y }, background, rects });
}

/// A stand-in for a decoded component: its box's 12 triangles, as many as the level has.
function boxMesh(component, level = 0) {
  const { min, max } = component.bounds;
  const positions = new Float32Array(24);
  for (let v = 0; v < 8; ++v) positions.set([0, 1, 2].map((i) => ((v >> i) & 1 ? max[i] : min[i])), 3 * v);
  const box = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3];
  const indices = new Uint32Array(3 * component.levels[level].triangles);
  indices.set(box.slice(0, indices.length));
  return { positions, indices, normals: new Float32Array(24).fill(0.5) };
}

describe('per-part colours, opacity and x-ray picks', { skip: skip ?? false }, () => {
  const site = phantomSite('osteon-render-', ['--no-lod'], { phantomArgs: kDetail ? ['--detail', kDetail] : [] });

  test('the scene: see-through parts leave their batches for a Mesh per instance, colours reach both', () => {
    const manifest = parseManifest(site.m);
    const s = createPackageScene(manifest, new Group());
    for (const c of manifest.components) s.addComponent(c.id, boxMesh(c));
    const batch = s.batches.find((b) => b.instanced && b.instances.length >= 3);
    const clearPart = manifest.instances[batch.instances[1]].part;
    const single = s.batches.find((b) => !b.instanced);
    const singlePart = manifest.instances[single.instances[0]].part;
    const opacity = new Float32Array(manifest.parts.length).fill(1);
    opacity[clearPart] = 0.4;
    opacity[singlePart] = 0;
    const colors = new Float32Array(3 * manifest.parts.length).fill(0.5);
    colors.set([1, 0, 0], 3 * singlePart);
    const everything = () => true;
    s.setStyle({ visible: everything, highlight: -1, colors, opacity });
    assert.equal(batch.object.count, batch.instances.length - 1, 'the see-through vertebra is packed out of its batch');
    assert.equal(single.object.visible, false);
    const clear = s.pickable().filter((o) => o.userData.batch.transparent);
    // Two objects per see-through instance, its back faces made (so drawn, at one depth) first.
    const wanted = [...manifest.instancesOfPart[clearPart], ...manifest.instancesOfPart[singlePart]].sort();
    assert.deepEqual(clear.map((o) => o.userData.batch.instances[0]).sort(), wanted.flatMap((i) => [i, i]));
    for (const o of clear) {
      const part = manifest.instances[o.userData.batch.instances[0]].part;
      assert.ok(o.isMesh && !o.isInstancedMesh && o.material.transparent && !o.material.depthWrite);
      assert.equal(o.material.opacity, Math.fround(opacity[part]));
      const twin = clear.find((t) => t !== o && t.userData.batch === o.userData.batch);
      assert.equal(o.material.side === BackSide, o.id < twin.id, 'back faces first');
    }
    assert.ok(clear.find((o) => manifest.instances[o.userData.batch.instances[0]].part === singlePart).material.color.equals(new Color().setRGB(1, 0, 0, SRGBColorSpace)));
    const grey = new Color().setRGB(0.5, 0.5, 0.5, SRGBColorSpace);
    const drawn = Array.from(batch.object.instanceColor.array.subarray(0, 3));
    assert.ok(drawn.every((v, i) => Math.abs(v - grey.toArray()[i]) < 1e-6), `instance colours follow: ${drawn}`);
    // Every instance still counts as drawn; the stats count the see-through meshes too.
    assert.equal(s.stats().instances, manifest.instances.length);
    for (const part of manifest.parts) assert.deepEqual(s.drawInfo(part.id), drawInfo(manifest, part.id, new Set(manifest.components.map((c) => c.id))));
    // All opaque again: batched as before, nothing see-through drawn or picked.
    s.setStyle({ opacity: null, colors: null });
    assert.equal(batch.object.count, batch.instances.length);
    assert.equal(s.pickable().filter((o) => o.userData.batch.transparent).length, 0);
    assert.deepEqual(s.stats(), drawStats(manifest, new Set(manifest.components.map((c) => c.id)), everything));
  });

  test('colours, opacity in depth order, and picks with points', async () => {
    const context = await site.browser.newContext(kDesktop);
    const { page, problems } = await openViewer(context, `${site.server.url}p/`);
    const loaded = await waitLoaded(page, 180000);
    assert.deepEqual(loaded.errors, []);
    const parts = site.m.parts.length;
    const partId = (name) => site.m.parts.find((p) => p.display_name === name).id;
    const { partBounds } = parseManifest(site.m);
    const bounds = async (name) => page.evaluate((n) => window.osteon.screenBoundsOf(n), name);
    const box = await page.locator('#canvas').boundingBox();
    const toNdc = (x, y) => [((x - box.x) / box.width) * 2 - 1, -((y - box.y) / box.height) * 2 + 1];
    const pickAt = (ndc, xray) => page.evaluate(([n, x]) => window.osteon.pickAt(n, { xray: x }), [ndc, xray]);
    const cameraAt = async () => (await page.evaluate(() => window.osteon.cameraState())).position;

    // (a) Every part green: every part's pixels change colour.
    const before = await shootCanvas(page, 'render-colors-before');
    assert.equal(await page.evaluate((c) => window.osteon.setPartStyle({ colors: c }), Array.from({ length: parts }, () => kGreen).flat()), true);
    await settle(page);
    const green = await shootCanvas(page, 'render-colors');
    const rects = await Promise.all(site.m.parts.map((p) => bounds(p.display_name)));
    const counts = await compareShots(context, before.png, green.png, box, loaded.background, rects);
    for (const [id, c] of counts.entries()) {
      if (c.foreground < 30) continue;  // too small or off screen
      assert.ok(c.changed / c.foreground > 0.9, `${site.m.parts[id].display_name}: ${c.changed} of ${c.foreground} pixels changed`);
      assert.ok(c.green / c.foreground > 0.8, `${site.m.parts[id].display_name}: ${c.green} of ${c.foreground} pixels green`);
    }
    assert.ok(counts.filter((c) => c.foreground >= 30).length >= parts - 4, 'most parts are on screen');

    // (c) Picks on opaque bones (back to the manifest's colours): a single Mesh, an instanced
    // vertebra, the mirrored femur: the point in the part's box, a unit normal facing the eye.
    await page.evaluate(() => window.osteon.setPartStyle({}));
    await settle(page);
    const eye = await cameraAt();
    const pickTimes = [];
    for (const name of ['skull', 'pelvis', 'vertebra_l2', 'femur_l', 'femur_r']) {
      const at = await page.evaluate((n) => window.osteon.screenPositionOf(n), name);
      const t0 = performance.now();
      const hit = await pickAt(toNdc(at.x, at.y), false);
      pickTimes.push(performance.now() - t0);
      assert.equal(hit.part, partId(name), `${name}: picked ${site.m.parts[hit.part]?.display_name}`);
      assert.ok(inBox(hit.point, partBounds[partId(name)]), `${name}: ${hit.point} outside its box`);
      assert.ok(Math.abs(Math.hypot(...hit.normal) - 1) < 1e-4, `${name}: |normal| ${Math.hypot(...hit.normal)}`);
      const toEye = eye.map((v, i) => v - hit.point[i]);
      assert.ok(hit.normal.reduce((s, v, i) => s + v * toEye[i], 0) > 0, `${name}: normal ${hit.normal} faces away from the eye`);
    }
    const miss = await pickAt([0.99, 0.99], false);
    assert.deepEqual([miss.part, miss.point, miss.normal], [-1, null, null]);
    // Once the skeleton is drawn, the drawn geometries get picking trees in idle time; picks
    // answer the same through them.
    let trees = null;
    for (let k = 0; k < 100 && !(trees?.built > 0 && trees.waiting === 0); ++k) {
      trees = (await pickAt([0.99, 0.99], false)).trees;
      if (trees.waiting > 0 || trees.built === 0) await page.waitForTimeout(100);
    }
    assert.ok(trees.built > 0 && trees.waiting === 0, JSON.stringify(trees));
    for (const name of ['skull', 'vertebra_l2', 'femur_l']) {
      const at = await page.evaluate((n) => window.osteon.screenPositionOf(n), name);
      const hit = await pickAt(toNdc(at.x, at.y), false);
      assert.equal(hit.part, partId(name), `${name} through the trees: picked ${site.m.parts[hit.part]?.display_name}`);
      assert.ok(inBox(hit.point, partBounds[partId(name)]), `${name} through the trees: ${hit.point} outside its box`);
    }

    // (b) From above: the skull over the atlas. At 0.3 the skull lets the atlas show through.
    const skull = partId('skull');
    const atlas = partId('atlas_c1');
    await page.evaluate(() => window.osteon.setViewState('v=1&cam=0,-15,2700,0,-15,1470,0,1,0,30'));
    await settle(page);
    const opaque = await shootCanvas(page, 'render-xray-opaque');
    const opacity = Array.from({ length: parts }, (_, p) => (p === skull ? 0.3 : 1));
    await page.evaluate((o) => window.osteon.setPartStyle({ opacity: o }), opacity);
    await settle(page);
    const first = await page.evaluate(() => ({ partsMs: window.osteon.partsMs, renderMs: window.osteon.renderMs, gl: window.osteon.gl }));
    const xray = await shootCanvas(page, 'render-xray');
    const atlasRect = await bounds('atlas_c1');
    const [seen] = await compareShots(context, opaque.png, xray.png, box, loaded.background, [atlasRect]);
    assert.ok(seen.changed > 0.3 * seen.foreground, `the atlas shows through the skull: ${seen.changed} of ${seen.foreground} pixels changed`);
    // A pixel over the atlas that a ray crosses the skull and then the atlas at.
    const top = await cameraAt();
    const [skullBox, atlasBox] = [partBounds[skull], partBounds[atlas]];
    let found = null;
    for (let i = 1; i < 8 && !found; ++i) {
      for (let j = 1; j < 8 && !found; ++j) {
        const ndc = toNdc(atlasRect.left + (i / 8) * (atlasRect.right - atlasRect.left), atlasRect.top + (j / 8) * (atlasRect.bottom - atlasRect.top));
        const [front, back] = [await pickAt(ndc, false), await pickAt(ndc, true)];
        if (front.part === skull && back.part === atlas) found = { front, back };
      }
    }
    assert.ok(found, 'a pixel where the ray crosses the skull, then the atlas');
    const { front, back } = found;
    assert.ok(inBox(front.point, skullBox), `skull point ${front.point}`);
    assert.ok(inBox(back.point, atlasBox), `atlas point ${back.point}`);
    assert.ok(distance(back.point, top) > distance(front.point, top), 'the atlas lies behind the skull');
    assert.ok(back.point[2] < front.point[2], 'seen from above, the atlas point is below the skull point');

    // What a change costs: setParts in the worker, its render() on the worker's thread, and
    // from the page's call to the frame drawn; opacity changes (a third of the parts and the
    // skull see-through, at another opacity each time), against colour changes of opaque parts.
    const cost = async (style) => {
      const changes = [];
      for (let k = 0; k < 4; ++k) {
        const t0 = performance.now();
        await page.evaluate((v) => window.osteon.setPartStyle(v), style(k));
        await page.waitForFunction(() => !window.osteon.framePending, null, { polling: 5 });
        const t1 = performance.now();
        const { partsMs, renderMs } = await page.evaluate(() => ({ partsMs: window.osteon.partsMs, renderMs: window.osteon.renderMs }));
        changes.push({ partsMs, renderMs, frameMs: t1 - t0 });
      }
      const median = (key) => changes.map((c) => c[key]).sort((a, b) => a - b)[changes.length >> 1];
      return { partsMs: median('partsMs'), renderMs: median('renderMs'), frameMs: median('frameMs') };
    };
    // The same parts at another opacity each time (a slider), and another third of them each time.
    const seeThrough = await cost((k) => ({ opacity: Array.from({ length: parts }, (_, p) => (p === skull || p % 3 === 0 ? 0.2 + 0.1 * k : 1)) }));
    const others = await cost((k) => ({ opacity: Array.from({ length: parts }, (_, p) => (p % 3 === k % 3 ? 0.5 : 1)) }));
    const recolour = await cost((k) => ({ colors: Array.from({ length: parts }, (_, p) => [(p + k) % 2, 0.5, 0.2]).flat() }));
    const triangles = site.m.components.reduce((sum, c) => sum + c.triangles, 0);
    const line = (c) => `setParts ${c.partsMs.toFixed(2)} ms + render() ${c.renderMs.toFixed(2)} ms in the worker, call to frame drawn ${c.frameMs.toFixed(1)} ms`;
    console.log(`# phantom of ${triangles} triangles (detail ${kDetail ?? 'default'}), ${parts} parts; medians of 4 changes`);
    console.log(`# opacity change, a third of the parts see-through: ${line(seeThrough)}`);
    console.log(`# another third see-through each time: ${line(others)}`);
    console.log(`# colour change, all opaque: ${line(recolour)}`);
    console.log(`# the first parts made see-through (new meshes and materials; the programs compiled once the skeleton was drawn): setParts ${first.partsMs.toFixed(2)} ms + render() ${first.renderMs.toFixed(2)} ms`);
    console.log(`# pick round trip on opaque bones: median ${pickTimes.sort((a, b) => a - b)[pickTimes.length >> 1].toFixed(1)} ms`);
    // What keeps a change cheap, whatever this machine's speed: once the first see-through part
    // has its programs, no change of opacity or colour links another or uploads a geometry.
    const gl = await page.evaluate(() => window.osteon.gl);
    assert.deepEqual(gl, first.gl, `WebGL objects after the first see-through part ${JSON.stringify(first.gl)}, after 12 changes ${JSON.stringify(gl)}`);
    assert.deepEqual(problems, []);
    await context.close();
  });
});
