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
// Why the first frame comes without three.js: parsing it, making its renderer and compiling the
// bone material take longer than the first chunks take to arrive and decode. Once the context,
// the manifest, the page's camera and a decoded component are here, first_frames.mjs (a small
// WebGL 2 program) draws what has arrived, at its first level or at a finer one the page's
// levels of detail have swapped in by then, and only then does three.js's import begin. Its view
// then takes the context over and draws the same meshes in its first frame, in the same task that
// makes it, so no empty frame shows in between.
//
// The bootstrap starts this worker from a blob: URL of this script's text, inlined in the page:
// fetching it first would cost a round trip before the context could be made. (Where blob:
// workers are refused, by a content security policy, it starts from this file.) Browsers without
// WebGL in an OffscreenCanvas get the same code on the page's main thread: main.mjs imports this
// module and calls startRenderer() with a MessagePort and the canvas.
//
// Messages from the page (all on `port`):
//   { type: 'init', width, height, pixelRatio, pageOrigin, base (the URL the viewer's files are
//     beside: three.js's part), fetchThree (this worker fetches that file itself), background
//     ('#rrggbb', or absent: camera.mjs kBackground) }
//   { type: 'canvas', canvas }              the OffscreenCanvas, transferred (a renderer on the
//                                           page has the canvas element from startRenderer)
//   { type: 'manifest', text } or { type: 'manifest', error }   manifest.json, fetched by the page
//   { type: 'three', text } or { type: 'three', error }         render_three.mjs, fetched by the
//                                                               page (without fetchThree)
//   { type: 'mesh', ids, mesh }             a decoded component (several ids: byte-identical
//                                           streams), its first level; its buffers transferred
//   { type: 'level', ids, level, mesh }     a finer level of components already sent (levels.mjs),
//                                           held, not yet drawn; its buffers transferred
//   { type: 'lod', show: [[id, level]], evict: [[id, level]] }
//                                           draw those components at those levels, then dispose
//                                           the evicted levels' geometry
//   { type: 'camera', position, quaternion, up, fov, aspect, near, far }
//   { type: 'size', width, height, pixelRatio }
//   { type: 'parts', hidden (Uint8Array, 1 per hidden part), highlight (part id or -1),
//     colors (Float32Array, 3 per part, 0..1 in the manifest's colour space, or null/absent: the
//     manifest's colours), opacity (Float32Array, 1 per part, 0..1, or null/absent: opaque) }
//   { type: 'clip', on, normal, constant, cap, planes? }
//                                           the cut: `planes` ([{ normal, constant }], 1 or 2)
//                                           wins over normal and constant; `cap` fills the sections
//   { type: 'background', color }          the view's background, '#rrggbb'
//   { type: 'pick', id, ndc: [x, y], xray } answered by { type: 'picked', id, part, point, normal }
//                                           (render_three.mjs pick: part -1 and point, normal
//                                           null where nothing is hit; `xray`: through parts
//                                           drawn see-through)
//   { type: 'render', seq }                 draw; the frame reports the seq
//   { type: 'shown', frame }                the page has had an animation frame since that frame
// Messages to the page (times are the page's performance.now()):
//   { type: 'frame', frame, seq, at, drawn: [ids], levels: [[id, level]], renderMs, partsMs, gl }
//                                                     a frame was drawn (render() returned, or
//                                                     first_frames.mjs's draw), with
//                                                     the page's changes up to `seq`; `drawn`
//                                                     appear in it first, `levels` at a new level;
//                                                     renderMs: how long three.js's render() took
//                                                     on this thread (not the GPU's work),
//                                                     partsMs: setParts, when a 'parts' message
//                                                     was applied since the last frame,
//                                                     gl: { programs, geometries } three.js holds
//   { type: 'failed', ids, error, at, level? }        a mesh the scene refused (`level`: a finer
//                                                     level's, the component stays drawn)
//   { type: 'fatal', error, at }                      nothing will be drawn
//   { type: 'timing', name, at }                      a step of the start: 'started', 'canvas'
//                                                     (it arrived), 'context',
//                                                     'firstFrames' (first_frames.mjs's program
//                                                     linked), 'three' (loaded), 'view' (renderer
//                                                     made), 'compiled'
//
// Based on: the HTML OffscreenCanvas (transferControlToOffscreen) model of rendering in a worker.

import { createFirstFrames } from './first_frames.mjs';
import { parseManifest } from './manifest.mjs';
import { drawingBufferSize } from './view_size.mjs';

// build.mjs replaces OSTEON_RENDER_THREE_FILE with the three.js part's content-hashed file name.
/* global OSTEON_RENDER_THREE_FILE */
const kThreeFile = typeof OSTEON_RENDER_THREE_FILE === 'string' ? OSTEON_RENDER_THREE_FILE : './render_three.mjs';

// What three.js's WebGLRenderer would ask for with the viewer's options ({ antialias: true,
// stencil: true }): the context is made here, before three.js has arrived, and handed to it. The
// stencil buffer fills the cut's sections (cap.mjs).
const kContextAttributes = {
  alpha: false,
  depth: true,
  stencil: true,
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
// three.js's import waits, while first frames are drawn, until every component is drawn or this
// long after the context was made: the components that arrive once its import has begun wait for
// its first frame.
const kFirstFramesWaitMs = 500;

/// The renderer's state: what has arrived from the page, the view once it can be made, and the
/// frames. Every step below takes it (as `r`).
function createRendererState(port, local) {
  return {
    port,
    local,
    pageOrigin: performance.timeOrigin,
    init: null,
    canvas: null,
    context: null,
    three: null,           // render_three.mjs, once loaded
    threeMessage: null,    // the page's 'three' message, until its import starts
    threeStarted: false,   // its import has started (no first frames after that)
    threeTimer: null,      // the import's start, when it waits for first frames
    contextAt: 0,          // when the context was made
    manifest: null,
    view: null,            // its view, once three.js, the context and the manifest are here
    firstFrames: null,     // the drawer of the frames before the view (first_frames.mjs), while in use
    firstFramesOff: false, // it cannot be used (its program did not link, or a draw threw)
    firstQueued: 0,        // the queue's messages it has taken up
    latest: new Map(),     // the latest camera, size, parts and clip, which the first frames draw with
    latestChanged: false,  // one of them changed since the last first frame
    reported: new Set(),   // component ids reported drawn
    fatal: null,
    settings: new Map(),   // the latest camera, size, parts and clip, not yet applied
    picks: [],             // picks asked for before the view existed
    queue: [],             // 'mesh', 'level' and 'lod' messages not yet applied to the scene, in order
    frame: 0,
    framePending: false,
    drawnComponents: 0,
    shownFrame: 0,         // the last frame the page says it has had an animation frame after
    shownTimer: null,
    seqSeen: 0,            // the page's last change (its 'render' seq) that the next frame includes
    partsMs: undefined,    // how long the 'parts' messages applied since the last frame took
    seeThroughReady: false, // the view has compiled the see-through parts' programs
  };
}

/// The page's performance.now() (the worker's clock starts later).
function now(r) {
  return performance.timeOrigin + performance.now() - r.pageOrigin;
}

function post(r, message) {
  r.port.postMessage(message);
}

function mark(r, name) {
  post(r, { type: 'timing', name, at: now(r) });
}

function fail(r, message) {
  if (r.fatal) return;
  r.fatal = message;
  post(r, { type: 'fatal', error: message, at: now(r) });
}

const nextFrame = typeof requestAnimationFrame === 'function'
  ? (f) => requestAnimationFrame(f)
  : (f) => setTimeout(f, 16);

function requestFrame(r) {
  if (r.framePending || !(r.view || canDrawFirst(r))) return;
  r.framePending = true;
  nextFrame(() => drawFrame(r));
}

/// A frame for components that arrived: at once, or once the page has seen the last frame.
function requestDataFrame(r) {
  if (r.shownFrame >= r.frame || r.drawnComponents === 0) {
    requestFrame(r);
  } else if (r.shownTimer === null) {
    r.shownTimer = setTimeout(() => {
      r.shownTimer = null;
      requestFrame(r);
    }, kShownWaitMs);
  }
}

/// How many queued meshes the next frame adds: everything that arrived since the last frame (one
/// render, however many components came together), but for the first frame with bones
/// (kFirstFrameTriangles, at least one mesh).
function meshesForFrame(r) {
  const { queue } = r;
  if (r.drawnComponents > 0) return queue.length;
  let triangles = 0;
  let take = 0;
  const size = (message) => (message.type === 'mesh' ? message.mesh.indices.length / 3 : 0);
  while (take < queue.length && (take === 0 || triangles + size(queue[take]) <= kFirstFrameTriangles)) {
    triangles += size(queue[take++]);
  }
  return take;
}

/// Applies the first `take` queued messages to the scene; returns the ids added (a mesh the
/// scene refuses is reported as failed).
function addMeshes(r, take) {
  const added = [];
  for (const message of r.queue.splice(0, take)) {
    if (message.type === 'lod') {
      for (const [id, level] of message.show) r.view.showLevel(id, level);
      for (const [id, level] of message.evict) r.view.removeLevel(id, level);
      continue;
    }
    for (const id of message.ids) {
      try {
        if (message.type === 'level') {
          r.view.addLevel(id, message.level, message.mesh);
        } else {
          r.view.add(id, message.mesh);
          // Drawn already, maybe, by the first frames.
          if (!r.reported.has(id)) {
            r.reported.add(id);
            added.push(id);
            r.drawnComponents++;
          }
        }
      } catch (e) {
        post(r, { type: 'failed', ids: [id], level: message.level, error: String(e?.message ?? e), at: now(r) });
      }
    }
  }
  return added;
}

/// Whether a frame can be drawn before the view exists (first_frames.mjs): the context, the
/// manifest and the page's camera are here, a mesh has arrived (the drawer is made with the first
/// one), and three.js's import has not begun (startThree). (Once it has, no more: a frame drawn
/// while three.js loads would delay it, its first frame waiting on the GPU for this one.)
function canDrawFirst(r) {
  if (r.view || r.threeStarted || r.fatal || r.firstFramesOff || !r.context || !r.manifest || !r.latest.has('camera')) return false;
  return r.firstFrames !== null || r.queue.some((message) => message.type === 'mesh');
}

/// Takes the queue's messages that the first frames have not seen yet: first levels (returns the
/// ids added), finer levels held, and the page's level swaps and evictions (into `changed`, the
/// ids whose drawn level changed). A level the first frames cannot hold is left to three.js's
/// view, which applies every message once it is made.
function takeUpFirst(r, changed) {
  const added = [];
  const { firstFrames } = r;
  for (const message of r.queue.slice(r.firstQueued)) {
    if (message.type === 'lod') {
      for (const [id, level] of message.show) if (firstFrames.show(id, level)) changed.add(id);
      for (const [id, level] of message.evict) if (firstFrames.remove(id, level)) changed.add(id);
      continue;
    }
    for (const id of message.ids) {
      if (message.type === 'level') firstFrames.addLevel(id, message.level, message.mesh);
      else if (firstFrames.add(id, message.mesh)) added.push(id);
    }
  }
  r.firstQueued = r.queue.length;
  return added;
}

/// A frame before three.js's view: every component that has arrived so far, at the level the
/// page last chose (its first, until refinement starts). The messages stay queued for the view,
/// which draws the same meshes once it is made.
function drawFirstFrame(r) {
  if (!canDrawFirst(r)) return;
  const { init, latest } = r;
  if (!r.firstFrames) {
    try {
      r.firstFrames = createFirstFrames(r.context, r.manifest);
    } catch (e) {
      r.firstFrames = null;
    }
    if (!r.firstFrames) {
      r.firstFramesOff = true;  // three.js draws the first frame instead
      return;
    }
    mark(r, 'firstFrames');
  }
  const changed = new Set();
  const added = takeUpFirst(r, changed);
  if (!added.length && !changed.size && !(r.frame > 0 && r.latestChanged)) return;
  r.latestChanged = false;
  const size = latest.get('size') ?? init;
  // The drawing buffer as three.js's setSize makes it (set only when it changes: setting it
  // clears the canvas).
  const { width: w, height: h } = drawingBufferSize(size, size.pixelRatio);
  if (r.canvas.width !== w) r.canvas.width = w;
  if (r.canvas.height !== h) r.canvas.height = h;
  try {
    r.firstFrames.draw({
      camera: latest.get('camera'),
      width: w,
      height: h,
      hidden: latest.get('parts')?.hidden ?? null,
      highlight: latest.get('parts')?.highlight ?? -1,
      clip: latest.get('clip') ?? null,
      background: latest.get('background')?.color ?? init.background,
    });
  } catch (e) {
    r.firstFramesOff = true;
    return;
  }
  for (const id of added) r.reported.add(id);
  r.drawnComponents += added.length;
  r.frame++;
  const levels = [...changed].map((id) => [id, r.firstFrames.drawnLevel(id)]);
  post(r, { type: 'frame', frame: r.frame, seq: r.seqSeen, at: now(r), drawn: added, levels });
}

function drawFrame(r) {
  r.framePending = false;
  if (r.fatal) return;
  if (!r.view) {
    drawFirstFrame(r);
    startThree(r);  // if it waited for this frame
    return;
  }
  const added = addMeshes(r, meshesForFrame(r));
  const start = performance.now();
  try {
    r.view.render();
  } catch (e) {
    fail(r, `osteon: drawing failed: ${e?.message ?? e}`);
    return;
  }
  const renderMs = performance.now() - start;
  r.frame++;
  const { partsMs } = r;
  r.partsMs = undefined;
  post(r, { type: 'frame', frame: r.frame, seq: r.seqSeen, at: now(r), drawn: added, levels: r.view.takeLevelChanges(), renderMs, partsMs, gl: r.view.glCounts() });
  if (r.queue.length) requestDataFrame(r);
  else if (!r.seeThroughReady && r.drawnComponents >= r.manifest.components.length) {
    // Every bone is on screen: the see-through parts' programs can compile now.
    r.seeThroughReady = true;
    r.view.prepareSeeThrough();
  }
  // Once every bone is on screen, what is drawn gets picking trees in idle time (new levels too).
  if (r.seeThroughReady) r.view.indexForPicking();
}

/// Applies a 'parts' message to the view, timed (the next frame reports it).
function setParts(r, message) {
  const start = performance.now();
  r.view.setParts(message);
  r.partsMs = (r.partsMs ?? 0) + performance.now() - start;
}

// Only what changed: setting a canvas's size, even to the same value, clears its drawing buffer.
function applySettings(r) {
  const { view } = r;
  for (const [type, message] of r.settings) {
    if (type === 'size') view.setSize(message);
    else if (type === 'camera') view.setCamera(message);
    else if (type === 'parts') setParts(r, message);
    else if (type === 'clip') view.setClip(message);
    else if (type === 'background') view.setBackground(message.color);
  }
  r.settings.clear();
}

/// Creates the view once its three ingredients are here (in any order).
function startView(r) {
  if (r.view || r.fatal || !r.three || !r.context || !r.manifest) return;
  const { init } = r;
  // The first frames' drawer goes before three.js's renderer takes the context.
  if (r.firstFrames) {
    r.firstFrames.dispose();
    r.firstFrames = null;
  }
  try {
    r.view = r.three.createView({ canvas: r.canvas, context: r.context, manifest: r.manifest, width: init.width, height: init.height, pixelRatio: init.pixelRatio, background: init.background });
    mark(r, 'view');
    applySettings(r);
    // The bone material's programs, compiled before the first mesh needs them (and drawn once,
    // unless first frames are on screen: then the frame with every bone follows at once).
    r.view.precompile({ draw: r.frame === 0 });
    mark(r, 'compiled');
  } catch (e) {
    fail(r, `osteon: the renderer failed: ${e?.message ?? e}`);
    return;
  }
  // After first frames, three.js's frame follows in this same task: making the view reset the
  // canvas, and an empty frame must not replace the bones on screen. Then the picks asked
  // meanwhile are answered, on what the first frames showed.
  if (r.frame > 0) drawFrame(r);
  else requestFrame(r);
  for (const message of r.picks.splice(0)) answerPick(r, message);
}

/// Starts three.js's import once the first frames are done: the first one drawn where it can be
/// drawn now (parsing three.js holds this thread for longer than that frame takes), the next ones
/// while components still arrive, until every one is drawn or kFirstFramesWaitMs have passed
/// since the context was made. (Not for finer levels that come later: with a software GPU each
/// more first frame waits for the last one's rasterization, as three.js's view does, and holds
/// three.js's import back by as much; at 10 Mbit/s BodyParts3D was refined later so.)
function startThree(r) {
  const message = r.threeMessage;
  if (!message) return;
  if (r.frame === 0) drawFirstFrame(r);
  const waited = now(r) - r.contextAt;
  if (r.frame > 0 && canDrawFirst(r) && r.drawnComponents < r.manifest.components.length && waited < kFirstFramesWaitMs) {
    // Cleared when it fires: a timer that fires a little early must be able to wait again.
    r.threeTimer ??= setTimeout(() => {
      r.threeTimer = null;
      startThree(r);
    }, kFirstFramesWaitMs - waited);
    return;
  }
  clearTimeout(r.threeTimer);
  r.threeMessage = null;
  r.threeStarted = true;
  loadThree(r, message.text);
}

/// Imports three.js's part of the renderer: from `text` (the page fetched it) by a blob: URL, or
/// from its file beside the page.
async function loadThree(r, text) {
  let module = null;
  if (text !== undefined) {
    const url = URL.createObjectURL(new Blob([text], { type: 'text/javascript' }));
    module = await import(url).catch(() => null);
    URL.revokeObjectURL(url);
  }
  try {
    // Beside the page (this script may run from a blob: URL, where import.meta.url says nothing).
    module ??= await import(new URL(kThreeFile, r.init?.base ?? import.meta.url).href);
  } catch (e) {
    fail(r, `osteon: the renderer could not be loaded: ${e?.message ?? e}`);
    return;
  }
  r.three = module;
  mark(r, 'three');
  startView(r);
}

/// 'init': the page's clock, where three.js's part is, and (on the page) the canvas.
function onInit(r, message) {
  r.init = message;
  r.pageOrigin = message.pageOrigin ?? performance.timeOrigin;
  mark(r, 'started');
  // three.js's part, fetched here (`fetchThree`) rather than on the page, whose thread would
  // inflate it; it then comes as the page's 'three' message would.
  if (message.fetchThree) {
    fetch(message.base, { priority: 'high' }).then(async (response) => {
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      return response.text();
    }).then((text) => {
      mark(r, 'threeFetched');
      handle(r, { type: 'three', text });
    }, (e) => handle(r, { type: 'three', error: String(e?.message ?? e) }));
  }
  // A worker's canvas comes in its own message (onCanvas).
  if (r.local.canvas) onCanvas(r, r.local.canvas);
}

/// The canvas (with 'init' on the page; in its own 'canvas' message in a worker, which the page
/// sends an animation frame later): the WebGL context, made before three.js is here.
function onCanvas(r, canvas) {
  if (r.canvas) return;
  r.canvas = canvas;
  mark(r, 'canvas');
  try {
    r.context = r.canvas.getContext('webgl2', kContextAttributes);
  } catch (e) {
    r.context = null;
  }
  if (!r.context) {
    fail(r, 'osteon: WebGL 2 is not available in this browser');
    return;
  }
  r.contextAt = now(r);
  mark(r, 'context');
  startView(r);
}

/// 'manifest': its text parsed (a failure is the page's to report: it parses the same text).
function onManifest(r, message) {
  if (message.error) {
    r.fatal = message.error;  // the page reports it
    return;
  }
  try {
    r.manifest = parseManifest(JSON.parse(message.text));
  } catch (e) {
    r.fatal = String(e?.message ?? e);  // the page parses the same text and reports it
    return;
  }
  startView(r);
}

/// 'shown': the page has had an animation frame since `message.frame`; a waiting frame may go.
function onShown(r, message) {
  r.shownFrame = Math.max(r.shownFrame, message.frame);
  if (r.queue.length && r.shownFrame >= r.frame) {
    clearTimeout(r.shownTimer);
    r.shownTimer = null;
    requestFrame(r);
  }
}

/// Answers a 'pick' with what the view has under it (render_three.mjs pick).
function answerPick(r, { id, ndc, xray }) {
  post(r, { type: 'picked', id, ...r.view.pick(ndc, { xray: !!xray }), trees: r.view.pickIndexStats() });
}

/// 'pick': answered now, with part -1 when nothing will be drawn, or once the view exists.
function onPick(r, message) {
  if (r.view) answerPick(r, message);
  else if (r.fatal) post(r, { type: 'picked', id: message.id, part: -1, point: null, normal: null });
  else r.picks.push(message);
}

function handle(r, message) {
  switch (message?.type) {
    case 'init':
      onInit(r, message);
      return;
    case 'canvas':
      onCanvas(r, message.canvas);
      return;
    case 'manifest':
      onManifest(r, message);
      return;
    case 'three':
      r.threeMessage = message;
      // After the messages already queued (the camera, meshes), which may make a first frame
      // to draw before three.js's import takes this thread.
      setTimeout(() => startThree(r), 0);
      return;
    case 'mesh':
    case 'level':
    case 'lod':
      r.queue.push(message);
      requestDataFrame(r);
      return;
    case 'shown':
      onShown(r, message);
      return;
    case 'camera':
    case 'size':
    case 'parts':
    case 'clip':
    case 'background':
      r.settings.set(message.type, message);
      r.latest.set(message.type, message);
      r.latestChanged = true;
      if (r.view) {
        applySettings(r);
        requestFrame(r);
      } else {
        requestFrame(r);  // a first frame, where one can be drawn
      }
      return;
    case 'pick':
      onPick(r, message);
      return;
    case 'render':
      r.seqSeen = Math.max(r.seqSeen, message.seq ?? 0);
      requestFrame(r);
      return;
    default:
  }
}

/// Serves one viewer on `port` (a worker's global scope or a MessagePort). `local.canvas`, on the
/// page's main thread, is the canvas element, which cannot be posted.
export function startRenderer(port, local = {}) {
  const r = createRendererState(port, local);
  port.onmessage = (event) => handle(r, event.data);
}

// In a worker, serve the page that started it.
if (typeof WorkerGlobalScope !== 'undefined' && globalThis instanceof WorkerGlobalScope) startRenderer(globalThis);
