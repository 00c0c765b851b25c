// SPDX-License-Identifier: Apache-2.0
// The three.js half of the render worker (render_worker.mjs imports it once the worker runs): the
// renderer on the canvas the worker was given, the scene with its lights, the camera the page
// steers, and the package's draw objects (scene.mjs). It draws when told to and answers picks.
//
// Frames are drawn on demand only (the worker asks for one when a component, a camera move, a
// resize or a visibility change arrives): an idle viewer costs nothing.
//
// Based on: three.js WebGLRenderer on an OffscreenCanvas; three.js compile() to build programs
// before they are needed.

import {
  BackSide,
  BufferAttribute,
  BufferGeometry,
  Color,
  DirectionalLight,
  FrontSide,
  Group,
  HemisphereLight,
  InstancedMesh,
  Matrix3,
  Matrix4,
  Mesh,
  Object3D,
  PerspectiveCamera,
  Plane,
  Raycaster,
  Scene,
  Vector2,
  Vector3,
  WebGLRenderer,
} from 'three';

import { kBackground, kFovDeg, packageView } from './camera.mjs';
import { createCapping } from './cap.mjs';
import { createPickIndex } from './pick_index.mjs';
import { createPackageScene } from './scene.mjs';

/// Creates the view of `manifest` (manifest.mjs) on `canvas` (an OffscreenCanvas or a canvas
/// element) with `context`, a WebGL 2 context made on it with the renderer's attributes.
/// `width`, `height`: the canvas's size in CSS pixels; `pixelRatio`: device pixels per CSS pixel;
/// `background`: the scene's colour ('#rrggbb' or a number; default camera.mjs kBackground).
export function createView({ canvas, context, manifest, width, height, pixelRatio, background = kBackground }) {
  const renderer = new WebGLRenderer({ canvas, context, antialias: true, stencil: true });
  // The context may have drawn the first frames (first_frames.mjs): three.js's cached state
  // starts from the context's defaults.
  renderer.resetState();
  renderer.localClippingEnabled = true;  // the clipping plane is set per material
  const scene = new Scene();
  scene.background = new Color(background ?? kBackground);
  const camera = new PerspectiveCamera(kFovDeg, Math.max(width, 1) / Math.max(height, 1), 0.1, 1000);
  const root = new Group();
  scene.add(root, camera);
  // Sky and ground light, plus a light that moves with the camera so the side in view is always
  // lit. The headlight comes from above and to the right of the eye: straight from the eye, every
  // surface facing the camera would be equally bright and the bones' relief would vanish.
  scene.add(new HemisphereLight(0xffffff, 0x4a4036, 0.7));
  const headlight = new DirectionalLight(0xffffff, 2.4);
  headlight.position.set(0.6, 0.9, 1);  // in camera space
  const headlightTarget = new Object3D();
  headlightTarget.position.set(0, 0, -1);
  camera.add(headlight, headlightTarget);
  headlight.target = headlightTarget;
  const clipPlanes = [];  // the planes in use (1 or 2), while the cut is on
  const raycaster = new Raycaster();
  const pickIndex = createPickIndex();
  const seeThroughStandIns = [];  // prepareSeeThrough's materials, which keep its programs
  const packageScene = createPackageScene(manifest, root);
  const capping = createCapping(scene);  // the cut's sections, filled (cap.mjs)

  let size = '';
  function setSize({ width: w, height: h, pixelRatio: ratio }) {
    // Setting a canvas's size, even to the same value, clears what it shows.
    if (size === `${w}x${h}@${ratio}`) return;
    size = `${w}x${h}@${ratio}`;
    renderer.setPixelRatio(ratio);
    renderer.setSize(Math.max(1, w), Math.max(1, h), false);  // an OffscreenCanvas has no style
    camera.aspect = Math.max(1, w) / Math.max(1, h);
    camera.updateProjectionMatrix();
  }
  setSize({ width, height, pixelRatio });

  // Until the page steers the camera, the view it will open with (the same computation there).
  const initial = packageView(manifest, kFovDeg, camera.aspect);
  camera.near = initial.near;
  camera.far = initial.far;
  camera.position.copy(initial.position);
  camera.up.copy(initial.up);
  camera.lookAt(initial.target);
  camera.updateProjectionMatrix();

  /// A raycast hit's point and face normal in the root group's frame, as [x, y, z] arrays.
  function hitInPackage(hit) {
    const { object } = hit;
    // Geometry to root: the object's own matrix, after the instance's in a batch.
    const toRoot = new Matrix4().copy(root.matrixWorld).invert().multiply(object.matrixWorld);
    if (object.isInstancedMesh) toRoot.multiply(object.getMatrixAt(hit.instanceId, new Matrix4()));
    const normal = hit.face.normal.clone().applyNormalMatrix(new Matrix3().getNormalMatrix(toRoot));
    // A mirrored batch draws a copy of the index buffer with every triangle turned round.
    if (object.isInstancedMesh && object.userData.batch?.mirror) normal.negate();
    return { point: root.worldToLocal(hit.point.clone()).toArray(), normal: normal.toArray() };
  }

  return {
    add: (id, mesh) => packageScene.addComponent(id, mesh),
    addLevel: (id, level, mesh) => packageScene.addLevel(id, level, mesh),
    showLevel: (id, level) => packageScene.showLevel(id, level),
    removeLevel: (id, level) => packageScene.removeLevel(id, level),
    takeLevelChanges: () => packageScene.takeLevelChanges(),

    render() {
      capping.update(packageScene.batches);
      renderer.render(scene, camera);
    },

    /// The WebGL objects three.js holds: linked programs and uploaded geometries.
    glCounts: () => ({ programs: renderer.info.programs?.length ?? 0, geometries: renderer.info.memory.geometries }),

    /// Compiles the programs the bone material needs (a plain mesh and an instanced batch with
    /// instance colours, under this scene's lights) on stand-in geometry, and draws them once, on
    /// the canvas: linking and the driver's own pipeline for the canvas's framebuffer happen at
    /// the first draw (with no parallel shader compilation; SwiftShader has none), and the first
    /// frame with bones would otherwise wait for them. (Drawn into a render target instead, the
    /// canvas would get no empty frame, but three.js would compile other programs: a target
    /// gets linear output, the canvas sRGB.) With `draw` false (first frames are on screen and
    /// the frame with every bone follows in the same task) only compiled: that frame's draw links.
    /// Compiles, without drawing, the programs of see-through parts (scene.mjs: transparent,
    /// one material per side), with the clipping planes as they are now, so that the first part
    /// made see-through does not wait for them. For the render worker to call once the skeleton
    /// is drawn: the compile holds up, on the GPU, the frames queued after it. The stand-in
    /// materials are kept (disposing them would free the programs).
    /// Queues the drawn objects' geometries for picking trees (pick_index.mjs), built in idle
    /// slices; for the render worker to call after its frames once the skeleton is drawn.
    indexForPicking() {
      pickIndex.add(packageScene.pickable());
    },

    pickIndexStats: () => pickIndex.stats(),

    prepareSeeThrough() {
      const geometry = new BufferGeometry();
      geometry.setAttribute('position', new BufferAttribute(new Float32Array(9), 3));
      geometry.setAttribute('normal', new BufferAttribute(new Float32Array([0, 0, 1, 0, 0, 1, 0, 0, 1]), 3));
      const bone = packageScene.materials[0];
      const objects = [BackSide, FrontSide].map((side) => {
        const material = Object.assign(bone.clone(), { transparent: true, depthWrite: false, side });
        material.clippingPlanes = bone.clippingPlanes;
        seeThroughStandIns.push(material);
        return Object.assign(new Mesh(geometry, material), { frustumCulled: false });
      });
      root.add(...objects);
      renderer.compile(scene, camera);
      root.remove(...objects);
      geometry.dispose();
    },

    precompile({ draw = true } = {}) {
      const geometry = new BufferGeometry();
      geometry.setAttribute('position', new BufferAttribute(new Float32Array(9), 3));
      geometry.setAttribute('normal', new BufferAttribute(new Float32Array([0, 0, 1, 0, 0, 1, 0, 0, 1]), 3));
      geometry.setIndex(new BufferAttribute(new Uint32Array([0, 1, 2]), 1));
      const material = packageScene.materials[0];
      const single = new Mesh(geometry, material);
      const batch = new InstancedMesh(geometry, material, 1);
      batch.setColorAt(0, new Color(1, 1, 1));
      for (const object of [single, batch]) {
        object.frustumCulled = false;
        root.add(object);
      }
      renderer.compile(scene, camera);
      if (draw) renderer.render(scene, camera);  // a degenerate triangle: draws nothing but the background
      root.remove(single, batch);
      batch.dispose();
      geometry.dispose();
    },

    setCamera({ position, quaternion, up, fov, aspect, near, far }) {
      camera.position.fromArray(position);
      camera.quaternion.fromArray(quaternion);
      camera.up.fromArray(up);
      Object.assign(camera, { fov, aspect, near, far });
      camera.updateProjectionMatrix();
    },

    setSize,

    /// The background colour ('#rrggbb').
    setBackground(color) {
      scene.background.set(color);
    },

    /// Which parts are hidden (1 per hidden part) and highlighted (a part id or -1), and how the
    /// others are drawn: `colors` (3 per part, 0..1, the manifest's colour space; null: the
    /// manifest's) and `opacity` (1 per part, 0..1; null: all opaque). scene.mjs setStyle.
    setParts({ hidden, highlight, colors = null, opacity = null }) {
      packageScene.setStyle({ visible: (part) => !hidden[part], highlight, colors, opacity });
    },

    /// The cut: `planes` ([{ normal: [x, y, z], constant }], 1 or 2; absent: the one plane of
    /// `normal` and `constant`), each keeping the side where normal . p + constant >= 0 (what
    /// any plane cuts away is removed), and with `cap`, the sections filled (cap.mjs).
    setClip({ on, normal, constant, cap = true, planes = null }) {
      const given = (planes?.length ? planes : [{ normal, constant }]).slice(0, 2);
      clipPlanes.length = 0;
      if (on) {
        for (const p of given) clipPlanes.push(new Plane(new Vector3().fromArray(p.normal), p.constant).normalize());
      }
      for (const material of packageScene.materials) {
        const cut = on ? [...clipPlanes] : null;
        if ((material.clippingPlanes?.length ?? 0) !== (cut?.length ?? 0)) material.needsUpdate = true;
        material.clippingPlanes = cut;
      }
      capping.setPlanes([...clipPlanes], on && cap);
    },

    /// What is under `ndc` (normalized device coordinates, [-1, 1] each): { part, point, normal },
    /// the nearest hit on a visible part (part -1, point and normal null where there is none).
    /// With `xray`, parts drawn see-through (opacity below 1) are skipped: the pick goes through
    /// to the opaque bone behind. Raycasts ignore clipping planes: hits on the side cut away are
    /// skipped. `point` and `normal` are [x, y, z] in the package's frame (the root group's, that
    /// of the manifest's bounds); `normal` is the hit triangle's, unit length, on the side its
    /// winding makes the front (outward on a consistently wound closed bone: it may face away
    /// from the camera where the pick hits the inside of a cut or open surface).
    /// O(log triangles) per object whose bounding sphere the ray crosses once its picking tree is
    /// built (pick_index.mjs), O(triangles) before.
    pick(ndc, { xray = false } = {}) {
      scene.updateMatrixWorld();  // objects made since the last frame
      raycaster.setFromCamera(new Vector2(ndc[0], ndc[1]), camera);
      const hit = raycaster.intersectObjects(packageScene.pickable(), false)
        .find((h) => clipPlanes.every((p) => p.distanceToPoint(h.point) >= 0) && !(xray && packageScene.partOpacity(packageScene.partOf(h)) < 1));
      if (!hit) return { part: -1, point: null, normal: null };
      return { part: packageScene.partOf(hit), ...hitInPackage(hit) };
    },
  };
}
