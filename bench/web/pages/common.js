// SPDX-License-Identifier: Apache-2.0
// What every peer page of bench/web shares with the osteon viewer (web/viewer/main.mjs and
// scene.mjs), so that only the way the skeleton arrives differs: the renderer (antialiased, pixel
// ratio at most 2), the background, the lights (a hemisphere light and a head light above and to
// the right of the eye), the material (MeshStandardMaterial 0xe6dcc6, roughness 0.6, double-sided),
// the camera (35 degrees, fitted to the box with its longest side up, looking at the front) and
// the rendering policy: a frame is drawn on the next animation frame after the scene changes, not
// on every frame, as the viewer does.
//
// The measurement state the benchmark reads, defined as the viewer defines its own (it counts a
// component as drawn once the frame that drew it has been rendered):
//
//   window.bench = { trianglesDrawn, firstTrianglesMs, allDrawnMs, trianglesRendered, frames,
//                    gpuBytes, done, errors }
//
// trianglesDrawn: the triangles in the scene (instances counted) when the last frame was rendered,
// set right after renderer.render() returns (so a first frame's shader compilation counts, as it
// does in the viewer); the benchmark samples it at the start of every animation frame, and that
// series gives its "first triangles" and "all drawn" times. firstTrianglesMs / allDrawnMs:
// performance.now() (ms from navigation start) after the first frame with a triangle and after the
// first frame with all of them once every file had loaded (the viewer's firstComponentMs and
// allLoadedMs); kept in the benchmark's JSON. trianglesRendered: three.js's count for that frame
// (renderer.info), a check on trianglesDrawn. gpuBytes: once everything is drawn, the byte lengths
// of the geometry buffers the scene's meshes upload (vertex attributes, each interleaved buffer
// once; indices; instance matrices), what the viewer's window.osteon.gpuBytes counts for its own.
//
// The canvas size comes from the page's URL (?w=&h=): the benchmark gives every way the size of
// the osteon viewer's canvas.

import {
  Box3,
  Color,
  DirectionalLight,
  DoubleSide,
  HemisphereLight,
  MeshStandardMaterial,
  Object3D,
  PerspectiveCamera,
  Scene,
  Vector3,
  WebGLRenderer,
} from 'three';

const kBoneColor = 0xe6dcc6;
const kBackground = '#1c2027';
const kFovDeg = 35;

export const bench = {
  firstTrianglesMs: null,
  allDrawnMs: null,
  trianglesDrawn: 0,
  trianglesRendered: 0,
  frames: 0,
  gpuBytes: null,
  done: false,
  errors: [],
};
window.bench = bench;

/// The up axis and viewing direction for a box: up along its longest side; from -Y when Z is up
/// (BodyParts3D faces -Y), from +Z otherwise (OpenSim and glTF face +Z). The viewer's rule.
function defaultView(box) {
  const size = box.getSize(new Vector3()).toArray();
  const axis = size.indexOf(Math.max(...size));
  if (axis === 2) return { up: new Vector3(0, 0, 1), eye: new Vector3(0, -1, 0) };
  if (axis === 1) return { up: new Vector3(0, 1, 0), eye: new Vector3(0, 0, 1) };
  return { up: new Vector3(1, 0, 0), eye: new Vector3(0, 0, 1) };
}

/// Places `camera` so the whole box shows with a 10% margin (box extents along the view axes,
/// not a bounding sphere: a skeleton is tall and thin); near and far as the viewer sets them.
function fitCamera(camera, box) {
  if (box.isEmpty()) return;
  const { up, eye } = defaultView(box);
  const target = box.getCenter(new Vector3());
  const half = box.getSize(new Vector3()).multiplyScalar(0.5);
  const right = new Vector3().crossVectors(up, eye).normalize();
  const trueUp = new Vector3().crossVectors(eye, right).normalize();
  const extent = (a) => Math.abs(a.x) * half.x + Math.abs(a.y) * half.y + Math.abs(a.z) * half.z;
  const tanV = Math.tan((camera.fov * Math.PI) / 360);
  const tanH = tanV * camera.aspect;
  const distance = Math.max(extent(trueUp) / tanV, extent(right) / tanH) * 1.1 + extent(eye);
  const radius = Math.max(half.length(), 1e-6);
  camera.up.copy(up);
  camera.position.copy(target).addScaledVector(eye, Math.max(distance, 1e-6));
  camera.near = radius / 500;
  camera.far = radius * 60;
  camera.lookAt(target);
  camera.updateProjectionMatrix();
}

/// The bytes of the geometry buffers `scene`'s meshes draw from, each array counted once.
function geometryBytes(scene) {
  const arrays = new Set();
  const add = (attribute) => {
    if (!attribute) return;
    arrays.add(attribute.isInterleavedBufferAttribute ? attribute.data.array : attribute.array);
  };
  scene.traverse((o) => {
    if (!o.isMesh || !o.geometry) return;
    for (const attribute of Object.values(o.geometry.attributes)) add(attribute);
    add(o.geometry.index);
    if (o.isInstancedMesh) {
      add(o.instanceMatrix);
      add(o.instanceColor);
    }
  });
  let bytes = 0;
  for (const a of arrays) bytes += a.byteLength;
  return bytes;
}

/// Records an error (shown on the page and reported by the benchmark) and ends the measurement.
export function fail(error) {
  const message = String(error && error.message ? error.message : error);
  bench.errors.push(message);
  bench.done = true;
  const p = document.createElement('p');
  p.className = 'error';
  p.textContent = `bench: ${message}`;
  document.body.append(p);
}

/// Creates the view. Returns { scene, add(object), setComplete() }: add() puts a loaded object in
/// the scene (its materials replaced by the shared bone material, the camera refitted to everything
/// added so far: a page of separate files cannot know the whole box before the last arrives);
/// setComplete() says every file has loaded.
/// Loads `url` with a configured GLTFLoader into a new view and marks it complete (the one-file
/// ways: Draco glTF and gltfpack).
export function loadOneGlb(loader, url = 'scene.glb') {
  const view = createView();
  return loader
    .loadAsync(url)
    .then((gltf) => {
      view.add(gltf.scene);
      view.setComplete();
    })
    .catch(fail);
}

export function createView() {
  const params = new URLSearchParams(location.search);
  const width = Number(params.get('w')) || window.innerWidth;
  const height = Number(params.get('h')) || window.innerHeight;
  const canvas = document.getElementById('canvas');
  const renderer = new WebGLRenderer({ canvas, antialias: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.setSize(width, height);

  const scene = new Scene();
  scene.background = new Color(kBackground);
  const camera = new PerspectiveCamera(kFovDeg, width / height, 0.1, 1000);
  scene.add(camera);
  scene.add(new HemisphereLight(0xffffff, 0x4a4036, 0.7));
  const headlight = new DirectionalLight(0xffffff, 2.4);
  headlight.position.set(0.6, 0.9, 1); // in camera space
  const headlightTarget = new Object3D();
  headlightTarget.position.set(0, 0, -1);
  camera.add(headlight, headlightTarget);
  headlight.target = headlightTarget;
  const material = new MeshStandardMaterial({ color: kBoneColor, roughness: 0.6, metalness: 0, side: DoubleSide });

  const box = new Box3();
  let inScene = 0;
  let complete = false;
  let framePending = false;
  function requestRender() {
    if (framePending) return;
    framePending = true;
    requestAnimationFrame(() => {
      framePending = false;
      const drawing = inScene;
      const all = complete;
      renderer.render(scene, camera);
      const now = performance.now();
      bench.trianglesRendered = renderer.info.render.triangles;
      bench.trianglesDrawn = drawing;
      bench.frames += 1;
      if (drawing > 0) bench.firstTrianglesMs ??= now;
      if (all && !bench.done) {
        bench.gpuBytes = geometryBytes(scene);
        bench.allDrawnMs = now;
        bench.done = true;
      }
    });
  }
  requestRender();

  function add(object) {
    let triangles = 0;
    object.traverse((o) => {
      if (!o.isMesh) return;
      o.material = material;
      const geometry = o.geometry;
      const count = geometry.index ? geometry.index.count : geometry.getAttribute('position').count;
      triangles += Math.floor(count / 3) * (o.isInstancedMesh ? o.count : 1);
    });
    scene.add(object);
    object.updateMatrixWorld(true);
    box.expandByObject(object);
    fitCamera(camera, box);
    inScene += triangles;
    requestRender();
  }

  return {
    scene,
    add,
    setComplete() {
      complete = true;
      requestRender();
    },
  };
}
