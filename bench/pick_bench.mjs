// SPDX-License-Identifier: Apache-2.0
// The cost of a pick (the ray cast the viewer's render worker does for a click) on the dense CT
// surface ct-like/skull_mc.ply (1.5 M triangles), with three.js's own raycast against
// three-mesh-bvh's bounding-volume hierarchy, on the same draw objects the viewer makes.
//
//   node bench/pick_bench.mjs [--data DIR] [--out DIR] [--rays N] [--write docs/BENCHMARKS.md]
//
// The mesh is packed with `osteon pack` twice: as the viewer gets it (components of at most
// 20,000 triangles, the default) and as one component (--max-triangles 0). Each component's full
// level is decoded with the WebAssembly decoder and added to web/viewer/scene.mjs's package
// scene, as the render worker does; the camera is the viewer's opening view (camera.mjs
// packageView). N seeded clicks on the surface (the projections of points of random triangles)
// are cast (every hit along the ray, the nearest kept, as the viewer does) with three.js's Raycaster over scene.pickable(); then again with three-mesh-bvh's
// acceleratedRaycast after computeBoundsTree on every geometry (built once, timed). Both must
// return the same part and distance for every ray (checked). A pick is CPU work in the render
// worker, not WebGL: these times are Node's, the same V8 as Chromium's worker, on a shared
// machine (medians; compare the ratio).
//
// --write replaces only the text between this benchmark's markers in that file.

import { execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, rmSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

import { parseCommandLine } from './lib/args.mjs';
import { writeSection } from './lib/section.mjs';
import { median } from './lib/stats.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..');
const { values } = parseCommandLine({
  usage: 'node bench/pick_bench.mjs [options]',
  about: 'Pick (ray cast) time on skull_mc.ply: three.js raycast against three-mesh-bvh; prints a Markdown table.',
  options: {
    data: { type: 'string', arg: 'DIR', help: 'the real meshes (default: ../shared/data)' },
    out: { type: 'string', arg: 'DIR', help: 'scratch folder (default: build/pick-bench)' },
    cli: { type: 'string', arg: 'FILE', help: 'the osteon CLI (default: build/release/osteon)' },
    rays: { type: 'string', arg: 'N', help: 'clicks per variant (default 300)' },
    write: { type: 'string', arg: 'FILE', help: 'replace this benchmark\'s section of FILE (docs/BENCHMARKS.md)' },
  },
});
const data = path.resolve(values.data ?? path.join(repo, '..', 'shared', 'data'));
const out = path.resolve(values.out ?? path.join(repo, 'build', 'pick-bench'));
const cli = path.resolve(values.cli ?? path.join(repo, 'build', 'release', 'osteon'));
const rays = Number(values.rays ?? 300);
const input = path.join(data, 'ct-like', 'skull_mc.ply');
if (!existsSync(input)) {
  console.error(`osteon: ${input} is missing: nothing to measure`);
  process.exit(0);
}
const wasmDir = [process.env.OSTEON_WASM_DIR, path.join(repo, 'build', 'wasm')]
  .find((d) => d && existsSync(path.join(d, 'osteon_decoder.wasm')));
if (!wasmDir) throw new Error('osteon: no built decoder (cd web && npm run build:decoder)');

const web = (file) => pathToFileURL(path.join(repo, 'web', file)).href;
const three = await import(web('node_modules/three/build/three.module.js'));
const bvh = await import(web('node_modules/three-mesh-bvh/src/index.js'));
const { parseManifest } = await import(web('viewer/manifest.mjs'));
const { createPackageScene } = await import(web('viewer/scene.mjs'));
const { packageView, kFovDeg } = await import(web('viewer/camera.mjs'));
const { createDecoder } = await import(pathToFileURL(path.join(wasmDir, 'osteon_decoder.mjs')).href);
const bvhVersion = JSON.parse(readFileSync(path.join(repo, 'web', 'node_modules', 'three-mesh-bvh', 'package.json'), 'utf8')).version;

const kHeading = '## Picking on a dense surface (bench/pick_bench.mjs)';
const kBegin = '<!-- bench/pick_bench.mjs: begin (written by the script; edits here are overwritten) -->';
const kEnd = '<!-- bench/pick_bench.mjs: end -->';

/// A small seeded generator (mulberry32), so every run casts the same rays.
function random(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = Math.imul(a ^ (a >>> 15), 1 | a);
    t = (t + Math.imul(t ^ (t >>> 7), 61 | t)) ^ t;
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

/// Packs the input, decodes every component into the viewer's scene; returns the scene.
async function load(name, extra) {
  const dir = path.join(out, name);
  rmSync(dir, { recursive: true, force: true });
  execFileSync(cli, ['pack', input, '-o', dir, '--no-lod', '--no-viewer', ...extra], { stdio: 'ignore' });
  const manifest = parseManifest(JSON.parse(readFileSync(path.join(dir, 'manifest.json'), 'utf8')));
  const decoder = await createDecoder({ wasm: readFileSync(path.join(wasmDir, 'osteon_decoder.wasm')) });
  const root = new three.Group();
  const scene = createPackageScene(manifest, root);
  const chunks = new Map();
  for (const c of manifest.components) {
    if (!chunks.has(c.file)) chunks.set(c.file, readFileSync(path.join(dir, c.file)));
    const bytes = chunks.get(c.file).subarray(c.offset, c.offset + c.bytes);
    scene.addComponent(c.id, decoder.decode(bytes, c.id));
  }
  root.updateMatrixWorld(true);
  const camera = new three.PerspectiveCamera(kFovDeg, 16 / 9, 0.1, 1000);
  const view = packageView(manifest, kFovDeg, camera.aspect);
  Object.assign(camera, { near: view.near, far: view.far });
  camera.position.copy(view.position);
  camera.up.copy(view.up);
  camera.lookAt(view.target);
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld();
  const triangles = manifest.components.reduce((sum, c) => sum + c.triangles, 0);
  return { scene, camera, triangles, components: manifest.components.length };
}

/// The seeded clicks: points of random triangles (area-blind, one random draw object, triangle
/// and instance each), projected to the view; only those inside the view are kept.
function clicks(scene, camera) {
  const next = random(7);
  const objects = scene.pickable();
  const out = [];
  const p = new three.Vector3();
  const m = new three.Matrix4();
  for (let guard = 0; out.length < rays && guard < rays * 100; ++guard) {
    const o = objects[Math.floor(next() * objects.length)];
    const position = o.geometry.attributes.position;
    const index = o.geometry.index;
    const t = Math.floor(next() * (index.count / 3));
    p.set(0, 0, 0);
    for (let c = 0; c < 3; ++c) p.add(new three.Vector3().fromBufferAttribute(position, index.getX(3 * t + c)));
    p.divideScalar(3);
    if (o.isInstancedMesh) {
      o.getMatrixAt(Math.floor(next() * o.count), m);
      p.applyMatrix4(m);
    }
    p.applyMatrix4(o.matrixWorld).project(camera);
    if (Math.abs(p.x) < 1 && Math.abs(p.y) < 1 && p.z > -1 && p.z < 1) out.push(new three.Vector2(p.x, p.y));
  }
  return out;
}

/// Casts a ray through each click (after 20 untimed ones, to warm the JIT); returns each pick's
/// time (ms) and answer (part, distance).
function cast(scene, camera, points, firstHitOnly) {
  const raycaster = new three.Raycaster();
  raycaster.firstHitOnly = firstHitOnly;
  const times = [];
  const answers = [];
  for (let k = -20; k < points.length; ++k) {
    const ndc = points[Math.max(k, 0)];
    const t0 = performance.now();
    raycaster.setFromCamera(ndc, camera);
    const hits = raycaster.intersectObjects(scene.pickable(), false);
    const hit = hits.length ? hits.reduce((a, b) => (b.distance < a.distance ? b : a)) : null;
    if (k < 0) continue;
    times.push(performance.now() - t0);
    answers.push(hit ? { part: scene.partOf(hit), distance: hit.distance } : null);
  }
  return { times, answers };
}

function percentile(values, p) {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
}

const rows = [];
mkdirSync(out, { recursive: true });
for (const [name, label, extra] of [
  ['segmented', 'as the viewer gets it (components of ≤ 20,000 triangles)', []],
  ['whole', 'one component (--max-triangles 0)', ['--max-triangles', '0']],
]) {
  const { scene, camera, triangles, components } = await load(name, extra);
  const points = clicks(scene, camera);
  const plain = cast(scene, camera, points, false);
  const originalRaycast = three.Mesh.prototype.raycast;
  const t0 = performance.now();
  const geometries = new Set(scene.pickable().map((o) => o.geometry));
  for (const g of geometries) bvh.computeBoundsTree.call(g, { indirect: true });  // as pick_index.mjs
  const buildMs = performance.now() - t0;
  three.Mesh.prototype.raycast = bvh.acceleratedRaycast;
  const fast = cast(scene, camera, points, false);  // every hit along the ray, as the viewer casts (x-ray picks skip some)
  three.Mesh.prototype.raycast = originalRaycast;
  let hits = 0;
  plain.answers.forEach((a, k) => {
    const b = fast.answers[k];
    if (!a !== !b || (a && (a.part !== b.part || Math.abs(a.distance - b.distance) > 1e-6 * Math.max(1, a.distance)))) {
      throw new Error(`osteon: ray ${k}: three.js and three-mesh-bvh disagree (${JSON.stringify(a)} vs ${JSON.stringify(b)})`);
    }
    if (a) ++hits;
  });
  rows.push({ label, triangles, components, hits, cast: points.length, buildMs, plain: plain.times, fast: fast.times });
  console.error(`osteon: ${name}: ${hits}/${points.length} rays hit; raycast median ${median(plain.times).toFixed(2)} ms, BVH ${median(fast.times).toFixed(3)} ms`);
}

const f = (v, d = 2) => v.toFixed(d);
const lines = [
  `Command: \`node bench/pick_bench.mjs --write docs/BENCHMARKS.md\`. Input: \`ct-like/skull_mc.ply\`,`,
  `${rays} seeded clicks on the surface (points of random triangles, in the viewer's opening view), every hit along the ray as the viewer casts, the nearest kept; three.js`,
  `${three.REVISION}, three-mesh-bvh ${bvhVersion}. Both answer the same part at the same distance`,
  'for every ray (checked). A pick is CPU work in the render worker: Node times on a shared',
  'machine (medians; the ratio is the figure to quote). Build: computeBoundsTree (indirect, as the',
  'viewer\'s pick_index.mjs builds them) on every',
  'geometry, once, after the components are decoded.',
  '',
  '| draw objects | triangles | components | rays hit | raycast median (ms) | p95 | BVH build (ms) | BVH pick median (ms) | p95 | speed-up |',
  '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|',
  ...rows.map((r) => `| ${r.label} | ${r.triangles.toLocaleString('en-US')} | ${r.components} | ${r.hits}/${r.cast} | ${f(median(r.plain))} | ${f(percentile(r.plain, 0.95))} | ${f(r.buildMs, 0)} | ${f(median(r.fast), 3)} | ${f(percentile(r.fast, 0.95), 3)} | ${f(median(r.plain) / median(r.fast), 0)}× |`),
];
const body = lines.join('\n');
console.log(`${kHeading}\n\n${body}`);
if (values.write) writeSection(path.resolve(repo, values.write), { heading: kHeading, begin: kBegin, end: kEnd, body, tag: 'pick_bench' });
