// SPDX-License-Identifier: Apache-2.0
// The viewer's modules under Node, without a browser: the manifest reader against a package made
// by the real `osteon pack` (several chunk files) and against broken manifests; the chunk stream
// with fake fetch and decode (order, two chunks in flight, components handed over while their
// chunk is still arriving, failures kept to what they touch, shared ranges decoded once); the
// three.js scene (batches, mirrored winding, hiding packs instances out, picking maps back to
// parts) and the page's own count of what it draws; the camera fit.

import assert from 'node:assert/strict';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import { Group, Raycaster, Vector3 } from 'three';

import { defaultView, fitBox } from '../viewer/camera.mjs';
import { determinant3, drawInfo, drawStats, findPart, formatLength, parseManifest, transformBox } from '../viewer/manifest.mjs';
import { createPackageScene, flipWinding } from '../viewer/scene.mjs';
import { createChunkStream, planChunks } from '../viewer/stream.mjs';
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
    bad((j) => { j.version = 1; }, /manifest\.json: version: this viewer reads version 2, the package is version 1/);
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
});

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
