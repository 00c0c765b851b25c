// SPDX-License-Identifier: Apache-2.0
// Picking a bone on the canvas: a tap or click (a pointer that moved no further than kTapPixels;
// further is a drag, which orbits) asks the renderer, which holds the meshes, to cast the ray; it
// answers with the part ('picked'), which the panel selects. Escape clears the selection.

import { select } from './panel.mjs';
import { send, sendCamera } from './view.mjs';

const kTapPixels = 6;  // a pointer that moves further is a drag (orbit), not a pick

function pick(state, clientX, clientY) {
  if (!state.manifest || !state.link) return;
  const rect = state.canvas.getBoundingClientRect();
  const ndc = [((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1];
  state.camera.updateMatrixWorld();
  sendCamera(state);  // the ray is cast from the camera as it is now, not as of the last frame
  send(state, { type: 'pick', id: ++state.pickSeq, ndc });
}

/// The renderer's answer to a pick: selects the part (or none, for -1) unless a later pick is out.
export function picked(state, message) {
  if (message.id === state.pickSeq && state.manifest) select(state, message.part);
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
    if (e.key === 'Escape' && state.manifest) select(state, -1);
  });
}
