// SPDX-License-Identifier: Apache-2.0
// The 3D view from the keyboard: on the canvas (in the tab order, labelled in index.html) the
// arrow keys orbit the camera as a drag does, + and - zoom as the wheel does (the orbit
// controls' own rotate and dolly, so the limits are the same; one step each, without damping),
// F frames the selected bone (everything when none is), H hides it, I isolates it (with no bone
// selected, the region selected in the tree), Esc clears the selection (picking.mjs's listener).
// H, I, F and Esc do the same in the region tree, where the arrows move through the tree.

import { hideNode, hidePart, isolateNode, isolatePart, select } from './panel.mjs';
import { fitAll, framePart } from './view.mjs';

/// How far one press of an arrow key orbits, and one press of + or - zooms.
const kOrbitRadians = Math.PI / 12;
const kZoomScale = 1.2;

/// The letter keys' actions (F, H, I, and Esc where `escape`); true if `e` was one. With no bone
/// selected, H and I act on the region the tree has selected.
function selectionKey(state, e, escape) {
  if (e.ctrlKey || e.metaKey || e.altKey) return false;
  const id = state.selectedPart;
  const region = id < 0 ? state.tree?.selectedKey ?? null : null;
  switch (e.key) {
    case 'f':
    case 'F':
      if (id >= 0) framePart(state, id);
      else fitAll(state);
      return true;
    case 'h':
    case 'H':
      if (id >= 0) hidePart(state, id);
      else if (region) hideNode(state, region);
      return true;
    case 'i':
    case 'I':
      if (id >= 0) isolatePart(state, id);
      else if (region) isolateNode(state, region);
      return true;
    case 'Escape':
      if (!escape) return false;
      select(state, -1);
      return true;
    default:
      return false;
  }
}

/// Moves the camera by `move(controls)` in one step: a key press is a step, not a throw, so the
/// controls' damping (which eases a drag out over many frames) is off for it.
function step(controls, move) {
  const damping = controls.enableDamping;
  controls.enableDamping = false;
  move(controls);
  controls.enableDamping = damping;
  return true;
}

function canvasKey(state, e) {
  const { controls } = state;
  if (!controls || e.ctrlKey || e.metaKey || e.altKey) return false;
  switch (e.key) {
    case 'ArrowLeft':
      return step(controls, (c) => c.rotateLeft(kOrbitRadians));
    case 'ArrowRight':
      return step(controls, (c) => c.rotateLeft(-kOrbitRadians));
    case 'ArrowUp':
      return step(controls, (c) => c.rotateUp(kOrbitRadians));
    case 'ArrowDown':
      return step(controls, (c) => c.rotateUp(-kOrbitRadians));
    // The controls' dollyOut divides the distance by its scale (their wheel's zoom in).
    case '+':
    case '=':
      return step(controls, (c) => c.dollyOut(kZoomScale));
    case '-':
    case '_':
      return step(controls, (c) => c.dollyIn(kZoomScale));
    default:
      // Esc on the canvas is picking.mjs's (it clears a measuring tool before the selection).
      return selectionKey(state, e, false);
  }
}

/// Attaches the keys to the canvas and the region tree (once).
export function wireKeyboard(state) {
  // In the capture phase, so the orbit controls' own key listener (which pans on the arrows)
  // does not see the keys handled here.
  state.canvas.addEventListener('keydown', (e) => {
    if (!state.manifest || !canvasKey(state, e)) return;
    e.preventDefault();
    e.stopImmediatePropagation();
  }, { capture: true });
  state.root.getElementById('region-tree')?.addEventListener('keydown', (e) => {
    if (!state.manifest || !selectionKey(state, e, true)) return;
    e.preventDefault();
    e.stopPropagation();
  });
}
