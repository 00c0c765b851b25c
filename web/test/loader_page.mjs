// SPDX-License-Identifier: Apache-2.0
// The page test/loader.test.mjs loads in Chromium: a three.js scene of its own, outside any
// package, that imports `three` and `osteon` as an application does (bundled by esbuild, or
// through an import map), loads packages with OsteonLoader and answers the test's questions
// through window.loaderTest. Every Worker the page makes is counted (made, terminated).

import * as THREE from 'three';
import { OsteonLoader } from 'osteon';

const workers = { made: 0, terminated: 0 };
const NativeWorker = globalThis.Worker;
globalThis.Worker = class CountedWorker extends NativeWorker {
  constructor(...args) {
    super(...args);
    ++workers.made;
  }
  terminate() {
    if (!this.counted) {
      this.counted = true;
      ++workers.terminated;
    }
    super.terminate();
  }
};

const kWidth = 480;
const kHeight = 640;
const renderer = new THREE.WebGLRenderer({ antialias: false });
renderer.setSize(kWidth, kHeight);
document.body.append(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x000000);
const camera = new THREE.PerspectiveCamera(35, kWidth / kHeight, 1, 1e5);
const light = new THREE.DirectionalLight(0xffffff, 2.5);
scene.add(camera, new THREE.AmbientLight(0xffffff, 0.3));
camera.add(light);
light.position.set(0, 0, 1);
let current = null;  // { loader, group }

/// Looks at `bounds` from the front (-Y, Z up: the phantom's and BodyParts3D's axes).
function frame(bounds) {
  const min = new THREE.Vector3(...bounds.min);
  const max = new THREE.Vector3(...bounds.max);
  const centre = min.clone().add(max).multiplyScalar(0.5);
  const height = (max.z - min.z) * 1.15;
  const distance = height / 2 / Math.tan((35 * Math.PI) / 360) + (max.y - min.y);
  camera.up.set(0, 0, 1);
  camera.position.set(centre.x, min.y - distance, centre.z);
  camera.lookAt(centre);
  camera.near = distance / 100;
  camera.far = distance * 4;
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld();
}

function describe(object) {
  const { userData } = object;
  const count = object.isInstancedMesh ? object.count : 1;
  const dets = [];
  const m = new THREE.Matrix4();
  for (let i = 0; i < count; ++i) {
    if (object.isInstancedMesh) object.getMatrixAt(i, m);
    else m.copy(object.matrix);
    dets.push(m.determinant());
  }
  return {
    name: object.name,
    type: object.isInstancedMesh ? 'InstancedMesh' : 'Mesh',
    count,
    parts: userData.parts,
    partIds: userData.partIds,
    part: userData.part ?? null,
    mirror: userData.mirror,
    component: userData.component,
    level: userData.level,
    levels: userData.levels,
    triangles: object.geometry.index.count / 3,
    dets,
    indices: Array.from(object.geometry.index.array.subarray(0, 6)),
    sharesPositions: null,
  };
}

function summary(group, extra) {
  const objects = group.children.map(describe);
  // A mirrored batch must draw the kept batch's positions through a flipped copy of its index.
  group.children.forEach((o, k) => {
    const twin = group.children.find((t) => t !== o && t.userData.component === o.userData.component && t.userData.mirror !== o.userData.mirror);
    if (twin) objects[k].sharesPositions = twin.geometry.getAttribute('position') === o.geometry.getAttribute('position');
  });
  JSON.stringify(group.children[0]?.userData ?? {});  // userData stays plain data (clone(), toJSON())
  return { name: group.name, url: group.url, objects, ...extra, workers: { ...workers } };
}

/// Waits until every Worker made has been terminated (at most `ms`); returns the counts.
async function workersGone(ms = 3000) {
  const end = performance.now() + ms;
  while (workers.made !== workers.terminated && performance.now() < end) await new Promise((r) => setTimeout(r, 20));
  return { ...workers };
}

function makeLoader(options) {
  const loader = new OsteonLoader();
  if (options.decoderPath) loader.setDecoderPath(options.decoderPath);
  if (options.levels) loader.setLevels(options.levels);
  if (options.workers) loader.setWorkerLimit(options.workers);
  if (options.timeout) loader.setTimeout(options.timeout);
  return loader;
}

/// The world-space winding of the hit triangle against the ray: true when the triangle's front
/// face (as the GPU decides it: counter-clockwise on screen, reversed for a Mesh whose matrix
/// mirrors) faces the ray.
function frontFacing(hit, ray) {
  const o = hit.object;
  const m = new THREE.Matrix4();
  if (o.isInstancedMesh) o.getMatrixAt(hit.instanceId, m);
  m.premultiply(o.matrixWorld);
  const p = o.geometry.getAttribute('position');
  const [a, b, c] = [hit.face.a, hit.face.b, hit.face.c].map((i) => new THREE.Vector3().fromBufferAttribute(p, i).applyMatrix4(m));
  const n = b.sub(a).cross(c.sub(a));
  const flips = !o.isInstancedMesh && o.matrixWorld.determinant() < 0;
  return (n.dot(ray.direction) < 0) !== flips;
}

/// Renders the scene with front faces only and returns, per part name, the lit pixels inside
/// its projected box and their mean luminance.
function litPixels(names) {
  const materials = new Set();
  current.group.traverse((o) => o.material && materials.add(o.material));
  const sides = new Map([...materials].map((m) => [m, m.side]));
  for (const m of materials) m.side = THREE.FrontSide;
  const target = new THREE.WebGLRenderTarget(kWidth, kHeight);
  renderer.setRenderTarget(target);
  renderer.render(scene, camera);
  const px = new Uint8Array(kWidth * kHeight * 4);
  renderer.readRenderTargetPixels(target, 0, 0, kWidth, kHeight, px);
  renderer.setRenderTarget(null);
  target.dispose();
  for (const [m, side] of sides) m.side = side;
  const out = {};
  for (const name of names) {
    const part = current.group.findPart(name);
    const box = current.group.manifest.partBounds[part.id];
    const ndc = [];
    for (let k = 0; k < 8; ++k) {
      ndc.push(new THREE.Vector3(k & 1 ? box.max[0] : box.min[0], k & 2 ? box.max[1] : box.min[1], k & 4 ? box.max[2] : box.min[2]).project(camera));
    }
    const x0 = Math.max(0, Math.floor(((Math.min(...ndc.map((v) => v.x)) + 1) / 2) * kWidth));
    const x1 = Math.min(kWidth, Math.ceil(((Math.max(...ndc.map((v) => v.x)) + 1) / 2) * kWidth));
    const y0 = Math.max(0, Math.floor(((Math.min(...ndc.map((v) => v.y)) + 1) / 2) * kHeight));
    const y1 = Math.min(kHeight, Math.ceil(((Math.max(...ndc.map((v) => v.y)) + 1) / 2) * kHeight));
    let lit = 0;
    let light = 0;
    for (let y = y0; y < y1; ++y) {
      for (let x = x0; x < x1; ++x) {
        const i = 4 * (y * kWidth + x);
        const l = 0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2];
        if (l > 8) {
          ++lit;
          light += l;
        }
      }
    }
    out[name] = { lit, luminance: lit ? light / lit : 0 };
  }
  return out;
}

window.loaderTest = {
  /// Loads `url`; resolves to the group's summary, the events and the progress calls.
  async load(url, options = {}) {
    current?.group.removeFromParent();
    const loader = makeLoader(options);
    const events = [];
    window.loaderEvents = events;  // read while the load runs, too
    const progress = [];
    const started = performance.now();
    let group;
    await new Promise((resolve, reject) => {
      group = loader.load(url, resolve, (e) => progress.push([e.loaded, e.total, e instanceof ProgressEvent]), reject);
      group.addEventListener('manifest', (e) => events.push({ type: 'manifest', parts: e.manifest.parts.length, at: performance.now() - started }));
      group.addEventListener('component', (e) => events.push({
        type: 'component', component: e.component, level: e.level, levels: e.levels, final: e.final,
        objects: e.objects.length, parts: e.parts, loaded: e.loaded, total: e.total, at: performance.now() - started,
      }));
      group.addEventListener('load', () => events.push({ type: 'load', at: performance.now() - started }));
    });
    scene.add(group);
    frame(group.manifest.bounds);
    renderer.render(scene, camera);
    current = { loader, group };
    return summary(group, { events, progress, ms: performance.now() - started });
  },

  /// A ray through the centre of part `name`'s box on screen: the part the loader names for the
  /// first hit, and whether that triangle faces the ray.
  pick(name) {
    const { group } = current;
    const part = group.findPart(name);
    const box = group.manifest.partBounds[part.id];
    const centre = new THREE.Vector3(...box.min).add(new THREE.Vector3(...box.max)).multiplyScalar(0.5).project(camera);
    const raycaster = new THREE.Raycaster();
    raycaster.setFromCamera(new THREE.Vector2(centre.x, centre.y), camera);
    const [hit] = raycaster.intersectObject(group, true);
    if (!hit) return { part: null };
    return {
      part: group.partAt(hit)?.name ?? null,
      displayName: group.partAt(hit)?.displayName ?? null,
      object: hit.object.name,
      instanced: !!hit.object.isInstancedMesh,
      instanceId: hit.instanceId ?? null,
      userDataPart: hit.object.userData.parts[hit.instanceId ?? 0],
      front: frontFacing(hit, raycaster.ray),
    };
  },

  /// Front faces only: the lit pixels and luminance per part; with `swapMirrored`, once more
  /// after drawing every mirrored batch from the kept batch's (unflipped) index buffer.
  lit(names, swapMirrored = false) {
    const before = litPixels(names);
    if (!swapMirrored) return { before };
    const swapped = [];
    for (const o of current.group.children) {
      if (!o.isInstancedMesh || !o.userData.mirror) continue;
      const twin = current.group.children.find((t) => t.userData.component === o.userData.component && !t.userData.mirror);
      if (!twin) continue;
      swapped.push([o, o.geometry]);
      o.geometry = twin.geometry;
    }
    const after = litPixels(names);
    for (const [o, geometry] of swapped) o.geometry = geometry;
    return { before, after };
  },

  /// Disposes the loader and the group; resolves to the worker counts once they are gone.
  async dispose() {
    current.loader.dispose();
    current.group.dispose();
    return workersGone();
  },

  /// A load that must fail: resolves to { message, ms, workers } (workers once all are gone),
  /// or { loaded: true } if it did not fail.
  async fail(url, options = {}) {
    const loader = makeLoader(options);
    const started = performance.now();
    try {
      await loader.loadAsync(url);
      loader.dispose();
      return { loaded: true };
    } catch (e) {
      const ms = performance.now() - started;
      return { message: String(e?.message ?? e), isError: e instanceof Error, ms, workers: await workersGone() };
    }
  },

  /// Loads `urls` at once with one loader (its workers shared): per url { ok, objects } or
  /// { message }; then the worker counts (all gone once the loader is disposed).
  async concurrent(urls, options = {}) {
    const loader = makeLoader(options);
    const before = { ...workers };
    const results = await Promise.all(urls.map((url) => loader.loadAsync(url).then(
      (group) => ({ ok: true, objects: group.children.length, parts: new Set(group.children.flatMap((o) => o.userData.parts)).size }),
      (e) => ({ ok: false, message: String(e.message) }))));
    const afterLoads = { made: workers.made - before.made, terminated: workers.terminated - before.terminated };
    loader.dispose();
    return { results, afterLoads, workers: await workersGone() };
  },

  /// Starts loading `url` and aborts once the first component is in: { message, objects, workers }.
  async abortAfterFirst(url, options = {}) {
    const loader = makeLoader(options);
    let group;
    const failed = new Promise((resolve) => {
      group = loader.load(url, () => resolve({ message: 'loaded' }), undefined, (e) => resolve({ message: String(e.message) }));
    });
    group.addEventListener('component', () => loader.abort());
    const { message } = await failed;
    const objects = group.children.length;
    group.dispose();
    return { message, objects, workers: await workersGone() };
  },

  workers: () => ({ ...workers }),
};
window.loaderTestReady = true;
