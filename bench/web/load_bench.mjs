// SPDX-License-Identifier: Apache-2.0
// bench/web: how fast a skeleton appears in a real browser, osteon against what a user would pick
// instead (the paper's Fig. 12), now with levels of detail. Headless Chromium (Debian's, driven by
// playwright-core, WebGL through SwiftShader) loads the same skeleton from `osteon serve` five
// ways, with the network throttled (and, for the phone, the CPU slowed) through the DevTools
// protocol and the cache disabled:
//
//   direct       the original part files, three.js's GLTFLoader / STLLoader, one request per file
//   draco        one Draco-compressed .glb (gltf-transform, 14-bit positions), GLTFLoader+DRACOLoader
//   gltfpack     one `gltfpack -cc -mi` .glb (EXT_meshopt_compression), GLTFLoader + MeshoptDecoder
//   gltfpack-cz  one `gltfpack -cz -mi` .glb (KHR_meshopt_compression), the same loader
//   osteon       `osteon pack` at the same error bound, loaded by the osteon viewer
//
// on three skeletons (datasets.mjs): BodyParts3D, the dense skeleton (BodyParts3D voxelized at
// 0.5 mm and surfaced unsimplified, about 16 M triangles, generated once into the work folder)
// and MyoSim, under three profiles: 10 Mbit/s with 40 ms, 100 Mbit/s with 10 ms, and a phone
// (390 x 844, CPU slowed 4x, 9 Mbit/s with 170 ms).
//
// Each way runs --runs times per profile (interleaved: run k loads every way before run k + 1
// starts, so a slow spell on the shared machine hits every way alike), each in a fresh browser
// context, each stopped at --timeout seconds and then reported with what it had reached ("did
// not finish in N s"). Then one unthrottled run per way reads back the triangles drawn and
// `osteon compare` measures them against the original parts (skipped above
// --readback-max-triangles).
//
// Usage: node load_bench.mjs [--runs 5] [--profiles slow,fast,phone] [--ways direct,draco,...]
//        [--datasets bodyparts3d,dense,myosim] [--timeout 120] [--no-write] ...   (`--help`)
// `bash bench/web/run.sh` installs the npm packages first and passes its arguments here.

import { spawn, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { parseCommandLine } from '../lib/args.mjs';
import { findDatasets } from './datasets.mjs';
import { canvasSize, kChromiumArgs, kProfiles, launchBrowser, measureLoad } from './measure.mjs';
import { kPositionBits, prepareDataset, toolVersions } from './prepare.mjs';
import { detailTable, kSectionTitle, summarise, svgPlot, table, targetLines, targets, writeSection } from './report.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..', '..');
const kAllWays = ['direct', 'draco', 'gltfpack', 'gltfpack-cz', 'osteon'];
const kViewport = { width: 1280, height: 800 };

function parseOptions() {
  const { values } = parseCommandLine({
    usage: 'node bench/web/load_bench.mjs [options]   (or: bash bench/web/run.sh [options])',
    options: {
      runs: { type: 'string', default: '5', arg: 'N', help: 'loads per way and profile (default 5; medians reported)' },
      profiles: { type: 'string', default: 'slow,fast,phone', arg: 'LIST',
        help: 'slow (10 Mbit/s, 40 ms), fast (100 Mbit/s, 10 ms) and/or phone (390 x 844,\nCPU / 4, 9 Mbit/s, 170 ms) (default slow,fast,phone)' },
      ways: { type: 'string', default: kAllWays.join(','), arg: 'LIST', help: `${kAllWays.join(',')} (default all)` },
      datasets: { type: 'string', default: 'bodyparts3d,dense,myosim', arg: 'LIST',
        help: 'bodyparts3d,dense,myosim,phantom (default bodyparts3d,dense,myosim; phantom\nwhen no data)' },
      data: { type: 'string', arg: 'DIR', help: 'the shared data folder (default $OSTEON_SHARED_DATA, else ../shared/data)' },
      osteon: { type: 'string', arg: 'PATH', help: 'the osteon CLI (default $OSTEON_CLI, else build/release/osteon)' },
      viewer: { type: 'string', arg: 'DIR', help: 'the built viewer (default build/viewer)' },
      chromium: { type: 'string', default: '/usr/bin/chromium', arg: 'PATH',
        help: 'Chromium (default /usr/bin/chromium; never downloaded)' },
      out: { type: 'string', arg: 'DIR', help: 'prepared files and results (default build/bench-web)' },
      write: { type: 'string', arg: 'FILE',
        help: `the Markdown file whose "${kSectionTitle}" section is replaced\n(default docs/BENCHMARKS.md)` },
      svg: { type: 'string', arg: 'FILE', help: 'the plot (default docs/load_time.svg)' },
      'no-write': { type: 'boolean', default: false, help: 'print only: write neither --write nor --svg' },
      'write-incomplete': { type: 'boolean', default: false,
        help: 'write --write and --svg from a run that is not complete too (they are\nwritten only from a complete run: every skeleton, way and profile)' },
      'no-hausdorff': { type: 'boolean', default: false, help: 'skip the drawn-triangles read-back and osteon compare' },
      'readback-max-triangles': { type: 'string', default: '3000000', arg: 'N',
        help: 'skip the read-back of a skeleton with more triangles (default 3000000:\nthe dense one is skipped; its error bounds are still reported)' },
      'prepare-only': { type: 'boolean', default: false, help: 'prepare (and cache) the datasets\' files for the ways asked for, then stop' },
      fresh: { type: 'boolean', default: false, help: 'redo every preparation step (not the dense skeleton\'s volume and\nparts: delete OUT/work/dense to remake those)' },
      timeout: { type: 'string', default: '120', arg: 'S',
        help: 'seconds one page load may take; a load still running then is reported as\n"did not finish in S s" with what it had reached (default 120)' },
      'dense-voxel': { type: 'string', default: '0.5', arg: 'MM', help: 'the dense skeleton\'s voxel size (default 0.5)' },
      'dense-volume': { type: 'string', arg: 'FILE',
        help: 'an existing voxelization of the BodyParts3D bones at --dense-voxel (osteon\nvoxelize output) to copy in instead of running voxelize; used only when\nOUT/work/dense has no volume yet' },
      json: { type: 'string', arg: 'FILE', help: "every run's numbers as JSON (default OUT/results.json)" },
    },
  });
  const list = (s) => s.split(',').map((x) => x.trim()).filter(Boolean);
  const runs = Number(values.runs);
  if (!Number.isInteger(runs) || runs < 1) throw new Error(`--runs: expected a positive integer, got "${values.runs}"`);
  const timeout = Number(values.timeout);
  if (!(timeout > 0)) throw new Error(`--timeout: expected seconds > 0, got "${values.timeout}"`);
  const denseVoxel = Number(values['dense-voxel']);
  if (!(denseVoxel > 0)) throw new Error(`--dense-voxel: expected millimetres > 0, got "${values['dense-voxel']}"`);
  const readbackMax = Number(values['readback-max-triangles']);
  if (!(readbackMax >= 0)) throw new Error(`--readback-max-triangles: expected a count, got "${values['readback-max-triangles']}"`);
  const profiles = list(values.profiles).map((id) => {
    if (!kProfiles[id]) throw new Error(`--profiles: unknown profile "${id}" (${Object.keys(kProfiles).join(', ')})`);
    return { id, ...kProfiles[id] };
  });
  const ways = list(values.ways);
  for (const w of ways) if (!kAllWays.includes(w)) throw new Error(`--ways: unknown way "${w}" (${kAllWays.join(', ')})`);
  const out = path.resolve(values.out ?? path.join(repo, 'build', 'bench-web'));
  return {
    runs,
    profiles,
    ways,
    datasetIds: list(values.datasets),
    data: path.resolve(values.data ?? process.env.OSTEON_SHARED_DATA ?? path.join(repo, '..', 'shared', 'data')),
    osteon: path.resolve(values.osteon ?? process.env.OSTEON_CLI ?? path.join(repo, 'build', 'release', 'osteon')),
    viewer: path.resolve(values.viewer ?? path.join(repo, 'build', 'viewer')),
    chromium: values.chromium,
    out,
    write: values['no-write'] ? null : path.resolve(values.write ?? path.join(repo, 'docs', 'BENCHMARKS.md')),
    svg: values['no-write'] ? null : path.resolve(values.svg ?? path.join(repo, 'docs', 'load_time.svg')),
    writeIncomplete: values['write-incomplete'],
    hausdorff: !values['no-hausdorff'],
    readbackMax,
    fresh: values.fresh,
    prepareOnly: values['prepare-only'],
    timeoutMs: timeout * 1000,
    dense: { voxel: denseVoxel, volume: values['dense-volume'] ? path.resolve(values['dense-volume']) : null },
    json: path.resolve(values.json ?? path.join(out, 'results.json')),
  };
}

const log = (...a) => console.error(...a);
const kStart = performance.now();

/// Starts `osteon serve ROOT --port 0` and resolves with { url, stop(), mark(), lines(),
/// requestsSince(mark) -> [[path, body bytes]] }.
/// The server's per-request log ("GET /x 200 1234 B 0.3 ms") gives a second count of the bytes.
/// `idleSeconds`: how long a connection may move no byte before the server closes it. The default
/// (5 s) is too short here: DevTools throttling leaves some of a page's connections unread for
/// longer while others take the link's share, and the server cut the direct way's large files off.
function startServer(osteon, root, idleSeconds) {
  return new Promise((resolve, reject) => {
    const args = ['serve', root, '--port', '0', '--host', '127.0.0.1', '--idle-timeout', String(idleSeconds)];
    const child = spawn(osteon, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    const lines = [];
    let stdout = '';
    let settled = false;
    let pendingErr = '';
    child.stderr.on('data', (chunk) => {
      pendingErr += chunk;
      const parts = pendingErr.split('\n');
      pendingErr = parts.pop();
      lines.push(...parts);
    });
    child.stdout.on('data', (chunk) => {
      stdout += chunk;
      const m = stdout.match(/at (http:\/\/[^ ]+\/) /);
      if (m && !settled) {
        settled = true;
        resolve({
          url: m[1],
          stop: () => child.kill('SIGTERM'),
          mark: () => lines.length,
          lines: () => lines,
          requestsSince: (mark) => lines.slice(mark).map((l) => l.match(/^\w+ (\S+) \d+ (\d+) B /)).filter(Boolean)
            .map((m) => [m[1].split('?')[0], Number(m[2])]),
        });
      }
    });
    child.on('exit', (code) => {
      if (!settled) {
        settled = true;
        reject(new Error(`osteon serve exited (${code}) before serving: ${lines.join('\n')}`));
      }
    });
  });
}

/// Writes a binary little-endian PLY (float x y z, uchar-count int triangles).
function writePly(file, positions, indices) {
  const header = `ply\nformat binary_little_endian 1.0\ncomment bench/web: the triangles a page drew, world space\n` +
    `element vertex ${positions.length / 3}\nproperty float x\nproperty float y\nproperty float z\n` +
    `element face ${indices.length / 3}\nproperty list uchar int vertex_indices\nend_header\n`;
  const faces = Buffer.alloc((indices.length / 3) * 13);
  for (let t = 0, o = 0; t < indices.length; t += 3, o += 13) {
    faces.writeUInt8(3, o);
    faces.writeInt32LE(indices[t], o + 1);
    faces.writeInt32LE(indices[t + 1], o + 5);
    faces.writeInt32LE(indices[t + 2], o + 9);
  }
  fs.writeFileSync(file, Buffer.concat([Buffer.from(header, 'ascii'), Buffer.from(positions.buffer, positions.byteOffset, positions.byteLength), faces]));
}

/// The checkout the run measured: commit and whether the working tree had changes.
function checkout() {
  const git = (args) => spawnSync('git', ['-C', repo, ...args], { encoding: 'utf8' });
  const head = git(['rev-parse', '--short=12', 'HEAD']);
  if (head.status !== 0) return 'not a git checkout';
  const dirty = git(['status', '--porcelain', '--untracked-files=no']).stdout.trim().length > 0;
  return `commit ${head.stdout.trim()}${dirty ? ' with uncommitted changes' : ''}`;
}

function machine(browserVersion, renderer) {
  const cpu = fs.readFileSync('/proc/cpuinfo', 'utf8').match(/model name\s*:\s*(.*)/)?.[1] ?? os.cpus()[0]?.model ?? 'unknown';
  return {
    cpu,
    cores: os.cpus().length,
    memoryGiB: +(os.totalmem() / 2 ** 30).toFixed(1),
    loadAverage: os.loadavg().map((x) => +x.toFixed(2)),
    chromium: browserVersion,
    webgl: renderer,
    node: process.version,
    platform: `${os.type()} ${os.release()}`,
    checkout: checkout(),
  };
}


function describeWay(way, prep) {
  const w = prep.ways[way];
  if (way === 'direct') {
    return prep.id === 'dense'
      ? `the ${prep.fileCount} GLB parts the surfaces were written as (positions, normals, indices; see below)`
      : `the ${prep.fileCount} original files`;
  }
  const merged = prep.format === 'glb'
    ? '`gltf-transform merge --merge-scenes` of the parts (merged.glb)'
    : 'the STL parts written as one GLB by glTF Transform (merged.glb: welded, smooth normals)';
  if (way === 'draco') return `${merged}, then \`gltf-transform draco merged.glb scene.glb --quantize-position ${kPositionBits} --quantization-volume scene\``;
  if (way === 'gltfpack') return '`gltfpack -i merged.glb -o scene.glb -cc -mi` (EXT_meshopt_compression)';
  if (way === 'gltfpack-cz') return '`gltfpack -i merged.glb -o scene.glb -cz -mi` (KHR_meshopt_compression), loaded by the same page';
  return w.packArgs ? `\`osteon ${w.packArgs.map((a) => (a.includes('/') ? path.relative(repo, a) || a : a)).join(' ')}\`, then the ` +
    `viewer's files (\`${path.relative(repo, w.viewer) || w.viewer}\`) copied in, as \`--viewer\` does` : '';
}

/// The largest error bound of what the viewer drew at the end, in the manifest's unit: over every
/// instance, the measured error of the level its component is drawn at (`levelDrawn`, 0 the
/// coarsest; the full level where the viewer reports none), plus what the instance's repeat
/// tolerance adds to its component's bound. NaN when nothing was drawn.
function drawnErrorBound(manifest, levelDrawn) {
  const components = new Map(manifest.components.map((c) => [c.id, c]));
  let worst = NaN;
  for (const inst of manifest.instances) {
    const c = components.get(inst.component);
    const errors = [...(c.levels ?? []).map((l) => l.error), c.error_bound];
    const k = levelDrawn ? levelDrawn[c.id] : errors.length - 1;
    if (!Number.isInteger(k)) continue;
    const e = errors[Math.min(k, errors.length - 1)] + Math.max(0, inst.error_bound - c.error_bound);
    worst = Number.isNaN(worst) ? e : Math.max(worst, e);
  }
  return worst;
}

const toMillimetres = (unit) => (unit === 'm' ? 1000 : unit === 'cm' ? 10 : unit === 'in' ? 25.4 : 1);
const fmt = (x) => (Number.isFinite(x) ? Math.round(x).toLocaleString('en-US') : x === null || x === undefined ? '-' : String(x));

async function main() {
  const opt = parseOptions();
  if (!fs.existsSync(opt.chromium)) throw new Error(`${opt.chromium}: no Chromium there (Debian: apt-get install chromium); it is never downloaded`);
  if (!fs.existsSync(opt.osteon)) throw new Error(`${opt.osteon}: no osteon CLI (cmake --build build/release --target osteon_cli)`);
  fs.mkdirSync(opt.out, { recursive: true });

  const { datasets, notes } = await findDatasets({ dataDir: opt.data, ids: opt.datasetIds, workDir: path.join(opt.out, 'work'),
    osteon: opt.osteon, dense: opt.dense, log });
  for (const n of notes) log(`note: ${n}`);
  const prepared = [];
  for (const d of datasets) {
    if (d.generated?.length) log(`  ${d.id}: generated ${d.generated.join(', ')}`);
    const p = await prepareDataset(d, { outDir: opt.out, osteon: opt.osteon, viewer: opt.viewer, fresh: opt.fresh, ways: opt.ways, log });
    p.title = d.title;
    p.unit = d.unit;
    p.format = d.format;
    p.fileCount = d.files.length;
    p.folder = d.folder;
    p.volume = d.volume ?? null;
    p.fallback = d.fallback;
    p.readBack = d.readBack !== false && p.triangles <= opt.readbackMax;
    if (p.ways.osteon?.manifest) p.manifest = JSON.parse(fs.readFileSync(p.ways.osteon.manifest, 'utf8'));
    prepared.push(p);
    log(`  ${d.id}: ${p.triangles.toLocaleString('en-US')} triangles; largest side ${p.largestSide.toPrecision(6)} ${d.unit}, ` +
      `${kPositionBits}-bit grid step ${p.gridStep.toPrecision(4)} ${d.unit}, osteon --precision ${p.precision.toPrecision(4)} ${d.unit} (half the step)`);
    for (const [way, w] of Object.entries(p.ways)) {
      if (w.servedBytes) log(`  ${d.id}/${way}: ${w.servedBytes.toLocaleString('en-US')} bytes on disk as served (gzip siblings counted)`);
    }
  }

  if (opt.prepareOnly) {
    log(`prepared in ${((performance.now() - kStart) / 1000).toFixed(0)} s (--prepare-only: nothing measured)`);
    return;
  }

  // A connection may idle as long as a load may take.
  const server = await startServer(opt.osteon, path.join(opt.out, 'site'), Math.min(3600, Math.max(5, Math.ceil(opt.timeoutMs / 1000))));
  const browser = await launchBrowser(opt.chromium);
  const results = {};
  const started = new Date();
  const viewportOf = (profile) => profile?.viewport ?? kViewport;
  let env;
  try {
    // Every peer page gets the canvas size of the osteon viewer in the same window (the window
    // when the viewer is absent): one probe per window size.
    const firstOsteon = prepared.find((p) => p.ways.osteon && !p.ways.osteon.skipped);
    const probeUrl = firstOsteon ? `${server.url}${firstOsteon.id}/osteon/` : `${server.url}${prepared[0].id}/direct/`;
    const canvases = new Map();
    let renderer = null;
    for (const viewport of [kViewport, ...opt.profiles.map(viewportOf)]) {
      const key = `${viewport.width}x${viewport.height}`;
      if (canvases.has(key)) continue;
      const probe = await canvasSize(browser, probeUrl, viewport, opt.timeoutMs);
      renderer ??= probe.renderer;
      canvases.set(key, firstOsteon ? { width: probe.width, height: probe.height } : { ...viewport });
    }
    const canvasOf = (profile) => canvases.get(`${viewportOf(profile).width}x${viewportOf(profile).height}`);
    env = { ...machine(browser.version(), renderer), viewport: kViewport, canvas: canvasOf(null),
      canvases: Object.fromEntries(canvases) };
    log(`chromium ${env.chromium}, WebGL: ${env.webgl}; canvas ${[...canvases].map(([k, c]) => `${c.width} x ${c.height} in ${k}`).join(', ')}` +
      `${firstOsteon ? " (the osteon viewer's)" : ''}; load average ${env.loadAverage.join(' ')}`);

    for (const p of prepared) {
      const ways = opt.ways.filter((w) => p.ways[w] && !p.ways[w].skipped);
      for (const w of opt.ways) if (p.ways[w]?.skipped) log(`${p.id}/${w}: skipped: ${p.ways[w].skipped}`);
      const urlOf = (way, profile) => {
        const c = canvasOf(profile);
        return `${server.url}${p.id}/${p.ways[way].path}${way === 'osteon' ? '' : `?w=${c.width}&h=${c.height}`}`;
      };
      const load = async (way, profile, extract = false) => {
        try {
          return await measureLoad(browser, urlOf(way, profile), { profile, viewport: viewportOf(profile), timeoutMs: opt.timeoutMs, extract });
        } catch (e) {
          return { errors: [e.message], series: [] };
        }
      };
      const runs = {};
      for (const way of ways) runs[way] = Object.fromEntries(opt.profiles.map((pr) => [pr.id, []]));
      for (const profile of opt.profiles) {
        for (let r = 0; r < opt.runs; ++r) {
          for (let k = 0; k < ways.length; ++k) {
            const way = ways[(k + r) % ways.length];
            let mark = server.mark();
            let result = await load(way, profile);
            // A load that ran out of time having drawn nothing, with less than half of what the
            // link carries in that time and not all of its files, stalled rather than ran slow (on
            // this machine a load has, rarely, had its requests answered by the server and never
            // completed in the browser): it is tried once more and both attempts are reported.
            const linkBytes = (profile.bitsPerSecond / 8) * (opt.timeoutMs / 1000);
            if (result.timedOut && !Number.isFinite(result.firstMs) && result.bytes < 0.5 * linkBytes &&
                result.bytes < 0.9 * (p.ways[way].servedBytes ?? Infinity)) {
              log(`${p.id} ${profile.id} run ${r + 1}/${opt.runs} ${way}: stalled (${fmt(result.bytes)} bytes in ${opt.timeoutMs / 1000} s, nothing drawn), trying once more`);
              const stalled = { bytes: result.bytes, transfers: result.transfers?.length ?? 0 };
              mark = server.mark();
              result = await load(way, profile);
              result.retriedAfter = stalled;
            }
            // The server logs a request once it has written the whole body, which for a throttled
            // load cut short can be during the next load: only this way's own paths count.
            const prefix = `/${p.id}/${p.ways[way].path}`;
            const served = server.requestsSince(mark).filter(([q]) => q.startsWith(prefix));
            result.serverBodyBytes = served.reduce((a, [, bytes]) => a + bytes, 0);
            if (!result.errors.length) {
              // A worker's own script is fetched before DevTools attaches to the worker, so the
              // browser's count misses it: the server's log adds the body of every request the
              // browser did not report (matched by path). Not for a load stopped at its limit:
              // its requests still loading are counted by what they had received.
              const seen = new Map();
              for (const [q] of result.transfers) seen.set(q, (seen.get(q) ?? 0) + 1);
              result.unseenBytes = 0;
              for (const [q, bytes] of result.timedOut ? [] : served) {
                if (seen.get(q) > 0) seen.set(q, seen.get(q) - 1);
                else result.unseenBytes += bytes;
              }
              result.browserBytes = result.bytes;
              result.bytes += result.unseenBytes;
              // The error bound of what is drawn at the end, in mm: osteon's levels as drawn; a peer's grid.
              result.drawnErrorBound = (way === 'osteon' && p.manifest
                ? drawnErrorBound(p.manifest, result.hasLevels ? result.levelDrawn : null)
                : p.ways[way].errorBound) * toMillimetres(p.unit);
              delete result.levelDrawn;
            }
            // A peer page also reports what three.js rendered in its last frame: it must be the scene's count.
            if (result.finished && result.trianglesRendered !== null && result.trianglesRendered !== undefined &&
                result.trianglesRendered !== result.trianglesDrawn) {
              log(`warning: ${way}: the last frame rendered ${result.trianglesRendered} triangles, the scene holds ${result.trianglesDrawn}`);
            }
            runs[way][profile.id].push(result);
            log(`${p.id} ${profile.id} run ${r + 1}/${opt.runs} ${way}: ` + (result.errors.length
              ? `FAILED: ${result.errors[0]}`
              : `${result.finished ? '' : `DID NOT FINISH in ${opt.timeoutMs / 1000} s: `}${fmt(result.bytes)} B ` +
                `(${fmt(result.unseenBytes)} of them from the server log; server bodies ${fmt(result.serverBodyBytes)}), ` +
                `first ${fmt(result.firstMs)} ms, complete ${fmt(result.completeMs)} ms, refined ${fmt(result.refinedMs)} ms, all ${fmt(result.allMs)} ms, ` +
                `TBT ${fmt(result.tbtMs)} ms, longest task ${fmt(result.longestTaskMs)} ms, heap ${(result.peakHeapBytes / 1048576).toFixed(1)} MB, ` +
                `GPU ${Number.isFinite(result.gpuBytesPeak ?? result.gpuBytes) ? `${((result.gpuBytesPeak ?? result.gpuBytes) / 1048576).toFixed(1)} MB` : '-'}, ` +
                `${fmt(result.trianglesDrawn)} triangles, error bound ${Number.isFinite(result.drawnErrorBound) ? result.drawnErrorBound.toPrecision(3) : '-'} mm` +
                (profile.cpuSlowdown ? `; CPU / ${result.cpu.rate}: page ${result.cpu.page ? 'yes' : 'NO'}, workers ${result.cpu.workersAccepted} yes, ${result.cpu.workersRefused} no` : '')));
          }
        }
      }

      // The triangles each way draws against the original parts, as osteon reads them.
      const hausdorff = {};
      if (opt.hausdorff && !p.readBack) {
        for (const way of ways) hausdorff[way] = { skipped: `more than ${fmt(opt.readbackMax)} triangles` };
        log(`${p.id}: no read-back (${fmt(p.triangles)} triangles, above --readback-max-triangles ${fmt(opt.readbackMax)})`);
      } else if (opt.hausdorff) {
        for (const way of ways) {
          try {
            const r = await load(way, null, true);
            if (r.errors.length) throw new Error(r.errors[0]);
            if (!r.drawn) throw new Error(`the unthrottled load did not finish in ${opt.timeoutMs / 1000} s`);
            const file = path.join(opt.out, 'work', p.id, `drawn_${way}.ply`);
            writePly(file, r.drawn.positions, r.drawn.indices);
            const c = spawnSync(opt.osteon, ['compare', p.folder, file, '--json'], { encoding: 'utf8', maxBuffer: 64 << 20 });
            if (c.status !== 0) throw new Error(`osteon compare: ${(c.stderr || '').trim().split('\n').pop()}`);
            const j = JSON.parse(c.stdout).symmetric;
            const toMm = toMillimetres(p.unit);
            hausdorff[way] = { max: j.max * toMm, mean: j.mean * toMm, rms: j.rms * toMm, triangles: r.drawn.indices.length / 3, file };
            log(`${p.id} ${way}: drawn ${hausdorff[way].triangles.toLocaleString('en-US')} triangles; Hausdorff to the original ` +
              `max ${hausdorff[way].max.toPrecision(3)} mm, mean ${hausdorff[way].mean.toPrecision(3)} mm`);
          } catch (e) {
            hausdorff[way] = { error: e.message };
            log(`${p.id} ${way}: Hausdorff FAILED: ${e.message}`);
          }
        }
      }
      results[p.id] = { runs, hausdorff };
    }
  } finally {
    await browser.close();
    server.stop();
    // The server's request log, one line per request, for looking into a slow run.
    fs.writeFileSync(path.join(opt.out, 'serve.log'), `${server.lines().join('\n')}\n`);
  }

  // Summaries, tables, targets, plot.
  const versions = toolVersions();
  const sections = [];
  const plotRows = [];
  const summary = {};
  const cpuNotes = new Set();
  let errorCurve = false;
  for (const p of prepared) {
    const { runs, hausdorff } = results[p.id];
    const byWay = {};
    for (const [way, byProfile] of Object.entries(runs)) {
      byWay[way] = Object.fromEntries(Object.entries(byProfile).map(([pr, rs]) => [pr, summarise(rs)]));
    }
    summary[p.id] = byWay;
    const tableText = table(p, byWay, hausdorff, opt.profiles);
    // The targets are set on BodyParts3D (or the phantom standing in for it) and on the dense skeleton.
    const targetId = p.id === 'dense' ? 'dense' : p.id === 'bodyparts3d' || p.fallback ? 'bodyparts3d' : null;
    const checks = targetId ? targets(targetId, byWay, opt.profiles) : [];
    const lines = [`### ${p.title}`, ''];
    if (p.fallback) lines.push(`**${p.fallback}.**`, '');
    const osteonBound = p.ways.osteon?.errorBound;
    lines.push(`${p.triangles.toLocaleString('en-US')} triangles in ${p.fileCount} files. Grid: ${kPositionBits} bits over the ` +
      `scene's largest side (${p.largestSide.toPrecision(6)} ${p.unit}), a step of ${p.gridStep.toPrecision(4)} ${p.unit}, so Draco ` +
      `moves a vertex by at most ${p.dracoBound.toPrecision(4)} ${p.unit} (sqrt(3)/2 steps); gltfpack's default 14-bit grid has a step of ` +
      `${p.ways.gltfpack?.gridStep?.toPrecision(4) ?? p.ways['gltfpack-cz']?.gridStep?.toPrecision(4)} ${p.unit} (its node scale); osteon packs at ` +
      `\`--precision ${p.precision.toPrecision(4)}\` (half a step)` +
      (Number.isFinite(osteonBound) ? `, and its manifest's largest error bound at full resolution is ${osteonBound.toPrecision(4)} ${p.unit}` +
        `${osteonBound <= p.dracoBound * (1 + 1e-6) ? ' (no larger than Draco\'s)' : ' (**larger than Draco\'s**)'}.` : '.'), '');
    if (p.id === 'dense') {
      lines.push(`The label volume \`${path.relative(repo, p.volume)}\` is \`osteon voxelize ${path.relative(repo, path.join(opt.data, 'aHer-dev__3DAnatomy/models/bones'))} ` +
        `--voxel ${opt.dense.voxel}\` (one label per bone, named by its file stem). osteon packs the volume itself with \`--surface-voxels 0\` ` +
        '(no simplification). The CLI writes no meshes from a volume, so the peers\' input is made by `osteon pack VOLUME --surface-voxels 0 ' +
        '--no-lod --no-repeats --max-triangles 0 --bits 24 --no-viewer` (one component per label on a 24-bit grid), each component\'s ' +
        'stream `osteon decode`d to PLY and written as one GLB per bone (positions, the decoder\'s smooth normals, indices); ' +
        `the read-back Hausdorff check is skipped at this size (the error-bound column still holds).`, '');
    }
    for (const way of Object.keys(byWay)) lines.push(`- ${way}: ${describeWay(way, p)}`);
    for (const w of kAllWays) if (p.ways[w]?.skipped && opt.ways.includes(w)) lines.push(`- ${w}: **not run**: ${p.ways[w].skipped}`);
    lines.push('', tableText, '');
    for (const profile of opt.profiles) lines.push(detailTable(byWay, profile), '');
    if (checks.length) {
      lines.push('Targets, computed from the medians above (this machine draws with software WebGL, SwiftShader, on 2 shared cores: ' +
        'absolute times are only comparable within one run):', '', ...targetLines(checks), '');
    } else if (targetId && !byWay.osteon) {
      lines.push('Targets: not checked, the osteon way did not run.', '');
    }
    const failures = Object.entries(byWay).flatMap(([way, bp]) => Object.entries(bp).filter(([, s]) => s.failed).map(([pr, s]) => `${way} ${pr}: ${s.failed} of ${s.runs} runs failed (${s.errors[0]})`));
    if (failures.length) lines.push('Failed runs (left out of the medians):', '', ...failures.map((f) => `- ${f}`), '');
    const retried = Object.entries(runs).flatMap(([way, bp]) => Object.entries(bp).flatMap(([pr, rs]) => rs.filter((r) => r.retriedAfter).map(() => `${way} ${pr}`)));
    if (retried.length) {
      lines.push(`Loads that stalled (nothing drawn in ${opt.timeoutMs / 1000} s with less than half the link's capacity transferred) and were run once more (the second attempt counts): ${retried.join(', ')}.`, '');
    }
    for (const [way, bp] of Object.entries(byWay)) {
      for (const [pr, s] of Object.entries(bp)) {
        if (s.cpu && s.cpu.rate > 1 && s.cpu.workersRefused) {
          cpuNotes.add(`${p.id} ${way}: ${s.cpu.workersRefused} worker${s.cpu.workersRefused > 1 ? 's' : ''}` +
            `${s.cpu.workerError ? ` ("${s.cpu.workerError}")` : ''}`);
        }
        if (s.errorSeries.length) errorCurve = true;
      }
    }
    sections.push(lines.join('\n'));
    if (p.id === 'bodyparts3d' || p.id === 'dense' || (p === prepared[0] && !prepared.some((q) => q.id === 'bodyparts3d'))) {
      plotRows.push({ id: p.id, title: p.id === 'dense' ? 'dense skeleton' : p.id, results: byWay, totalTriangles: p.triangles });
    }
    console.log(`\n${p.title}\n\n${tableText}\n`);
    if (checks.length) console.log(targetLines(checks).join('\n'));
  }

  fs.writeFileSync(opt.json, JSON.stringify({ started, env, versions, options: { ...opt }, prepared: prepared.map((p) => ({ ...p, manifest: undefined })), results, summary },
    (k, v) => (k === 'drawn' ? undefined : v), 1));
  log(`\nevery run: ${opt.json}`);

  // The section and the plot are written only from a complete run: every dataset, way and
  // profile of the defaults, each measured.
  const missing = [];
  for (const id of ['bodyparts3d', 'dense', 'myosim']) if (!prepared.some((p) => p.id === id)) missing.push(`dataset ${id}`);
  for (const w of kAllWays) if (!opt.ways.includes(w) || prepared.some((p) => !results[p.id].runs[w])) missing.push(`way ${w}`);
  for (const pr of Object.keys(kProfiles)) if (!opt.profiles.some((q) => q.id === pr)) missing.push(`profile ${pr}`);
  const complete = (missing.length === 0 && !prepared.some((p) => p.fallback)) || opt.writeIncomplete;
  if ((opt.write || opt.svg) && !complete) {
    log(`not writing ${[opt.write, opt.svg].filter(Boolean).map((f) => path.relative(repo, f)).join(' or ')}: the run is not complete (${missing.join(', ') || 'the phantom stood in for real data'})`);
  }
  const cmd = `bash bench/web/run.sh${process.argv.slice(2).length ? ` ${process.argv.slice(2).join(' ')}` : ''}`;
  const subtitle = `headless Chromium ${env.chromium.split('.')[0]}, SwiftShader WebGL, cache disabled; median run of ${opt.runs} per way`;
  const svg = svgPlot({ title: 'Triangles drawn over time', subtitle, profiles: opt.profiles, rows: plotRows });
  fs.writeFileSync(path.join(opt.out, 'load_time.svg'), svg);
  if (opt.svg && complete && plotRows.length) {
    fs.writeFileSync(opt.svg, svg);
    log(`plot: ${opt.svg}`);
  }
  if (opt.write && complete) {
    const profileText = opt.profiles.map((pr) => `${pr.label}${pr.cpuSlowdown ? ` (Emulation.setCPUThrottlingRate ${pr.cpuSlowdown} on the page, a ${pr.viewport.width} x ${pr.viewport.height} window at device pixel ratio 1, as every profile: SwiftShader draws every pixel in software)` : ''}`).join('; ');
    const body = [
      `## ${kSectionTitle}`,
      '',
      `Made by \`${cmd}\` (bench/web/load_bench.mjs; bench/README.md says what it does) on ${started.toISOString().slice(0, 10)}, ` +
        `osteon at ${env.checkout}.`,
      `Machine: ${env.cpu}, ${env.cores} cores (shared with other jobs; load average ${env.loadAverage.join(', ')} at the start), ` +
        `Chromium ${env.chromium} headless (Debian; ${kChromiumArgs.join(' ')}), WebGL: ${env.webgl}, Node ${env.node}; three ${versions.three}, ` +
        `@gltf-transform/cli ${versions['@gltf-transform/cli']}, gltfpack ${versions.gltfpack}, playwright-core ${versions['playwright-core']}. ` +
        'WebGL is software (SwiftShader) on 2 shared cores: absolute times are only comparable within one run.',
      '',
      `Each way loads the skeleton from \`osteon serve\` on this machine in a fresh browser context, throttled by the DevTools ` +
        `protocol (Network.emulateNetworkConditions on the page and on every worker it starts), the cache disabled and service workers ` +
        `blocked (the viewer's offline copy of the package, which it fetches once loading has settled, is not part of a load), under ` +
        `each profile: ${profileText}. ${opt.runs} run${opt.runs > 1 ? 's' : ''} per way and profile, the ways interleaved; the table ` +
        `gives the median and, in brackets, the fastest and slowest run. A load is stopped after ${opt.timeoutMs / 1000} s (\`--timeout\`); ` +
        `what it had not reached by then counts as later than that, and a median past it reads "did not finish in ${opt.timeoutMs / 1000} s". ` +
        `Canvas ${[...Object.entries(env.canvases)].map(([k, c]) => `${c.width} x ${c.height} in a ${k.replace('x', ' x ')} window`).join(', ')} ` +
        '(the osteon viewer\'s); the peer pages (bench/web/pages/) get the same size and use the viewer\'s renderer settings, lights, ' +
        'material and camera fit, and draw a frame whenever the scene changes, as the viewer does.',
      '',
      '- **bytes transferred**: Network.loadingFinished encodedDataLength (headers included) summed over the page and its workers, ' +
        'plus the body of any request the browser did not report, from the server\'s log (a worker\'s own script is fetched before ' +
        'DevTools attaches to the worker). ' +
        'Every served file has a gzip -9 sibling where that saves at least 5%, which `osteon serve` sends (as nginx `gzip_static` does), ' +
        'so every way gets the same transport compression.',
      '- **first frame**: milliseconds from navigation start to the first frame drawn with a triangle, as the page reports it: ' +
        '`window.bench.firstTrianglesMs` on the peer pages (set when `renderer.render()` returns, so a first frame\'s shader ' +
        'compilation counts), the viewer\'s `firstFrameMs` (its render worker\'s frame, on the page\'s clock; `firstComponentMs` in ' +
        'a viewer without it). A script injected before the page\'s own also samples the page\'s triangle count at the start of every ' +
        'animation frame (`trianglesDrawn`, instances counted): the plot\'s lines, and the fallback where a page reports no moment. ' +
        '**triangles drawn** is that count at the end.',
      '- **skeleton complete**: every bone drawn at some level: the viewer\'s `skeletonCompleteMs` (`allLoadedMs` in a viewer without ' +
        'levels of detail); a peer draws every bone at its only level when it draws them all, so its figure is its all drawn.',
      '- **refined / all drawn**: for osteon the viewer\'s `refinedMs`, every visible bone within 1 px of screen-space error (the level\'s ' +
        'measured error projected at the view) or at its finest level, waiting until the viewer has nothing more in flight ' +
        '(`refineIdle`); for the peers the first animation frame holding every triangle.',
      '- **TBT / longest task**: total blocking time, the part beyond 50 ms of every main-thread long task (PerformanceObserver ' +
        '`longtask`, registered before any page script) that started before the load ended (refined or all drawn; the time limit for ' +
        'a load that did not finish), and the longest of those tasks.',
      '- **peak JS heap**: the largest sum over the page and its workers of V8\'s used heap plus ArrayBuffer and WebAssembly ' +
        'memory (`Runtime.getHeapUsage`: usedSize + backingStorageSize), sampled every 50 ms; MB = 2^20 bytes.',
      '- **GPU MB** (2^20 bytes): the bytes of geometry handed to WebGL: for osteon the viewer\'s `gpuBytesPeak` (resident levels\' positions, normals ' +
        'and indices; `gpuBytes` in a viewer without a peak), for the peers the byte lengths of the scene\'s geometry buffers once ' +
        'everything is drawn (vertex attributes, each interleaved buffer once, indices, instance matrices).',
      '- **error bound drawn**: how far what is drawn at the end may be from the input, from the files rather than measured: osteon, the ' +
        'largest manifest `error` (measured Hausdorff plus quantization) of the level each bone is drawn at (`levelDrawn`), plus an ' +
        'instance\'s repeat tolerance; Draco and gltfpack, their 14-bit grid\'s sqrt(3)/2 steps; direct, 0.',
      '- **Hausdorff**: one more, unthrottled load per way in the desktop window; the triangles in its three.js scene (world and instance matrices ' +
        'applied) are read back, written as PLY and measured by `osteon compare ORIGINAL DRAWN` against the original parts as ' +
        'osteon reads them (the source folder, node transforms applied, merged into one mesh): symmetric max, mean and RMS in mm; ' +
        'the scene is found through three.js\'s `__THREE_DEVTOOLS__` hook, installed in the page and in every worker before their ' +
        `scripts run (the viewer draws in a worker, on an OffscreenCanvas). Skipped above ${fmt(opt.readbackMax)} triangles ` +
        '(`--readback-max-triangles`). The direct way\'s figure checks the read-back: three.js and osteon apply the node transforms in float.',
      ...(cpuNotes.size ? ['', '**The phone\'s CPU slowdown reaches the page\'s main thread only**: Chromium refuses ' +
        '`Emulation.setCPUThrottlingRate` for workers, so work done in workers (the osteon viewer\'s renderer and decoders, ' +
        `DRACOLoader's decoders) ran at this machine's full speed, which favours those ways. Refused by: ${[...cpuNotes].join('; ')}.`] : []),
      '',
      ...sections,
      `![Triangles drawn over time](${path.basename(opt.svg ?? 'load_time.svg')})`,
      '',
      `The plot (\`docs/${path.basename(opt.svg ?? 'load_time.svg')}\`, written by the same run) shows ${plotRows.map((r) => r.title).join(' and ')}: triangles ` +
        'drawn against time for the median run of each way (by refined or all-drawn time), one panel per profile; a dot marks the first frame. ' +
        (errorCurve
          ? 'Under each, osteon\'s largest screen-space error of a drawn bone in pixels (log scale): sampled by the bench in the page, at most ' +
            'every 100 ms while frames are drawn, as the largest over the components on screen of `window.osteon.levelPixels(id)[levelDrawn[id]]`; ' +
            'the curve starts when the viewer first projects its levels (it plans them once the skeleton is complete).'
          : 'No screen-space error curve: the viewer exposes no `levelPixels` / `levelDrawn` to sample.'),
      '',
    ].join('\n');
    writeSection(opt.write, body);
    log(`section "${kSectionTitle}" written to ${opt.write}`);
  }
}

main().catch((e) => {
  console.error(`bench/web: error: ${e.message}`);
  process.exit(1);
});
