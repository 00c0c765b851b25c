// SPDX-License-Identifier: Apache-2.0
// The osteon viewer's page: wires the panel (panel.mjs), the camera controls and the renderer's
// link (view.mjs), picking (picking.mjs) and the data path (streaming.mjs: the package's chunk
// files read as streams, each component handed to the decoder workers the moment its bytes are
// in, each decoded mesh passed on to the renderer) around one state object (state.mjs), which
// every function is handed and whose report is window.osteon. The renderer is a worker
// (render_worker.mjs) that the page's inline bootstrap (boot.js) started with the canvas before
// this script had even arrived, along with the manifest, the decoder and its workers; this script
// picks them up from window.osteonBoot. Where the canvas cannot go to a worker, the same renderer
// runs here, on a MessagePort (boot.js says when).
//
// Why so: nothing on the main thread takes long (no WebGL context, no shader compilation, no mesh
// upload, no decoding; reading a stream is a copy per network packet), so clicks, scrolling and
// typing answer at once while a skeleton streams in, and the streams keep being read while the
// renderer waits on the GPU. window.osteon's counts are computed here from the manifest and the
// set of components the renderer has drawn (manifest.mjs drawStats), so they are exact the moment
// a control changes, without a round trip.
//
// window.osteon exposes the loading state (counts, times from performance.now(), errors, the
// per-component fetch log) and a few functions the browser tests and benchmarks call; see
// state.mjs.
//
// Based on: Zhou, Jia & Su 2018 (progressive, per-component streaming of a compressed skeleton);
// three.js DRACOLoader (decoding off the main thread in a worker pool).

import { PerspectiveCamera } from 'three';

import { kFovDeg } from './camera.mjs';
import { parseManifest } from './manifest.mjs';
import { $, buildGroups, buildListsSoon, kListsAfterMs, reportError, selectByName, updateClip, updateStats, updateStatus, wirePanel } from './panel.mjs';
import { picked, wirePicking } from './picking.mjs';
import { budgetFromParams, createViewerState, exposeState } from './state.mjs';
import { componentsDrawn, componentsFailed, finish, levelFailed, levelsShown, rendererFailed, startLog, startStream } from './streaming.mjs';
import { frameDrawn, resize, screenBoundsOf, screenPositionOf, startControls } from './view.mjs';

// build.mjs replaces OSTEON_RENDER_WORKER_FILE with the render worker's content-hashed file name.
/* global OSTEON_RENDER_WORKER_FILE */
const kRenderWorkerFile = typeof OSTEON_RENDER_WORKER_FILE === 'string' ? OSTEON_RENDER_WORKER_FILE : './render_worker.mjs';

// How long the page waits for the render worker to start before reading the manifest regardless.
const kRendererStartWaitMs = 1000;

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
    const { startRenderer } = await import(new URL(kRenderWorkerFile, import.meta.url).href);
    startRenderer(boot.rendererPort, { canvas: state.canvas });
  } catch (e) {
    boot.messages.push({ type: 'fatal', error: `osteon: the renderer could not be loaded: ${e?.message ?? e}`, at: performance.now() });
  }
}

/// Reads the manifest the bootstrap fetched into state.manifest; false (reported) if it is bad.
async function readManifest(state) {
  const { boot } = state;
  try {
    state.manifest = parseManifest(JSON.parse(await boot.manifest));
    return true;
  } catch (e) {
    const message = String(e?.message ?? e);
    reportError(state, message.startsWith('osteon:') ? message : `osteon: ${new URL(boot.manifestUrl).pathname.split('/').pop()}: not JSON: ${message}`);
    $('progress-text').textContent = 'Could not load the package';
    state.fatal = true;
    state.report.framePending = false;
    state.report.done = true;
    for (const worker of boot.decoders) worker.terminate();
    return false;
  }
}

async function main(state) {
  const { boot, report } = state;
  if (!boot?.link) {
    reportError(state, boot?.rendererError ?? "osteon: the page's bootstrap did not run (index.html without its inline script?)");
    $('progress-text').textContent = 'Could not start the viewer';
    report.done = true;
    return;
  }
  state.link = boot.link;
  report.renderer = boot.offscreen ? 'worker' : 'page';
  report.timings = boot.timings;  // the renderer's steps are added as they come
  if (!boot.offscreen) await startPageRenderer(state);
  const onResize = () => resize(state, $('view').getBoundingClientRect());
  new ResizeObserver(onResize).observe($('view'));
  onResize();  // the camera's aspect, before the view is fitted below

  // The render worker gets its first message (the canvas) through this thread, so this thread's
  // own long work (the manifest's parse, the panel) waits until the worker has started: done
  // first, it would hold back the worker's start, and so its WebGL context, by as long.
  if (boot.offscreen) await Promise.race([boot.rendererStarted, new Promise((resolve) => setTimeout(resolve, kRendererStartWaitMs))]);
  if (!(await readManifest(state))) return;
  startLog(state);
  startControls(state);
  buildGroups(state);
  updateClip(state);
  updateStats(state);
  updateStatus(state);

  // What the renderer said before the manifest was read here, then everything after, as it comes.
  boot.deliver = (message) => onRendererMessage(state, message);
  for (const message of boot.messages.splice(0)) onRendererMessage(state, message);
  startStream(state);
  setTimeout(() => buildListsSoon(state), kListsAfterMs);
  if (report.componentsTotal === 0) finish(state, performance.now());
}

const state = createViewerState({
  boot: window.osteonBoot,
  canvas: $('canvas'),
  camera: new PerspectiveCamera(kFovDeg, 1, 0.1, 1000),
  budget: budgetFromParams(new URLSearchParams(location.search)),
});
exposeState(state, {
  screenPositionOf: (name) => screenPositionOf(state, name),
  screenBoundsOf: (name) => screenBoundsOf(state, name),
  select: (name) => selectByName(state, name, { frame: false }),
  frame: (name) => selectByName(state, name, { frame: true }),
  setBudget: (budget) => state.levels?.setBudget(budget) ?? null,
  setMaxPixelError: (px) => state.levels?.setMaxPixelError(px) ?? null,
  levelPixels: (id) => state.levels?.levelPixels(id) ?? null,
});
wirePicking(state);
wirePanel(state);
main(state).catch((e) => {
  reportError(state, `osteon: the viewer failed: ${e?.stack ?? e}`);
  state.report.done = true;
});
