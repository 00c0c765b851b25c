// SPDX-License-Identifier: Apache-2.0
// The viewer's renderer, off the page's main thread: a module worker that owns the canvas (an
// OffscreenCanvas the page's bootstrap, boot.js, transferred to it) and draws the decoded
// components the page sends it with three.js, several to a frame when they come together. The
// page keeps the panel, the camera controls, the chunk streams and the decoder pool (all short
// tasks), and learns from this worker's messages what is on screen.
//
// Why a worker: creating the WebGL context, compiling the bone material's shaders and uploading
// meshes are long tasks (60 to 800 ms for the context alone with a software GPU), which on the
// main thread block clicks, scrolling and typing while the skeleton loads. Here they block nothing
// the page does, and the page's streams keep reading while this thread waits on the GPU.
//
// Why this file is small and three.js comes apart (render_three.mjs): the context is created
// while three.js, most of the viewer's bytes, still downloads. The page's bootstrap fetches it
// (it can start before this worker's script has even arrived) and sends its text, which is
// imported from a blob: URL; where that fails (a content security policy without blob:), it is
// imported by its own URL. Meshes that arrive before three.js is ready wait in a queue and are
// drawn in its first frame.
//
// The bootstrap starts this worker from a blob: URL of this script's text, inlined in the page:
// fetching it first would cost a round trip before the context could be made. (Where blob:
// workers are refused, by a content security policy, it starts from this file.) Browsers without
// WebGL in an OffscreenCanvas get the same code on the page's main thread: main.mjs imports this
// module and calls startRenderer() with a MessagePort and the canvas.
//
// Messages from the page (all on `port`):
//   { type: 'init', canvas?, width, height, pixelRatio, pageOrigin, base (the page's URL) }
//   { type: 'manifest', text } or { type: 'manifest', error }   manifest.json, fetched by the page
//   { type: 'three', text } or { type: 'three', error }         render_three.mjs, fetched by the page
//   { type: 'mesh', ids, mesh }             a decoded component (several ids: byte-identical
//                                           streams); its buffers transferred
//   { type: 'camera', position, quaternion, up, fov, aspect, near, far }
//   { type: 'size', width, height, pixelRatio }
//   { type: 'parts', hidden (Uint8Array, 1 per hidden part), highlight (part id or -1) }
//   { type: 'clip', on, normal, constant }
//   { type: 'pick', id, ndc: [x, y] }      answered by { type: 'picked', id, part }
//   { type: 'render', seq }                 draw; the frame reports the seq
//   { type: 'shown', frame }                the page has had an animation frame since that frame
// Messages to the page (times are the page's performance.now()):
//   { type: 'frame', frame, seq, at, drawn: [ids] }   a frame was drawn (render() returned), with
//                                                     the page's changes up to `seq`; `drawn`
//                                                     appear in it first
//   { type: 'failed', ids, error, at }                a mesh the scene refused
//   { type: 'fatal', error, at }                      nothing will be drawn
//   { type: 'timing', name, at }                      a step of the start: 'started', 'context',
//                                                     'three' (loaded), 'view' (renderer made),
//                                                     'compiled'
//
// Based on: the HTML OffscreenCanvas (transferControlToOffscreen) model of rendering in a worker.

import { parseManifest } from './manifest.mjs';

// build.mjs replaces OSTEON_RENDER_THREE_FILE with the three.js part's content-hashed file name.
/* global OSTEON_RENDER_THREE_FILE */
const kThreeFile = typeof OSTEON_RENDER_THREE_FILE === 'string' ? OSTEON_RENDER_THREE_FILE : './render_three.mjs';

// What three.js's WebGLRenderer would ask for with the viewer's options ({ antialias: true }):
// the context is made here, before three.js has arrived, and handed to it.
const kContextAttributes = {
  alpha: false,
  depth: true,
  stencil: false,
  antialias: true,
  premultipliedAlpha: true,
  preserveDrawingBuffer: false,
  powerPreference: 'default',
  failIfMajorPerformanceCaveat: false,
};

// The first frame draws at most this many triangles (at least one component), the next one the
// rest of what has arrived: the first frame's GPU work (uploads, rasterization) delays when it
// shows, so a small one shows the skeleton's largest bones (first in stream order) sooner, and
// costs the frames after it only its own small redraw.
const kFirstFrameTriangles = 60000;
// A frame with new components waits until the page has had an animation frame since the last one
// was drawn ('shown'), at most this long: the GPU process runs a canvas's frames in order, and a
// heavy frame queued right behind the first would hold the first one off the screen until both
// were done (a second and more with a software GPU).
const kShownWaitMs = 250;

/// Serves one viewer on `port` (a worker's global scope or a MessagePort). `local.canvas`, on the
/// page's main thread, is the canvas element, which cannot be posted.
export function startRenderer(port, local = {}) {
  let pageOrigin = performance.timeOrigin;
  const now = () => performance.timeOrigin + performance.now() - pageOrigin;
  const post = (message) => port.postMessage(message);
  const mark = (name) => post({ type: 'timing', name, at: now() });

  let init = null;
  let canvas = null;
  let context = null;
  let three = null;           // render_three.mjs, once loaded
  let manifest = null;
  let view = null;            // its view, once three.js, the context and the manifest are here
  let fatal = null;
  const settings = new Map(); // the latest camera, size, parts and clip, not yet applied
  const picks = [];           // picks asked for before the view existed
  const queue = [];           // { ids, mesh } not yet added to the scene
  let frame = 0;
  let framePending = false;
  let drawnComponents = 0;
  let shownFrame = 0;         // the last frame the page says it has had an animation frame after
  let shownTimer = null;
  let seqSeen = 0;            // the page's last change (its 'render' seq) that the next frame includes

  function fail(message) {
    if (fatal) return;
    fatal = message;
    post({ type: 'fatal', error: message, at: now() });
  }

  const nextFrame = typeof requestAnimationFrame === 'function'
    ? (f) => requestAnimationFrame(f)
    : (f) => setTimeout(f, 16);

  function requestFrame() {
    if (framePending || !view) return;
    framePending = true;
    nextFrame(drawFrame);
  }

  /// A frame for components that arrived: at once, or once the page has seen the last frame.
  function requestDataFrame() {
    if (shownFrame >= frame || drawnComponents === 0) {
      requestFrame();
    } else if (shownTimer === null) {
      shownTimer = setTimeout(() => {
        shownTimer = null;
        requestFrame();
      }, kShownWaitMs);
    }
  }

  function drawFrame() {
    framePending = false;
    if (fatal) return;
    // Everything that arrived since the last frame goes into this one (one render, however many
    // components came together), but for the first frame with bones (kFirstFrameTriangles).
    const added = [];
    let take = queue.length;
    if (drawnComponents === 0) {
      let triangles = 0;
      take = 0;
      while (take < queue.length && (take === 0 || triangles + queue[take].mesh.indices.length / 3 <= kFirstFrameTriangles)) {
        triangles += queue[take++].mesh.indices.length / 3;
      }
    }
    for (const { ids, mesh } of queue.splice(0, take)) {
      for (const id of ids) {
        try {
          view.add(id, mesh);
          added.push(id);
          drawnComponents++;
        } catch (e) {
          post({ type: 'failed', ids: [id], error: String(e?.message ?? e), at: now() });
        }
      }
    }
    try {
      view.render();
    } catch (e) {
      fail(`osteon: drawing failed: ${e?.message ?? e}`);
      return;
    }
    frame++;
    post({ type: 'frame', frame, seq: seqSeen, at: now(), drawn: added });
    if (queue.length) requestDataFrame();
  }

  // Only what changed: setting a canvas's size, even to the same value, clears its drawing buffer.
  function applySettings() {
    for (const [type, message] of settings) {
      if (type === 'size') view.setSize(message);
      else if (type === 'camera') view.setCamera(message);
      else if (type === 'parts') view.setParts(message);
      else if (type === 'clip') view.setClip(message);
    }
    settings.clear();
  }

  /// Creates the view once its three ingredients are here (in any order).
  function startView() {
    if (view || fatal || !three || !context || !manifest) return;
    try {
      view = three.createView({ canvas, context, manifest, width: init.width, height: init.height, pixelRatio: init.pixelRatio });
      mark('view');
      applySettings();
      // The bone material's programs, compiled before the first mesh needs them.
      view.precompile();
      mark('compiled');
    } catch (e) {
      fail(`osteon: the renderer failed: ${e?.message ?? e}`);
      return;
    }
    for (const { id, ndc } of picks.splice(0)) post({ type: 'picked', id, part: view.pick(ndc) });
    requestFrame();
  }

  async function loadThree(text) {
    let module = null;
    if (text !== undefined) {
      const url = URL.createObjectURL(new Blob([text], { type: 'text/javascript' }));
      module = await import(url).catch(() => null);
      URL.revokeObjectURL(url);
    }
    try {
      // Beside the page (this script may run from a blob: URL, where import.meta.url says nothing).
      module ??= await import(new URL(kThreeFile, init?.base ?? import.meta.url).href);
    } catch (e) {
      fail(`osteon: the renderer could not be loaded: ${e?.message ?? e}`);
      return;
    }
    three = module;
    mark('three');
    startView();
  }

  function handle(message) {
    switch (message?.type) {
      case 'init': {
        init = message;
        pageOrigin = message.pageOrigin ?? performance.timeOrigin;
        mark('started');
        canvas = local.canvas ?? message.canvas;
        try {
          context = canvas.getContext('webgl2', kContextAttributes);
        } catch (e) {
          context = null;
        }
        if (!context) {
          fail('osteon: WebGL 2 is not available in this browser');
          return;
        }
        mark('context');
        startView();
        return;
      }
      case 'manifest':
        if (message.error) {
          fatal = message.error;  // the page reports it
          return;
        }
        try {
          manifest = parseManifest(JSON.parse(message.text));
        } catch (e) {
          fatal = String(e?.message ?? e);  // the page parses the same text and reports it
          return;
        }
        startView();
        return;
      case 'three':
        loadThree(message.text);
        return;
      case 'mesh':
        queue.push(message);
        requestDataFrame();
        return;
      case 'shown':
        shownFrame = Math.max(shownFrame, message.frame);
        if (queue.length && shownFrame >= frame) {
          clearTimeout(shownTimer);
          shownTimer = null;
          requestFrame();
        }
        return;
      case 'camera':
      case 'size':
      case 'parts':
      case 'clip':
        settings.set(message.type, message);
        if (view) {
          applySettings();
          requestFrame();
        }
        return;
      case 'pick':
        if (view) post({ type: 'picked', id: message.id, part: view.pick(message.ndc) });
        else if (fatal) post({ type: 'picked', id: message.id, part: -1 });
        else picks.push(message);
        return;
      case 'render':
        seqSeen = Math.max(seqSeen, message.seq ?? 0);
        requestFrame();
        return;
      default:
    }
  }

  port.onmessage = (event) => handle(event.data);
}

// In a worker, serve the page that started it.
if (typeof WorkerGlobalScope !== 'undefined' && globalThis instanceof WorkerGlobalScope) startRenderer(globalThis);
