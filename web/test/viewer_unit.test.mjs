// SPDX-License-Identifier: Apache-2.0
// The viewer's modules under Node, without a browser: the manifest reader against a package made
// by the real `osteon pack` and against broken manifests; the component stream with fake fetch
// and decode (order, bounded parallelism, progressive delivery, failures); the three.js scene
// (batches, mirrored winding, hiding packs instances out, picking maps back to parts); the camera fit.

import assert from 'node:assert/strict';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import { Group, Raycaster, Vector3 } from 'three';

import { defaultView, fitBox } from '../viewer/camera.mjs';
import { determinant3, findPart, formatLength, parseManifest, transformBox } from '../viewer/manifest.mjs';
import { createPackageScene, flipWinding } from '../viewer/scene.mjs';
import { createComponentStream, fetchComponent } from '../viewer/stream.mjs';
import { cli, osteon } from './browser_helpers.mjs';

const skipCli = cli && existsSync(cli) ? false : 'the osteon CLI is not built (set OSTEON_CLI)';

/// A decoded mesh for `component`: its bounding box as 12 triangles, then degenerate triangles up
/// to the manifest's triangle count (addComponent checks the count).
function fakeMesh(component) {
  const { min, max } = component.bounds;
  const positions = new Float32Array(24);
  for (let v = 0; v < 8; ++v) positions.set([0, 1, 2].map((i) => ((v >> i) & 1 ? max[i] : min[i])), 3 * v);
  const box = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3];
  const indices = new Uint32Array(3 * component.triangles);
  indices.set(box.slice(0, indices.length));
  return { positions, indices, normals: new Float32Array(24).fill(0.5) };
}

describe('manifest, scene and camera on a packed phantom', { skip: skipCli }, () => {
  let work;
  let json;

  before(() => {
    work = mkdtempSync(path.join(tmpdir(), 'osteon-viewer-unit-'));
    osteon('phantom', '-o', path.join(work, 'src'));
    osteon('pack', path.join(work, 'src'), '-o', path.join(work, 'pkg'),
      ...(osteon('pack', '--help').includes('--no-viewer') ? ['--no-viewer'] : []));
    json = JSON.parse(readFileSync(path.join(work, 'pkg', 'manifest.json'), 'utf8'));
  });
  after(() => work && rmSync(work, { recursive: true, force: true }));

  test('parseManifest reads every table and derives part boxes', () => {
    const m = parseManifest(json);
    assert.equal(m.parts.length, json.parts.length);
    assert.equal(m.components.length, json.components.length);
    assert.deepEqual(m.streamOrder.map((c) => c.id), json.stream_order);
    assert.equal(m.bytesTotal, json.components.reduce((s, c) => s + c.bytes, 0));
    for (const inst of m.instances) assert.equal(inst.mirror, json.instances[inst.index].mirror);
    // Every part's box lies inside the package's box (within float rounding).
    for (const box of m.partBounds) {
      for (let i = 0; i < 3; ++i) {
        assert.ok(box.min[i] >= m.bounds.min[i] - 1e-3 && box.max[i] <= m.bounds.max[i] + 1e-3);
      }
    }
    assert.equal(findPart(m, 'SKULL').displayName, 'skull');
    assert.equal(findPart(m, 'skull.stl').name, 'skull');
    assert.equal(findPart(m, 'no such bone'), null);
  });

  test('parseManifest names the bad field', () => {
    const bad = (edit, pattern) => {
      const copy = structuredClone(json);
      edit(copy);
      assert.throws(() => parseManifest(copy), pattern);
    };
    bad((j) => { j.version = 2; }, /manifest\.json: version: this viewer reads version 1/);
    bad((j) => { j.format = 'x'; }, /format/);
    bad((j) => { j.unit = 'furlong'; }, /unit/);
    bad((j) => { j.parts[3].prototype = 999; }, /parts\[3\]\.prototype: no part 999/);
    bad((j) => { j.components[1].file = '../../etc/passwd'; }, /components\[1\]\.file: not a relative path/);
    bad((j) => { j.components[1].file = 'https://elsewhere.example/x.ostm'; }, /components\[1\]\.file/);
    bad((j) => { j.instances[0].matrix = [1, 2]; }, /instances\[0\]\.matrix: expected 16 numbers/);
    bad((j) => { j.instances[0].matrix = new Array(16).fill(0); }, /singular/);
    bad((j) => { j.instances[0].component = 'c999'; }, /instances\[0\]\.component: no component "c999"/);
    bad((j) => { j.stream_order.pop(); }, /stream_order: misses/);
    bad((j) => { j.stream_order.push(j.stream_order[0]); }, /appears twice/);
    bad((j) => { j.bounds.min = [0, 0, 'x']; }, /bounds\.min\[2\]/);
    assert.throws(() => parseManifest([]), /top level/);
  });

  test('the scene draws one Mesh per single use, InstancedMesh batches for repeats, mirrored ones apart', () => {
    const m = parseManifest(json);
    const root = new Group();
    const s = createPackageScene(m, root);
    for (const c of m.components) s.addComponent(c.id, fakeMesh(c));
    const stats = s.stats();
    assert.equal(stats.instances, m.instances.length);
    assert.equal(stats.triangles, m.parts.reduce((sum, p) => sum + p.triangles, 0));
    for (const c of m.components) {
      const uses = m.instancesOf.get(c.id);
      const batches = s.batches.filter((b) => b.component === c.id);
      if (uses.length === 1) {
        assert.equal(batches.length, 1);
        assert.equal(batches[0].object.isInstancedMesh, undefined);
      } else {
        const mirrored = uses.filter((i) => m.instances[i].mirror).length;
        assert.equal(batches.length, (mirrored > 0) + (mirrored < uses.length));
        for (const b of batches) {
          assert.ok(b.object.isInstancedMesh);
          assert.ok(b.instances.every((i) => m.instances[i].mirror === b.mirror));
          // The mirrored batch's triangles run the other way round; positions are shared.
          const index = b.object.geometry.index.array;
          assert.deepEqual(Array.from(index.subarray(0, 3)), b.mirror ? [0, 3, 1] : [0, 1, 3]);
        }
        const [a, b] = batches;
        if (b) assert.equal(a.object.geometry.getAttribute('position'), b.object.geometry.getAttribute('position'));
      }
    }
    assert.throws(() => s.addComponent(m.components[0].id, fakeMesh(m.components[0])), /added twice/);
  });

  test('hiding packs instances out of a batch; a pick maps instanceId back to the part', () => {
    const m = parseManifest(json);
    const s = createPackageScene(m, new Group());
    for (const c of m.components) s.addComponent(c.id, fakeMesh(c));
    // A batch of three or more non-mirrored instances (the phantom's vertebrae).
    const batch = s.batches.find((b) => b.instanced && b.instances.length >= 3);
    assert.ok(batch, 'the phantom has a bone repeated three times');
    const [first, second] = batch.instances.map((i) => m.instances[i].part);
    s.setVisibility((p) => p !== first);
    assert.equal(batch.object.count, batch.instances.length - 1);
    assert.equal(s.partOf({ object: batch.object, instanceId: 0 }), second);
    assert.equal(s.stats().instances, m.instances.length - 1);
    s.setVisibility(() => false);
    assert.equal(s.stats().instances, 0);
    assert.equal(s.pickable().length, 0);
    s.setVisibility(() => true);
    assert.equal(s.partOf({ object: batch.object, instanceId: 0 }), first);

    // A real raycast from the front through the middle of the skull hits the skull.
    const part = m.parts.find((p) => p.displayName === 'skull');
    const box = m.partBounds[part.id];
    const centre = new Vector3(...box.min.map((v, i) => (v + box.max[i]) / 2));
    const ray = new Raycaster(centre.clone().add(new Vector3(0, -5000, 0)), new Vector3(0, 1, 0));
    s.setVisibility(() => true);
    const hits = ray.intersectObjects(s.pickable(), false);
    assert.ok(hits.length > 0);
    assert.equal(s.partOf(hits[0]), part.id);
  });

  test('the camera fits the package box, upright', () => {
    const m = parseManifest(json);
    const { eye, up } = defaultView(m.bounds);
    assert.deepEqual(up.toArray(), [0, 0, 1], 'the phantom stands along Z');
    const fit = fitBox(m.bounds, eye, up, 35, 1.5);
    // Every corner of the box projects inside the frustum.
    const forward = fit.target.clone().sub(fit.position).normalize();
    const right = new Vector3().crossVectors(forward, up).normalize();
    const trueUp = new Vector3().crossVectors(right, forward);
    const tanV = Math.tan((35 * Math.PI) / 360);
    for (let c = 0; c < 8; ++c) {
      const p = new Vector3(...[0, 1, 2].map((i) => ((c >> i) & 1 ? m.bounds.max[i] : m.bounds.min[i]))).sub(fit.position);
      const depth = p.dot(forward);
      assert.ok(depth > 0);
      assert.ok(Math.abs(p.dot(trueUp) / depth) <= tanV * 1.0001);
      assert.ok(Math.abs(p.dot(right) / depth) <= tanV * 1.5 * 1.0001);
    }
  });
});

describe('viewer helpers', () => {
  test('flipWinding swaps two corners of every triangle', () => {
    assert.deepEqual(Array.from(flipWinding(new Uint32Array([0, 1, 2, 3, 4, 5]))), [0, 2, 1, 3, 5, 4]);
  });

  test('a mirror matrix has a negative determinant; boxes transform by their corners', () => {
    const mirror = [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 10, 0, 0, 1];
    assert.equal(determinant3(mirror), -1);
    assert.deepEqual(transformBox({ min: [1, 2, 3], max: [2, 3, 4] }, mirror), { min: [8, 2, 3], max: [9, 3, 4] });
  });

  test('lengths carry the unit', () => {
    assert.equal(formatLength(0.004387, 'mm'), '0.00439 mm');
    assert.equal(formatLength(1684, 'mm'), '1684 mm');
    assert.equal(formatLength(0.5, 'unknown'), '0.500 units');
  });

  test('the stream fetches in order, at most `limit` at once, and decodes while fetching', async () => {
    const items = Array.from({ length: 20 }, (_, i) => ({ id: `c${i}`, file: `c/${i}.ostm`, bytes: 4 }));
    let clock = 0;
    let inFlight = 0;
    let most = 0;
    const decodedBeforeLastFetch = [];
    let fetchesDone = 0;
    const tick = () => new Promise((r) => setTimeout(r, 1));
    const stream = createComponentStream(items, {
      limit: 3,
      now: () => clock++,
      fetchBytes: async (item) => {
        most = Math.max(most, ++inFlight);
        await tick();
        await tick();
        --inFlight;
        ++fetchesDone;
        if (item.id === 'c13') throw new Error('osteon: c/13.ostm: HTTP 404');
        return new Uint8Array(4);
      },
      decode: async (bytes, item) => {
        await tick();
        if (item.id === 'c7') throw new Error(`osteon: ${item.file}: checksum mismatch`);
        return { item };
      },
      onDecoded: (item) => {
        if (fetchesDone < items.length) decodedBeforeLastFetch.push(item.id);
      },
    });
    await stream.run();
    const log = stream.log();
    assert.equal(most, 3);
    assert.deepEqual(log.map((e) => e.id), items.map((i) => i.id));
    for (let i = 1; i < log.length; ++i) assert.ok(log[i].fetchStart > log[i - 1].fetchStart);
    assert.equal(log[13].error, 'osteon: c/13.ostm: HTTP 404');
    assert.equal(log[7].error, 'osteon: c/7.ostm: checksum mismatch');
    assert.equal(log.filter((e) => e.error).length, 2);
    assert.ok(log.filter((e) => !e.error).every((e) => e.decodedAt > e.fetchEnd));
    assert.ok(decodedBeforeLastFetch.length > 0, 'components are decoded before the last fetch ends');
  });

  test('fetchComponent names the file on HTTP errors and size mismatches', async () => {
    const item = { url: 'http://x/c/a.ostm', file: 'c/a.ostm', bytes: 3 };
    const fake = (status, body) => async () => ({ ok: status === 200, status, statusText: '', arrayBuffer: async () => body });
    await assert.rejects(fetchComponent(item, fake(404)), /osteon: c\/a\.ostm: HTTP 404/);
    await assert.rejects(fetchComponent(item, fake(200, new ArrayBuffer(2))), /c\/a\.ostm: 2 bytes, the manifest says 3/);
    await assert.rejects(fetchComponent(item, async () => { throw new TypeError('Failed to fetch'); }), /c\/a\.ostm: fetch failed/);
    assert.equal((await fetchComponent(item, fake(200, new ArrayBuffer(3)))).length, 3);
  });
});
