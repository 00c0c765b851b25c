// SPDX-License-Identifier: Apache-2.0
// The skeletons bench/web loads. Each is a folder of part files in one format:
//   bodyparts3d  BodyParts3D (aHer-dev__3DAnatomy/models/bones): 235 GLB bones in millimetres,
//                named by meta.json; the main skeleton (the targets are set on it)
//   myosim       MyoSim (MyoHub__myo_sim/meshes): 200 binary STL files in metres
//   phantom      `osteon phantom`: the generated skeleton (STL, mm), used when ../shared/data is
//                absent so the benchmark still runs (and says so)

import { execFileSync } from 'node:child_process';
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

/// The datasets asked for (`ids`, e.g. ['bodyparts3d', 'myosim']) that exist under `dataDir`.
/// When none of them exists (no ../shared/data), the phantom is generated into `workDir` with
/// `osteon` and returned instead, with `fallback` set to the reason. Returns
/// { datasets: [{ id, title, folder, files, format, unit, names }], notes: [string] }.
export function findDatasets({ dataDir, ids, workDir, osteon }) {
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
    const d = known[id];
    if (!d) throw new Error(`unknown dataset "${id}" (known: ${Object.keys(known).join(', ')}, phantom)`);
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
