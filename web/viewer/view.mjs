// SPDX-License-Identifier: Apache-2.0
// The page's side of the 3D view: the messages that keep the renderer (render_worker.mjs, which
// lists them) in step with the page (camera, size, visible parts, frame requests), the view the
// levels of detail are planned for (levels.mjs), the camera's fit to the package or to a part,
// the orbit controls, and the projection of world boxes to client pixels
// (window.osteon.screenPositionOf, screenBoundsOf). Every function takes the viewer's state
// (state.mjs).

import { Vector3 } from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { fitBox, kFovDeg, packageView } from './camera.mjs';
import { findPart } from './manifest.mjs';
import { partVisible, viewChanged } from './state.mjs';
import { cssSize, viewPixelRatio } from './view_size.mjs';

// ---------------------------------------------------------------------------------------------
// Talking to the renderer

export function send(state, message, transfer = []) {
  state.link?.postMessage(message, transfer);
}

export function sendCamera(state) {
  const { camera } = state;
  send(state, {
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
export function requestRender(state) {
  if (state.fatal) return;  // nothing will be drawn: no frame to wait for
  state.report.framePending = true;
  if (state.pagePending) return;
  state.pagePending = true;
  requestAnimationFrame(() => {
    state.pagePending = false;
    if (state.fatal) {
      state.report.framePending = false;
      return;
    }
    // Until the manifest has fitted this camera, the renderer keeps the view it opened with.
    if (state.controls) {
      state.controls.update();
      // The levels for this camera first: a level already held is swapped in by the frame that
      // shows its component (the renderer applies them in order).
      planView(state);
      sendCamera(state);
    }
    send(state, { type: 'render', seq: ++state.changeSeq });
    state.report.framePending = state.changeSeq > state.drawnSeq;
  });
}

/// What the levels' planner needs of the view (refine.mjs screenNeeds), and which instances show.
export function planView(state) {
  const { camera, manifest, levels } = state;
  if (!levels?.hasLevels || !manifest) return;
  camera.updateMatrixWorld();
  levels.setView({
    position: camera.position.toArray(),
    projection: camera.projectionMatrix.elements,
    view: camera.matrixWorldInverse.elements,
    fovDeg: camera.fov,
    near: camera.near,
    heightPx: state.viewSize.height * state.viewSize.pixelRatio,  // the drawing buffer's pixels
    clip: state.clip?.on ? state.clip : null,
  }, (i) => partVisible(state, manifest.instances[i].part));
}

/// The renderer drew frame `message.frame`, with the page's changes up to `message.seq`.
export function frameDrawn(state, message) {
  // The renderer paces the frames that add components to this page's frames.
  requestAnimationFrame(() => send(state, { type: 'shown', frame: message.frame }));
  state.report.frames = message.frame;
  if (message.renderMs !== undefined) state.report.renderMs = message.renderMs;
  if (message.partsMs !== undefined) state.report.partsMs = message.partsMs;
  if (message.gl) state.report.gl = message.gl;
  state.drawnSeq = Math.max(state.drawnSeq, message.seq ?? 0);
  state.report.framePending = state.pagePending || state.changeSeq > state.drawnSeq;
}

/// Tells the renderer which parts are hidden and which is highlighted, and the parts' colours
/// and opacity (state.partColors, state.partOpacity: copies, transferred; null where unset).
export function sendParts(state) {
  const { manifest } = state;
  if (!manifest) return;
  const hidden = new Uint8Array(manifest.parts.length);
  for (const part of manifest.parts) hidden[part.id] = partVisible(state, part.id) ? 0 : 1;
  const colors = state.partColors ? Float32Array.from(state.partColors) : null;
  const opacity = state.partOpacity ? Float32Array.from(state.partOpacity) : null;
  const transfer = [hidden.buffer, colors?.buffer, opacity?.buffer].filter(Boolean);
  send(state, { type: 'parts', hidden, highlight: state.selectedPart, colors, opacity }, transfer);
  requestRender(state);
}

/// Gives the renderer the view's size in CSS pixels (`rect`: the view's client rectangle).
export function resize(state, rect) {
  const { width, height } = cssSize(rect);
  const pixelRatio = viewPixelRatio();
  state.viewSize = { width, height, pixelRatio };
  send(state, { type: 'size', width, height, pixelRatio });
  state.camera.aspect = width / height;
  state.camera.updateProjectionMatrix();
  requestRender(state);
}

// ---------------------------------------------------------------------------------------------
// Camera fitting and the controls

function fitCamera(state, bounds, eye, up, margin = 1.1) {
  const { camera, controls } = state;
  const fit = fitBox(bounds, eye, up, kFovDeg, camera.aspect, margin);
  camera.position.copy(fit.position);
  camera.up.copy(up);
  camera.lookAt(fit.target);
  if (controls) controls.target.copy(fit.target);
  requestRender(state);
  viewChanged(state);
}

/// Fits the whole package in view, from the direction the renderer opened with.
export function fitAll(state) {
  const { manifest } = state;
  if (!manifest) return;
  const view = packageView(manifest, kFovDeg, state.camera.aspect);
  fitCamera(state, manifest.bounds, view.position.clone().sub(view.target).normalize(), view.up);
}

/// Frames a part from the current direction of view.
export function framePart(state, partId) {
  const { camera } = state;
  const eye = camera.position.clone().sub(state.controls.target).normalize();
  fitCamera(state, state.manifest.partBounds[partId], eye, camera.up.clone(), 1.6);
}

/// Orbit controls on the camera, listening on the canvas. They read camera.up once, when made:
/// a new up (setCameraView) makes new controls.
function makeControls(state) {
  state.controls?.dispose();
  const controls = new OrbitControls(state.camera, state.canvas);
  controls.enableDamping = true;
  controls.maxDistance = state.maxDistance;
  controls.addEventListener('change', () => {
    requestRender(state);
    viewChanged(state);
  });
  controls.listenToKeyEvents(state.canvas);
  state.controls = controls;
  return controls;
}

/// Once the manifest is read: the same view the renderer opened with (camera.mjs packageView),
/// then orbit controls on it, listening on the canvas.
export function startControls(state) {
  const { camera } = state;
  const view = packageView(state.manifest, kFovDeg, camera.aspect);
  camera.near = view.near;
  camera.far = view.far;
  camera.updateProjectionMatrix();
  state.maxDistance = view.maxDistance;
  fitAll(state);  // sets camera.up, which OrbitControls reads once, in its constructor
  makeControls(state);
  fitAll(state);  // again, now that there is a target to set
}

/// Puts the camera at `position` looking at `target` (arrays), with `up` and vertical field of
/// view `fov` in degrees (each null: kept), exactly as given (share.mjs restores views with it).
export function setCameraView(state, { position, target, up, fov }) {
  const { camera } = state;
  if (fov) {
    camera.fov = fov;
    camera.updateProjectionMatrix();
  }
  if (up) camera.up.fromArray(up);
  camera.position.fromArray(position);
  camera.lookAt(new Vector3().fromArray(target));
  // New controls: they take the new up, and no momentum of a drag (damping) carries on.
  makeControls(state);
  state.controls.target.fromArray(target);
  requestRender(state);
  viewChanged(state);
}

/// The view's background colour ('#rrggbb'), on the page behind the canvas and in the renderer.
export function setBackground(state, color) {
  state.report.background = color;
  state.root.getElementById('view').style.background = color;
  send(state, { type: 'background', color });
  requestRender(state);
}

// ---------------------------------------------------------------------------------------------
// Screen projection

function toClient(state, world) {
  const rect = state.canvas.getBoundingClientRect();
  const ndc = world.clone().project(state.camera);
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
export function screenPositionOf(state, name) {
  const { manifest } = state;
  const part = manifest && findPart(manifest, name);
  if (!part) return null;
  state.camera.updateMatrixWorld();
  const box = manifest.partBounds[part.id];
  return toClient(state, new Vector3(...box.min.map((v, i) => (v + box.max[i]) / 2)));
}

/// The client rectangle { left, top, right, bottom } a world box projects to: a part's (by
/// name) or, without a name, the whole package's (manifest.bounds).
export function screenBoundsOf(state, name) {
  const { manifest } = state;
  if (!manifest) return null;
  const part = name === undefined ? null : findPart(manifest, name);
  if (name !== undefined && !part) return null;
  state.camera.updateMatrixWorld();
  const points = boxCorners(part ? manifest.partBounds[part.id] : manifest.bounds).map((p) => toClient(state, p));
  const xs = points.map((p) => p.x);
  const ys = points.map((p) => p.y);
  return { left: Math.min(...xs), top: Math.min(...ys), right: Math.max(...xs), bottom: Math.max(...ys) };
}
