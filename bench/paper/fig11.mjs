// SPDX-License-Identifier: Apache-2.0
// Fig. 11 of Zhou, Jia & Su 2018 ("lightweight for shape": model size before and after
// repeated-component substitution), redone with `osteon pack` on skeletons with repeated bones.
//
//   node bench/paper/fig11.mjs [--quick] [--work DIR]
//
// Runs: MyoSim (200 STL files in metres: mirrored and moved copies), BodyParts3D (235 GLB bones,
// display names from meta.json) at the default tolerance and at --repeat-tolerance 0.5 (mm),
// and the phantom (osteon phantom; always, since it needs no data). For each:
//
// - with repeats: `osteon pack FOLDER --json` (repeats found and substituted, as shipped);
// - without repeats: `osteon pack FOLDER --no-repeats` with the same options (every part stores
//   its own components). A prototype part is packed the same way in both (same part, same
//   options, deterministic), so the difference is the members' components;
// - raw: the input files' bytes, and the indexed mesh the stored components hold (12 bytes a
//   vertex + 12 a triangle) without and with repeats, plus 64 bytes a 4x4 float matrix an
//   instance needs;
// - counts: parts, prototypes, instances, mirrored instances, components, files; the manifest's
//   bytes, raw and under gzip -9 (it grows with the instances).
//
// Writes docs/paper/results/fig11.json. Without ../shared/data only the phantom row is measured.

import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { gzipSync } from 'node:zlib';
import {
  cliPath, dataDir, log, machine, phantomDir, resultsDir, runJson, writeJson,
} from './lib.mjs';
import { parseCommandLine } from '../lib/args.mjs';

/// The stored components of a package folder: distinct files, bytes, vertices and triangles.
function readPackage(dir) {
  const manifestPath = path.join(dir, 'manifest.json');
  const text = readFileSync(manifestPath);
  const manifest = JSON.parse(text);
  const files = new Map();
  let vertices = 0;
  let triangles = 0;
  // Package version 3 stores the components' streams in chunk files (manifest.chunks); earlier
  // versions gave each component its own file.
  for (const chunk of manifest.chunks ?? []) {
    files.set(chunk.file, statSync(path.join(dir, chunk.file)).size);
  }
  for (const c of manifest.components) {
    if (c.file) files.set(c.file, statSync(path.join(dir, c.file)).size);
    vertices += c.vertices;
    triangles += c.triangles;
  }
  return {
    manifest,
    component_bytes: [...files.values()].reduce((a, b) => a + b, 0),
    component_files: files.size,
    vertices, triangles,
    manifest_bytes: text.length,
    manifest_gzip_bytes: gzipSync(text, { level: 9 }).length,
  };
}

function packOne(cli, inputs, out, options) {
  rmSync(out, { recursive: true, force: true });
  const report = runJson(cli, ['pack', ...inputs, '-o', out, '--json', '--no-viewer', ...options]);
  return { report, pkg: readPackage(out) };
}

function measure(cli, run, work) {
  log(`fig11: ${run.name}: pack with repeats`);
  const withDir = path.join(work, `${run.id}.with`);
  const { report, pkg } = packOne(cli, [run.input], withDir, run.options);
  const instances = pkg.manifest.instances;
  const members = pkg.manifest.parts.filter((p) => p.prototype !== p.id).length;

  // Without repeats: the same folder and options, the repeat search off.
  log(`fig11: ${run.name}: pack with --no-repeats`);
  const alone = run.options.filter((o, i, a) =>
    o !== '--repeat-tolerance' && a[i - 1] !== '--repeat-tolerance');
  const withoutDir = path.join(work, `${run.id}.without`);
  const plain = packOne(cli, [run.input], withoutDir, [...alone, '--no-repeats']);
  rmSync(withoutDir, { recursive: true, force: true });
  if (plain.report.prototypes !== plain.report.parts || plain.report.parts !== report.parts) {
    throw new Error(`${run.name}: --no-repeats stored ${plain.report.prototypes} of ${
      plain.report.parts} parts (the folder has ${report.parts})`);
  }
  const without = {
    parts: plain.report.parts, components: plain.report.components,
    component_files: plain.pkg.component_files, component_bytes: plain.pkg.component_bytes,
    triangles: plain.pkg.triangles, vertices: plain.pkg.vertices,
    indexed_bytes: 12 * plain.pkg.vertices + 12 * plain.pkg.triangles,
  };
  return {
    name: run.name, id: run.id, input: run.label,
    options: run.options.map((o) => (path.isAbsolute(o) ? path.basename(o) : o)).join(' '),
    unit: pkg.manifest.unit,
    parts: report.parts, prototypes: report.prototypes, members,
    instances: instances.length,
    mirrored_members: new Set(instances.filter((i) => i.mirror).map((i) => i.part)).size,
    input_bytes: report.input_bytes,
    without,
    with: {
      components: report.components, component_files: pkg.component_files,
      component_bytes: pkg.component_bytes, triangles: pkg.triangles, vertices: pkg.vertices,
      indexed_bytes: 12 * pkg.vertices + 12 * pkg.triangles,
      matrix_bytes: 64 * members,
      manifest_bytes: pkg.manifest_bytes, manifest_gzip_bytes: pkg.manifest_gzip_bytes,
      output_bytes: report.output_bytes,
    },
    time_ms: report.time_ms,
    truth: run.truth ? checkTruth(run.truth, pkg.manifest) : undefined,
  };
}

/// The phantom's known copies (truth.json: copy_of) against what the package made of them: a copy
/// is found when it is drawn by the same prototype as the part it copies.
function checkTruth(truthFile, manifest) {
  const truth = JSON.parse(readFileSync(truthFile, 'utf8'));
  const byName = new Map(manifest.parts.map((p) => [path.basename(p.name), p]));
  const copies = truth.parts.filter((p) => p.copy_of);
  const rows = copies.map((c) => {
    const part = byName.get(c.name);
    const original = byName.get(c.copy_of);
    const found = Boolean(part && original && part.prototype === original.prototype);
    return { name: c.name, kind: c.kind, copy_of: c.copy_of, noise: c.noise, found };
  });
  return { copies: rows.length, found: rows.filter((r) => r.found).length, rows };
}

function main() {
  const { values: args } = parseCommandLine({
    usage: 'node bench/paper/fig11.mjs [--quick] [--work DIR]',
    about: 'Fig. 11: osteon pack with and without repeated components; writes\n' +
      'docs/paper/results/fig11.json.',
    options: {
      quick: { type: 'boolean', help: 'the same runs, marked quick in the results (run.sh passes it to every item)' },
      work: { type: 'string', arg: 'DIR', help: 'keep the work files in DIR (default: a temporary folder, removed)' },
    },
  });
  const cli = cliPath();
  const data = dataDir();
  const work = args.work ?? mkdtempSync(path.join(tmpdir(), 'osteon-fig11-'));
  mkdirSync(work, { recursive: true });
  try {
    const runs = [];
    if (data) {
      const myo = path.join(data, 'MyoHub__myo_sim', 'meshes');
      if (existsSync(myo)) {
        runs.push({ id: 'myosim', name: 'MyoSim, 200 files', input: myo,
          label: 'MyoHub__myo_sim/meshes', options: [] });
      }
      const bones = path.join(data, 'aHer-dev__3DAnatomy', 'models', 'bones');
      const meta = path.join(data, 'aHer-dev__3DAnatomy', 'meta.json');
      if (existsSync(bones)) {
        const names = existsSync(meta) ? ['--names', meta] : [];
        runs.push({ id: 'bp3d', name: 'BodyParts3D, default tolerance', input: bones,
          label: 'aHer-dev__3DAnatomy/models/bones', options: names });
        runs.push({ id: 'bp3d_05', name: 'BodyParts3D, 0.5 mm', input: bones,
          label: 'aHer-dev__3DAnatomy/models/bones', options: [...names, '--repeat-tolerance', '0.5'] });
      }
    } else {
      log('../shared/data is absent: Fig. 11 measures the phantom only');
    }
    const phantom = phantomDir(cli, work);
    runs.push({ id: 'phantom', name: 'phantom', input: phantom,
      label: 'osteon phantom -o DIR', options: [], truth: path.join(phantom, 'truth.json') });
    const rows = [];
    for (const r of runs) {
      rows.push(measure(cli, r, work));
    }
    writeJson(path.join(resultsDir, 'fig11.json'), {
      item: 'Fig. 11', quick: Boolean(args.quick), data: data ? 'shared' : 'phantom',
      machine: machine(), rows,
    });
    log('fig11: wrote docs/paper/results/fig11.json');
  } finally {
    if (!args.work) rmSync(work, { recursive: true, force: true });
  }
}

try {
  main();
} catch (e) {
  process.stderr.write(`fig11: ${e?.message ?? e}\n`);
  process.exit(1);
}
