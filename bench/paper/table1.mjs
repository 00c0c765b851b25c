// SPDX-License-Identifier: Apache-2.0
// Table 1 of Zhou, Jia & Su 2018 ("Performance of the compression method in a Web3D
// environment"): original size, compressed size, rate and decompression time in the browser,
// redone on the densest bones in ../shared/data.
//
//   node bench/paper/table1.mjs [--quick] [--work DIR] [--runs N]
//
// Meshes: both ct-like surfaces (hip_mcs.ply, skull_mc.ply), the Visible Human bone STL with the
// most triangles and the SPL bone VTK with the most triangles (intervertebral discs are not
// bone), each found by `osteon info --json`. Each is compressed by `osteon encode --bits 14` and,
// for reference, by Debian's `draco_encoder -qp 14 -cl 10` (on the file itself when it is a
// positions-only PLY, else on the 24-bit copy lib.mjs's referencePly makes), then both streams are
// decoded in headless Chromium by browser_decode.mjs. Writes docs/paper/results/table1.json.
// Without ../shared/data, the phantom's two largest parts stand in, and the result says so.

import { mkdtempSync, mkdirSync, rmSync, readdirSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import {
  cliPath, dataDir, fileSize, log, machine, phantomDir, referencePly, resultsDir,
  root, run, runJson, writeJson, here,
} from './lib.mjs';
import { parseCommandLine } from '../lib/args.mjs';

/// Triangle and vertex counts of each file, by osteon's reader (one part per file).
function census(cli, files) {
  const info = runJson(cli, ['info', '--json', ...files]);
  const parts = info.parts ?? [info];
  return files.map((file) => {
    const part = parts.find((p) => path.resolve(root, p.source) === path.resolve(root, file)) ??
      parts.find((p) => p.source === file);
    if (!part) throw new Error(`osteon info did not report ${file}`);
    return { file, triangles: part.triangles, vertices: part.vertices };
  });
}

function largest(cli, files) {
  if (files.length === 0) return null;
  return census(cli, files).sort((a, b) => b.triangles - a.triangles)[0];
}

function pickMeshes(cli, data, work) {
  if (!data) {
    log('../shared/data is absent: Table 1 runs on the phantom (osteon phantom), not on real bones');
    const dir = phantomDir(cli, work);
    const stls = readdirSync(dir).filter((f) => f.endsWith('.stl')).map((f) => path.join(dir, f));
    return census(cli, stls).sort((a, b) => b.triangles - a.triangles).slice(0, 2)
      .map((m) => ({ ...m, group: 'phantom (shared data absent)' }));
  }
  const meshes = [];
  for (const name of ['hip_mcs.ply', 'skull_mc.ply']) {
    const file = path.join(data, 'ct-like', name);
    if (existsSync(file)) meshes.push({ ...census(cli, [file])[0], group: 'ct-like' });
    else log(`skipping ${file}: not there`);
  }
  const vhDir = path.join(data, 'ingvilddevold__muscle-growth', 'data', 'VHF_surfaces');
  if (existsSync(vhDir)) {
    const bones = ['Left', 'Right'].flatMap((side) => {
      const d = path.join(vhDir, side);
      return existsSync(d) ? readdirSync(d).filter((f) => /_Bone_.*\.stl$/i.test(f))
        .map((f) => path.join(d, f)) : [];
    });
    const m = largest(cli, bones);
    if (m) meshes.push({ ...m, group: 'Visible Human, largest bone' });
  }
  const splDir = path.join(data, 'stity__spl-abdominal-atlas', 'Data');
  if (existsSync(splDir)) {
    const bones = readdirSync(splDir).filter((f) => f.endsWith('.vtk') && !/Disc/i.test(f))
      .map((f) => path.join(splDir, f));
    const m = largest(cli, bones);
    if (m) meshes.push({ ...m, group: 'SPL atlas, largest bone' });
  }
  return meshes;
}

async function main() {
  const { values: args } = parseCommandLine({
    usage: 'node bench/paper/table1.mjs [--quick] [--work DIR] [--runs N]',
    about: 'Table 1: size, rate and browser decode time of the densest bones; writes\n' +
      'docs/paper/results/table1.json.',
    options: {
      quick: { type: 'boolean', help: 'fewer browser decodes (--runs 5)' },
      work: { type: 'string', arg: 'DIR', help: 'keep the work files in DIR (default: a temporary folder, removed)' },
      runs: { type: 'string', arg: 'N', help: 'browser decodes after the first, at least (default 15)' },
    },
  });
  const cli = cliPath();
  const data = dataDir();
  const work = args.work ?? mkdtempSync(path.join(tmpdir(), 'osteon-table1-'));
  mkdirSync(work, { recursive: true });
  const runs = Number(args.runs ?? (args.quick ? 5 : 15));
  const bits = 14;
  try {
    const meshes = pickMeshes(cli, data, work);
    if (meshes.length === 0) throw new Error('no mesh to measure');
    const streams = [];
    for (const m of meshes) {
      const stem = path.basename(m.file).replace(/\.[^.]+$/, '');
      log(`table1: ${stem} (${m.triangles} triangles)`);
      const ostm = path.join(work, `${stem}.ostm`);
      m.file_bytes = fileSize(m.file);
      m.indexed_bytes = 12 * m.vertices + 12 * m.triangles;
      m.osteon = runJson(cli, ['encode', m.file, '-o', ostm, '--bits', String(bits), '--json']);
      // Draco reads a positions-only PLY as is; anything else goes through the 24-bit copy.
      const dracoInput = m.file.endsWith('.ply') ? m.file : referencePly(cli, m.file, work, stem);
      const drc = path.join(work, `${stem}.drc`);
      run('draco_encoder', ['-i', dracoInput, '-o', drc, '-qp', String(bits), '-cl', '10',
        '--skip', 'NORMAL']);
      m.draco = { bytes: fileSize(drc), input: dracoInput === m.file ? 'the file' : '24-bit copy' };
      streams.push(ostm, drc);
    }
    log(`table1: decoding ${streams.length} streams in Chromium (${runs} runs each) ...`);
    const browser = JSON.parse(run(process.execPath, [path.join(here, 'browser_decode.mjs'),
      '--runs', String(runs), ...streams]));
    const byFile = new Map(browser.results.map((r) => [r.file, r]));
    meshes.forEach((m, i) => {
      m.osteon.browser = byFile.get(path.resolve(streams[2 * i]));
      m.draco.browser = byFile.get(path.resolve(streams[2 * i + 1]));
      for (const [codec, r] of [['osteon', m.osteon.browser], ['draco', m.draco.browser]]) {
        if (!r || r.error) throw new Error(`${codec} decode of ${m.file} in Chromium failed: ${r?.error}`);
        if (r.triangles !== m.osteon.triangles) {
          throw new Error(`${codec} decoded ${r.triangles} triangles of ${m.file}, the encoder coded ${
            m.osteon.triangles}`);
        }
      }
      // Keep no temporary or machine-specific path in the results.
      m.osteon.browser.file = path.basename(m.osteon.browser.file);
      m.draco.browser.file = path.basename(m.draco.browser.file);
      m.file = data && m.file.startsWith(data) ? path.relative(data, m.file) : path.basename(m.file);
      delete m.osteon.input;
      delete m.osteon.output;
    });
    writeJson(path.join(resultsDir, 'table1.json'), {
      item: 'Table 1', quick: Boolean(args.quick), data: data ? 'shared' : 'phantom',
      machine: machine(), bits, runs,
      browser: browser.browser, playwright_core: browser.playwright_core,
      user_agent: browser.user_agent, draco3d: browser.draco3d,
      osteon_module: browser.osteon_module, timing: browser.timing,
      draco_encoder: 'Debian draco_encoder -qp 14 -cl 10 --skip NORMAL',
      meshes,
    });
    log('table1: wrote docs/paper/results/table1.json');
  } finally {
    if (!args.work) rmSync(work, { recursive: true, force: true });
  }
}

main().catch((e) => {
  process.stderr.write(`table1: ${e?.message ?? e}\n`);
  process.exit(1);
});
