// SPDX-License-Identifier: Apache-2.0
// One viewer: createViewer() wires the panel (panel.mjs), the camera controls and the renderer's
// link (view.mjs), picking (picking.mjs), the shared view (share.mjs) and the data path
// (streaming.mjs: the package's chunk files read as streams, each component handed to the decoder
// workers the moment its bytes are in, each decoded mesh passed on to the renderer) around one
// state object (state.mjs), which every function is handed and whose report is the element's
// `report` (and the standalone page's window.osteon). The <osteon-viewer> element (element.mjs)
// makes one per element, in its shadow root. The renderer is a worker (render_worker.mjs) that
// the bootstrap (boot.js) started with the canvas, along with the manifest, the decoder and its
// workers: on the standalone page before this script had even arrived. Where the canvas cannot
// go to a worker, the same renderer runs here, on a MessagePort (boot.js says when).
//
// Why so: nothing on the main thread takes long (no WebGL context, no shader compilation, no mesh
// upload, no decoding; reading a stream is a copy per network packet), so clicks, scrolling and
// typing answer at once while a skeleton streams in, and the streams keep being read while the
// renderer waits on the GPU. The report's counts are computed here from the manifest and the
// set of components the renderer has drawn (manifest.mjs drawStats), so they are exact the moment
// a control changes, without a round trip.
//
// The report exposes the loading state (counts, times from performance.now(), errors, the
// per-component fetch log) and a few functions the browser tests and benchmarks call; see
// state.mjs.
//
// Based on: Zhou, Jia & Su 2018 (progressive, per-component streaming of a compressed skeleton);
// three.js DRACOLoader (decoding off the main thread in a worker pool).

import { PerspectiveCamera } from 'three';

import { kFovDeg } from './camera.mjs';
import { wireKeyboard } from './keyboard.mjs';
import { findPart, parseManifestSliced } from './manifest.mjs';
import { measure, measureHits } from './measure.mjs';
import { addNote, annotationsExport, checkNotesDepth, wireNotes } from './notes.mjs';
import { drawOverlay, wireOverlay } from './overlay.mjs';
import {
  $, buildGroups, buildListsSoon, hidePart, isolatePart, kListsAfterMs, reportError, select, selectByName, showAllParts, showPart, updateClip,
  updateStats, updateStatus, wirePanel,
} from './panel.mjs';
import { pickAt, picked, wirePicking } from './picking.mjs';
import { applyView, captureView, encodeViewState, parseViewState } from './share.mjs';
import { createViewerState, emit, exposeState } from './state.mjs';
import { nextTask } from './stream.mjs';
import { componentsDrawn, componentsFailed, finish, levelFailed, levelsShown, rendererFailed, startLog, startStream } from './streaming.mjs';
import { fitAll, frameDrawn, resize, screenBoundsOf, screenPositionOf, sendParts, setBackground, setCameraView, startControls } from './view.mjs';

// How long after the view's last change the URL's hash is rewritten (shareHash).
const kShareHashMs = 300;

// How long the page waits for the render worker to start before reading the manifest regardless.
const kRendererStartWaitMs = 1000;
// How long the viewer waits for the page's first frame to learn the view's size before it measures
// it itself (a page opened in a background tab gets no frame until shown).
const kFirstSizeWaitMs = 100;

/// The renderer's messages (render_worker.mjs lists them).
function onRendererMessage(state, message) {
  switch (message?.type) {
    case 'failed':
      if (Number.isInteger(message.level)) for (const id of message.ids) levelFailed(state, id, message.level, message.error);
      else componentsFailed(state, message.ids, message.error);
      break;
    case 'frame':
      frameDrawn(state, message);
      if (message.drawn.length) componentsDrawn(state, message.drawn, message.at);
      if (message.levels?.length) levelsShown(state, message.levels, message.at);
      break;
    case 'fatal':
      rendererFailed(state, message.error, message.at);
      break;
    case 'picked':
      picked(state, message);
      break;
    case 'timing':
      state.report.timings[message.name] = message.at;
      break;
    default:
  }
}

/// No OffscreenCanvas: the renderer runs here, on the channel the bootstrap opened (its messages
/// have waited there).
async function startPageRenderer(state) {
  const { boot } = state;
  try {
    const { startRenderer } = await import(boot.renderWorkerFile);
    startRenderer(boot.rendererPort, { canvas: state.canvas });
  } catch (e) {
    boot.messages.push({ type: 'fatal', error: `osteon: the renderer could not be loaded: ${e?.message ?? e}`, at: performance.now() });
  }
}

/// Reads the manifest the bootstrap fetched into state.manifest; false (reported) if it is bad.
async function readManifest(state) {
  const { boot } = state;
  try {
    const json = boot.manifestJson ? await boot.manifestJson : JSON.parse(await boot.manifest);
    await nextTask();
    state.manifest = await parseManifestSliced(json, nextTask);
    return true;
  } catch (e) {
    const message = String(e?.message ?? e);
    reportError(state, message.startsWith('osteon:') ? message : `osteon: ${new URL(boot.manifestUrl).pathname.split('/').pop()}: not JSON: ${message}`);
    $(state, 'progress-text').textContent = 'Could not load the package';
    state.fatal = true;
    state.report.framePending = false;
    state.report.done = true;
    state.report.listsBuilt = true;  // no bones to list
    for (const worker of boot.decoders) worker.terminate();
    emit(state, 'error', { message: state.report.errors.at(-1) });
    return false;
  }
}

async function main(state) {
  const { boot, report } = state;
  if (!boot?.link) {
    reportError(state, boot?.rendererError ?? 'osteon: the viewer\'s bootstrap did not start');
    $(state, 'progress-text').textContent = 'Could not start the viewer';
    report.done = true;
    report.listsBuilt = true;  // no bones to list
    return;
  }
  state.link = boot.link;
  report.renderer = boot.offscreen ? 'worker' : 'page';
  report.timings = boot.timings;  // the renderer's steps are added as they come
  if (!boot.offscreen) await startPageRenderer(state);
  let awaitingSize = null;  // ends the wait for the first size below, on the observer's first call
  const onResize = () => {
    resize(state, $(state, 'view').getBoundingClientRect());
    drawOverlay(state);
    awaitingSize?.();
    awaitingSize = null;
  };
  state.resizeObserver = new ResizeObserver(onResize);
  state.resizeObserver.observe($(state, 'view'));
  const after = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
  // The camera's aspect, before the view is fitted below: from the observer's first call, in the
  // next frame, once the page has laid itself out. Measured here, it would lay the page out within
  // this script (a fifth of a second on a slow phone). A background tab has no frames: there it is
  // measured after kFirstSizeWaitMs.
  const waits = [Promise.race([new Promise((resolve) => { awaitingSize = resolve; }), after(kFirstSizeWaitMs)])];
  // The render worker gets its first messages through this thread, so this thread's own long
  // work (the manifest's parse, the panel) waits until the worker has started: done first, it
  // would hold back the worker's start, and so its WebGL context, by as long.
  if (boot.offscreen) waits.push(Promise.race([boot.rendererStarted, after(kRendererStartWaitMs)]));
  await Promise.all(waits);
  if (awaitingSize && !state.destroyed) onResize();
  if (state.destroyed || !(await readManifest(state)) || state.destroyed) return;
  // A task each for the fetch log and the levels' planner, the controls and the panel, and the
  // stream: with thousands of components each is tens of milliseconds on a slow phone.
  startLog(state);
  await nextTask();
  if (state.destroyed) return;
  startControls(state);
  buildGroups(state);
  updateClip(state);
  // The view asked for (the element's camera and view attributes, the page's hash), before the
  // first camera goes to the renderer: the first frame already shows it.
  for (const pending of state.pendingViews.splice(0)) applyPending(state, pending);
  state.shareArmed = true;
  state.startView = captureView(state);
  updateStats(state);
  updateStatus(state);
  await nextTask();
  if (state.destroyed) return;
  state.onReady?.();

  // What the renderer said before the manifest was read here, then everything after, as it comes.
  boot.deliver = (message) => onRendererMessage(state, message);
  for (const message of boot.messages.splice(0)) onRendererMessage(state, message);
  startStream(state);
  setTimeout(() => buildListsSoon(state), kListsAfterMs);
  if (report.componentsTotal === 0) finish(state, performance.now());
}

/// Draws the parts with `colors` (3 per part, 0..1 sRGB) and `opacity` (1 per part), arrays or
/// null (window.osteon.setPartStyle, for tests: the panel sets the same state fields).
function setPartStyle(state, { colors = null, opacity = null } = {}) {
  if (!state.manifest) return false;
  state.partColors = colors ? Float32Array.from(colors) : null;
  state.partOpacity = opacity ? Float32Array.from(opacity) : null;
  sendParts(state);
  return true;
}

/// A view asked for before or after the manifest was read: { camera } (parseCamera's) or
/// { view } (parseViewState's), with the messages of its parse. Applied now if it can be, else
/// once the manifest is read; what cannot be used is reported ('osteon: view: ...').
function applyPending(state, pending) {
  if (!state.manifest || !state.controls) {
    state.pendingViews.push(pending);
    return;
  }
  const errors = [...(pending.errors ?? [])];
  if (pending.camera) setCameraView(state, pending.camera);
  if (pending.view) errors.push(...applyView(state, pending.view));
  for (const e of errors) reportError(state, `osteon: view: ${e}`);
}

/// Whether views `a` and `b` (share.mjs captureView) are the same but for rounding errors in the
/// camera (1e-9 of the distance to the target).
function sameView(a, b) {
  const { camera: ca, ...restA } = a;
  const { camera: cb, ...restB } = b;
  if (JSON.stringify(restA) !== JSON.stringify(restB) || ca.fov !== cb.fov) return false;
  const scale = Math.hypot(...cb.position.map((v, i) => v - cb.target[i])) * 1e-9;
  const close = (u, v) => u.every((x, i) => Math.abs(x - v[i]) <= scale);
  return close(ca.position, cb.position) && close(ca.target, cb.target) && close(ca.up, cb.up);
}

/// The link that opens this viewer's view: the page's own URL with the view as its hash where
/// the page keeps the view in its hash (the standalone page), else the package's own page (the
/// index.html beside its manifest) with it.
function shareLink(state, syncHash) {
  const text = encodeViewState(captureView(state) ?? {});
  if (syncHash) {
    // The page's URL becomes the link at once (its hash may lag the camera by a rounding error:
    // the controls' updates move it by less than they report as a change).
    if (location.hash.slice(1) !== text) history.replaceState(history.state, '', `#${text}`);
    return location.href;
  }
  const manifest = new URL(state.boot.manifestUrl);
  const file = manifest.pathname.split('/').pop();
  const page = new URL('./', manifest);
  if (file !== 'manifest.json') page.search = `?manifest=${encodeURIComponent(file)}`;
  page.hash = text;
  return page.href;
}

/// Creates one viewer in `root` (the element's shadow root, holding index.html's markup), on the
/// downloads `boot` (boot.js startBoot) has started. `host`: the element (events go there).
/// Options: budget ({ bytes?, triangles? }), background ('#rrggbb'), syncHash (keep the view in
/// the page's URL hash, as the standalone page does). Returns { state, report, setView(text),
/// setCamera(camera), viewState(), setBackground(color), setBudget(budget), destroy() }.
export function createViewer({ host, root, boot, budget = {}, background, syncHash = false }) {
  const state = createViewerState({
    boot,
    host,
    root,
    canvas: root.getElementById('canvas'),
    camera: new PerspectiveCamera(kFovDeg, 1, 0.1, 1000),
    budget,
    ...(background ? { background } : {}),
  });
  let ready;
  const readyPromise = new Promise((resolve) => { ready = resolve; });
  state.onReady = () => ready(state.report);
  const byName = (fn) => (name) => {
    const part = state.manifest && findPart(state.manifest, name);
    if (!part) return false;
    fn(state, part.id);
    return true;
  };
  const report = exposeState(state, {
    screenPositionOf: (name) => screenPositionOf(state, name),
    screenBoundsOf: (name) => screenBoundsOf(state, name),
    select: (name) => (name === null ? (state.manifest ? (select(state, -1), true) : false) : selectByName(state, name, { frame: false })),
    frame: (name) => (name === undefined ? (state.manifest ? (fitAll(state), true) : false) : selectByName(state, name, { frame: true })),
    hide: byName(hidePart),
    show: byName(showPart),
    isolate: byName(isolatePart),
    showAll: () => (state.manifest ? (showAllParts(state), true) : false),
    setBudget: (b) => state.levels?.setBudget(b) ?? null,
    setMaxPixelError: (px) => state.levels?.setMaxPixelError(px) ?? null,
    levelPixels: (id) => state.levels?.levelPixels(id) ?? null,
    viewState: () => (state.manifest && state.controls ? encodeViewState(captureView(state)) : null),
    setViewState: (text) => applyPending(state, parseViewState(text)),
    cameraState: () => (state.controls ? captureView(state).camera : null),
    measure: (...points) => measure(state, ...points),
    measureAt: async (...ndcs) => measureHits(state, await Promise.all(ndcs.map((ndc) => pickAt(state, ndc)))),
    setPartStyle: (style) => setPartStyle(state, style),
    pickAt: (ndc, { xray = false } = {}) => pickAt(state, ndc, { xray }),
    addNote: (note) => addNote(state, note),
    notes: () => annotationsExport(state),
  });
  state.shareLink = () => shareLink(state, syncHash);
  let shareTimer = null;
  state.onViewChanged = () => {
    drawOverlay(state);  // the measurements and notes follow the camera
    checkNotesDepth(state);  // and a note that a bone hides now is faded
    if (!state.shareArmed || shareTimer !== null) return;
    shareTimer = setTimeout(() => {
      shareTimer = null;
      if (state.destroyed || !state.controls) return;
      const view = captureView(state);
      // The controls' first update after the start moves the camera by a rounding error: the view
      // the viewer opened with is not written into the page's URL.
      if (!state.viewMoved && sameView(view, state.startView)) return;
      state.viewMoved = true;
      const text = encodeViewState(view);
      if (syncHash && location.hash.slice(1) !== text) history.replaceState(history.state, '', `#${text}`);
      emit(state, 'viewchange', { view: text });
    }, kShareHashMs);
  };
  if (syncHash && location.hash.length > 1) applyPending(state, parseViewState(location.hash));
  if (background) root.getElementById('view').style.background = background;
  wirePicking(state);
  wireOverlay(state);
  wireNotes(state);
  wirePanel(state);
  wireKeyboard(state);
  main(state).catch((e) => {
    reportError(state, `osteon: the viewer failed: ${e?.stack ?? e}`);
    state.report.done = true;
    state.report.listsBuilt = true;  // none will be built
  });
  return {
    state,
    report,
    ready: readyPromise,
    setCamera: (pending) => applyPending(state, pending),
    setView: (text) => applyPending(state, parseViewState(text)),
    setBackground: (color) => setBackground(state, color),
    setBudget: (b) => {
      if (state.levels) state.levels.setBudget(b);
      else Object.assign(state.initialBudget, b);
    },
    destroy: () => destroy(state, () => clearTimeout(shareTimer)),
  };
}

/// Stops one viewer: its fetches, its workers (the renderer, the decoders), its observers.
function destroy(state, more) {
  if (state.destroyed) return;
  state.destroyed = true;
  state.fatal = true;
  more();
  state.stopStream.abort();
  clearTimeout(state.statusTimer);
  state.resizeObserver?.disconnect();
  state.controls?.dispose();
  const { boot } = state;
  if (boot) {
    boot.deliver = () => {};
    if (boot.link?.terminate) boot.link.terminate();
    else boot.link?.close?.();
    for (const worker of boot.decoders) worker.terminate();
  }
  state.pool?.then((pool) => pool.terminate(), () => {});
}
