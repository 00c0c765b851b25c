// SPDX-License-Identifier: Apache-2.0
// The viewer page's state: one object, made by createViewerState and passed to every function of
// the page's modules (view.mjs, panel.mjs, picking.mjs, streaming.mjs); no module keeps mutable
// state of its own. Its `report` is what tests and benchmarks read: exposeState publishes it, with
// a few functions, as window.osteon.

import { kBackground } from './camera.mjs';

/// A fresh state for the page. `boot` is window.osteonBoot (boot.js), `canvas` the 3D view's
/// canvas element, `camera` the page's three.js PerspectiveCamera (the renderer draws with a copy).
export function createViewerState({ boot, canvas, camera, budget = {} }) {
  return {
    boot,
    canvas,
    camera,
    link: null,              // the renderer: a Worker or a MessagePort (boot.js)
    manifest: null,          // manifest.mjs parseManifest, once read
    controls: null,          // OrbitControls, once the manifest has fitted the camera
    fatal: false,            // nothing will be drawn
    selectedPart: -1,
    loaded: new Set(),       // component ids on screen
    settled: new Set(),      // component ids on screen or failed
    logById: new Map(),      // component id -> its report.fetchLog entry
    hiddenParts: new Set(),
    groupOn: new Map(),      // group -> whether its checkbox is on
    partRows: [],            // { part, li, checkbox, button } per part, in list order
    listsBuilt: false,
    changeSeq: 0,            // the last change sent to the renderer
    drawnSeq: 0,             // the last change a drawn frame includes
    pagePending: false,      // an animation frame is scheduled on the page
    pickSeq: 0,              // the last pick asked of the renderer
    pointerDown: null,       // { x, y, id } of the primary pointer while it is down on the canvas
    statusTimer: null,       // the status line's pending rewrite (panel.mjs scheduleStatus)
    statusAt: -Infinity,     // when it was last rewritten
    streaming: false,
    stopStream: new AbortController(),  // once nothing can be drawn, nothing more is fetched
    streamBytes: 0,          // bytes the first-stream chunks brought
    pool: null,              // Promise of the decoder pool (streaming.mjs)
    levels: null,            // the levels of detail (levels.mjs createLevelLoader), once the manifest is read
    initialBudget: budget,   // { bytes?, triangles? } from the page's URL
    viewSize: { width: 1, height: 1, pixelRatio: 1 },  // the view in CSS pixels
    clip: null,              // the clipping plane as sent to the renderer: { on, normal, constant }

    /// Everything a test or benchmark reads (window.osteon). Times are performance.now() values:
    /// milliseconds since navigation start.
    report: {
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
      firstFrameMs: null,      // the same moment: something drawn
      allLoadedMs: null,       // every component drawn (at its first level) or failed
      skeletonCompleteMs: null, // every component drawn at some level (null if one failed)
      bytesAtSkeletonComplete: null,
      // Levels of detail (levels.mjs fills these in once the manifest is read): levelsTotal,
      // levelsLoaded, levelsFailed, levelDrawn ({ id: level }, 0 the coarsest), levelWanted,
      // levelLog, levelBytesLoaded, gpuBytes, gpuTriangles, gpuBytesPeak, gpuTrianglesPeak,
      // budget ({ bytes, triangles }), maxPixelError, evictions, refinedMs, firstRefinedMs,
      // refineIdle.
      errors: [],              // 'osteon: ...' messages, as listed in the page
      done: false,             // every component loaded or failed (or the manifest failed)
      fetchLog: [],            // per component in fetch order: { id, chunk, file, offset, bytes, fetchStart, fetchEnd, decodedAt, addedAt, error }
      frames: 0,               // frames the renderer has drawn
      framePending: false,     // a change is waiting for its frame
      renderer: null,          // 'worker' (OffscreenCanvas) or 'page'
      timings: {},             // the page's bootstrap: manifest, threeFetched; the renderer's start: started, context, firstFrames (absent when three.js drew the first frame), three, view, compiled
      unit: null,
      background: kBackground,
      selected: null,          // the selected part's display name
    },
  };
}

/// Publishes `state.report` as window.osteon, with the functions tests and benchmarks call:
/// `api` holds screenPositionOf(name), screenBoundsOf(name?), select(name), frame(name),
/// setBudget({ bytes, triangles }), setMaxPixelError(px) and levelPixels(componentId).
/// window.osteon is the report itself, so it reads what the page's modules write there.
export function exposeState(state, api) {
  window.osteon = Object.assign(state.report, api);
}

/// Whether part `id` is shown: neither hidden itself nor in a group that is switched off.
export function partVisible(state, id) {
  const part = state.manifest.parts[id];
  return !state.hiddenParts.has(id) && state.groupOn.get(part.group) !== false;
}

/// The memory budget a page's URL asks for: ?budgetMB=64 (10^6 bytes) and ?budgetTriangles=500000;
/// absent or not a number: the default (levels.mjs kDefaultBudget).
export function budgetFromParams(params) {
  const budget = {};
  const mb = Number.parseFloat(params.get('budgetMB') ?? '');
  const triangles = Number.parseFloat(params.get('budgetTriangles') ?? '');
  if (Number.isFinite(mb) && mb >= 0) budget.bytes = Math.round(mb * 1e6);
  if (Number.isFinite(triangles) && triangles >= 0) budget.triangles = Math.round(triangles);
  return budget;
}
