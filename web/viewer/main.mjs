// SPDX-License-Identifier: Apache-2.0
// The osteon viewer: loads the package it is served with (manifest.json beside index.html, or the
// ?manifest=URL given), streams its components in the manifest's order through a pool of
// WebAssembly decoder workers, and draws each one the moment it is decoded. Bones can be picked,
// searched, hidden, isolated, grouped and cut by a clipping plane.
//
// window.osteon exposes the loading state (counts, times from performance.now(), errors, the
// per-component fetch log) and a few functions the browser tests and benchmarks call; see `state`.
//
// Frames are drawn on demand (a change, a new component, a resize), not in a loop: an idle viewer
// costs nothing, which matters on phones and when timing the load.
//
// Based on: Zhou, Jia & Su 2018 (progressive, per-component streaming of a compressed skeleton);
// three.js DRACOLoader (decoding off the main thread in a worker pool).

import {
  Color,
  DirectionalLight,
  Group,
  HemisphereLight,
  Object3D,
  PerspectiveCamera,
  Plane,
  Raycaster,
  Scene,
  Vector2,
  Vector3,
  WebGLRenderer,
} from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { createDecoderPool } from '../decoder/pool.mjs';
import { defaultView, fitBox } from './camera.mjs';
import { findPart, formatLength, parseManifest } from './manifest.mjs';
import { createPackageScene } from './scene.mjs';
import { createComponentStream, fetchComponent } from './stream.mjs';

// build.mjs replaces OSTEON_WORKER_FILE with the worker bundle's content-hashed file name.
/* global OSTEON_WORKER_FILE */
const kWorkerFile = typeof OSTEON_WORKER_FILE === 'string' ? OSTEON_WORKER_FILE : '../decoder/worker.mjs';
const kBackground = '#1c2027';
const kFetchesInFlight = 6;
const kFovDeg = 35;
const kTapPixels = 6;       // a pointer that moves further is a drag (orbit), not a pick

const $ = (id) => document.getElementById(id);

/// Everything a test or benchmark reads (window.osteon). Times are performance.now() values:
/// milliseconds since navigation start.
const state = {
  componentsTotal: 0,
  componentsLoaded: 0,
  componentsFailed: 0,
  instancesTotal: 0,
  instancesDrawn: 0,
  trianglesDrawn: 0,
  drawCalls: 0,
  bytesTotal: 0,
  bytesLoaded: 0,
  manifestMs: null,        // manifest parsed
  firstComponentMs: null,  // first component added to the scene
  allLoadedMs: null,       // every component added or failed
  errors: [],              // 'osteon: ...' messages, as listed in the page
  done: false,             // every component loaded or failed (or the manifest failed)
  fetchLog: [],            // per component in fetch order: { id, file, bytes, fetchStart, fetchEnd, decodedAt, addedAt, error }
  frames: 0,               // frames drawn
  unit: null,
  background: kBackground,
  selected: null,          // the selected part's display name
  screenPositionOf,
  screenBoundsOf,
  select: (name) => selectByName(name, { frame: false }),
  frame: (name) => selectByName(name, { frame: true }),
};
window.osteon = state;

let manifest = null;
let packageScene = null;
let controls = null;
let selectedPart = -1;
const hiddenParts = new Set();
const groupOn = new Map();
const partRows = [];        // { part, li, checkbox, button } per part, in list order

// ---------------------------------------------------------------------------------------------
// Renderer, camera, lights

const canvas = $('canvas');
let renderer;
try {
  renderer = new WebGLRenderer({ canvas, antialias: true });
  renderer.localClippingEnabled = true;  // the clipping plane is set per material
} catch (e) {
  renderer = null;
  reportError(`osteon: WebGL is not available in this browser: ${e?.message ?? e}`);
}
const scene = new Scene();
scene.background = new Color(kBackground);
const camera = new PerspectiveCamera(kFovDeg, 1, 0.1, 1000);
const root = new Group();
scene.add(root, camera);
// Sky and ground light, plus a light that moves with the camera so the side in view is always lit.
// The headlight comes from above and to the right of the eye: straight from the eye, every surface
// facing the camera would be equally bright and the bones' relief would vanish.
scene.add(new HemisphereLight(0xffffff, 0x4a4036, 0.7));
const headlight = new DirectionalLight(0xffffff, 2.4);
headlight.position.set(0.6, 0.9, 1);        // in camera space
const headlightTarget = new Object3D();
headlightTarget.position.set(0, 0, -1);
camera.add(headlight, headlightTarget);
headlight.target = headlightTarget;
const clipPlane = new Plane(new Vector3(0, 0, 1), 0);
const raycaster = new Raycaster();

let framePending = false;
function requestRender() {
  if (framePending || !renderer) return;
  framePending = true;
  requestAnimationFrame(() => {
    framePending = false;
    controls?.update();
    renderer.render(scene, camera);
    state.frames++;
  });
}

function resize() {
  if (!renderer) return;
  const rect = $('view').getBoundingClientRect();
  const width = Math.max(1, Math.floor(rect.width));
  const height = Math.max(1, Math.floor(rect.height));
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.setSize(width, height, false);
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  requestRender();
}
new ResizeObserver(resize).observe($('view'));
resize();

// ---------------------------------------------------------------------------------------------
// Camera fitting and screen projection

function fitCamera(bounds, eye, up, margin = 1.1) {
  const fit = fitBox(bounds, eye, up, kFovDeg, camera.aspect, margin);
  camera.position.copy(fit.position);
  camera.up.copy(up);
  camera.lookAt(fit.target);
  if (controls) controls.target.copy(fit.target);
  requestRender();
}

function fitAll() {
  if (!manifest) return;
  const { eye, up } = defaultView(manifest.bounds);
  fitCamera(manifest.bounds, eye, up);
}

/// Frames a part from the current direction of view.
function framePart(partId) {
  const eye = camera.position.clone().sub(controls.target).normalize();
  fitCamera(manifest.partBounds[partId], eye, camera.up.clone(), 1.6);
}

function toClient(world) {
  const rect = canvas.getBoundingClientRect();
  const ndc = world.clone().project(camera);
  return {
    x: rect.left + ((ndc.x + 1) / 2) * rect.width,
    y: rect.top + ((1 - ndc.y) / 2) * rect.height,
    inFront: ndc.z > -1 && ndc.z < 1,
  };
}

function boxCorners(box) {
  return Array.from({ length: 8 }, (_, c) => new Vector3(
    c & 1 ? box.max[0] : box.min[0], c & 2 ? box.max[1] : box.min[1], c & 4 ? box.max[2] : box.min[2]));
}

/// The client (CSS pixel) position of a part's world bounding-box centre: { x, y, inFront }, or
/// null for an unknown name (display name, name or source file, any case).
function screenPositionOf(name) {
  const part = manifest && findPart(manifest, name);
  if (!part) return null;
  camera.updateMatrixWorld();
  const box = manifest.partBounds[part.id];
  return toClient(new Vector3(...box.min.map((v, i) => (v + box.max[i]) / 2)));
}

/// The client rectangle { left, top, right, bottom } a world box projects to: a part's (by
/// name) or, without a name, the whole package's (manifest.bounds).
function screenBoundsOf(name) {
  if (!manifest) return null;
  const part = name === undefined ? null : findPart(manifest, name);
  if (name !== undefined && !part) return null;
  camera.updateMatrixWorld();
  const points = boxCorners(part ? manifest.partBounds[part.id] : manifest.bounds).map(toClient);
  const xs = points.map((p) => p.x);
  const ys = points.map((p) => p.y);
  return { left: Math.min(...xs), top: Math.min(...ys), right: Math.max(...xs), bottom: Math.max(...ys) };
}

// ---------------------------------------------------------------------------------------------
// Status, errors, statistics

function reportError(message) {
  state.errors.push(message);
  const li = document.createElement('li');
  li.textContent = message;
  $('error-list').append(li);
  $('errors').hidden = false;
}

function megabytes(bytes) {
  return `${(bytes / 1e6).toFixed(bytes < 1e7 ? 2 : 1)} MB`;
}

function updateStatus() {
  const settled = state.componentsLoaded + state.componentsFailed;
  $('progress').max = Math.max(1, state.componentsTotal);
  $('progress').value = settled;
  const failed = state.componentsFailed ? `, ${state.componentsFailed} failed` : '';
  if (state.done) {
    const seconds = ((state.allLoadedMs ?? performance.now()) / 1000).toFixed(2);
    $('progress-text').textContent =
      `${state.componentsLoaded} of ${state.componentsTotal} components${failed} · ${megabytes(state.bytesLoaded)} · ${seconds} s`;
    $('status').classList.add('done');
  } else {
    $('progress-text').textContent =
      `${settled} / ${state.componentsTotal} components${failed} · ${megabytes(state.bytesLoaded)} / ${megabytes(state.bytesTotal)}`;
  }
}

function updateStats() {
  if (!packageScene) return;
  const s = packageScene.stats();
  state.instancesDrawn = s.instances;
  state.trianglesDrawn = s.triangles;
  state.drawCalls = s.drawCalls;
  $('stats').textContent =
    `${s.instances.toLocaleString('en')} of ${state.instancesTotal.toLocaleString('en')} instances · ` +
    `${s.triangles.toLocaleString('en')} triangles · ${s.drawCalls} draw calls`;
}

// ---------------------------------------------------------------------------------------------
// Selection, visibility, lists

function partVisible(id) {
  const part = manifest.parts[id];
  return !hiddenParts.has(id) && groupOn.get(part.group) !== false;
}

function applyVisibility() {
  packageScene.setVisibility(partVisible);
  for (const row of partRows) {
    const visible = partVisible(row.part.id);
    row.checkbox.checked = visible;
    row.li.classList.toggle('hidden-part', !visible);
  }
  for (const [group, on] of groupOn) {
    const box = document.querySelector(`#group-list input[data-group="${CSS.escape(group)}"]`);
    if (box) box.checked = on;
  }
  updateStats();
  requestRender();
}

function drawnAs(part) {
  const info = packageScene.drawInfo(part.id);
  const words = [];
  if (part.prototype !== part.id) {
    const mirrored = info.some((i) => i.mirror);
    words.push(`an instance of ${manifest.parts[part.prototype].displayName}${mirrored ? ', mirrored' : ''}`);
  } else {
    const copies = manifest.parts.filter((p) => p.prototype === part.id && p.id !== part.id).length;
    words.push(copies ? `its own mesh, repeated by ${copies} other part${copies > 1 ? 's' : ''}` : 'its own mesh');
  }
  const instanced = info.filter((i) => i.instanced);
  if (instanced.length) {
    const batch = Math.max(...instanced.map((i) => i.batchSize));
    words.push(`GPU-instanced${batch ? ` (${batch} in one draw call)` : ''}`);
  }
  words.push(`${info.length} component${info.length > 1 ? 's' : ''}${info.every((i) => i.loaded) ? '' : `, ${info.filter((i) => !i.loaded).length} not loaded`}`);
  return { text: words.join(' · '), instance: part.prototype !== part.id, gpuInstanced: instanced.length > 0 };
}

function showInfo() {
  const part = selectedPart >= 0 ? manifest.parts[selectedPart] : null;
  state.selected = part ? part.displayName : null;
  $('info-name').textContent = part ? part.displayName : 'No bone selected';
  $('info-hint').hidden = !!part;
  $('info-fields').hidden = !part;
  for (const id of ['frame', 'hide', 'isolate']) $(id).disabled = !part;
  for (const row of partRows) row.button.setAttribute('aria-current', String(row.part.id === selectedPart));
  if (!part) return;
  const bound = Math.max(...manifest.instancesOfPart[part.id].map((i) => manifest.instances[i].errorBound));
  const drawn = drawnAs(part);
  $('info-group').textContent = part.group || '(none)';
  $('info-triangles').textContent = part.triangles.toLocaleString('en');
  $('info-error').textContent = Number.isFinite(bound) ? formatLength(bound, manifest.unit) : '–';
  $('info-drawn').textContent = drawn.text;
  $('info').dataset.instance = String(drawn.instance);
  $('info').dataset.gpuInstanced = String(drawn.gpuInstanced);
  $('info-source').textContent = part.source || part.name;
}

function select(partId, { frame = false, scroll = true } = {}) {
  selectedPart = partId;
  packageScene.setHighlight(partId);
  showInfo();
  if (partId >= 0) {
    if (frame) framePart(partId);
    const row = partRows.find((r) => r.part.id === partId);
    if (scroll && row && row.li.offsetParent) row.li.scrollIntoView({ block: 'nearest' });
  }
  requestRender();
}

function selectByName(name, options) {
  const part = manifest && findPart(manifest, name);
  if (!part) return false;
  select(part.id, options);
  return true;
}

function buildLists() {
  const list = $('part-list');
  const sorted = [...manifest.parts].sort((a, b) => a.displayName.localeCompare(b.displayName, 'en', { numeric: true }));
  for (const part of sorted) {
    const li = document.createElement('li');
    const checkbox = document.createElement('input');
    checkbox.type = 'checkbox';
    checkbox.checked = true;
    checkbox.setAttribute('aria-label', `Show ${part.displayName}`);
    checkbox.addEventListener('change', () => {
      if (checkbox.checked) {
        hiddenParts.delete(part.id);
        groupOn.set(part.group, true);
      } else {
        hiddenParts.add(part.id);
      }
      applyVisibility();
    });
    const button = document.createElement('button');
    button.type = 'button';
    button.textContent = part.displayName;
    button.title = part.name;
    button.dataset.part = String(part.id);
    button.addEventListener('click', () => select(part.id, { frame: true, scroll: false }));
    li.append(checkbox, button);
    list.append(li);
    partRows.push({ part, li, checkbox, button });
  }
  filterList();

  const groups = $('group-list');
  for (const group of [...manifest.groups].sort()) {
    groupOn.set(group, true);
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = true;
    box.dataset.group = group;
    box.addEventListener('change', () => {
      groupOn.set(group, box.checked);
      applyVisibility();
    });
    const n = manifest.parts.filter((p) => p.group === group).length;
    label.append(box, ` ${group || '(no group)'} (${n})`);
    groups.append(label);
  }
}

function filterList() {
  const q = $('search').value.trim().toLowerCase();
  let shown = 0;
  for (const row of partRows) {
    const match = !q || row.part.displayName.toLowerCase().includes(q) || row.part.name.toLowerCase().includes(q);
    row.li.hidden = !match;
    shown += match;
  }
  $('part-count').textContent = q ? `${shown} of ${partRows.length} match` : `${partRows.length} bones`;
  return partRows.filter((r) => !r.li.hidden);
}

// ---------------------------------------------------------------------------------------------
// Clipping plane

function updateClip() {
  if (!manifest) return;
  const on = $('clip-on').checked;
  const axis = Number($('clip-axis').value);
  const t = Number($('clip-pos').value) / 1000;
  const lo = manifest.bounds.min[axis];
  const hi = manifest.bounds.max[axis];
  const at = lo + t * (hi - lo);
  const sign = $('clip-flip').checked ? -1 : 1;
  // Three.js draws the side where normal . p + constant >= 0: keep p[axis] >= at, or <= at.
  clipPlane.normal.set(0, 0, 0).setComponent(axis, sign);
  clipPlane.constant = -sign * at;
  $('clip-value').textContent = `${'XYZ'[axis]} = ${formatLength(at, manifest.unit)}`;
  for (const material of packageScene.materials) {
    const planes = on ? [clipPlane] : null;
    if ((material.clippingPlanes?.length ?? 0) !== (planes?.length ?? 0)) material.needsUpdate = true;
    material.clippingPlanes = planes;
  }
  requestRender();
}

// ---------------------------------------------------------------------------------------------
// Picking

function pick(clientX, clientY) {
  if (!packageScene) return;
  const rect = canvas.getBoundingClientRect();
  const ndc = new Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  const clipping = $('clip-on').checked;
  // Raycasts ignore clipping planes: skip hits on the part cut away.
  const hit = raycaster.intersectObjects(packageScene.pickable(), false)
    .find((h) => !clipping || clipPlane.distanceToPoint(h.point) >= 0);
  select(hit ? packageScene.partOf(hit) : -1);
}

let down = null;
canvas.addEventListener('pointerdown', (e) => {
  down = e.isPrimary ? { x: e.clientX, y: e.clientY, id: e.pointerId } : null;
});
canvas.addEventListener('pointerup', (e) => {
  if (down && e.pointerId === down.id && Math.hypot(e.clientX - down.x, e.clientY - down.y) <= kTapPixels) {
    pick(e.clientX, e.clientY);
  }
  down = null;
});
canvas.addEventListener('pointercancel', () => { down = null; });
canvas.addEventListener('keydown', (e) => {
  if (e.key === 'Escape' && packageScene) select(-1);
});

// ---------------------------------------------------------------------------------------------
// Controls wiring

$('fit').addEventListener('click', fitAll);
$('panel-toggle').addEventListener('click', () => {
  const collapsed = $('panel').classList.toggle('collapsed');
  $('panel-toggle').setAttribute('aria-expanded', String(!collapsed));
});
$('frame').addEventListener('click', () => selectedPart >= 0 && framePart(selectedPart));
$('hide').addEventListener('click', () => {
  if (selectedPart < 0) return;
  hiddenParts.add(selectedPart);
  applyVisibility();
});
$('isolate').addEventListener('click', () => {
  if (selectedPart < 0) return;
  for (const part of manifest.parts) if (part.id !== selectedPart) hiddenParts.add(part.id);
  hiddenParts.delete(selectedPart);
  groupOn.set(manifest.parts[selectedPart].group, true);
  applyVisibility();
});
$('show-all').addEventListener('click', () => {
  if (!manifest) return;
  hiddenParts.clear();
  for (const group of groupOn.keys()) groupOn.set(group, true);
  applyVisibility();
});
$('search').addEventListener('input', filterList);
$('search').addEventListener('keydown', (e) => {
  if (e.key !== 'Enter' || !manifest) return;
  const first = filterList()[0];
  if (first) select(first.part.id, { frame: true });
});
for (const id of ['clip-on', 'clip-axis', 'clip-flip']) $(id).addEventListener('change', updateClip);
$('clip-pos').addEventListener('input', updateClip);

// ---------------------------------------------------------------------------------------------
// Loading

async function loadManifest(url) {
  const name = url.pathname.split('/').pop() || url.href;
  let response;
  try {
    response = await fetch(url);
  } catch (e) {
    throw new Error(`osteon: ${name}: fetch failed: ${e?.message ?? e}`);
  }
  if (!response.ok) throw new Error(`osteon: ${name}: HTTP ${response.status}`);
  let json;
  try {
    json = await response.json();
  } catch (e) {
    throw new Error(`osteon: ${name}: not JSON: ${e?.message ?? e}`);
  }
  return parseManifest(json);
}

async function main() {
  const params = new URLSearchParams(location.search);
  const manifestUrl = new URL(params.get('manifest') ?? 'manifest.json', location.href);
  // A worker that fails to start (its script missing, say) answers nothing: the pool rejects the
  // jobs it had, and decode() below refuses the later ones instead of waiting forever.
  let workerFailure = null;
  const poolPromise = createDecoderPool({
    wasm: new URL('osteon_decoder.wasm', import.meta.url).href,
    createWorker: () => {
      const worker = new Worker(new URL(kWorkerFile, import.meta.url), { type: 'module' });
      worker.addEventListener('error', (e) => {
        workerFailure ??= `the decoder worker failed: ${e?.message || 'it could not be started'}`;
      });
      return worker;
    },
  });
  poolPromise.catch(() => {});  // handled where awaited; avoids an unhandled-rejection report first

  try {
    manifest = await loadManifest(manifestUrl);
  } catch (e) {
    reportError(String(e?.message ?? e));
    $('progress-text').textContent = 'Could not load the package';
    state.done = true;
    return;
  }
  state.manifestMs = performance.now();
  state.unit = manifest.unit;
  state.componentsTotal = manifest.components.length;
  state.instancesTotal = manifest.instances.length;
  state.bytesTotal = manifest.bytesTotal;
  packageScene = createPackageScene(manifest, root);

  // The camera is fitted to the whole package before any bone arrives, so each appears in place.
  // Near and far from the package's size: 24-bit depth keeps a fraction of a millimetre at the
  // distance a whole skeleton is seen from, and zooming to a small bone stays unclipped.
  const radius = Math.max(Math.hypot(...manifest.bounds.max.map((v, i) => v - manifest.bounds.min[i])) / 2, 1e-6);
  camera.near = radius / 500;
  camera.far = radius * 60;
  camera.updateProjectionMatrix();
  fitAll();  // sets camera.up, which OrbitControls reads once, in its constructor
  controls = new OrbitControls(camera, canvas);
  controls.enableDamping = true;
  controls.maxDistance = radius * 20;
  controls.addEventListener('change', requestRender);
  controls.listenToKeyEvents(canvas);
  fitAll();  // again, now that there is a target to set
  buildLists();
  showInfo();
  updateClip();
  updateStatus();
  updateStats();

  let pool;
  try {
    pool = await poolPromise;
  } catch (e) {
    const message = String(e?.message ?? e);
    reportError(message.startsWith('osteon:') ? message : `osteon: cannot start the decoder: ${message}`);
    state.componentsFailed = state.componentsTotal;
    state.done = true;
    updateStatus();
    return;
  }

  const items = manifest.streamOrder.map((c) => ({ id: c.id, file: c.file, bytes: c.bytes, url: new URL(c.file, manifestUrl) }));
  const stream = createComponentStream(items, {
    limit: kFetchesInFlight,
    fetchBytes: (item) => fetchComponent(item),
    decode: (bytes, item) => (workerFailure
      ? Promise.reject(new Error(`osteon: ${item.file}: ${workerFailure}`))
      : pool.decode(bytes, item.file)),
    onFetched: (item, entry) => {
      state.bytesLoaded += entry.receivedBytes;
      updateStatus();
    },
    onDecoded: (item, mesh, entry) => {
      packageScene.addComponent(item.id, mesh);
      entry.addedAt = performance.now();
      state.firstComponentMs ??= entry.addedAt;
      state.componentsLoaded++;
      // The visibility of a part hidden before its component arrived applies to it too.
      if (hiddenParts.size || [...groupOn.values()].includes(false)) packageScene.setVisibility(partVisible);
      if (selectedPart >= 0) {
        packageScene.setHighlight(selectedPart);
        showInfo();
      }
      updateStatus();
      updateStats();
      requestRender();
    },
    onFailed: (item, error) => {
      state.componentsFailed++;
      reportError(error);
      updateStatus();
    },
  });
  state.fetchLog = stream.log();
  await stream.run();
  pool.terminate();
  state.allLoadedMs = performance.now();
  state.done = true;
  updateStatus();
  requestRender();
}

main().catch((e) => {
  reportError(`osteon: the viewer failed: ${e?.stack ?? e}`);
  state.done = true;
});
