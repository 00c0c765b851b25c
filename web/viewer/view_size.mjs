// SPDX-License-Identifier: Apache-2.0
// The view's size, computed one way wherever it is needed: the page's 'size' messages (view.mjs),
// the drawing buffer the bootstrap gives the render worker's canvas before its context is made
// (boot.js), and the one the first frames draw into (render_worker.mjs). Where these agree, the
// first frame finds the drawing buffer at its size and does not make it again.

/// The pixel ratio the viewer draws at: the screen's, at most 2.
export function viewPixelRatio() {
  return Math.min(globalThis.devicePixelRatio || 1, 2);
}

/// A box's size in whole CSS pixels, at least 1 each (`rect`: a client rectangle).
export function cssSize(rect) {
  return { width: Math.max(1, Math.floor(rect.width)), height: Math.max(1, Math.floor(rect.height)) };
}

/// The drawing buffer, in device pixels, for `width` x `height` CSS pixels at `pixelRatio`, as
/// three.js's setSize makes it.
export function drawingBufferSize({ width, height }, pixelRatio) {
  return { width: Math.floor(Math.max(1, width) * pixelRatio), height: Math.floor(Math.max(1, height) * pixelRatio) };
}
