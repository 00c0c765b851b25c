// SPDX-License-Identifier: Apache-2.0
// Fig. 9 of Zhou, Jia & Su 2018 (Hausdorff max / mean / RMS of the compressed mesh), redone on
// real bones: osteon at 8..16 position bits against Draco at equal size.
//
//   node bench/paper/fig9.mjs [--quick] [--work DIR]
//
// Meshes: hip_mcs.ply and skull_mc.ply (ct-like), the BodyParts3D bone and the Visible Human
// bone with the most triangles (--quick: the last two only, bits 8, 10, 12, 14, 16). Every mesh is
// first brought to one positions-only PLY, the 24-bit copy of lib.mjs's referencePly, which both
// codecs compress and against which both are measured, so neither is judged on a mesh the other
// did not see.
//
// osteon: `osteon encode --bits b`, `osteon decode` to PLY. Draco: Debian's `draco_encoder -qp q
// -cl 10 --skip NORMAL` for every q in a range around the bits, `draco_decoder` to PLY. Equal
// size, two ways: the q whose Draco stream is nearest in size to osteon's (smallest |log ratio|,
// the ratio kept), and Draco's error interpolated at osteon's exact size on its size-error curve
// (every q from one below the fewest bits to the most, dominated points dropped). Error:
// `osteon compare REF DECODED --json`, the symmetric max, mean and RMS
// relative to the bounding-box diagonal (10 samples a triangle each way; 2 a triangle on the
// meshes over 200k triangles, still over 2M samples). Writes docs/paper/results/fig9.json.

import { existsSync, mkdirSync, mkdtempSync, readdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import {
  cliPath, dataDir, fileSize, log, machine, phantomDir, referencePly, resultsDir, run, runJson,
  writeJson,
} from './lib.mjs';
import { parseCommandLine } from '../lib/args.mjs';

const kDenseTriangles = 200000;

function pickMeshes(cli, data, work, quick) {
  if (!data) {
    log('../shared/data is absent: Fig. 9 runs on the phantom skull and femur, not on real bones');
    const dir = phantomDir(cli, work);
    return ['skull.stl', 'femur_l.stl'].map((f) => ({ name: f.replace('.stl', ''),
      file: path.join(dir, f), group: 'phantom (shared data absent)' }));
  }
  const meshes = [];
  if (!quick) {
    for (const name of ['hip_mcs', 'skull_mc']) {
      const file = path.join(data, 'ct-like', `${name}.ply`);
      if (existsSync(file)) meshes.push({ name, file, group: 'ct-like' });
    }
  }
  const pickLargest = (files, group) => {
    if (files.length === 0) return;
    const info = runJson(cli, ['info', '--json', ...files]);
    const best = info.parts.reduce((a, b) => (b.triangles > a.triangles ? b : a));
    const file = files.find((f) => path.resolve(f) === path.resolve(best.source)) ?? best.source;
    meshes.push({ name: path.basename(file).replace(/\.[^.]+$/, ''), file, group });
  };
  const bones = path.join(data, 'aHer-dev__3DAnatomy', 'models', 'bones');
  if (existsSync(bones)) {
    pickLargest(readdirSync(bones).filter((f) => f.endsWith('.glb')).map((f) => path.join(bones, f)),
      'BodyParts3D, largest bone');
  }
  const vh = path.join(data, 'ingvilddevold__muscle-growth', 'data', 'VHF_surfaces');
  if (existsSync(vh)) {
    pickLargest(['Left', 'Right'].flatMap((s) => (existsSync(path.join(vh, s))
      ? readdirSync(path.join(vh, s)).filter((f) => /_Bone_.*\.stl$/i.test(f))
        .map((f) => path.join(vh, s, f)) : [])), 'Visible Human, largest bone');
  }
  return meshes;
}

function hausdorff(cli, ref, decoded, triangles) {
  const samples = triangles > kDenseTriangles ? ['--samples-per-face', '2'] : [];
  const r = runJson(cli, ['compare', ref, decoded, '--json', ...samples]);
  const s = r.symmetric;
  return {
    max: s.max_relative, mean: s.mean_relative, rms: s.rms_relative,
    diagonal: s.diagonal, samples: s.samples,
  };
}

/// Draco's points that no other point beats on both size and RMS error, by size: a larger q can
/// give a smaller stream at the low end, and the dominated point is no choice anyone would make.
function paretoFront(curve) {
  const bySize = [...curve].sort((a, b) => a.bytes - b.bytes);
  const front = [];
  for (const p of bySize) if (front.length === 0 || p.error.rms < front.at(-1).error.rms) front.push(p);
  return front;
}

/// Draco's max, mean and RMS error at `bytes`, interpolated on the front linearly in log(error)
/// against log(size) (errors halve per bit while sizes grow by a near-constant step); null
/// outside the measured sizes.
function interpolate(front, bytes) {
  for (let i = 1; i < front.length; ++i) {
    const a = front[i - 1];
    const b = front[i];
    if (bytes < a.bytes || bytes > b.bytes) continue;
    const t = Math.log(bytes / a.bytes) / Math.log(b.bytes / a.bytes);
    const at = (key) => Math.exp((1 - t) * Math.log(a.error[key]) + t * Math.log(b.error[key]));
    return { max: at('max'), mean: at('mean'), rms: at('rms'), between_qp: [a.qp, b.qp] };
  }
  return null;
}

function measureMesh(cli, mesh, work, bitsList) {
  const stem = mesh.name;
  const ref = referencePly(cli, mesh.file, work, stem);
  const info = runJson(cli, ['info', '--json', ref]);
  mesh.triangles = info.triangles;
  mesh.vertices = info.vertices;
  const side = Math.max(...info.bbox_max.map((v, i) => v - info.bbox_min[i]));
  mesh.largest_side = side;
  mesh.osteon = [];
  for (const bits of bitsList) {
    log(`fig9: ${stem} osteon ${bits} bits`);
    const ostm = path.join(work, `${stem}.${bits}.ostm`);
    const ply = path.join(work, `${stem}.${bits}.ostm.ply`);
    const enc = runJson(cli, ['encode', ref, '-o', ostm, '--bits', String(bits), '--json']);
    run(cli, ['decode', ostm, '-o', ply]);
    const error = hausdorff(cli, ref, ply, mesh.triangles);
    // The codec's own bound on any vertex: half a grid step on each axis, sqrt(3)/2 steps.
    const bound = (Math.sqrt(3) / 2) * (side / (2 ** bits - 1)) / error.diagonal;
    mesh.osteon.push({ bits, bytes: enc.bytes, bits_per_vertex: 8 * enc.bytes / mesh.vertices,
      error, vertex_bound_relative: bound });
  }
  // Draco's sizes at every q around the range, then decode and measure the ones that match.
  const qs = [];
  for (let q = Math.max(1, bitsList[0] - 3); q <= Math.min(30, bitsList.at(-1) + 2); ++q) qs.push(q);
  const sizes = new Map();
  for (const q of qs) {
    const drc = path.join(work, `${stem}.q${q}.drc`);
    run('draco_encoder', ['-i', ref, '-o', drc, '-qp', String(q), '-cl', '10', '--skip', 'NORMAL']);
    sizes.set(q, fileSize(drc));
  }
  mesh.draco_sizes = Object.fromEntries(sizes);
  // Errors at every q from one below the fewest bits to the most (the curve the plots draw), and
  // at any nearest-size match outside that range.
  const nearest = mesh.osteon.map((point) => qs.reduce((best, q) => (
    Math.abs(Math.log(sizes.get(q) / point.bytes)) < Math.abs(Math.log(sizes.get(best) / point.bytes))
      ? q : best), qs[0]));
  const toMeasure = new Set([...qs.filter((q) => q >= bitsList[0] - 1 && q <= bitsList.at(-1)),
    ...nearest]);
  const measured = new Map();
  for (const q of [...toMeasure].sort((a, b) => a - b)) {
    log(`fig9: ${stem} Draco qp ${q}`);
    const drc = path.join(work, `${stem}.q${q}.drc`);
    const ply = path.join(work, `${stem}.q${q}.drc.ply`);
    run('draco_decoder', ['-i', drc, '-o', ply]);
    measured.set(q, hausdorff(cli, ref, ply, mesh.triangles));
  }
  mesh.draco_curve = [...measured].map(([q, error]) => ({ qp: q, bytes: sizes.get(q), error }))
    .sort((a, b) => a.qp - b.qp);
  const front = paretoFront(mesh.draco_curve);
  mesh.draco = mesh.osteon.map((point, i) => ({
    osteon_bits: point.bits, qp: nearest[i], bytes: sizes.get(nearest[i]),
    size_ratio: sizes.get(nearest[i]) / point.bytes, error: measured.get(nearest[i]),
    at_osteon_size: interpolate(front, point.bytes),
  }));
  return mesh;
}

function main() {
  const { values: args } = parseCommandLine({
    usage: 'node bench/paper/fig9.mjs [--quick] [--work DIR]',
    about: 'Fig. 9: osteon at 8..16 position bits against Draco at equal size, Hausdorff errors;\n' +
      'writes docs/paper/results/fig9.json.',
    options: {
      quick: { type: 'boolean', help: 'two meshes only, bits 8, 10, 12, 14, 16' },
      work: { type: 'string', arg: 'DIR', help: 'keep the work files in DIR (default: a temporary folder, removed)' },
    },
  });
  const cli = cliPath();
  const data = dataDir();
  const work = args.work ?? mkdtempSync(path.join(tmpdir(), 'osteon-fig9-'));
  mkdirSync(work, { recursive: true });
  const bitsList = args.quick ? [8, 10, 12, 14, 16] : [8, 9, 10, 11, 12, 13, 14, 15, 16];
  try {
    const meshes = pickMeshes(cli, data, work, args.quick);
    if (meshes.length === 0) throw new Error('no mesh to measure');
    for (const mesh of meshes) {
      measureMesh(cli, mesh, work, bitsList);
      mesh.file = data && mesh.file.startsWith(data) ? path.relative(data, mesh.file)
        : path.basename(mesh.file);
    }
    writeJson(path.join(resultsDir, 'fig9.json'), {
      item: 'Fig. 9', quick: Boolean(args.quick), data: data ? 'shared' : 'phantom',
      machine: machine(), bits: bitsList,
      draco: 'Debian draco_encoder -qp Q -cl 10 --skip NORMAL, draco_decoder to PLY',
      compare: `osteon compare REF DECODED --json, symmetric; 10 samples a triangle, 2 above ${
        kDenseTriangles} triangles`,
      reference: 'each mesh encoded by osteon at 24 bits and decoded (positions-only PLY): both ' +
        'codecs compress it and are measured against it',
      meshes,
    });
    log('fig9: wrote docs/paper/results/fig9.json');
  } finally {
    if (!args.work) rmSync(work, { recursive: true, force: true });
  }
}

try {
  main();
} catch (e) {
  process.stderr.write(`fig9: ${e?.message ?? e}\n`);
  process.exit(1);
}
