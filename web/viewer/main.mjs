// SPDX-License-Identifier: Apache-2.0
// The osteon viewer's page: the panel, the camera controls, picking, window.osteon, and the data
// path: the package's chunk files read as streams (stream.mjs), each component handed to the
// decoder workers (decoder/pool.mjs) the moment its bytes are in, and each decoded mesh passed on
// to the renderer. The renderer is a worker (render_worker.mjs) that the page's inline bootstrap
// (boot.js) started with the canvas before this script had even arrived, along with the manifest,
// the decoder and its workers; this script picks them up from window.osteonBoot. Where the canvas
// cannot go to a worker, the same renderer runs here, on a MessagePort (boot.js says when).
//
// Why so: nothing on the main thread takes long (no WebGL context, no shader compilation, no mesh
// upload, no decoding; reading a stream is a copy per network packet), so clicks, scrolling and
// typing answer at once while a skeleton streams in, and the streams keep being read while the
// renderer waits on the GPU. window.osteon's counts are computed here from the manifest and the
// set of components the renderer has drawn (manifest.mjs drawStats), so they are exact the moment
// a control changes, without a round trip.
//
// window.osteon exposes the loading state (counts, times from performance.now(), errors, the
// per-component fetch log) and a few functions the browser tests and benchmarks call; see `state`.
//
// Based on: Zhou, Jia & Su 2018 (progressive, per-component streaming of a compressed skeleton);
// three.js DRACOLoader (decoding off the main thread in a worker pool).

import { PerspectiveCamera, Vector3 } from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { createDecoderPool } from '../decoder/pool.mjs';
import { fitBox, kBackground, kFovDeg, packageView } from './camera.mjs';
import { drawInfo, drawStats, findPart, formatLength, parseManifest } from './manifest.mjs';
import { createChunkStream, planChunks } from './stream.mjs';

// build.mjs replaces OSTEON_RENDER_WORKER_FILE with the render worker's content-hashed file name.
/* global OSTEON_RENDER_WORKER_FILE */
const kRenderWorkerFile = typeof OSTEON_RENDER_WORKER_FILE === 'string' ? OSTEON_RENDER_WORKER_FILE : './render_worker.mjs';
const kTapPixels = 6;       // a pointer that moves further is a drag (orbit), not a pick
const kChunksInFlight = 2;

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
  chunksTotal: 0,
  manifestMs: null,        // manifest parsed (on the page)
  firstComponentMs: null,  // the renderer's first frame with a component drawn (render() returned)
  allLoadedMs: null,       // every component drawn or failed
  errors: [],              // 'osteon: ...' messages, as listed in the page
  done: false,             // every component loaded or failed (or the manifest failed)
  fetchLog: [],            // per component in fetch order: { id, chunk, file, offset, bytes, fetchStart, fetchEnd, decodedAt, addedAt, error }
  frames: 0,               // frames the renderer has drawn
  framePending: false,     // a change is waiting for its frame
  renderer: null,          // 'worker' (OffscreenCanvas) or 'page'
  timings: {},             // the page's bootstrap: manifest, threeFetched; the renderer's start: started, context, three, view, compiled
  unit: null,
  background: kBackground,
  selected: null,          // the selected part's display name
  screenPositionOf,
  screenBoundsOf,
  select: (name) => selectByName(name, { frame: false }),
  frame: (name) => selectByName(name, { frame: true }),
};
window.osteon = state;

const boot = window.osteonBoot;
let link = null;            // the renderer: a Worker or a MessagePort (boot.js)
let manifest = null;
let controls = null;
let selectedPart = -1;
let fatal = false;
const loaded = new Set();   // component ids on screen
const settled = new Set();  // component ids on screen or failed
const logById = new Map();  // component id -> its fetchLog entry
const hiddenParts = new Set();
const groupOn = new Map();
const partRows = [];        // { part, li, checkbox, button } per part, in list order

const canvas = $('canvas');
const camera = new PerspectiveCamera(kFovDeg, 1, 0.1, 1000);

// ---------------------------------------------------------------------------------------------
// Talking to the renderer

let changeSeq = 0;          // the last change sent to the renderer
let drawnSeq = 0;           // the last change a drawn frame includes
let pagePending = false;    // an animation frame is scheduled here

function send(message, transfer = []) {
  link?.postMessage(message, transfer);
}

function sendCamera() {
  send({
    type: 'camera',
    position: camera.position.toArray(),
    quaternion: camera.quaternion.toArray(),
    up: camera.up.toArray(),
    fov: camera.fov,
    aspect: camera.aspect,
    near: camera.near,
    far: camera.far,
  });
}

/// Asks for a frame: at this page's next animation frame the controls move the camera (damping),
/// and the camera and a render request go to the renderer, which draws at its own next frame.
function requestRender() {
  if (fatal) return;  // nothing will be drawn: no frame to wait for
  state.framePending = true;
  if (pagePending) return;
  pagePending = true;
  requestAnimationFrame(() => {
    pagePending = false;
    if (fatal) {
      state.framePending = false;
      return;
    }
    // Until the manifest has fitted this camera, the renderer keeps the view it opened with.
    if (controls) {
      controls.update();
      sendCamera();
    }
    send({ type: 'render', seq: ++changeSeq });
    state.framePending = changeSeq > drawnSeq;
  });
}

function sendParts() {
  if (!manifest) return;
  const hidden = new Uint8Array(manifest.parts.length);
  for (const part of manifest.parts) hidden[part.id] = partVisible(part.id) ? 0 : 1;
  send({ type: 'parts', hidden, highlight: selectedPart }, [hidden.buffer]);
  requestRender();
}

function resize() {
  const rect = $('view').getBoundingClientRect();
  const width = Math.max(1, Math.floor(rect.width));
  const height = Math.max(1, Math.floor(rect.height));
  send({ type: 'size', width, height, pixelRatio: Math.min(window.devicePixelRatio || 1, 2) });
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  requestRender();
}

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
  const view = packageView(manifest.bounds, kFovDeg, camera.aspect);
  fitCamera(manifest.bounds, view.position.clone().sub(view.target).normalize(), view.up);
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

// The status line and the statistics are rewritten at most every kStatusMs while loading, however
// many components arrive: every change on the page is a new frame for the browser's compositor,
// which (with a software GPU, headless) reads the whole window back each time, on the same GPU
// thread that creates the renderer's context and compiles its shaders. Changing the text at every
// animation frame kept that thread busy and delayed the first bones by hundreds of milliseconds.
const kStatusMs = 500;
let statusTimer = null;
let statusAt = -Infinity;
function scheduleStatus() {
  if (statusTimer !== null) return;
  statusTimer = setTimeout(() => {
    statusTimer = null;
    statusAt = performance.now();
    updateStatus();
  }, Math.max(0, statusAt + kStatusMs - performance.now()));
}

function updateStatus() {
  const settledCount = state.componentsLoaded + state.componentsFailed;
  $('progress').max = Math.max(1, state.componentsTotal);
  $('progress').value = settledCount;
  const failed = state.componentsFailed ? `, ${state.componentsFailed} failed` : '';
  if (state.done) {
    const seconds = ((state.allLoadedMs ?? performance.now()) / 1000).toFixed(2);
    $('progress-text').textContent =
      `${state.componentsLoaded} of ${state.componentsTotal} components${failed} · ${megabytes(state.bytesLoaded)} · ${seconds} s`;
    $('status').classList.add('done');
  } else {
    $('progress-text').textContent =
      `${settledCount} / ${state.componentsTotal} components${failed} · ${megabytes(state.bytesLoaded)} / ${megabytes(state.bytesTotal)}`;
  }
  $('stats').textContent =
    `${state.instancesDrawn.toLocaleString('en')} of ${state.instancesTotal.toLocaleString('en')} instances · ` +
    `${state.trianglesDrawn.toLocaleString('en')} triangles · ${state.drawCalls} draw calls`;
}

/// The counts in window.osteon, from the manifest and what is on screen (synchronous: a test
/// reads them right after a click).
function updateStats() {
  if (!manifest) return;
  const s = drawStats(manifest, loaded, partVisible);
  state.instancesDrawn = s.instances;
  state.trianglesDrawn = s.triangles;
  state.drawCalls = s.drawCalls;
  scheduleStatus();
}

// ---------------------------------------------------------------------------------------------
// Selection, visibility, lists

function partVisible(id) {
  const part = manifest.parts[id];
  return !hiddenParts.has(id) && groupOn.get(part.group) !== false;
}

function applyVisibility() {
  for (const row of partRows) {
    const visible = partVisible(row.part.id);
    row.checkbox.checked = visible;
    row.li.classList.toggle('hidden-part', !visible);
  }
  for (const [group, on] of groupOn) {
    const box = document.querySelector(`#group-list input[data-group="${CSS.escape(group)}"]`);
    if (box) box.checked = on;
  }
  sendParts();
  updateStats();
}

function drawnAs(part) {
  const info = drawInfo(manifest, part.id, loaded);
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
  sendParts();
  showInfo();
  if (partId >= 0) {
    if (frame) framePart(partId);
    const row = partRows.find((r) => r.part.id === partId);
    if (scroll && row && row.li.offsetParent) row.li.scrollIntoView({ block: 'nearest' });
  }
}

function selectByName(name, options) {
  const part = manifest && findPart(manifest, name);
  if (!part) return false;
  select(part.id, options);
  return true;
}

function buildLists() {
  const list = $('part-list');
  const rows = document.createDocumentFragment();
  const sorted = [...manifest.parts].sort((a, b) => a.displayName.localeCompare(b.displayName, 'en', { numeric: true }));
  for (const part of sorted) {
    const li = document.createElement('li');
    const checkbox = document.createElement('input');
    checkbox.type = 'checkbox';
    checkbox.checked = partVisible(part.id);
    checkbox.dataset.part = String(part.id);
    checkbox.setAttribute('aria-label', `Show ${part.displayName}`);
    const button = document.createElement('button');
    button.type = 'button';
    button.textContent = part.displayName;
    button.title = part.name;
    button.dataset.part = String(part.id);
    li.append(checkbox, button);
    li.classList.toggle('hidden-part', !partVisible(part.id));
    rows.append(li);
    partRows.push({ part, li, checkbox, button });
  }
  list.append(rows);
  // One listener each for the whole list instead of two per bone.
  list.addEventListener('change', (e) => {
    const id = Number(e.target.dataset.part);
    if (!(id >= 0)) return;
    if (e.target.checked) {
      hiddenParts.delete(id);
      groupOn.set(manifest.parts[id].group, true);
    } else {
      hiddenParts.add(id);
    }
    applyVisibility();
  });
  list.addEventListener('click', (e) => {
    const button = e.target.closest('button[data-part]');
    if (button) select(Number(button.dataset.part), { frame: true, scroll: false });
  });
  filterList();
  showInfo();
}

function buildGroups() {
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
  const normal = [0, 0, 0];
  normal[axis] = sign;
  $('clip-value').textContent = `${'XYZ'[axis]} = ${formatLength(at, manifest.unit)}`;
  send({ type: 'clip', on, normal, constant: -sign * at });
  requestRender();
}

// ---------------------------------------------------------------------------------------------
// Picking: the renderer holds the meshes, so it casts the ray and answers with the part.

let pickSeq = 0;
function pick(clientX, clientY) {
  if (!manifest || !link) return;
  const rect = canvas.getBoundingClientRect();
  const ndc = [((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1];
  camera.updateMatrixWorld();
  sendCamera();  // the ray is cast from the camera as it is now, not as of the last frame
  send({ type: 'pick', id: ++pickSeq, ndc });
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
  if (e.key === 'Escape' && manifest) select(-1);
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
// The renderer's messages (render_worker.mjs lists them)

// The list of bones (235 rows for BodyParts3D) is built once loading has ended, or kListsAfterMs
// after the manifest, when the browser is idle: painting it takes the GPU process (which, with a
// software GPU, rasterizes the page's text too) from the renderer's frames, and held them off the
// screen by a third of a second when it was built at the first frame.
const kListsAfterMs = 3000;
let listsBuilt = false;
function buildListsSoon() {
  if (listsBuilt || !manifest) return;
  listsBuilt = true;
  const idle = window.requestIdleCallback ?? ((f) => setTimeout(f, 1));
  idle(buildLists, { timeout: 500 });
}

function finish(at) {
  if (state.done) return;
  state.allLoadedMs = at;
  state.done = true;
  for (const worker of boot?.decoders ?? []) worker.terminate();
  updateStatus();
  buildListsSoon();
}

function componentsFailed(ids, error) {
  if (fatal) return;
  for (const id of ids) {
    const entry = logById.get(id);
    if (entry) entry.error = error;
    if (!settled.has(id)) {
      settled.add(id);
      state.componentsFailed++;
    }
  }
  reportError(error);
  scheduleStatus();
  if (settled.size === state.componentsTotal) finish(performance.now());
}

function onRendererMessage(message) {
  switch (message?.type) {
    case 'failed':
      componentsFailed(message.ids, message.error);
      break;
    case 'frame':
      // The renderer paces the frames that add components to this page's frames.
      requestAnimationFrame(() => send({ type: 'shown', frame: message.frame }));
      state.frames = message.frame;
      drawnSeq = Math.max(drawnSeq, message.seq ?? 0);
      state.framePending = pagePending || changeSeq > drawnSeq;
      if (message.drawn.length) {
        for (const id of message.drawn) {
          const entry = logById.get(id);
          if (entry) entry.addedAt = message.at;
          loaded.add(id);
          if (!settled.has(id)) {
            settled.add(id);
            state.componentsLoaded++;
          }
        }
        state.firstComponentMs ??= message.at;
        updateStats();
        if (selectedPart >= 0) showInfo();
        if (settled.size === state.componentsTotal) finish(message.at);
      }
      break;
    case 'fatal':
      if (fatal || state.done) break;
      fatal = true;
      state.framePending = false;
      stopStream.abort();
      reportError(message.error);
      state.componentsFailed = state.componentsTotal - state.componentsLoaded;
      finish(message.at);
      break;
    case 'picked':
      if (message.id === pickSeq && manifest) select(message.part);
      break;
    case 'timing':
      state.timings[message.name] = message.at;

      break;
    default:
  }
}

// ---------------------------------------------------------------------------------------------
// Loading

let streaming = false;
const stopStream = new AbortController();  // once nothing can be drawn, nothing more is fetched

/// Streams the chunks: each component decoded as soon as its bytes are in, each mesh passed on to
/// the renderer (its buffers transferred, not copied).
async function startStream() {
  if (streaming || !manifest || fatal || state.done) return;
  streaming = true;
  let next = 0;
  const poolReady = boot.wasm.then((wasm) =>
    createDecoderPool({ workers: boot.decoders.length, wasm, createWorker: () => boot.decoders[next++] }));
  poolReady.catch((e) => {
    const message = String(e?.message ?? e);
    onRendererMessage({ type: 'fatal', error: message.startsWith('osteon:') ? message : `osteon: cannot start the decoder: ${message}`, at: performance.now() });
  });
  // The bootstrap starts the first chunks itself (once three.js is in): the stream takes them up.
  await boot.chunksStarted;
  const stream = createChunkStream(planChunks(manifest, boot.manifestUrl), {
    limit: kChunksInFlight,
    // The first chunks are already on their way (boot.js).
    fetchChunk: (chunk) => boot.chunks.get(chunk.index) ?? fetch(chunk.url, { signal: stopStream.signal }),
    signal: stopStream.signal,
    // A decoder worker that never started would never answer.
    decode: async (buffer, range) => {
      const pool = await poolReady;
      if (boot.decoderError) throw new Error(`osteon: ${range.label}: ${boot.decoderError}`);
      return pool.decode(buffer, range.label);
    },
    onChunkStart: (chunk, at) => {
      const start = boot.chunkStarts.get(chunk.index) ?? at;
      for (const range of chunk.ranges) for (const c of range.components) logById.get(c.id).fetchStart = start;
    },
    onReceived: (range, at, bytesReceived) => {
      for (const c of range.components) logById.get(c.id).fetchEnd = at;
      state.bytesLoaded = bytesReceived;
      scheduleStatus();
    },
    onDecoded: (range, mesh, at) => {
      for (const c of range.components) logById.get(c.id).decodedAt = at;
      if (fatal) return;
      const buffers = [mesh.positions?.buffer, mesh.indices?.buffer, mesh.normals?.buffer].filter(Boolean);
      send({ type: 'mesh', ids: range.components.map((c) => c.id), mesh }, buffers);
    },
    onFailed: (range, error) => componentsFailed(range.components.map((c) => c.id), error),
    onChunkError: (chunk, error) => reportError(error),
  });
  await stream.run();
  (await poolReady.catch(() => null))?.terminate();
}

async function main() {
  if (!boot?.link) {
    reportError(boot?.rendererError ?? "osteon: the page's bootstrap did not run (index.html without its inline script?)");
    $('progress-text').textContent = 'Could not start the viewer';
    state.done = true;
    return;
  }
  link = boot.link;
  state.renderer = boot.offscreen ? 'worker' : 'page';
  state.timings = boot.timings;  // the renderer's steps are added as they come
  if (!boot.offscreen) {
    // No OffscreenCanvas: the renderer runs here, on the channel the bootstrap opened (its
    // messages have waited there).
    try {
      const { startRenderer } = await import(new URL(kRenderWorkerFile, import.meta.url).href);
      startRenderer(boot.rendererPort, { canvas });
    } catch (e) {
      boot.messages.push({ type: 'fatal', error: `osteon: the renderer could not be loaded: ${e?.message ?? e}`, at: performance.now() });
    }
  }
  new ResizeObserver(resize).observe($('view'));
  resize();  // the camera's aspect, before the view is fitted below

  let text;
  try {
    text = await boot.manifest;
    manifest = parseManifest(JSON.parse(text));
  } catch (e) {
    const message = String(e?.message ?? e);
    reportError(message.startsWith('osteon:') ? message : `osteon: ${new URL(boot.manifestUrl).pathname.split('/').pop()}: not JSON: ${message}`);
    $('progress-text').textContent = 'Could not load the package';
    fatal = true;
    state.framePending = false;
    state.done = true;
    for (const worker of boot.decoders) worker.terminate();
    return;
  }
  state.manifestMs = performance.now();
  state.unit = manifest.unit;
  state.componentsTotal = manifest.components.length;
  state.instancesTotal = manifest.instances.length;
  state.bytesTotal = manifest.bytesTotal;
  state.chunksTotal = manifest.chunks.length;
  state.fetchLog = manifest.streamOrder.map((c) => ({
    id: c.id,
    chunk: c.chunk,
    file: c.file,
    offset: c.offset,
    bytes: c.bytes,
    fetchStart: null,
    fetchEnd: null,
    decodedAt: null,
    addedAt: null,
    error: null,
  }));
  for (const entry of state.fetchLog) logById.set(entry.id, entry);

  // The same view the renderer opened with (camera.mjs packageView), then the controls on it.
  const view = packageView(manifest.bounds, kFovDeg, camera.aspect);
  camera.near = view.near;
  camera.far = view.far;
  camera.updateProjectionMatrix();
  fitAll();  // sets camera.up, which OrbitControls reads once, in its constructor
  controls = new OrbitControls(camera, canvas);
  controls.enableDamping = true;
  controls.maxDistance = view.maxDistance;
  controls.addEventListener('change', requestRender);
  controls.listenToKeyEvents(canvas);
  fitAll();  // again, now that there is a target to set
  buildGroups();
  updateClip();
  updateStats();
  updateStatus();

  // What the renderer said before the manifest was read here, then everything after, as it comes.
  boot.deliver = onRendererMessage;
  for (const message of boot.messages.splice(0)) onRendererMessage(message);
  startStream();
  setTimeout(buildListsSoon, kListsAfterMs);
  if (state.componentsTotal === 0) finish(performance.now());
}

main().catch((e) => {
  reportError(`osteon: the viewer failed: ${e?.stack ?? e}`);
  state.done = true;
});
