// SPDX-License-Identifier: Apache-2.0
// Where the camera looks from. A package made from label volumes says which way is up and where
// the front is (the manifest's "view": the patient's axes are known). Otherwise it carries no
// "up" (docs/FORMAT.md): skeletons come Z-up (BodyParts3D, CT scanners' patient axes) or Y-up
// (OpenSim, glTF), so the tallest side of the package's box is taken as up, which holds for a
// standing skeleton or any long bone. The default view then looks at the front: from -Y for Z-up
// (BodyParts3D's face points to -Y), from +Z for Y-up (OpenSim's and glTF's front).
//
// Fitting works on the box, not its bounding sphere: a skeleton is tall and thin, and a sphere
// fit would leave it a third of the screen high.

import { Vector3 } from 'three';

/// The view's vertical field of view, and its background (the page's CSS paints the same colour
/// behind the canvas until the first frame).
export const kFovDeg = 35;
export const kBackground = '#1c2027';

/// { up, eye } unit vectors for a box { min, max }: up along its longest side, eye the direction
/// from the box's centre to the camera.
export function defaultView(bounds) {
  const size = [0, 1, 2].map((i) => bounds.max[i] - bounds.min[i]);
  const axis = size.indexOf(Math.max(...size));
  if (axis === 2) return { up: new Vector3(0, 0, 1), eye: new Vector3(0, -1, 0) };
  if (axis === 1) return { up: new Vector3(0, 1, 0), eye: new Vector3(0, 0, 1) };
  return { up: new Vector3(1, 0, 0), eye: new Vector3(0, 0, 1) };
}

/// The camera position and target that show the whole box { min, max } from direction `eye`
/// (unit, centre to camera) with `up`, for a perspective camera of vertical field of view
/// `fovDeg` and `aspect`, leaving `margin` (1.1: 10%) around it.
export function fitBox(bounds, eye, up, fovDeg, aspect, margin = 1.1) {
  const min = new Vector3().fromArray(bounds.min);
  const max = new Vector3().fromArray(bounds.max);
  const target = min.clone().add(max).multiplyScalar(0.5);
  const half = max.clone().sub(min).multiplyScalar(0.5);
  const right = new Vector3().crossVectors(up, eye).normalize();
  const trueUp = new Vector3().crossVectors(eye, right).normalize();
  // The box's half extent along a unit axis a: sum of |a_i| * half_i.
  const extent = (a) => Math.abs(a.x) * half.x + Math.abs(a.y) * half.y + Math.abs(a.z) * half.z;
  const tanV = Math.tan((fovDeg * Math.PI) / 360);
  const tanH = tanV * aspect;
  const depth = extent(eye);
  const distance = Math.max(extent(trueUp) / tanV, extent(right) / tanH) * margin + depth;
  const position = target.clone().addScaledVector(eye, Math.max(distance, 1e-6));
  return { position, target, distance, radius: half.length() };
}

/// The view a package opens with, the same in the page and in the render worker (each fits its
/// own camera before the other has said anything): the front view of `bounds` fitted with a 10%
/// margin, near and far from the package's size (24-bit depth keeps a fraction of a millimetre at
/// the distance a whole skeleton is seen from, and zooming to a small bone stays unclipped), and
/// how far the controls may zoom out. Returns { position, target, up, near, far, maxDistance }.
export function packageView(manifest, fovDeg, aspect) {
  const { bounds } = manifest;
  const radius = Math.max(Math.hypot(...bounds.max.map((v, i) => v - bounds.min[i])) / 2, 1e-6);
  const { eye, up } = manifest.view
    ? { eye: new Vector3().fromArray(manifest.view.eye).normalize(), up: new Vector3().fromArray(manifest.view.up).normalize() }
    : defaultView(bounds);
  const fit = fitBox(bounds, eye, up, fovDeg, aspect, 1.1);
  return { position: fit.position, target: fit.target, up, near: radius / 500, far: radius * 60, maxDistance: radius * 20 };
}
