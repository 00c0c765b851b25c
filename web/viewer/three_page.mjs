// SPDX-License-Identifier: Apache-2.0
// The part of three.js the page's own script uses (main.mjs, view.mjs, camera.mjs and three's
// OrbitControls): build.mjs resolves 'three' to this file for that bundle only. three's
// single-file build keeps almost all of itself in any bundle that imports from it (its top-level
// statements construct objects, which a bundler must assume have side effects), 255 KB for a
// camera and its controls; importing from its source modules keeps the page's script to what it
// runs. The renderer, with the rest of three.js, lives in the render worker (render_three.mjs).

export { MOUSE, TOUCH } from 'three/src/constants.js';
export { Controls } from 'three/src/extras/Controls.js';
export { PerspectiveCamera } from 'three/src/cameras/PerspectiveCamera.js';
export { Plane } from 'three/src/math/Plane.js';
export { Quaternion } from 'three/src/math/Quaternion.js';
export { Ray } from 'three/src/math/Ray.js';
export { Spherical } from 'three/src/math/Spherical.js';
export { Vector2 } from 'three/src/math/Vector2.js';
export { Vector3 } from 'three/src/math/Vector3.js';
export * as MathUtils from 'three/src/math/MathUtils.js';
