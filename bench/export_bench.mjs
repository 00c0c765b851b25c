// SPDX-License-Identifier: Apache-2.0
// The size of `osteon export` (glTF 2.0, KHR_mesh_quantization + EXT_meshopt_compression +
// EXT_mesh_gpu_instancing) against gltfpack 1.3 (-cc and -cz) on the same meshes at the same
// error bound, with the osteon package (`osteon pack --no-lod`) for reference, on BodyParts3D
// (235 GLB, meta.json names) and MyoSim (200 STL in metres, mirrored and repeated parts).
//
//   node bench/export_bench.mjs [--data DIR] [--out DIR] [--write docs/BENCHMARKS.md]
//
// Same input: gltfpack reads `osteon export --float --no-compress` of the same package (float
// positions, the package's decoded vertices, with its normals and instancing), so that every
// row holds the same vertices, triangles and instances. Same bound: osteon's grid step is the
// package's (2 x 0.05 mm by default); gltfpack quantises positions to -vp N bits over the scene's
// largest side, so N is the smallest for which that side / (2^N - 1) is at most osteon's step
// (gltfpack's quantisation error then is at most osteon's). Every output's largest distance from
// the package is measured with `osteon compare` (sampled, a lower bound of the Hausdorff distance).
// --write replaces only the text between this benchmark's markers in that file (appending the
// section when the markers are absent).

import { execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, readdirSync, rmSync, statSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { parseCommandLine } from './lib/args.mjs';
import { writeSection } from './lib/section.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..');
const { values } = parseCommandLine({
  usage: 'node bench/export_bench.mjs [options]',
  about: 'osteon export against gltfpack -cc / -cz at the same error bound; prints a Markdown table.',
  options: {
    data: { type: 'string', arg: 'DIR', help: 'the real meshes (default: ../shared/data)' },
    out: { type: 'string', arg: 'DIR', help: 'scratch folder (default: build/export-bench)' },
    cli: { type: 'string', arg: 'FILE', help: 'the osteon CLI (default: build/release/osteon)' },
    write: { type: 'string', arg: 'FILE', help: 'replace this benchmark\'s section of FILE (docs/BENCHMARKS.md)' },
  },
});
const data = path.resolve(values.data ?? path.join(repo, '..', 'shared', 'data'));
const out = path.resolve(values.out ?? path.join(repo, 'build', 'export-bench'));
const cli = path.resolve(values.cli ?? path.join(repo, 'build', 'release', 'osteon'));
const gltfpack = [path.join(repo, 'bench', 'node_modules', 'gltfpack', 'cli.js'),
  path.join(repo, 'web', 'node_modules', 'gltfpack', 'cli.js')].find(existsSync);
if (!gltfpack) throw new Error('osteon: gltfpack is not installed (cd web && npm ci)');
const gltfpackVersion = JSON.parse(readFileSync(path.join(path.dirname(gltfpack), 'package.json'), 'utf8')).version;

const kHeading = '## glTF export against gltfpack (bench/export_bench.mjs)';
const kBegin = '<!-- bench/export_bench.mjs: begin (written by the script; edits here are overwritten) -->';
const kEnd = '<!-- bench/export_bench.mjs: end -->';

const bodyparts = path.join(data, 'aHer-dev__3DAnatomy');
const datasets = [
  { name: 'BodyParts3D skeleton (235 GLB, meta.json names)', key: 'bodyparts3d',
    inputs: [path.join(bodyparts, 'models', 'bones')], pack: ['--names', path.join(bodyparts, 'meta.json')] },
  { name: 'MyoSim bone set (200 STL, metres)', key: 'myosim',
    inputs: [path.join(data, 'MyoHub__myo_sim', 'meshes')], pack: [] },
].filter((d) => d.inputs.every(existsSync));
if (datasets.length === 0) {
  console.error(`osteon: ${data} holds neither BodyParts3D nor MyoSim: nothing to measure`);
  process.exit(1);
}

function run(file, args) {
  return execFileSync(file, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'], maxBuffer: 256 << 20 });
}
const osteon = (...args) => run(cli, args);
const pack = (...args) => run(process.execPath, [gltfpack, ...args]);

function folderBytes(dir) {
  let total = 0;
  for (const entry of readdirSync(dir, { withFileTypes: true, recursive: true })) {
    if (entry.isFile()) total += statSync(path.join(entry.parentPath ?? entry.path, entry.name)).size;
  }
  return total;
}

/// The largest sampled distance between the package and a glTF, both ways, in the package's unit.
/// -cz writes KHR_meshopt_compression's v1 vertex codec, which Debian's meshoptimizer 0.18 (the
/// reader's) does not decode: undefined then (it quantises as -cc does).
function fileTriangles(file) {
  try {
    return JSON.parse(osteon('info', file, '--json')).triangles;
  } catch (e) {
    if (/vertex codec version 1/.test(String(e.stderr))) return undefined;
    throw e;
  }
}

function measuredError(pkg, file) {
  try {
    const report = JSON.parse(osteon('compare', pkg, file, '--whole', '--samples-per-face', '2', '--threads', '2',
      '--json'));
    return report.symmetric.max;
  } catch (e) {
    if (/vertex codec version 1/.test(String(e.stderr))) return undefined;
    throw e;
  }
}

rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });
const rows = [];
for (const d of datasets) {
  const dir = path.join(out, d.key);
  mkdirSync(dir, { recursive: true });
  const pkg = path.join(dir, 'package');
  const packed = JSON.parse(osteon('pack', ...d.inputs, ...d.pack, '-o', pkg, '--no-viewer', '--no-lod',
    '--threads', '2', '--json'));
  const exported = JSON.parse(osteon('export', pkg, '-o', path.join(dir, 'osteon.glb'), '--json'));
  const plain = JSON.parse(osteon('export', pkg, '-o', path.join(dir, 'float.glb'), '--float', '--no-compress',
    '--json'));
  const manifest = JSON.parse(readFileSync(path.join(pkg, 'manifest.json'), 'utf8'));
  // osteon's grid step is twice its per-coordinate bound (sqrt(3)/2 steps is the manifest's bound).
  const step = 2 * Math.max(...manifest.components.map((c) => c.error_bound)) / Math.sqrt(3);
  const b = manifest.bounds;
  const side = Math.max(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]);
  let bits = 1;
  while (side / (2 ** bits - 1) > step) bits += 1;
  const vp = Math.min(bits, 16);
  const outputs = [
    { tool: 'osteon package (`pack --no-lod`)', bytes: packed.output_bytes, error: null },
    { tool: '**osteon export**', bytes: exported.bytes, file: path.join(dir, 'osteon.glb') },
  ];
  for (const mode of ['-cc', '-cz']) {
    const file = path.join(dir, `gltfpack${mode}.glb`);
    pack('-i', path.join(dir, 'float.glb'), '-o', file, mode, '-vp', String(vp), '-kn', '-ke');
    outputs.push({ tool: `gltfpack ${gltfpackVersion} \`${mode} -vp ${vp} -kn -ke\``, bytes: statSync(file).size, file });
  }
  // gltfpack without quantisation or compression: what its processing alone does to the meshes.
  const unquantised = path.join(dir, 'gltfpack-noq.glb');
  pack('-i', path.join(dir, 'float.glb'), '-o', unquantised, '-noq', '-kn', '-ke');
  outputs.push({ tool: `gltfpack ${gltfpackVersion} \`-noq -kn -ke\` (no quantisation, no compression)`,
    bytes: statSync(unquantised).size, file: unquantised });
  outputs.push({ tool: 'osteon export `--float --no-compress` (gltfpack\'s input)', bytes: plain.bytes,
    file: path.join(dir, 'float.glb') });
  for (const o of outputs) {
    o.error = o.file ? measuredError(pkg, o.file) : null;
    o.fileTriangles = o.file ? fileTriangles(o.file) : null;
    rows.push({ dataset: d.name, unit: manifest.unit, step, vp, vertices: exported.vertices,
      triangles: exported.triangles, instances: exported.instances, mirrored: exported.mirrored_instances, ...o });
  }
}

const f = (x, digits = 2) => x.toFixed(digits);
const table = [
  '| input | output | bytes | bits / vertex | bits / triangle | triangles read back | largest distance from the package (measured) |',
  '|---|---|---:|---:|---:|---:|---:|',
  ...rows.map((r) => `| ${r.dataset} | ${r.tool} | ${r.bytes} | ${f(8 * r.bytes / r.vertices)} | ${f(8 * r.bytes / r.triangles)} | ` +
    `${r.fileTriangles === null ? r.triangles : r.fileTriangles === undefined ? 'not read' : r.fileTriangles} | ` +
    `${r.error === null ? '(the reference)' : r.error === undefined ? 'not read (meshopt v1 codec; as -cc\'s grid)' : `${r.error.toPrecision(3)} ${r.unit}`} |`),
].join('\n');
const sets = [...new Map(rows.map((r) => [r.dataset, r])).values()];
const body = [
  'One glTF 2.0 file from a package, as `osteon export` writes it (docs/FORMAT.md "glTF export"), against gltfpack on the same meshes at the same position error. ' +
  'gltfpack reads `osteon export --float --no-compress` of the same package (the package\'s decoded vertices in float, with its normals and EXT_mesh_gpu_instancing), so every row holds the same vertices, triangles and instances; `-kn -ke` keeps the named part nodes and their extras (the part identifiers osteon writes). ' +
  'Same bound: osteon keeps every vertex on the package\'s grid (step s); gltfpack quantises positions to `-vp N` bits over the scene\'s largest side L, with N the smallest for which L / (2^N - 1) <= s, which keeps its quantisation error within osteon\'s. gltfpack\'s files still end up further from the package than that; its `-noq` row (no quantisation at all) separates what its own processing does (it drops some triangles: the "triangles read back" column; the comparison samples them on the package\'s side) from what its quantisation adds. ' +
  'Bits per vertex and per triangle use the same counts for every row: the vertices stored in the export and the triangles drawn (instances included). ' +
  'The last column is `osteon compare PACKAGE FILE --whole` (every part merged, 2 samples a triangle, both ways; a sampled lower bound of the Hausdorff distance). ' +
  'KHR_meshopt_compression (gltfpack `-cz`) needs meshoptimizer\'s v1 vertex codec, which Debian 12\'s libmeshoptimizer 0.18 (what osteon links) does not have: osteon export writes EXT_meshopt_compression (v0), and cannot read `-cz` files back.',
  '',
  ...sets.map((r) => `- ${r.dataset}: ${r.vertices} vertices stored, ${r.triangles} triangles drawn, ${r.instances} parts drawn as instances (${r.mirrored} mirrored); grid step ${r.step.toPrecision(3)} ${r.unit}, gltfpack \`-vp ${r.vp}\`.`),
  '',
  `Machine: ${os.cpus()[0]?.model ?? 'unknown CPU'}, ${os.cpus().length} cores; Node ${process.version}. Date: ${new Date().toISOString().slice(0, 10)}. Command (from the repository root, after \`cmake --build build/release\` and \`cd web && npm ci\`):`,
  '',
  '```',
  'node bench/export_bench.mjs --write docs/BENCHMARKS.md',
  '```',
  '',
  table,
].join('\n');
console.log(body);

if (values.write) {
  writeSection(path.resolve(repo, values.write), { heading: kHeading, begin: kBegin, end: kEnd, body, tag: 'export_bench' });
}
