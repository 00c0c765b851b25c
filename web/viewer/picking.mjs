// SPDX-License-Identifier: Apache-2.0
// Picking a bone on the canvas: a tap or click (a pointer that moved no further than kTapPixels;
// further is a drag, which orbits) asks the renderer, which holds the meshes, to cast the ray; it
// answers with the part ('picked'), which the panel selects. Escape clears the selection.
// With the Measure or Note tool on (overlay.mjs), the answer's surface point goes to the tool
// instead (measure.mjs, notes.mjs), and Escape clears the measurements first, then the tool.

import { clearMeasurements, finishMeasurement, measurePicked } from './measure.mjs';
import { notePicked } from './notes.mjs';
import { annotations, setTool } from './overlay.mjs';
import { select } from './panel.mjs';
import { send, sendCamera } from './view.mjs';

const kTapPixels = 6;  // a pointer that moves further is a drag (orbit), not a pick

function pick(state, clientX, clientY) {
  if (!state.manifest || !state.link) return;
  const rect = state.canvas.getBoundingClientRect();
  const ndc = [((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1];
  annotations(state).lastTap = { x: clientX, y: clientY };  // where the note's field opens
  castRay(state, ndc);
}

/// Asks the renderer for the ray through `ndc`; returns the pick's id.
function castRay(state, ndc, { quiet = false, xray = state.xrayPick } = {}) {
  state.camera.updateMatrixWorld();
  sendCamera(state);  // the ray is cast from the camera as it is now, not as of the last frame
  // A quiet pick (negative ids) is no later pick for a tap's answer to give way to.
  const id = quiet ? -(state.quietPicks = (state.quietPicks ?? 0) + 1) : ++state.pickSeq;
  send(state, { type: 'pick', id, ndc, xray });
  return id;
}

/// A pick at `ndc` ([x, y], normalized device coordinates) that neither selects nor feeds a tool:
/// a Promise of the renderer's 'picked' answer ({ part, point, normal }), null before the
/// manifest is read (window.osteon.measureAt). Options: `quiet`, a pick of the viewer's own
/// (notes.mjs checkNotesDepth) that leaves the taps' sequence alone; `xray` (default: the
/// panel's x-ray picking).
export function pickAt(state, ndc, options = {}) {
  if (!state.manifest || !state.link) return Promise.resolve(null);
  const id = castRay(state, ndc, options);
  return new Promise((resolve) => annotations(state).pickWaiters.set(id, resolve));
}

/// The renderer's answer to a pick: selects the part (or none, for -1) unless a later pick is out;
/// with a tool on, the tool takes the point instead.
export function picked(state, message) {
  const waiters = state.annotations?.pickWaiters;
  const waiter = waiters?.get(message.id);
  if (waiter) {
    waiters.delete(message.id);
    waiter(message);
    return;
  }
  if (message.id !== state.pickSeq || !state.manifest) return;
  const tool = state.annotations?.tool;
  if (tool === 'measure') measurePicked(state, message);
  else if (tool === 'note') notePicked(state, message);
  else select(state, message.part);
}

/// Attaches the canvas's pointer and key listeners (once).
export function wirePicking(state) {
  const { canvas } = state;
  canvas.addEventListener('pointerdown', (e) => {
    state.pointerDown = e.isPrimary ? { x: e.clientX, y: e.clientY, id: e.pointerId } : null;
  });
  canvas.addEventListener('pointerup', (e) => {
    const down = state.pointerDown;
    if (down && e.pointerId === down.id && Math.hypot(e.clientX - down.x, e.clientY - down.y) <= kTapPixels) {
      pick(state, e.clientX, e.clientY);
    }
    state.pointerDown = null;
  });
  canvas.addEventListener('pointercancel', () => { state.pointerDown = null; });
  canvas.addEventListener('keydown', (e) => {
    if (!state.manifest) return;
    if (e.key === 'Enter' && state.annotations?.tool === 'measure') finishMeasurement(state);
    if (e.key !== 'Escape') return;
    if (clearMeasurements(state)) return;
    if (state.annotations?.tool) setTool(state, null);
    else select(state, -1);
  });
}
