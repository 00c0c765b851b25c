// SPDX-License-Identifier: Apache-2.0
// The viewer's modules under Node, without a browser: the manifest reader against a package made
// by the real `osteon pack` (several chunk files) and against broken manifests; the chunk stream
// with fake fetch and decode (order, two chunks in flight, components handed over while their
// chunk is still arriving, failures kept to what they touch, shared ranges decoded once); the
// three.js scene (batches, mirrored winding, hiding packs instances out, picking maps back to
// parts, levels swapped on every batch) and the page's own count of what it draws; the camera
// fit; levels of detail: the planner (screen-space error, priorities, eviction, the budget), the
// loader with fake fetch, decoder and renderer (byte ranges, a host that ignores them, failures
// kept to their level), and version 2 packages loading as before.

import assert from 'node:assert/strict';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import { Group, PerspectiveCamera, Raycaster, Vector3 } from 'three';

import { defaultView, fitBox } from '../viewer/camera.mjs';
import { determinant3, drawInfo, drawStats, findPart, formatLength, kMaxEntries, parseManifest, transformBox } from '../viewer/manifest.mjs';
import { cameraMatrices } from '../viewer/first_frames.mjs';
import { createPackageScene, flipWinding } from '../viewer/scene.mjs';
import { createChunkStream, createChunkCache, fetchRange, planChunks } from '../viewer/stream.mjs';
import { createLevelLoader } from '../viewer/levels.mjs';
import {
  assignDrawn, createRecord, evictionOrder, frustumPlanes, gpuBytes, indexCopies, instanceSpheres, isRefined, multiply4,
  pixelsPerUnit, planLevels, projectedError, screenNeeds, sphereOutside, wantedLevel,
} from '../viewer/refine.mjs';
import { encodeViewState, parseCamera, parseViewState } from '../viewer/share.mjs';
import { budgetFromParams, budgetOf } from '../viewer/state.mjs';
import { cli, osteon } from './browser_helpers.mjs';

const skipCli = cli && existsSync(cli) ? false : 'the osteon CLI is not built (set OSTEON_CLI)';

/// A decoded mesh for `component` at `level` (default 0, its first): its bounding box as 12
/// triangles (shrunk towards the centre by `shrink`, so levels differ), then degenerate triangles
/// up to the manifest's triangle count for that level (the scene checks the count).
function fakeMesh(component, level = 0, shrink = 0) {
  const { min, max } = component.bounds;
  const mid = min.map((v, i) => (v + max[i]) / 2);
  const positions = new Float32Array(24);
  for (let v = 0; v < 8; ++v) positions.set([0, 1, 2].map((i) => mid[i] + (1 - shrink) * (((v >> i) & 1 ? max[i] : min[i]) - mid[i])), 3 * v);
  const box = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3];
  // 16-bit, as the viewer's decodes hand over the indices of a mesh this small.
  const indices = new Uint16Array(3 * component.levels[level].triangles);
  indices.set(box.slice(0, indices.length));
  return { positions, indices, normals: new Float32Array(24).fill(0.5) };
}

describe('manifest, scene and camera on a packed phantom', { skip: skipCli }, () => {
  let work;
  let json;

  before(() => {
    work = mkdtempSync(path.join(tmpdir(), 'osteon-viewer-unit-'));
    osteon('phantom', '-o', path.join(work, 'src'));
    // Small chunks, so the package has several.
    osteon('pack', path.join(work, 'src'), '-o', path.join(work, 'pkg'), '--no-viewer', '--chunk-bytes', '4000');
    json = JSON.parse(readFileSync(path.join(work, 'pkg', 'manifest.json'), 'utf8'));
  });
  after(() => work && rmSync(work, { recursive: true, force: true }));

  test('parseManifest reads every table and derives part boxes', () => {
    const m = parseManifest(json);
    assert.equal(m.parts.length, json.parts.length);
    assert.equal(m.components.length, json.components.length);
    assert.deepEqual(m.streamOrder.map((c) => c.id), json.stream_order);
    assert.ok(m.chunks.length > 2, `${m.chunks.length} chunks`);
    assert.equal(m.bytesTotal, json.chunks.reduce((s, c) => s + c.bytes, 0));
    for (const c of m.components) {
      assert.equal(c.file, json.chunks[c.chunk].file);
      assert.ok(c.offset + c.bytes <= m.chunks[c.chunk].bytes);
    }
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
    bad((j) => { j.version = 1; }, /manifest\.json: version: this viewer reads versions 2 and 3, the package is version 1/);
    bad((j) => { j.format = 'x'; }, /format/);
    bad((j) => { j.unit = 'furlong'; }, /unit/);
    bad((j) => { j.parts[3].prototype = 999; }, /parts\[3\]\.prototype: no part 999/);
    bad((j) => { delete j.chunks; }, /manifest\.json: chunks: expected an array/);
    bad((j) => { j.chunks[1].file = '../../etc/passwd'; }, /chunks\[1\]\.file: expected "c\/<24 lower-case hex digits>\.ostc"/);
    bad((j) => { j.chunks[1].file = 'https://elsewhere.example/c/0123456789abcdef01234567.ostc'; }, /chunks\[1\]\.file/);
    bad((j) => { j.chunks[1].file = j.chunks[1].file.toUpperCase(); }, /chunks\[1\]\.file/);
    bad((j) => { j.chunks[1].file = j.chunks[0].file; }, /chunks\[1\]\.file: .* appears twice/);
    bad((j) => { j.chunks[0].bytes = -1; }, /chunks\[0\]\.bytes: expected a count/);
    bad((j) => { j.components[1].chunk = j.chunks.length; }, /components\[1\]\.chunk: no chunk \d+/);
    bad((j) => { j.components[1].offset = 'x'; }, /components\[1\]\.offset: expected a count/);
    bad((j) => { j.components[1].offset = j.chunks[j.components[1].chunk].bytes; }, /components\[1\]\.bytes: bytes \d+-\d+ lie beyond the \d+ bytes of chunks\[\d+\]/);
    bad((j) => { j.components[1].bytes = 0; }, /components\[1\]\.bytes: expected at least one byte/);
    bad((j) => { j.instances[0].matrix = [1, 2]; }, /instances\[0\]\.matrix: expected 16 numbers/);
    bad((j) => { j.instances[0].matrix = new Array(16).fill(0); }, /singular/);
    bad((j) => { j.instances[0].component = 'c999'; }, /instances\[0\]\.component: no component "c999"/);
    bad((j) => { j.stream_order.pop(); }, /stream_order: misses/);
    bad((j) => { j.stream_order.push(j.stream_order[0]); }, /appears twice/);
    bad((j) => { j.bounds.min = [0, 0, 'x']; }, /bounds\.min\[2\]/);
    assert.throws(() => parseManifest([]), /top level/);
  });

  test('a manifest listing more than kMaxEntries is refused before its entries are read; an Infinity matrix refuses its instance alone', () => {
    const many = structuredClone(json);
    many.instances = new Array(kMaxEntries + 1).fill(null);
    assert.throws(() => parseManifest(many), new RegExp(`manifest\\.json: instances: ${kMaxEntries + 1} entries, this viewer reads at most ${kMaxEntries}`));
    const infinite = structuredClone(json);
    infinite.instances[1].matrix[13] = Infinity;  // JSON.parse reads 1e999 so
    const m = parseManifest(infinite);
    assert.deepEqual(m.refused, ['osteon: manifest.json: instances[1].matrix[13]: Infinity, not a finite number: the instance is not drawn']);
    assert.equal(m.instances.length, json.instances.length - 1);
    assert.deepEqual(m.instances.map((inst) => inst.index), m.instances.map((_, i) => i));
    assert.equal(m.instances[1].source, 2);
    assert.deepEqual([...m.instancesOf.values()].flat().sort((a, b) => a - b), m.instances.map((_, i) => i));
    for (const b of m.partBounds) assert.ok([...b.min, ...b.max].every(Number.isFinite));
  });

  test('the scene draws one Mesh per single use, InstancedMesh batches for repeats, mirrored ones apart', () => {
    const m = parseManifest(json);
    const root = new Group();
    const s = createPackageScene(m, root);
    for (const c of m.components) s.addComponent(c.id, fakeMesh(c));
    const stats = s.stats();
    assert.equal(stats.instances, m.instances.length);
    // Drawn at the first (coarsest) level, then at the full one.
    const atLevel = (pick) => m.instances.reduce((sum, i) => {
      const { levels } = m.componentById.get(i.component);
      return sum + levels[pick(levels)].triangles;
    }, 0);
    assert.equal(stats.triangles, atLevel(() => 0));
    for (const c of m.components) {
      for (let k = 1; k < c.levels.length; ++k) s.addLevel(c.id, k, fakeMesh(c, k));
      s.showLevel(c.id, c.levels.length - 1);
    }
    assert.equal(s.stats().triangles, m.parts.reduce((sum, p) => sum + p.triangles, 0));
    assert.equal(s.stats().triangles, atLevel((levels) => levels.length - 1));
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

  test('the page counts what the scene draws (drawStats, drawInfo) from the manifest alone', () => {
    const m = parseManifest(json);
    const s = createPackageScene(m, new Group());
    const loaded = new Set();
    const femur = findPart(m, 'femur_l').id;
    const checks = [() => true, (p) => p !== femur, (p) => p % 3 !== 0, () => false];
    const compare = () => {
      for (const visible of checks) {
        s.setVisibility(visible);
        assert.deepEqual(drawStats(m, loaded, visible), s.stats());
      }
      for (const part of m.parts) assert.deepEqual(drawInfo(m, part.id, loaded), s.drawInfo(part.id));
    };
    compare();
    // Half the components, then all.
    for (const [i, c] of m.streamOrder.entries()) {
      s.addComponent(c.id, fakeMesh(c));
      loaded.add(c.id);
      if (i === Math.floor(m.streamOrder.length / 2) || i === m.streamOrder.length - 1) compare();
    }
  });

  test('levels swap on every batch of a component: the mirrored one keeps its flipped winding, picks hit at every level, removed levels are disposed', () => {
    const m = parseManifest(json);
    const s = createPackageScene(m, new Group());
    for (const c of m.components) s.addComponent(c.id, fakeMesh(c));
    // The femurs: one component, two instances, the left one mirrored.
    const femur = findPart(m, 'femur_l');
    const id = m.instances[m.instancesOfPart[femur.id][0]].component;
    const c = m.componentById.get(id);
    assert.ok(c.levels.length >= 2, `${id} has ${c.levels.length} levels`);
    const batches = s.batches.filter((b) => b.component === id);
    assert.deepEqual(batches.map((b) => b.mirror).sort(), [false, true]);
    const box = m.partBounds[femur.id];
    const centre = new Vector3(...box.min.map((v, i) => (v + box.max[i]) / 2));
    const pick = () => {
      const hits = new Raycaster(centre.clone().add(new Vector3(0, -5000, 0)), new Vector3(0, 1, 0)).intersectObjects(s.pickable(), false);
      return hits.length ? m.parts[s.partOf(hits[0])].displayName : null;
    };
    const disposed = [];
    for (let k = 0; k < c.levels.length; ++k) {
      // Each level a smaller box: what is picked shows which geometry is drawn.
      if (k > 0) s.addLevel(id, k, fakeMesh(c, k, 0.1 * k));
      assert.equal(s.showLevel(id, k), k > 0);
      assert.equal(s.drawnLevel(id), k);
      const [plain, mirrored] = [batches.find((b) => !b.mirror), batches.find((b) => b.mirror)];
      assert.equal(plain.object.geometry.index.count, 3 * c.levels[k].triangles);
      assert.deepEqual(Array.from(plain.object.geometry.index.array.subarray(0, 3)), [0, 1, 3]);
      assert.deepEqual(Array.from(mirrored.object.geometry.index.array.subarray(0, 3)), [0, 3, 1]);
      assert.equal(plain.object.geometry.getAttribute('position'), mirrored.object.geometry.getAttribute('position'));
      assert.equal(plain.object.geometry.getAttribute('position').array[0], fakeMesh(c, k, 0.1 * k).positions[0]);
      assert.equal(pick(), 'femur_l', `picked at level ${k}`);
      plain.object.geometry.addEventListener('dispose', () => disposed.push(k));
    }
    assert.deepEqual(s.takeLevelChanges(), [[id, c.levels.length - 1]]);
    assert.deepEqual(s.drawInfo(femur.id).map((i) => i.level), [c.levels.length - 1]);
    // The GPU bytes the page estimates from the counts are the buffers the scene holds.
    const held = s.levelsHeld(id);
    const bytes = () => m.components.reduce((sum, x) => sum + s.levelsHeld(x.id)
      .reduce((t, k) => t + gpuBytes(8, x.levels[k].triangles, indexCopies(m, x.id)), 0), 0);
    assert.equal(s.gpuBytes(), bytes());
    // Removing the drawn level falls back to the next coarser one; the first level stays.
    const finest = held[held.length - 1];
    assert.ok(s.removeLevel(id, finest));
    assert.equal(s.drawnLevel(id), finest - 1);
    assert.deepEqual(disposed, [finest]);
    assert.equal(pick(), 'femur_l');
    assert.equal(s.removeLevel(id, 0), false, 'the first level is never removed');
    assert.equal(s.gpuBytes(), bytes());
    assert.throws(() => s.addLevel(id, finest, fakeMesh(c, finest - 1)), /decoded \d+ triangles, the manifest says/);
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
  test('the first frames see through the camera three.js would: its view and projection matrices', () => {
    const camera = new PerspectiveCamera(35, 1.6, 0.4, 9000);
    camera.position.set(120, -900, 310);
    camera.up.set(0, 0, 1);
    camera.lookAt(10, 20, 300);
    camera.updateMatrixWorld();
    const { view, projection } = cameraMatrices({
      position: camera.position.toArray(), quaternion: camera.quaternion.toArray(),
      fov: camera.fov, aspect: camera.aspect, near: camera.near, far: camera.far,
    });
    const close = (a, b, what) => a.forEach((v, i) => assert.ok(Math.abs(v - b[i]) <= 1e-4 * Math.max(1, Math.abs(b[i])), `${what}[${i}]: ${v} against ${b[i]}`));
    close(view, camera.matrixWorldInverse.elements, 'view');
    close(projection, camera.projectionMatrix.elements, 'projection');
  });

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

  test('the chunk stream reads chunks in order, two at a time, and hands each component over while its chunk still arrives', async () => {
    const { manifest, bytesOf } = fakePackage(6, 3, 10);
    const plan = planChunks(manifest, 'http://x/pkg/manifest.json');
    assert.deepEqual(plan.map((c) => c.url), manifest.chunks.map((c) => `http://x/pkg/${c.file}`));
    let inFlight = 0;
    let most = 0;
    const started = [];
    const readerDone = new Set();
    const decodedEarly = [];
    let lastReceived = 0;
    const stream = createChunkStream(plan, {
      fetchChunk: async (chunk) => {
        started.push(chunk.index);
        most = Math.max(most, ++inFlight);
        await tick();
        return fakeResponse(bytesOf(chunk.index), {
          pieceSize: 7,
          onEnd: () => {
            --inFlight;
            readerDone.add(chunk.index);
          },
        });
      },
      decode: async (buffer, range) => {
        assert.ok(buffer instanceof ArrayBuffer);
        assert.equal(buffer.byteLength, range.bytes);
        const chunk = range.components[0].chunk;
        assert.deepEqual(new Uint8Array(buffer), bytesOf(chunk).subarray(range.offset, range.end));
        if (!readerDone.has(chunk)) decodedEarly.push(range.components[0].id);
        return { ids: range.components.map((c) => c.id) };
      },
      onReceived: (range, at, bytesReceived) => {
        assert.ok(bytesReceived > lastReceived);
        lastReceived = bytesReceived;
      },
      onFailed: (range, message) => assert.fail(message),
    });
    await stream.run();
    assert.deepEqual(started, [0, 1, 2, 3, 4, 5]);
    assert.equal(most, 2);
    assert.equal(lastReceived, 6 * 30);
    // The first component of every chunk is complete after two 7-byte pieces of a 30-byte chunk.
    for (let k = 0; k < 6; ++k) assert.ok(decodedEarly.includes(`c${3 * k}`), `c${3 * k} decoded while chunk ${k} arrived`);
  });

  test('failures stay with what they touch: an HTTP error or a lost connection fails the rest of its chunk, a short chunk its missing components, a bad stream itself', async () => {
    const { manifest, bytesOf } = fakePackage(6, 3, 10);
    const plan = planChunks(manifest);
    const failed = new Map();
    const decoded = [];
    await createChunkStream(plan, {
      fetchChunk: async (chunk) => {
        await tick();
        switch (chunk.index) {
          case 1: return { ok: false, status: 404, statusText: 'Not Found' };
          case 2: return fakeResponse(bytesOf(2).subarray(0, 15), { pieceSize: 5 });
          case 3: return fakeResponse(bytesOf(3), { pieceSize: 6, breakAfter: 12 });
          case 4: throw new TypeError('Failed to fetch');
          default: return fakeResponse(bytesOf(chunk.index), { pieceSize: 8 });
        }
      },
      decode: async (buffer, range) => {
        await tick();
        if (range.components[0].id === 'c1') throw new Error(`osteon: ${range.label}: checksum mismatch: the stream is corrupt (byte 3)`);
        decoded.push(range.components[0].id);
        return {};
      },
      onFailed: (range, message) => {
        for (const c of range.components) failed.set(c.id, message);
      },
    }).run();
    const file = (k) => manifest.chunks[k].file;
    assert.match(failed.get('c1'), /^osteon: c\/0{23}0\.ostc \(component c1, bytes 10-20\): checksum mismatch/);
    for (const id of ['c3', 'c4', 'c5']) {
      const at = (Number(id.slice(1)) - 3) * 10;
      assert.equal(failed.get(id), `osteon: ${file(1)} (component ${id}, bytes ${at}-${at + 10}): HTTP 404 Not Found`);
    }
    assert.ok(!failed.has('c6'));
    for (const id of ['c7', 'c8']) assert.match(failed.get(id), /^osteon: c\/0{23}2\.ostc \(component c\d, bytes \d+-\d+\): 15 bytes, the manifest says 30$/);
    assert.ok(!failed.has('c9'));
    for (const id of ['c10', 'c11']) assert.match(failed.get(id), /c\/0{23}3\.ostc .*: the download broke off after 12 of 30 bytes: connection reset$/);
    for (const id of ['c12', 'c13', 'c14']) assert.match(failed.get(id), /c\/0{23}4\.ostc .*: fetch failed: Failed to fetch$/);
    assert.equal(failed.size, 1 + 3 + 2 + 2 + 3);
    assert.deepEqual(decoded.sort(), ['c0', 'c15', 'c16', 'c17', 'c2', 'c6', 'c9']);
  });

  test('components sharing a byte range are decoded once; a chunk nobody uses is not fetched; a long chunk and a body without streams', async () => {
    const { manifest, bytesOf } = fakePackage(3, 2, 10);
    // c5 repeats c4's bytes (the same chunk, offset and length); chunk 1 is then left unused.
    manifest.components[5].chunk = 2;
    manifest.components[5].offset = 0;
    manifest.components[2].chunk = 0;
    manifest.components[2].offset = 0;
    manifest.components[3].chunk = 0;
    manifest.components[3].offset = 10;
    const plan = planChunks(manifest);
    assert.deepEqual(plan.map((c) => c.index), [0, 2]);
    assert.deepEqual(plan[0].ranges.map((r) => r.components.map((c) => c.id)), [['c0', 'c2'], ['c1', 'c3']]);
    assert.equal(plan[0].ranges[0].label, `${manifest.chunks[0].file} (components c0, c2, bytes 0-10)`);
    const decodes = [];
    const chunkErrors = [];
    await createChunkStream(plan, {
      fetchChunk: async (chunk) => (chunk.index === 0
        ? { ok: true, status: 200, arrayBuffer: async () => bytesOf(0).slice().buffer }  // no body stream
        : fakeResponse(new Uint8Array([...bytesOf(2), 1, 2, 3]), { pieceSize: 9 })),
      decode: async (buffer, range) => {
        decodes.push(range.components.map((c) => c.id).join('+'));
        return {};
      },
      onFailed: (range, message) => assert.fail(message),
      onChunkError: (chunk, message) => chunkErrors.push(message),
    }).run();
    assert.deepEqual(decodes, ['c0+c2', 'c1+c3', 'c4+c5']);
    assert.deepEqual(chunkErrors, [`osteon: ${manifest.chunks[2].file}: more than the 20 bytes the manifest says`]);
  });
  test('a body that stalls fails its chunk\'s remaining ranges after stallMs; the next chunk still loads', async () => {
    const { manifest, bytesOf } = fakePackage(2, 2, 10);
    const failed = [];
    const decoded = [];
    let cancelled = 0;
    await createChunkStream(planChunks(manifest), {
      limit: 1,
      stallMs: 50,
      fetchChunk: async (chunk) => {
        if (chunk.index === 1) return fakeResponse(bytesOf(1), { pieceSize: 5 });
        let sent = false;
        return {
          ok: true,
          status: 200,
          body: {
            getReader: () => ({
              read: () => (sent ? new Promise(() => {}) : (sent = true, Promise.resolve({ done: false, value: bytesOf(0).subarray(0, 12) }))),
              cancel: async () => { ++cancelled; },
            }),
          },
        };
      },
      decode: async (buffer, range) => {
        decoded.push(range.components[0].id);
        return {};
      },
      onFailed: (range, message) => failed.push(message),
    }).run();
    assert.deepEqual(decoded, ['c0', 'c2', 'c3']);
    assert.deepEqual(failed, [`osteon: ${manifest.chunks[0].file} (component c1, bytes 10-20): the download broke off after 12 of 20 bytes: no byte for 0.05 s`]);
    assert.equal(cancelled, 1);
  });
});

describe('levels of detail', () => {
  test('the screen-space error: a length over the distance (clamped at near), in the drawing buffer\'s pixels', () => {
    const view = { fovDeg: 35, heightPx: 800, near: 0.1 };
    const perUnit = 800 / (2 * Math.tan((35 * Math.PI) / 360));
    assert.ok(Math.abs(pixelsPerUnit(35, 800) - perUnit) < 1e-9);
    assert.ok(Math.abs(projectedError(0.5, 100, view) - (0.5 * perUnit) / 100) < 1e-9);
    assert.ok(Math.abs(projectedError(0.5, 200, view) - projectedError(0.5, 100, view) / 2) < 1e-9);
    assert.equal(projectedError(1, 0, { ...view, near: 2 }), perUnit / 2);
    assert.equal(projectedError(1, 1, { ...view, near: 2 }), perUnit / 2);
    assert.deepEqual(multiply4([...identity()], [...identity()]), identity());
  });

  test('the frustum keeps what is in front and within the view; needs take the coarsest level within one pixel, the finest instance\'s, nothing hidden, off screen or cut away', () => {
    const camera = cameraAt([0, -100, 0], [0, 0, 0]);
    const planes = frustumPlanes(multiply4(camera.projectionMatrix.elements, camera.matrixWorldInverse.elements));
    assert.equal(sphereOutside(planes, { center: [0, 0, 0], radius: 1 }), false);
    assert.equal(sphereOutside(planes, { center: [0, -200, 0], radius: 1 }), true, 'behind the camera');
    assert.equal(sphereOutside(planes, { center: [1000, 0, 0], radius: 1 }), true, 'far to the side');
    assert.equal(sphereOutside(planes, { center: [0, 0, 40], radius: 20 }), false, 'straddling the top plane');

    const m = parseManifest(levelPackage());
    const spheres = instanceSpheres(m);
    assert.deepEqual(spheres.map((x) => x.center), [[0, 0, 0], [100, 0, 0], [-100, 0, 0], [200, 0, 0]]);
    assert.ok(spheres.every((x) => Math.abs(x.radius - Math.sqrt(75)) < 1e-9 && x.scale === 1));
    const needsAt = (y, x = 0, options = {}, clip = null) => screenNeeds(m, spheres, viewOf(cameraAt([x, y, 0], [x, 0, 0]), 800, clip), options);
    // c0's errors: 2, 0.5, 0.05 (its bound); coarsest within 1 px beyond 2537 units, level 1 beyond 643.
    const far = needsAt(-3000);
    assert.deepEqual([...far.keys()].sort(), ['c0', 'c1', 'c2']);
    assert.equal(far.get('c0').target, 0);
    const expected = projectedError(2, Math.hypot(3000) - Math.sqrt(75), { fovDeg: 35, heightPx: 800, near: 0.1 });
    assert.ok(Math.abs(far.get('c0').pixels[0] - expected) < 1e-9);
    assert.equal(needsAt(-1000).get('c0').target, 1);
    assert.equal(needsAt(-100).get('c0').target, 2);
    assert.equal(needsAt(-100, 0, { maxPixelError: 1000 }).get('c0').target, 0);
    // Close to c0, the others are off screen.
    assert.deepEqual([...needsAt(-30).keys()], ['c0']);
    // c1 is drawn by two instances: the nearer one decides.
    const right = needsAt(-60, 100);
    assert.deepEqual([...right.keys()], ['c1']);
    assert.equal(right.get('c1').target, 1);
    assert.ok(right.get('c1').pixels[0] > needsAt(-3000).get('c1').pixels[0]);
    // Hidden parts and what the clipping plane cuts away need nothing.
    assert.deepEqual([...needsAt(-3000, 0, { shown: (i) => i !== 0 }).keys()].sort(), ['c1', 'c2']);
    const clipped = needsAt(-3000, 0, {}, { normal: [1, 0, 0], constant: -50 });
    assert.deepEqual([...clipped.keys()].sort(), ['c1', 'c2']);
    const onlyLeft = needsAt(-3000, 0, { shown: (i) => i === 2 });
    assert.deepEqual([...onlyLeft.keys()], ['c1']);
  });

  test('priorities: the worst-looking component on screen first, the level it needs fetched directly, a few at a time', () => {
    const m = parseManifest(levelPackage());
    const [c0, c1] = records(m);
    const needs = new Map([
      ['c0', { pixels: [10, 3, 0.3], target: 2 }],
      ['c1', { pixels: [20, 0.9], target: 1 }],
    ]);
    const big = { bytes: 1e9, triangles: 1e9 };
    assert.deepEqual(planLevels([c0, c1], needs, big, { slots: 1 }).fetch.map((f) => [f.id, f.level]), [['c1', 1]]);
    assert.deepEqual(planLevels([c0, c1], needs, big, { slots: 3 }).fetch.map((f) => [f.id, f.level]), [['c1', 1], ['c0', 2]]);
    // Beyond the slots, more go while the stream bytes in flight stay small, in the same order.
    const small = (options) => planLevels([c0, c1], needs, big, options).fetch.map((f) => [f.id, f.level, f.streamBytes]);
    const [b1, b2] = [c1.levels[1].bytes, c0.levels[2].bytes];
    assert.deepEqual(small({ slots: 1, moreSlots: 1, smallBytes: b1 + b2 }), [['c1', 1, b1], ['c0', 2, b2]]);
    assert.deepEqual(small({ slots: 1, moreSlots: 1, smallBytes: b1 + b2 - 1 }), [['c1', 1, b1]]);
    assert.deepEqual(small({ slots: 0, moreSlots: 2, smallBytes: b1 + b2 }), [['c1', 1, b1], ['c0', 2, b2]]);
    assert.deepEqual(small({ slots: 0, moreSlots: 2, streamBytes: 1, smallBytes: b1 }), [], 'the first in order does not fit: none goes');
    assert.deepEqual(small({ slots: 0, moreSlots: 1, smallBytes: 1e9 }), [['c1', 1, b1]]);
    // The priority is the error of what is drawn now: c1 drawn at its finest needs nothing.
    c1.resident.set(1, { bytes: c1.gpu[1], lastVisible: 0 });
    const plan = planLevels([c0, c1], needs, big, { slots: 3 });
    assert.deepEqual(plan.fetch.map((f) => [f.id, f.level]), [['c0', 2]]);
    assert.equal(plan.drawn.get('c1'), 1);
    // In flight: not asked again.
    c0.pending = 2;
    assert.deepEqual(planLevels([c0, c1], needs, big, { slots: 3 }).fetch, []);
    c0.pending = null;
    // A failed level is not asked again; the next best is.
    c0.failed.add(2);
    assert.equal(wantedLevel(c0, 2), 1);
    c0.failed.add(1);
    assert.equal(wantedLevel(c0, 2), -1);
    assert.equal(isRefined([c0], needs, () => 0), true, 'at its finest level that did not fail');
    c0.failed.clear();
    assert.equal(isRefined([c0], needs, () => 1), false);
    assert.equal(isRefined([c0], needs, () => 2), true);
  });

  test('eviction: the coarsest level never, levels drawn on screen last, the least recently seen first', () => {
    const m = parseManifest(levelPackage());
    const [c0, c1] = records(m);
    c0.resident.set(1, { bytes: 100, lastVisible: 50 });
    c0.resident.set(2, { bytes: 300, lastVisible: 10 });
    c1.resident.set(1, { bytes: 200, lastVisible: 30 });
    const order = (needs, drawnOf) => evictionOrder([c0, c1], needs, drawnOf).map((v) => `${v.rec.id}/${v.level}${v.inUse ? '*' : ''}`);
    // Nothing on screen: by last sight.
    assert.deepEqual(order(new Map(), () => 0), ['c0/2', 'c1/1', 'c0/1']);
    // c0 on screen drawn at level 2: that one goes last.
    const needs = new Map([['c0', { pixels: [9, 3, 1], target: 2 }]]);
    assert.deepEqual(order(needs, (r) => (r.id === 'c0' ? 2 : 0)), ['c1/1', 'c0/1', 'c0/2*']);
    // Planning for c1 with room for its level only after an eviction: the unseen c0 level goes, not the one drawn.
    const base = c0.resident.get(0).bytes + c1.resident.get(0).bytes;
    c0.drawn = 2;
    c1.resident.delete(1);
    const plan = planLevels([c0, c1], new Map([...needs, ['c1', { pixels: [5, 0.5], target: 1 }]]),
      { bytes: base + 400 + c1.gpu[1] - 100, triangles: 1e9 }, { slots: 2 });
    assert.deepEqual(plan.fetch.map((f) => [f.id, f.level]), [['c1', 1]]);
    assert.deepEqual(plan.evict.map((e) => [e.id, e.level]), [['c0', 1]]);
    assert.equal(plan.drawn.get('c0'), 2);
    assert.ok(plan.bytes + c1.gpu[1] <= base + 400 + c1.gpu[1] - 100);
    // The budget lowered below what is drawn: the drawn level goes too, and c0 falls back.
    const low = planLevels([c0, c1], needs, { bytes: base + 50, triangles: 1e9 });
    assert.deepEqual(low.evict.map((e) => [e.id, e.level]).sort(), [['c0', 1], ['c0', 2]]);
    assert.equal(low.drawn.get('c0'), 0);
  });

  test('the triangle budget: drawn levels fit it, the largest errors served first; the coarsest levels always drawn', () => {
    const m = parseManifest(levelPackage());
    const [c0, c1, c2] = records(m);
    for (const l of [1, 2]) c0.resident.set(l, { bytes: 1, lastVisible: 0 });
    c1.resident.set(1, { bytes: 1, lastVisible: 0 });
    const needs = new Map([['c0', { pixels: [9, 3, 0.1], target: 2 }], ['c1', { pixels: [20, 0.5], target: 1 }]]);
    const base = 40 + 2 * 100 + 50;
    assert.deepEqual([...assignDrawn([c0, c1, c2], needs, 1e9).drawn], [['c0', 2], ['c1', 1], ['c2', 0]]);
    // Room for c1's full level (2 instances x 300 more) and c0's level 1 (120 more), not its level 2.
    const fit = assignDrawn([c0, c1, c2], needs, base + 600 + 120);
    assert.deepEqual([...fit.drawn], [['c0', 1], ['c1', 1], ['c2', 0]]);
    assert.equal(fit.triangles, base + 720);
    assert.deepEqual([...assignDrawn([c0, c1, c2], needs, 10).drawn], [['c0', 0], ['c1', 0], ['c2', 0]]);
    // Off screen: the coarsest.
    assert.deepEqual([...assignDrawn([c0, c1, c2], new Map(), 1e9).drawn], [['c0', 0], ['c1', 0], ['c2', 0]]);
    // A fetch whose triangles would not fit is not started; a coarser one that fits is.
    c0.resident.delete(2);
    c0.resident.delete(1);
    const plan = planLevels([c0, c1, c2], needs, { bytes: 1e9, triangles: base + 600 + 120 }, { slots: 2 });
    assert.deepEqual(plan.fetch.map((f) => [f.id, f.level]), [['c0', 1]]);
  });

  test('whatever the views and budgets, resident bytes and drawn triangles stay within the budget (beyond the coarsest levels)', async () => {
    const m = parseManifest(levelPackage());
    let seed = 7;
    const random = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
    const { loader, renderer, flush } = fakeLoader(m);
    const base = { bytes: loader.report.gpuBytes, triangles: loader.report.gpuTriangles };
    loader.start(0);
    let fetched = 0;
    for (let step = 0; step < 150; ++step) {
      if (step % 3 === 0) {
        loader.setBudget({ bytes: base.bytes + Math.floor(random() * 30000), triangles: base.triangles + Math.floor(random() * 1300) });
      }
      const x = -150 + 400 * random();
      loader.setView(viewOf(cameraAt([x, -20 - 1500 * random() ** 2, 0], [x, 0, 0])));
      await flush();
      renderer.frame();
      const { report } = loader;
      assert.ok(report.gpuBytes <= Math.max(report.budget.bytes, base.bytes), `step ${step}: ${report.gpuBytes} bytes, budget ${report.budget.bytes}`);
      assert.ok(report.gpuBytesPeak <= Math.max(report.budget.bytes, base.bytes));
      assert.ok(report.gpuTriangles <= Math.max(report.budget.triangles, base.triangles), `step ${step}: ${report.gpuTriangles} triangles`);
      assert.equal(report.gpuBytes, renderer.bytes(), 'the page counts what the renderer holds');
      fetched = report.levelLog.length;
    }
    console.log(`# budget walk: ${fetched} level fetches, ${loader.report.evictions} evictions`);
    assert.ok(fetched > 5, `${fetched} level fetches`);
    assert.ok(loader.report.evictions > 0, 'some levels were evicted');
  });

  test('the loader: byte ranges for what the view needs, the level swapped in, refined once shown; off screen back to the coarsest', async () => {
    const m = parseManifest(levelPackage());
    const { loader, renderer, flush, requests, messages } = fakeLoader(m);
    assert.equal(loader.hasLevels, true);
    assert.equal(loader.report.levelsTotal, 3 + 2 + 1);
    assert.equal(loader.report.levelsLoaded, 3);
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    assert.equal(requests.length, 0, 'nothing before start');
    loader.start(5);
    await flush();
    const c0 = m.componentById.get('c0');
    assert.deepEqual(requests, [`${m.chunks[1].file} bytes=${c0.levels[2].offset}-${c0.levels[2].offset + c0.levels[2].bytes - 1}`]);
    assert.equal(loader.report.refinedMs, null, 'not refined until the renderer shows it');
    assert.equal(loader.report.refineIdle, false);
    renderer.frame(42);
    assert.equal(loader.report.levelDrawn.c0, 2);
    assert.equal(loader.report.refinedMs, 42);
    assert.equal(loader.report.firstRefinedMs, 42);
    assert.equal(loader.report.refineIdle, true);
    const log = loader.report.levelLog;
    assert.deepEqual(log.map((e) => [e.id, e.level, e.status, e.received, e.shownAt]), [['c0', 2, 206, c0.levels[2].bytes, 42]]);
    assert.equal(loader.report.levelBytesLoaded, c0.levels[2].bytes);
    assert.equal(loader.report.gpuBytes, renderer.bytes());
    // To c1: it refines, c0 (off screen) is drawn at its coarsest again, its level kept.
    loader.setView(viewOf(cameraAt([100, -60, 0], [100, 0, 0])));
    await flush();
    renderer.frame(50);
    assert.deepEqual(loader.report.levelDrawn, { c0: 0, c1: 1, c2: 0 });
    assert.equal(loader.report.refinedMs, 50);
    assert.equal(loader.report.firstRefinedMs, 42);
    assert.ok(messages.some((x) => x.type === 'lod' && x.show.some(([id, l]) => id === 'c0' && l === 0)));
    assert.equal(renderer.held('c0').join(), '0,2');
    // Back: c0's level 2 is still resident, swapped in by the same plan, not fetched again.
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    assert.equal(renderer.pendingShow('c0'), 2);
    await flush();
    assert.equal(requests.length, 2);
  });

  test('the loader: with every first level sent and nothing drawn yet, the finer levels the view needs are fetched and swapped in; refined only once drawn', async () => {
    const m = parseManifest(levelPackage());
    const { loader, renderer, flush, requests, messages } = fakeLoader(m, { drawn: false });
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    assert.equal(requests.length, 0, 'nothing before the first levels are all sent');
    loader.allSent();
    await flush();
    const c0 = m.componentById.get('c0');
    assert.deepEqual(requests, [`${m.chunks[1].file} bytes=${c0.levels[2].offset}-${c0.levels[2].offset + c0.levels[2].bytes - 1}`]);
    assert.ok(messages.some((x) => x.type === 'lod' && x.show.some(([id, l]) => id === 'c0' && l === 2)), 'swapped in before the first frame');
    assert.equal(loader.report.refinedMs, null);
    assert.equal(loader.report.refineIdle, false, 'not idle before refinement has started');
    // The first frame draws every bone, c0 at its finer level: refined with it.
    loader.firstDrawn(m.components.map((c) => c.id));
    renderer.frame(30);
    assert.equal(loader.report.refinedMs, null, 'refinement starts with the whole skeleton drawn');
    loader.start(30);
    assert.equal(loader.report.levelDrawn.c0, 2);
    assert.equal(loader.report.refinedMs, 30);
    assert.equal(loader.report.refineIdle, true);
    await flush();
    assert.equal(requests.length, 1, 'nothing fetched twice');
  });

  test('a level that arrives after the view stopped needing it is held, not drawn, and refinement still settles', async () => {
    const m = parseManifest(levelPackage());
    const { loader, renderer, flush } = fakeLoader(m);
    loader.start(0);
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    loader.setView(viewOf(cameraAt([0, -5000, 0], [0, 0, 0])));  // before the level is in
    await flush();
    renderer.frame(3);
    assert.deepEqual(renderer.held('c0'), [0, 2]);
    assert.equal(loader.report.levelDrawn.c0, 0);
    assert.equal(loader.report.refineIdle, true);
    assert.notEqual(loader.report.refinedMs, null);
  });

  test('a host that ignores Range: the whole chunk once, the other levels sliced from the cache', async () => {
    const m = parseManifest(levelPackage());
    const { loader, renderer, flush, requests } = fakeLoader(m, { ignoreRange: true });
    loader.start(0);
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    await flush();
    loader.setView(viewOf(cameraAt([100, -60, 0], [100, 0, 0])));
    await flush();
    renderer.frame();
    assert.equal(requests.length, 1, requests.join('\n'));
    assert.deepEqual(loader.report.levelLog.map((e) => [e.id, e.level, e.status]), [['c0', 2, 200], ['c1', 1, 'cache']]);
    assert.equal(loader.report.levelBytesLoaded, m.chunks[1].bytes);
    assert.deepEqual(loader.report.levelDrawn, { c0: 0, c1: 1, c2: 0 });
  });

  test('a corrupt level or a failed fetch fails alone: reported, never asked again, the coarser level stays drawn', async () => {
    const m = parseManifest(levelPackage());
    const errors = [];
    const { loader, renderer, flush, requests } = fakeLoader(m, { corrupt: ['c0/2'], missing: ['c1/1'], onError: (e) => errors.push(e) });
    loader.start(0);
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    await flush();
    renderer.frame(7);
    const c0 = m.componentById.get('c0');
    assert.equal(errors.length, 1);
    assert.equal(errors[0], `osteon: ${m.chunks[1].file} (component c0, level 3 of 3, bytes ${c0.levels[2].offset}-${c0.levels[2].offset + c0.levels[2].bytes}): checksum mismatch: the stream is corrupt`);
    // Level 2 failed: the next best, level 1, came instead, and that is as good as it gets.
    assert.deepEqual(loader.report.levelLog.map((e) => [e.level, !!e.error]), [[2, true], [1, false]]);
    assert.equal(loader.report.levelDrawn.c0, 1);
    assert.equal(loader.report.levelsFailed, 1);
    assert.equal(loader.report.refinedMs, 7);
    loader.setView(viewOf(cameraAt([0, -90, 0], [0, 0, 0])));
    await flush();
    assert.equal(requests.length, 2, 'the failed level is not asked for again');
    loader.setView(viewOf(cameraAt([100, -60, 0], [100, 0, 0])));
    await flush();
    renderer.frame(8);
    assert.match(errors[1], /^osteon: c\/0{23}b\.ostc \(component c1, level 2 of 2, bytes \d+-\d+\): HTTP 404 Not Found$/);
    assert.equal(loader.report.levelDrawn.c1, 0);
    assert.equal(loader.report.levelsFailed, 2);
    // The renderer refusing a level counts the same.
    renderer.refuse('c0', 1);
    loader.failedInRenderer('c0', 1, 'osteon: ... decoded 3 triangles, the manifest says 160');
    await flush();
    renderer.frame(9);
    assert.equal(loader.report.levelDrawn.c0, 0);
    assert.equal(errors.length, 3);
    assert.equal(loader.report.gpuBytes, renderer.bytes());
  });

  test('lowering the budget evicts at once, shown levels after unseen ones, and the renderer falls back before disposing', async () => {
    const m = parseManifest(levelPackage());
    const { loader, renderer, flush, messages } = fakeLoader(m);
    const base = loader.report.gpuBytes;
    loader.start(0);
    loader.setView(viewOf(cameraAt([100, -60, 0], [100, 0, 0])));
    await flush();
    loader.setView(viewOf(cameraAt([0, -100, 0], [0, 0, 0])));
    await flush();
    renderer.frame(1);
    assert.deepEqual(loader.report.levelDrawn, { c0: 2, c1: 0, c2: 0 });
    const c1Full = loader.report.levelLog.find((e) => e.id === 'c1');
    assert.ok(c1Full && c1Full.evictedAt === null);
    // Room for c0's level 2 alone: c1's unseen level goes.
    const c0Full = renderer.levelBytes('c0', 2);
    messages.length = 0;
    assert.deepEqual(loader.setBudget({ bytes: base + c0Full }), { bytes: base + c0Full, triangles: 4e6 });
    assert.deepEqual(messages.filter((x) => x.type === 'lod').map((x) => x.evict), [[['c1', 1]]]);
    assert.equal(loader.report.gpuBytes, base + c0Full);
    assert.equal(loader.report.levelDrawn.c0, 2);
    // Below that: the drawn level goes too, shown coarser first.
    messages.length = 0;
    loader.setBudget({ bytes: base });
    const lod = messages.find((x) => x.type === 'lod');
    assert.deepEqual(lod.show, [['c0', 0]]);
    assert.deepEqual(lod.evict, [['c0', 2]]);
    await flush();
    renderer.frame(2);
    assert.equal(loader.report.gpuBytes, base);
    assert.equal(loader.report.levelDrawn.c0, 0);
    assert.equal(loader.report.refinedMs, null, 'not refined: the budget holds it back');
    assert.equal(loader.report.refineIdle, true, 'and nothing more will come');
    assert.equal(loader.report.evictions, 2);
  });

  test('version 2 packages: no levels, the first stream is the component\'s, nothing refines', () => {
    const json = levelPackage();
    json.version = 2;
    for (const c of json.components) delete c.levels;
    // Only the full streams are left; c0 and c1 lie in chunk 1, c2 in chunk 0.
    const m = parseManifest(json);
    assert.ok(m.components.every((c) => c.levels.length === 1 && c.first === c.levels[0] && c.first.chunk === c.chunk && c.first.offset === c.offset));
    assert.deepEqual(planChunks(m).map((p) => [p.index, p.ranges.map((r) => r.components.map((c) => c.id).join())]), [[0, ['c2']], [1, ['c0', 'c1']]]);
    const { loader } = fakeLoader(m);
    assert.equal(loader.hasLevels, false);
    assert.equal(loader.report.refineIdle, true);
    loader.start(12);
    assert.equal(loader.report.refinedMs, 12);
    assert.equal(loader.report.levelsLoaded, 3);
    assert.equal(loader.report.levelsTotal, 3);
    // Version 3: the first streams alone are streamed.
    const v3 = parseManifest(levelPackage());
    assert.deepEqual(planChunks(v3).map((p) => [p.index, p.ranges.map((r) => r.components.map((c) => `${c.id}@${r.offset}`).join())]), [[0, ['c0@0', 'c1@20', 'c2@40']]]);
  });

  test('fetchRange: 206 checked against the range asked, 200 cached whole, errors said plainly; the chunk cache keeps the most recent', async () => {
    const chunk = { url: 'http://x/c/a.ostc', file: 'c/a.ostc', bytes: 10 };
    const whole = Uint8Array.from({ length: 10 }, (_, i) => i);
    const answer = (status, body, headers = {}) => async () => ({
      ok: status < 300, status, statusText: status === 404 ? 'Not Found' : '',
      headers: { get: (k) => headers[k] ?? null }, arrayBuffer: async () => body.slice().buffer,
    });
    let got = await fetchRange(chunk, 2, 3, { fetch: answer(206, whole.slice(2, 5), { 'Content-Range': 'bytes 2-4/10' }) });
    assert.deepEqual([...got.data], [2, 3, 4]);
    assert.equal(got.status, 206);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: answer(206, whole.slice(3, 6), { 'Content-Range': 'bytes 3-5/10' }) }), /the host sent bytes 3-5, not bytes 2-4/);
    // An answer cut short is continued where it stopped, past the browser's cache.
    const asked = [];
    const rangeHost = async (url, init) => {
      asked.push([init.headers.Range, init.cache ?? 'default']);
      const [, a, b] = /bytes=(\d+)-(\d+)/.exec(init.headers.Range).map(Number);
      const body = asked.length === 1 ? whole.slice(a, a + 2) : whole.slice(a, b + 1);
      return answer(206, body, { 'Content-Range': `bytes ${a}-${b}/10` })();
    };
    got = await fetchRange(chunk, 2, 5, { fetch: rangeHost });
    assert.deepEqual([...got.data], [2, 3, 4, 5, 6]);
    assert.deepEqual(asked, [['bytes=2-6', 'default'], ['bytes=4-6', 'no-store']]);
    assert.equal(got.received, 5);
    assert.equal(got.requests, 2);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: answer(206, new Uint8Array()) }), /0 bytes in the answers, the range has 3/);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: answer(206, whole.slice(2, 6)) }), /4 bytes in the answer, the range has 3/);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: answer(404, new Uint8Array()) }), /^Error: HTTP 404 Not Found$/);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: async () => { throw new TypeError('Failed to fetch'); } }), /fetch failed: Failed to fetch/);
    await assert.rejects(fetchRange(chunk, 2, 3, { fetch: answer(200, whole.slice(0, 9)) }), /9 bytes, the manifest says 10/);
    const cache = createChunkCache(25);
    got = await fetchRange(chunk, 2, 3, { fetch: answer(200, whole), cache });
    assert.deepEqual([got.status, [...got.data]], [200, [2, 3, 4]]);
    got = await fetchRange(chunk, 7, 3, { fetch: () => assert.fail('fetched again'), cache });
    assert.deepEqual([got.status, [...got.data], got.received], ['cache', [7, 8, 9], 0]);
    got.data[0] = 99;
    assert.equal(cache.get('c/a.ostc')[7], 7, 'a slice is a copy');
    cache.put('c/b.ostc', new Uint8Array(10));
    cache.get('c/a.ostc');
    cache.put('c/c.ostc', new Uint8Array(10));
    assert.ok(cache.get('c/a.ostc') && cache.get('c/c.ostc') && !cache.get('c/b.ostc'));
    assert.equal(cache.bytes, 20);
  });

  test('the memory budget from the page\'s URL', () => {
    assert.deepEqual(budgetFromParams(new URLSearchParams('?budgetMB=64&budgetTriangles=500000')), { bytes: 64e6, triangles: 500000 });
    assert.deepEqual(budgetFromParams(new URLSearchParams('?budgetMB=0.5')), { bytes: 500000 });
    assert.deepEqual(budgetFromParams(new URLSearchParams('?budgetMB=lots&budgetTriangles=-1')), {});
  });
});

const identity = () => [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];

/// A camera at `position` looking at `target`, Z up, 35 degrees, 3:2.
function cameraAt(position, target) {
  const camera = new PerspectiveCamera(35, 1.5, 0.1, 100000);
  camera.up.set(0, 0, 1);
  camera.position.set(...position);
  camera.lookAt(...target);
  camera.updateMatrixWorld();
  return camera;
}

/// What the page's view.mjs planView hands the planner.
function viewOf(camera, heightPx = 800, clip = null) {
  camera.updateMatrixWorld();
  return {
    position: camera.position.toArray(),
    projection: camera.projectionMatrix.elements,
    view: camera.matrixWorldInverse.elements,
    fovDeg: camera.fov,
    near: camera.near,
    heightPx,
    clip,
  };
}

/// The planner's records of every component of `m`, each with its first level resident.
function records(m) {
  return m.components.map((c) => {
    const rec = createRecord(m, c);
    rec.resident.set(0, { bytes: rec.gpu[0], lastVisible: 0 });
    return rec;
  });
}

/// A hand-made version 3 package of 10-unit boxes along X: part "single" (c0: 3 levels, errors 2,
/// 0.5 and its bound 0.05; at x = 0), "right" and "left" (c1: 2 levels, error 1 then 0.05; at
/// x = 100 and, mirrored, x = -100), "small" (c2: no levels; at x = 200). Chunk 0 holds the first
/// streams (20 bytes each), chunk 1 the finer ones (30 bytes each). A stream's first two bytes are
/// its component's index and level (fakeLoader's decoder reads them).
function levelPackage() {
  const specs = [
    { levels: [[40, 24, 2], [160, 90, 0.5]], full: [640, 330] },
    { levels: [[100, 60, 1]], full: [400, 210] },
    { levels: [], full: [50, 30] },
  ];
  const chunks = [[], []];
  const place = (k, ci, level) => {
    const size = k === 0 ? 20 : 30;
    const offset = chunks[k].length;
    chunks[k].push(ci, level, ...Array.from({ length: size - 2 }, (_, i) => (ci * 31 + level * 7 + i) & 255));
    return { chunk: k, offset, bytes: size };
  };
  const components = specs.map((spec, ci) => ({
    id: `c${ci}`, triangles: spec.full[0], vertices: spec.full[1],
    bounds: { min: [-5, -5, -5], max: [5, 5, 5] }, error_bound: 0.05,
    levels: spec.levels.map(([triangles, vertices, error], level) => ({ ...place(level === 0 ? 0 : 1, ci, level), triangles, vertices, error })),
  }));
  components.forEach((c, ci) => Object.assign(c, place(specs[ci].levels.length ? 1 : 0, ci, specs[ci].levels.length)));
  for (const c of components) if (!c.levels.length) delete c.levels;
  const at = (x, mirror = false) => [mirror ? -1 : 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, 0, 1];
  const part = (id, name, triangles, prototype) => ({ id, name, display_name: name, group: '', source: `${name}.stl`, triangles, prototype });
  return {
    format: 'osteon-package', version: 3, unit: 'mm',
    bounds: { min: [-105, -5, -5], max: [205, 5, 5] },
    chunks: chunks.map((bytes, k) => ({ file: `c/${'0'.repeat(23)}${'ab'[k]}.ostc`, bytes: bytes.length, content: bytes })),
    parts: [part(0, 'single', 640, 0), part(1, 'right', 400, 1), part(2, 'left', 400, 1), part(3, 'small', 50, 3)],
    components,
    instances: [
      { part: 0, component: 'c0', matrix: at(0), mirror: false },
      { part: 1, component: 'c1', matrix: at(100), mirror: false },
      { part: 2, component: 'c1', matrix: at(-100, true), mirror: true },
      { part: 3, component: 'c2', matrix: at(200), mirror: false },
    ],
    stream_order: ['c0', 'c1', 'c2'],
  };
}

/// A level loader on manifest `m` (from levelPackage) with a fake host, decoder and renderer.
/// Every component's first level is sent, and drawn unless `drawn` is false. `ignoreRange`: the host answers 200 with the
/// whole chunk; `corrupt`, `missing`: 'c0/2' streams the decoder refuses, ranges the host has not.
/// Returns { loader, renderer (frame(at), bytes(), held(id), levelBytes(id, level),
/// pendingShow(id)), flush (waits for the fetches and decodes), requests ('file bytes=a-b'),
/// messages (to the renderer) }.
function fakeLoader(m, { ignoreRange = false, corrupt = [], missing = [], onError = () => {}, drawn: firstDrawn = true } = {}) {
  const json = levelPackage();
  const contentOf = new Map(json.chunks.map((c) => [c.file, Uint8Array.from(c.content)]));
  const requests = [];
  const messages = [];
  let inFlight = 0;
  const streamOf = (bytes) => {
    const c = m.components[bytes[0]];
    return { c, level: bytes[1] };
  };
  const meshOf = (c, level) => {
    const l = c.levels[level];
    return { positions: new Float32Array(3 * l.vertices), normals: new Float32Array(3 * l.vertices), indices: new Uint32Array(3 * l.triangles) };
  };
  // The renderer: levels held per component, the level drawn, changes since the last frame.
  const held = new Map(m.components.map((c) => [c.id, new Map()]));
  const drawn = new Map();
  const changes = new Map();
  let lastShow = new Map();
  const fetch = async (url, init) => {
    const file = url.slice(url.indexOf('c/'));
    const range = /bytes=(\d+)-(\d+)/.exec(init.headers.Range);
    requests.push(`${file} ${init.headers.Range}`);
    inFlight++;
    await tick();
    inFlight--;
    const content = contentOf.get(file);
    const [a, b] = [Number(range[1]), Number(range[2])];
    if (missing.includes(`${m.components[content[a]].id}/${content[a + 1]}`)) return { ok: false, status: 404, statusText: 'Not Found', headers: { get: () => null } };
    const body = ignoreRange ? content : content.slice(a, b + 1);
    return {
      ok: true, status: ignoreRange ? 200 : 206,
      headers: { get: (k) => (k === 'Content-Range' && !ignoreRange ? `bytes ${a}-${b}/${content.length}` : null) },
      arrayBuffer: async () => body.slice().buffer,
    };
  };
  const decode = async (buffer, label) => {
    inFlight++;
    await tick();
    inFlight--;
    const { c, level } = streamOf(new Uint8Array(buffer));
    if (corrupt.includes(`${c.id}/${level}`)) throw new Error(`osteon: ${label}: checksum mismatch: the stream is corrupt`);
    return meshOf(c, level);
  };
  const send = (message) => {
    messages.push(message);
    if (message.type === 'level') {
      for (const id of message.ids) {
        assert.ok(!held.get(id).has(message.level), `${id} level ${message.level} sent twice`);
        const mesh = message.mesh;
        held.get(id).set(message.level, gpuBytes(mesh.positions.length / 3, mesh.indices.length / 3, indexCopies(m, id)));
      }
    } else if (message.type === 'lod') {
      for (const [id, level] of message.show) {
        assert.ok(held.get(id).has(level), `${id} shown at level ${level}, which the renderer does not hold`);
        drawn.set(id, level);
        changes.set(id, level);
        lastShow.set(id, level);
      }
      for (const [id, level] of message.evict) {
        assert.notEqual(drawn.get(id), level, `${id} level ${level} disposed while drawn`);
        assert.notEqual(level, 0, 'the coarsest level is never evicted');
        held.get(id).delete(level);
      }
    }
  };
  const loader = createLevelLoader(m, { fetch, decode, send, onError, base: 'http://x/pkg/manifest.json', now: () => 0 });
  for (const c of m.components) {
    const mesh = meshOf(c, 0);
    held.get(c.id).set(0, gpuBytes(mesh.positions.length / 3, mesh.indices.length / 3, indexCopies(m, c.id)));
    drawn.set(c.id, 0);
    loader.firstSent([c.id], mesh);
  }
  if (firstDrawn) loader.firstDrawn(m.components.map((c) => c.id));
  const renderer = {
    frame(at = 0) {
      const list = [...changes];
      changes.clear();
      loader.shown(list, at);
    },
    bytes: () => [...held.values()].reduce((sum, levels) => sum + [...levels.values()].reduce((a, b) => a + b, 0), 0),
    held: (id) => [...held.get(id).keys()].sort((a, b) => a - b),
    levelBytes: (id, level) => held.get(id).get(level),
    pendingShow: (id) => lastShow.get(id),
    // The renderer refused a level it was sent: it holds nothing of it, and draws what it drew.
    refuse(id, level) {
      held.get(id).delete(level);
      if (drawn.get(id) === level) drawn.set(id, 0);
    },
  };
  const flush = async () => {
    for (let i = 0; i < 200; ++i) {
      await tick();
      if (inFlight === 0 && loader.report.levelLog.every((e) => e.error || e.decodedAt !== null)) {
        await tick();
        if (inFlight === 0) return;
      }
    }
    assert.fail('the loader did not settle');
  };
  return { loader, renderer, flush, requests, messages };
}

/// A package of `chunks` chunks of `perChunk` components of `size` bytes, in stream order, as
/// parseManifest returns it (the fields planChunks reads), with each chunk's bytes.
function fakePackage(chunks, perChunk, size) {
  const manifest = { chunks: [], components: [], streamOrder: [] };
  for (let k = 0; k < chunks; ++k) {
    manifest.chunks.push({ index: k, file: `c/${String(k).padStart(24, '0')}.ostc`, bytes: perChunk * size });
    for (let j = 0; j < perChunk; ++j) {
      const c = { id: `c${k * perChunk + j}`, chunk: k, offset: j * size, bytes: size };
      manifest.components.push(c);
      manifest.streamOrder.push(c);
    }
  }
  const bytesOf = (k) => Uint8Array.from({ length: perChunk * size }, (_, i) => (k * 31 + i) & 255);
  return { manifest, bytesOf };
}

const tick = () => new Promise((resolve) => setTimeout(resolve, 1));

/// A fetch Response whose body yields `bytes` in pieces of `pieceSize`, one a tick; with
/// `breakAfter`, the read after that many bytes rejects (a dropped connection).
function fakeResponse(bytes, { pieceSize, breakAfter = Infinity, onEnd = () => {} }) {
  let at = 0;
  return {
    ok: true,
    status: 200,
    body: {
      getReader: () => ({
        async read() {
          await tick();
          if (at >= breakAfter) {
            onEnd();
            throw new TypeError('connection reset');
          }
          if (at >= bytes.length) {
            onEnd();
            return { done: true, value: undefined };
          }
          const piece = bytes.slice(at, Math.min(bytes.length, at + pieceSize, breakAfter));
          at += piece.length;
          return { done: false, value: piece };
        },
        cancel: async () => onEnd(),
      }),
    },
  };
}

describe('share state (share.mjs)', () => {
  test('a view round-trips exactly: every double, names with separators, quotes and other scripts', () => {
    let seed = 12345;
    const random = () => {
      seed = (seed * 1103515245 + 12345) % 2147483648;
      return seed / 2147483648;
    };
    for (let k = 0; k < 200; ++k) {
      const value = () => (random() - 0.5) * 10 ** Math.floor(random() * 12 - 4);
      const view = {
        camera: { position: [value(), value(), value()], target: [value(), value(), value()], up: [value(), value(), 1 + random()], fov: 1 + random() * 170 },
        selected: k % 3 ? 'os frontale, pars "squamosa" & co, 50%' : null,
        hidden: k % 2 ? ['femur_l', 'a,b', 'ä/β=γ#', 'x&y'] : null,
        only: k % 2 ? null : ['skull', 'rib #1'],
        groupsOff: k % 4 ? ['left leg', 'arm,upper'] : [],
        clip: k % 5 ? {
          axis: k % 3, position: k % 1001, flip: k % 2 === 0,
          second: k % 7 ? { axis: (k + 1) % 3, position: (7 * k) % 1001, flip: k % 3 === 0 } : null,
          cap: k % 4 !== 1,
        } : null,
      };
      const text = encodeViewState(view);
      assert.doesNotMatch(text, /[ #"]/, 'URL-safe');
      const { view: back, errors } = parseViewState(`#${text}`);
      assert.deepEqual(errors, []);
      assert.deepEqual(back, { ...view, hidden: view.only ? null : view.hidden });
      assert.equal(encodeViewState(back), text);
    }
  });

  test('bad values are left out, each with a message; another version or none is ignored whole', () => {
    const { view, errors } = parseViewState('v=1&cam=1,2,x,4,5,6&sel=skull&clip=3,10,0&hide=%E0%A4%A,femur_l&zoom=2&sel=pelvis');
    assert.equal(view.camera, null);
    assert.equal(view.selected, 'skull');
    assert.equal(view.clip, null);
    assert.deepEqual(view.hidden, ['femur_l']);
    assert.equal(errors.length, 5, errors.join('\n'));
    for (const word of ['camera "1,2,x', 'clip "3,10,0"', 'not URL-encoded', '"zoom" is not a field', '"sel" is given twice']) {
      assert.ok(errors.some((e) => e.includes(word)), `${word}: ${errors}`);
    }
    assert.deepEqual(parseViewState('v=2&sel=skull'), { view: null, errors: ['version "2" is not 1: the view is ignored'] });
    assert.equal(parseViewState('sel=skull').view, null);
    assert.deepEqual(parseViewState(''), { view: null, errors: [] });
    assert.deepEqual(parseViewState('#'), { view: null, errors: [] });
    // The second plane and the cap setting need the first plane.
    const second = parseViewState('v=1&clip2=0,500,1&cap=0');
    assert.equal(second.view.clip, null);
    assert.match(second.errors.join('; '), /clip2: a second plane without "clip" is ignored/);
    assert.match(parseViewState('v=1&clip=0,1,0&cap=2').errors.join('; '), /cap "2": expected 0/);
    assert.deepEqual(parseViewState('v=1&clip=0,1,0&clip2=2,3,1&cap=0').view.clip,
      { axis: 0, position: 1, flip: false, second: { axis: 2, position: 3, flip: true }, cap: false });
    for (const clip of ['1,1001,0', '1,-1,0', '1,2.5,0', '1,2,2', '1,2', '']) {
      assert.equal(parseViewState(`v=1&clip=${clip}`).view.clip, null, clip);
    }
    assert.equal(parseViewState('v=1&only=').view.only, null);
    assert.equal(parseViewState('v=1&hide=a&only=b').view.hidden, null);
  });

  test('the camera attribute: position and target, then up, then the field of view', () => {
    assert.deepEqual(parseCamera('1,2,3,4,5,6'), { camera: { position: [1, 2, 3], target: [4, 5, 6], up: null, fov: null }, error: null });
    assert.deepEqual(parseCamera(' 1, 2,3,4,5,6,0,0,1 ').camera.up, [0, 0, 1]);
    assert.equal(parseCamera('1,2,3,4,5,6,0,0,1,50').camera.fov, 50);
    for (const bad of ['1,2,3,4,5', '1,2,3,4,5,6,7', '1,2,3,1,2,3', '1,2,3,4,5,6,0,0,0', '1,2,3,4,5,6,0,0,1,180', '1,2,3,4,5,6,0,0,1,0', 'a,b', '1,,3,4,5,6', 'Infinity,2,3,4,5,6']) {
      const { camera, error } = parseCamera(bad);
      assert.equal(camera, null, bad);
      assert.match(error, /^camera "/, bad);
    }
  });

  test('the budget from an element\'s attributes', () => {
    assert.deepEqual(budgetOf('64', '500000'), { bytes: 64e6, triangles: 500000 });
    assert.deepEqual(budgetOf(null, 'lots'), {});
    assert.deepEqual(budgetOf('-1', undefined), {});
  });
});
