// SPDX-License-Identifier: Apache-2.0
// The skeletons bench/web loads. Each is a folder of part files in one format:
//   bodyparts3d  BodyParts3D (aHer-dev__3DAnatomy/models/bones): 235 GLB bones in millimetres,
//                named by meta.json; the main skeleton (the targets are set on it)
//   myosim       MyoSim (MyoHub__myo_sim/meshes): 200 binary STL files in metres
//   dense        the dense skeleton: BodyParts3D voxelized at 0.5 mm (`osteon voxelize`, about
//                2.1 G voxels) and surfaced without simplification (`--surface-voxels 0`: about
//                16 M triangles), the size of a thin-slice whole-body CT's bone surfaces. osteon
//                packs the volume itself; the peers get the same surfaces as 235 GLB parts (see
//                denseSkeleton below). Generated into the work folder, kept between runs and
//                regenerated only when missing
//   phantom      `osteon phantom`: the generated skeleton (STL, mm), used when ../shared/data is
//                absent so the benchmark still runs (and says so)

import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

const kMeshExtension = { glb: '.glb', stl: '.stl' };

function listParts(folder, format) {
  const ext = kMeshExtension[format];
  return fs
    .readdirSync(folder)
    .filter((name) => name.toLowerCase().endsWith(ext))
    .sort()
    .map((name) => path.join(folder, name));
}

/// The datasets asked for (`ids`, e.g. ['bodyparts3d', 'dense', 'myosim']) that exist under
/// `dataDir`. When none of them exists (no ../shared/data), the phantom is generated into `workDir`
/// with `osteon` and returned instead, with `fallback` set to the reason. `dense`: { voxel (mm),
/// volume (an existing voxelization to copy in instead of running voxelize, or null) }. Returns
/// { datasets: [{ id, title, folder, files, format, unit, names, pack?, volume?, readBack? }],
/// notes: [string] }; `pack` ({ inputs, extra }) replaces the parts folder as what osteon packs.
export async function findDatasets({ dataDir, ids, workDir, osteon, dense = { voxel: 0.5, volume: null }, log = () => {} }) {
  const known = {
    bodyparts3d: {
      title: 'BodyParts3D skeleton (235 GLB, mm)',
      folder: path.join(dataDir, 'aHer-dev__3DAnatomy/models/bones'),
      names: path.join(dataDir, 'aHer-dev__3DAnatomy/meta.json'),
      format: 'glb',
      unit: 'mm',
    },
    myosim: {
      title: 'MyoSim bones (200 STL, metres)',
      folder: path.join(dataDir, 'MyoHub__myo_sim/meshes'),
      names: null,
      format: 'stl',
      unit: 'm',
    },
  };
  const datasets = [];
  const notes = [];
  for (const id of ids) {
    if (id === 'phantom') continue;
    if (id === 'dense') {
      const bones = known.bodyparts3d;
      if (!fs.existsSync(bones.folder)) {
        notes.push(`dense: ${bones.folder} (the bones it is voxelized from) is absent, skipped`);
        continue;
      }
      const names = fs.existsSync(bones.names) ? bones.names : null;
      const d = await denseSkeleton({ bones: bones.folder, workDir, osteon, ...dense, log });
      datasets.push({
        id,
        title: `Dense skeleton: BodyParts3D voxelized at ${dense.voxel} mm, surfaced unsimplified (${d.files.length} parts, mm)`,
        format: 'glb',
        unit: 'mm',
        names,
        ...d,
      });
      continue;
    }
    const d = known[id];
    if (!d) throw new Error(`unknown dataset "${id}" (known: ${Object.keys(known).join(', ')}, dense, phantom)`);
    if (!fs.existsSync(d.folder)) {
      notes.push(`${id}: ${d.folder} is absent, skipped`);
      continue;
    }
    const files = listParts(d.folder, d.format);
    if (!files.length) throw new Error(`${d.folder}: no ${kMeshExtension[d.format]} files`);
    if (d.names && !fs.existsSync(d.names)) d.names = null;
    datasets.push({ id, ...d, files });
  }
  if (ids.includes('phantom') || !datasets.length) {
    const folder = path.join(workDir, 'phantom', 'parts');
    if (!fs.existsSync(path.join(folder, 'skull.stl'))) {
      fs.mkdirSync(folder, { recursive: true });
      execFileSync(osteon, ['phantom', '-o', folder], { stdio: ['ignore', 'ignore', 'inherit'] });
    }
    const reason = datasets.length
      ? 'asked for with --datasets phantom'
      : `no real skeleton under ${dataDir}: using the generated phantom skeleton (osteon phantom), not real data`;
    notes.push(`phantom: ${reason}`);
    datasets.push({
      id: 'phantom',
      title: 'osteon phantom skeleton (generated, STL, mm)',
      folder,
      names: null,
      format: 'stl',
      unit: 'mm',
      files: listParts(folder, 'stl'),
      fallback: reason,
    });
  }
  return { datasets, notes };
}

/// Runs a program; throws with its stderr's tail when it fails. Returns stdout.
function run(program, args) {
  const r = spawnSync(program, args, { encoding: 'utf8', maxBuffer: 64 << 20 });
  if (r.error) throw new Error(`${path.basename(program)}: ${r.error.message}`);
  if (r.status !== 0) {
    const tail = `${r.stderr || ''}${r.stdout || ''}`.trim().split('\n').slice(-8).join('\n');
    throw new Error(`${path.basename(program)} ${args.slice(0, 3).join(' ')} ... failed (exit ${r.status}):\n${tail}`);
  }
  return r.stdout;
}

/// Reads the binary little-endian PLY `osteon decode` writes: float vertex properties (x y z,
/// and nx ny nz when present) and faces as `list uchar int` triangles. Returns { positions,
/// normals (or null), indices }; throws on any other layout.
function readDecodedPly(file) {
  const bytes = fs.readFileSync(file);
  const end = bytes.indexOf('end_header\n');
  if (end < 0) throw new Error(`${file}: not a PLY file (no end_header)`);
  const header = bytes.subarray(0, end).toString('latin1').split('\n');
  if (header[1] !== 'format binary_little_endian 1.0') throw new Error(`${file}: expected binary_little_endian PLY`);
  let vertices = 0, faces = 0, element = '';
  const props = [];
  for (const line of header) {
    const w = line.trim().split(/\s+/);
    if (w[0] === 'element') {
      element = w[1];
      if (element === 'vertex') vertices = Number(w[2]);
      else if (element === 'face') faces = Number(w[2]);
      else throw new Error(`${file}: unexpected element ${w[1]}`);
    } else if (w[0] === 'property' && element === 'vertex') {
      if (w[1] !== 'float') throw new Error(`${file}: vertex property ${w[2]} is ${w[1]}, expected float`);
      props.push(w[2]);
    } else if (w[0] === 'property' && element === 'face' && !(w[1] === 'list' && w[2] === 'uchar' && (w[3] === 'int' || w[3] === 'uint'))) {
      throw new Error(`${file}: expected faces as list uchar int`);
    }
  }
  const at = (name) => props.indexOf(name);
  const stride = props.length;
  let o = end + 'end_header\n'.length;
  if (bytes.length < o + vertices * stride * 4 + faces * 13) throw new Error(`${file}: truncated`);
  const data = new Float32Array(bytes.buffer.slice(bytes.byteOffset + o, bytes.byteOffset + o + vertices * stride * 4));
  o += vertices * stride * 4;
  const positions = new Float32Array(vertices * 3);
  const hasNormals = at('nx') >= 0 && at('ny') >= 0 && at('nz') >= 0;
  const normals = hasNormals ? new Float32Array(vertices * 3) : null;
  const [x, y, z, nx, ny, nz] = ['x', 'y', 'z', 'nx', 'ny', 'nz'].map(at);
  for (let v = 0; v < vertices; ++v) {
    const b = v * stride;
    positions[3 * v] = data[b + x];
    positions[3 * v + 1] = data[b + y];
    positions[3 * v + 2] = data[b + z];
    if (normals) {
      normals[3 * v] = data[b + nx];
      normals[3 * v + 1] = data[b + ny];
      normals[3 * v + 2] = data[b + nz];
    }
  }
  const indices = vertices <= 65535 ? new Uint16Array(faces * 3) : new Uint32Array(faces * 3);
  for (let f = 0; f < faces; ++f, o += 13) {
    if (bytes[o] !== 3) throw new Error(`${file}: face ${f} has ${bytes[o]} corners, expected 3`);
    indices[3 * f] = bytes.readInt32LE(o + 1);
    indices[3 * f + 1] = bytes.readInt32LE(o + 5);
    indices[3 * f + 2] = bytes.readInt32LE(o + 9);
  }
  return { positions, normals, indices };
}

/// The dense skeleton, made once into `workDir`/dense and reused while its files are there:
///   1. the label volume: `osteon voxelize BONES -o bodyparts3d_<voxel>mm.nii.gz --voxel <voxel>`
///      (a label per bone, named by its file stem), or a copy of `volume` when one is given (an
///      earlier voxelization: the same command's output);
///   2. its surfaces as the peers' input: `osteon pack VOLUME --surface-voxels 0 --no-lod
///      --no-repeats --max-triangles 0 --bits 24 --no-viewer` (the CLI writes no meshes from a
///      volume, but a package of one component per label at 24 bits, a grid step of a few
///      hundredths of a micrometre, holds the surfaces as extracted), then every component's
///      stream is cut out of its chunk and `osteon decode`d to PLY, and each bone written as one
///      GLB (positions, the decoder's smooth normals, indices; named by its stem, so meta.json
///      names it) by glTF Transform.
/// osteon itself packs the volume (`pack`), with `--surface-voxels 0`: the same surfaces.
/// Returns { folder, files, volume, pack: { inputs, extra }, readBack: false, generated }.
export async function denseSkeleton({ bones, workDir, osteon, voxel = 0.5, volume: source = null, log = () => {} }) {
  const dir = path.join(workDir, 'dense');
  fs.mkdirSync(dir, { recursive: true });
  const volume = path.join(dir, `bodyparts3d_${voxel}mm.nii.gz`);
  const generated = [];
  if (!fs.existsSync(volume)) {
    const partial = path.join(dir, `partial_${voxel}mm.nii.gz`);
    const start = performance.now();
    if (source) {
      if (!fs.existsSync(source)) throw new Error(`--dense-volume ${source}: no such file`);
      log(`dense: copying ${source} (given as the ${voxel} mm voxelization of ${bones})`);
      fs.copyFileSync(source, partial);
    } else {
      log(`dense: osteon voxelize ${bones} --voxel ${voxel} (about 2 G voxels at 0.5 mm: minutes)`);
      run(osteon, ['voxelize', bones, '-o', partial, '--voxel', String(voxel)]);
    }
    fs.renameSync(partial, volume);
    generated.push(`volume in ${((performance.now() - start) / 1000).toFixed(0)} s${source ? ` (copied from ${source})` : ''}`);
  }

  const folder = path.join(dir, 'parts');
  const done = path.join(folder, '.complete');
  if (!fs.existsSync(done)) {
    const start = performance.now();
    const exported = path.join(dir, 'export');
    log('dense: extracting the surfaces (osteon pack --surface-voxels 0 --bits 24) and writing them as GLB parts');
    fs.rmSync(exported, { recursive: true, force: true });
    run(osteon, ['pack', volume, '-o', exported, '--surface-voxels', '0', '--no-lod', '--no-repeats', '--max-triangles', '0',
      '--bits', '24', '--no-viewer']);
    const manifest = JSON.parse(fs.readFileSync(path.join(exported, 'manifest.json'), 'utf8'));
    const { Document, NodeIO } = await import('@gltf-transform/core');
    fs.rmSync(folder, { recursive: true, force: true });
    fs.mkdirSync(folder, { recursive: true });
    const chunks = new Map();
    const chunk = (k) => {
      if (!chunks.has(k)) chunks.set(k, fs.readFileSync(path.join(exported, manifest.chunks[k].file)));
      return chunks.get(k);
    };
    const components = new Map(manifest.components.map((c) => [c.id, c]));
    const stream = path.join(dir, 'component.ostm');
    const ply = path.join(dir, 'component.ply');
    const io = new NodeIO();
    for (const part of manifest.parts) {
      const stem = path.basename(part.name);
      const doc = new Document();
      const buffer = doc.createBuffer();
      const mesh = doc.createMesh(stem);
      for (const inst of manifest.instances.filter((i) => i.part === part.id)) {
        const c = components.get(inst.component);
        fs.writeFileSync(stream, chunk(c.chunk).subarray(c.offset, c.offset + c.bytes));
        run(osteon, ['decode', stream, '-o', ply]);
        const m = readDecodedPly(ply);
        const identity = inst.matrix.every((v, i) => v === (i % 5 === 0 ? 1 : 0));
        if (!identity) throw new Error(`${part.name}: instance matrix is not the identity (pack ran with --no-repeats)`);
        const prim = doc.createPrimitive()
          .setAttribute('POSITION', doc.createAccessor().setType('VEC3').setArray(m.positions).setBuffer(buffer))
          .setIndices(doc.createAccessor().setType('SCALAR').setArray(m.indices).setBuffer(buffer));
        if (m.normals) prim.setAttribute('NORMAL', doc.createAccessor().setType('VEC3').setArray(m.normals).setBuffer(buffer));
        mesh.addPrimitive(prim);
      }
      doc.createScene(stem).addChild(doc.createNode(stem).setMesh(mesh));
      await io.write(path.join(folder, `${stem}.glb`), doc);
    }
    fs.rmSync(stream, { force: true });
    fs.rmSync(ply, { force: true });
    fs.rmSync(exported, { recursive: true, force: true });
    fs.writeFileSync(done, JSON.stringify({ volume: path.basename(volume), parts: manifest.parts.length }));
    generated.push(`${manifest.parts.length} GLB parts in ${((performance.now() - start) / 1000).toFixed(0)} s`);
  }
  return {
    folder,
    files: listParts(folder, 'glb'),
    volume,
    pack: { inputs: [volume], extra: ['--surface-voxels', '0'] },
    readBack: false,
    generated,
  };
}
