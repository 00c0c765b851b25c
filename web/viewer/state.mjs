// SPDX-License-Identifier: Apache-2.0
// One viewer's state: one object, made by createViewerState and passed to every function of the
// viewer's modules (view.mjs, panel.mjs, picking.mjs, streaming.mjs, share.mjs); no module keeps
// mutable state of its own, and none looks its elements up in the document or keeps a page global, so several
// <osteon-viewer> elements (element.mjs) live on one page side by side. Its `report` is what tests
// and benchmarks read: the element's `report`, which the standalone page also shows as
// window.osteon.

import { kBackground } from './camera.mjs';

/// A fresh state for one viewer. `boot` is what boot.js startBoot started for it, `host` the
/// <osteon-viewer> element (its events are dispatched there), `root` its shadow root (the panel's
/// elements are looked up there), `canvas` the 3D view's canvas element, `camera` the viewer's
/// three.js PerspectiveCamera (the renderer draws with a copy).
export function createViewerState({ boot, host = null, root, canvas, camera, budget = {}, background = kBackground }) {
  return {
    boot,
    host,
    root,
    canvas,
    camera,
    resizeObserver: null,    // on the view, once started
    onViewChanged: null,     // called when the camera, selection, visibility or clipping change
    shareLink: null,         // () => the link that opens this view (main.mjs)
    pendingViews: [],        // views asked for before the manifest was read (main.mjs applyPending)
    shareArmed: false,       // the view the viewer opened with is set: changes count from here
    startView: null,         // that view (share.mjs captureView)
    viewMoved: false,        // the view has differed from it (the page's hash is written from then on)
    maxDistance: Infinity,   // how far the controls may zoom out (camera.mjs packageView)
    destroyed: false,
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
    groupBoxes: new Map(),   // group -> its checkbox in the group list (none with a region tree)
    partRows: [],            // { part, li, checkbox, button } per part, in list order
    listsStarted: false,
    tree: null,              // the region tree (region_tree.mjs createTreeModel), once the lists are built
    language: 'und',         // the language the panel names bones in (a tag of manifest.languages)
    colorBy: 'part',         // the colour menu: 'part' (the manifest's colours), 'region', 'system'
    partColors: null,        // Float32Array(3 * parts), sRGB 0..1, drawn instead of the parts' colours; null: theirs
    partOpacity: null,       // Float32Array(parts), 0..1, as drawn (the chosen opacities, x-ray applied); null: all opaque
    chosenOpacity: null,     // Float32Array(parts), the opacities set per tree node; null: all 1
    xray: false,             // every bone but the selected one drawn see-through
    xrayPick: false,         // picks go through see-through bones to the selected one's (picking.mjs)
    legend: null,            // the colour legend, [{ color (0..255), label(language) }]; null for 'part'
    searchIndex: null,       // per part, its names in every language and its groups' names, lower case
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
      bytesAtSkeletonComplete: null, // the bytes the skeleton took (its first levels' chunks)
      // Levels of detail (levels.mjs fills these in once the manifest is read): levelsTotal,
      // levelsLoaded, levelsFailed, levelDrawn ({ id: level }, 0 the coarsest), levelWanted,
      // levelLog, levelBytesLoaded, gpuBytes, gpuTriangles, gpuBytesPeak, gpuTrianglesPeak,
      // budget ({ bytes, triangles }), maxPixelError, evictions, refinedMs, firstRefinedMs,
      // refineIdle.
      errors: [],              // 'osteon: ...' messages, as listed in the page
      done: false,             // every component loaded or failed (or the manifest failed)
      listsBuilt: false,       // the panel's list of bones is whole (built a few rows a task once loading ends; true at once without a manifest)
      fetchLog: [],            // per component in fetch order: { id, chunk, file, offset, bytes, fetchStart, fetchEnd, decodedAt, addedAt, error }
      frames: 0,               // frames the renderer has drawn
      renderMs: null,          // how long the renderer's last render() took on its thread (not the GPU's work)
      partsMs: null,           // how long it took to apply the last 'parts' message (render_three.mjs setParts)
      gl: null,                // after the last frame, the WebGL objects three.js holds: { programs, geometries }
      framePending: false,     // a change is waiting for its frame
      renderer: null,          // 'worker' (OffscreenCanvas) or 'page'
      timings: {},             // the page's bootstrap: manifestResponse, manifest, threeFetched; the renderer's start: started, context, firstFrames (absent when three.js drew the first frame), three, view, compiled
      unit: null,
      background,
      selected: null,          // the selected part's display name
      language: 'und',         // the panel's language (a tag of the manifest's languages)
      colorBy: 'part',         // the colour menu's choice
      partColors: null,        // state.partColors as an array (3 per part), null for 'part'
      partOpacity: null,       // state.partOpacity as an array (1 per part), null when all opaque
      xray: false,
    },
  };
}

/// Adds to `state.report` the functions tests and benchmarks call (`api`: screenPositionOf(name),
/// screenBoundsOf(name?), select(name), frame(name), setBudget({ bytes, triangles }),
/// setMaxPixelError(px), levelPixels(componentId), ...) and returns it: the report itself, so
/// it reads what the viewer's modules write there.
export function exposeState(state, api) {
  return Object.assign(state.report, api);
}

/// Dispatches a CustomEvent `type` with `detail` on the viewer's element.
export function emit(state, type, detail) {
  state.host?.dispatchEvent(new CustomEvent(type, { detail }));
}

/// The view (camera, selection, visibility, clipping) changed: the share state follows (main.mjs).
export function viewChanged(state) {
  state.onViewChanged?.();
}

/// Whether part `id` is shown: neither hidden itself nor in a group that is switched off.
export function partVisible(state, id) {
  const part = state.manifest.parts[id];
  return !state.hiddenParts.has(id) && state.groupOn.get(part.group) !== false;
}

/// The memory budget a page's URL asks for: ?budgetMB=64 (10^6 bytes) and ?budgetTriangles=500000;
/// absent or not a number: the default (levels.mjs kDefaultBudget).
export function budgetFromParams(params) {
  return budgetOf(params.get('budgetMB'), params.get('budgetTriangles'));
}

/// The budget of `mb` megabytes (10^6 bytes) and `triangles` (strings, as an attribute or a URL
/// gives them; null, absent or not a non-negative number: the default).
export function budgetOf(mb, triangles) {
  const budget = {};
  const bytes = Number.parseFloat(mb ?? '');
  const count = Number.parseFloat(triangles ?? '');
  if (Number.isFinite(bytes) && bytes >= 0) budget.bytes = Math.round(bytes * 1e6);
  if (Number.isFinite(count) && count >= 0) budget.triangles = Math.round(count);
  return budget;
}
