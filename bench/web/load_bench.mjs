// SPDX-License-Identifier: Apache-2.0
// bench/web: how fast a skeleton appears in a real browser, osteon against what a user would pick
// instead (the paper's Fig. 12). Headless Chromium (Debian's, driven by
// playwright-core, WebGL through SwiftShader) loads the same skeleton from `osteon serve` four
// ways, with the network throttled through the DevTools protocol and the cache disabled:
//
//   direct    the original part files, three.js's GLTFLoader / STLLoader, one request per file
//   draco     one Draco-compressed .glb (gltf-transform, 14-bit positions), GLTFLoader+DRACOLoader
//   gltfpack  one `gltfpack -cc -mi` .glb, GLTFLoader + MeshoptDecoder
//   osteon    `osteon pack` at the same error bound, loaded by the osteon viewer
//
// Each way runs --runs times per network profile (interleaved: run k loads every way before run
// k + 1 starts, so a slow spell on the shared machine hits every way alike), each in a fresh
// browser context. Then one unthrottled run per way reads back the triangles drawn and
// `osteon compare` measures them against the original parts.
//
// Usage: node load_bench.mjs [--runs 5] [--profiles slow,fast] [--ways direct,draco,gltfpack,osteon]
//        [--datasets bodyparts3d,myosim] [--no-write] ...   (`--help` lists every option)
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
const kAllWays = ['direct', 'draco', 'gltfpack', 'osteon'];
const kViewport = { width: 1280, height: 800 };

function parseOptions() {
  const { values } = parseCommandLine({
    usage: 'node bench/web/load_bench.mjs [options]   (or: bash bench/web/run.sh [options])',
    options: {
      runs: { type: 'string', default: '5', arg: 'N', help: 'loads per way and network profile (default 5; medians reported)' },
      profiles: { type: 'string', default: 'slow,fast', arg: 'LIST',
        help: 'slow (10 Mbit/s, 40 ms) and/or fast (100 Mbit/s, 10 ms) (default slow,fast)' },
      ways: { type: 'string', default: kAllWays.join(','), arg: 'LIST', help: 'direct,draco,gltfpack,osteon (default all)' },
      datasets: { type: 'string', default: 'bodyparts3d,myosim', arg: 'LIST',
        help: 'bodyparts3d,myosim,phantom (default bodyparts3d,myosim; phantom when no data)' },
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
      'no-hausdorff': { type: 'boolean', default: false, help: 'skip the drawn-triangles read-back and osteon compare' },
      fresh: { type: 'boolean', default: false, help: 'redo every preparation step' },
      timeout: { type: 'string', default: '60', arg: 'S', help: 'seconds one page load may take (default 60)' },
      json: { type: 'string', arg: 'FILE', help: "every run's numbers as JSON (default OUT/results.json)" },
    },
  });
  const list = (s) => s.split(',').map((x) => x.trim()).filter(Boolean);
  const runs = Number(values.runs);
  if (!Number.isInteger(runs) || runs < 1) throw new Error(`--runs: expected a positive integer, got "${values.runs}"`);
  const timeout = Number(values.timeout);
  if (!(timeout > 0)) throw new Error(`--timeout: expected seconds > 0, got "${values.timeout}"`);
  const profiles = list(values.profiles).map((id) => {
    if (!kProfiles[id]) throw new Error(`--profiles: unknown profile "${id}" (slow, fast)`);
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
    hausdorff: !values['no-hausdorff'],
    fresh: values.fresh,
    timeoutMs: timeout * 1000,
    json: path.resolve(values.json ?? path.join(out, 'results.json')),
  };
}

const log = (...a) => console.error(...a);

/// Starts `osteon serve ROOT --port 0` and resolves with { url, stop(), bodyBytesSince(mark) }.
/// The server's per-request log ("GET /x 200 1234 B 0.3 ms") gives a second count of the bytes.
function startServer(osteon, root) {
  return new Promise((resolve, reject) => {
    const child = spawn(osteon, ['serve', root, '--port', '0', '--host', '127.0.0.1'], { stdio: ['ignore', 'pipe', 'pipe'] });
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
          bodyBytesSince: (mark) => lines.slice(mark).reduce((sum, l) => sum + Number(l.match(/ (\d+) B /)?.[1] ?? 0), 0),
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
  if (way === 'direct') return `the ${prep.fileCount} original files`;
  const merged = prep.format === 'glb'
    ? '`gltf-transform merge --merge-scenes` of the parts (merged.glb)'
    : 'the STL parts written as one GLB by glTF Transform (merged.glb: welded, smooth normals)';
  if (way === 'draco') return `${merged}, then \`gltf-transform draco merged.glb scene.glb --quantize-position ${kPositionBits} --quantization-volume scene\``;
  if (way === 'gltfpack') return '`gltfpack -i merged.glb -o scene.glb -cc -mi`';
  return w.packArgs ? `\`osteon ${w.packArgs.map((a) => (a.includes('/') ? path.relative(repo, a) || a : a)).join(' ')}\`` : '';
}

async function main() {
  const opt = parseOptions();
  if (!fs.existsSync(opt.chromium)) throw new Error(`${opt.chromium}: no Chromium there (Debian: apt-get install chromium); it is never downloaded`);
  if (!fs.existsSync(opt.osteon)) throw new Error(`${opt.osteon}: no osteon CLI (cmake --build build/release --target osteon_cli)`);
  fs.mkdirSync(opt.out, { recursive: true });

  const { datasets, notes } = findDatasets({ dataDir: opt.data, ids: opt.datasetIds, workDir: path.join(opt.out, 'work'), osteon: opt.osteon });
  for (const n of notes) log(`note: ${n}`);
  const prepared = [];
  for (const d of datasets) {
    const p = await prepareDataset(d, { outDir: opt.out, osteon: opt.osteon, viewer: opt.viewer, fresh: opt.fresh, log });
    p.title = d.title;
    p.unit = d.unit;
    p.format = d.format;
    p.fileCount = d.files.length;
    p.folder = d.folder;
    p.fallback = d.fallback;
    prepared.push(p);
    log(`  ${d.id}: largest side ${p.largestSide.toPrecision(6)} ${d.unit}, ${kPositionBits}-bit grid step ${p.gridStep.toPrecision(4)} ${d.unit}, ` +
      `osteon --precision ${p.precision.toPrecision(4)} ${d.unit} (half the step)`);
    for (const [way, w] of Object.entries(p.ways)) {
      if (w.servedBytes) log(`  ${d.id}/${way}: ${w.servedBytes.toLocaleString('en-US')} bytes on disk as served (gzip siblings counted)`);
    }
  }

  const server = await startServer(opt.osteon, path.join(opt.out, 'site'));
  const browser = await launchBrowser(opt.chromium);
  const results = {};
  const started = new Date();
  let env;
  try {
    // Every peer page gets the canvas size of the osteon viewer (the viewport when it is absent).
    const firstOsteon = prepared.find((p) => p.ways.osteon && !p.ways.osteon.skipped);
    const probeUrl = firstOsteon ? `${server.url}${firstOsteon.id}/osteon/` : `${server.url}${prepared[0].id}/direct/`;
    const probe = await canvasSize(browser, probeUrl, kViewport, opt.timeoutMs);
    const canvas = firstOsteon ? { width: probe.width, height: probe.height } : { width: kViewport.width, height: kViewport.height };
    env = { ...machine(browser.version(), probe.renderer), viewport: kViewport, canvas };
    log(`chromium ${env.chromium}, WebGL: ${env.webgl}; canvas ${canvas.width} x ${canvas.height}` +
      `${firstOsteon ? " (the osteon viewer's)" : ''}; load average ${env.loadAverage.join(' ')}`);

    for (const p of prepared) {
      const ways = opt.ways.filter((w) => p.ways[w] && !p.ways[w].skipped);
      for (const w of opt.ways) if (p.ways[w]?.skipped) log(`${p.id}/${w}: skipped: ${p.ways[w].skipped}`);
      const urlOf = (way) => `${server.url}${p.id}/${p.ways[way].path}${way === 'osteon' ? '' : `?w=${canvas.width}&h=${canvas.height}`}`;
      const runs = {};
      for (const way of ways) runs[way] = Object.fromEntries(opt.profiles.map((pr) => [pr.id, []]));
      for (const profile of opt.profiles) {
        for (let r = 0; r < opt.runs; ++r) {
          for (let k = 0; k < ways.length; ++k) {
            const way = ways[(k + r) % ways.length];
            let mark = server.mark();
            let result;
            try {
              result = await measureLoad(browser, urlOf(way), { profile, viewport: kViewport, timeoutMs: opt.timeoutMs });
            } catch (e) {
              result = { errors: [e.message], series: [] };
            }
            // A load that times out is tried once more (on this machine a load has stalled, rarely,
            // with its requests answered by the server and never completed in the browser); both
            // attempts are reported.
            if (result.errors.length && /Timeout/.test(result.errors[0])) {
              log(`${p.id} ${profile.id} run ${r + 1}/${opt.runs} ${way}: timed out, trying once more: ${result.errors[0]}`);
              const timedOut = result.errors[0];
              mark = server.mark();
              try {
                result = await measureLoad(browser, urlOf(way), { profile, viewport: kViewport, timeoutMs: opt.timeoutMs });
              } catch (e) {
                result = { errors: [e.message], series: [] };
              }
              result.retriedAfter = timedOut;
            }
            result.serverBodyBytes = server.bodyBytesSince(mark);
            if (!result.errors.length) {
              // A worker's own script is fetched before DevTools attaches to the worker, so the
              // browser's count misses it: the server's log adds the body of every request the
              // browser did not report (matched by path).
              const seen = new Map();
              for (const [p] of result.transfers) seen.set(p, (seen.get(p) ?? 0) + 1);
              result.unseenBytes = 0;
              for (const [p, bytes] of server.requestsSince(mark)) {
                if (seen.get(p) > 0) seen.set(p, seen.get(p) - 1);
                else result.unseenBytes += bytes;
              }
              result.browserBytes = result.bytes;
              result.bytes += result.unseenBytes;
            }
            // A peer page also reports what three.js rendered in its last frame: it must be the scene's count.
            if (!result.errors.length && result.trianglesRendered !== null && result.trianglesRendered !== undefined &&
                result.trianglesRendered !== result.trianglesDrawn) {
              log(`warning: ${way}: the last frame rendered ${result.trianglesRendered} triangles, the scene holds ${result.trianglesDrawn}`);
            }
            runs[way][profile.id].push(result);
            log(`${p.id} ${profile.id} run ${r + 1}/${opt.runs} ${way}: ` + (result.errors.length
              ? `FAILED: ${result.errors[0]}`
              : `${result.bytes.toLocaleString('en-US')} B (${result.unseenBytes.toLocaleString('en-US')} of them from the server log; server bodies ${result.serverBodyBytes.toLocaleString('en-US')}), ` +
                `first ${Math.round(result.firstMs)} ms, all ${Math.round(result.allMs)} ms, TBT ${Math.round(result.tbtMs)} ms, ` +
                `heap ${(result.peakHeapBytes / 1048576).toFixed(1)} MB, ${result.trianglesDrawn.toLocaleString('en-US')} triangles`));
          }
        }
      }

      // The triangles each way draws against the original parts, as osteon reads them.
      const hausdorff = {};
      if (opt.hausdorff) {
        for (const way of ways) {
          try {
            const r = await measureLoad(browser, urlOf(way), { profile: null, viewport: kViewport, timeoutMs: opt.timeoutMs, extract: true });
            if (r.errors.length) throw new Error(r.errors[0]);
            const file = path.join(opt.out, 'work', p.id, `drawn_${way}.ply`);
            writePly(file, r.drawn.positions, r.drawn.indices);
            const c = spawnSync(opt.osteon, ['compare', p.folder, file, '--json'], { encoding: 'utf8', maxBuffer: 64 << 20 });
            if (c.status !== 0) throw new Error(`osteon compare: ${(c.stderr || '').trim().split('\n').pop()}`);
            const j = JSON.parse(c.stdout).symmetric;
            const toMm = p.unit === 'm' ? 1000 : p.unit === 'cm' ? 10 : 1;
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
  const svgs = [];
  const summary = {};
  for (const p of prepared) {
    const { runs, hausdorff } = results[p.id];
    const byWay = {};
    for (const [way, byProfile] of Object.entries(runs)) {
      byWay[way] = Object.fromEntries(Object.entries(byProfile).map(([pr, rs]) => [pr, summarise(rs)]));
    }
    summary[p.id] = byWay;
    const tableText = table(p, byWay, hausdorff, opt.profiles);
    const slow = opt.profiles.find((pr) => pr.id === 'slow');
    // The load-time targets are set on the BodyParts3D skeleton (or on the phantom standing in for it).
    const targetSet = slow && (p.id === 'bodyparts3d' || p.fallback);
    const checks = targetSet && byWay.osteon ? targets(byWay, 'slow') : [];
    const lines = [`### ${p.title}`, ''];
    if (p.fallback) lines.push(`**${p.fallback}.**`, '');
    const osteonBound = p.ways.osteon?.errorBound;
    lines.push(`${p.triangles.toLocaleString('en-US')} triangles in ${p.fileCount} files. Grid: ${kPositionBits} bits over the ` +
      `scene's largest side (${p.largestSide.toPrecision(6)} ${p.unit}), a step of ${p.gridStep.toPrecision(4)} ${p.unit}, so Draco ` +
      `moves a vertex by at most ${p.dracoBound.toPrecision(4)} ${p.unit} (sqrt(3)/2 steps); gltfpack's default 14-bit grid has a step of ` +
      `${p.ways.gltfpack?.gridStep?.toPrecision(4)} ${p.unit} (its node scale); osteon packs at ` +
      `\`--precision ${p.precision.toPrecision(4)}\` (half a step)` +
      (Number.isFinite(osteonBound) ? `, and its manifest's largest error bound is ${osteonBound.toPrecision(4)} ${p.unit}` +
        `${osteonBound <= p.dracoBound * (1 + 1e-6) ? ' (no larger than Draco\'s)' : ' (**larger than Draco\'s**)'}.` : '.'), '');
    for (const way of Object.keys(byWay)) lines.push(`- ${way}: ${describeWay(way, p)}`);
    for (const w of kAllWays) if (p.ways[w]?.skipped && opt.ways.includes(w)) lines.push(`- ${w}: **not run**: ${p.ways[w].skipped}`);
    lines.push('', tableText, '');
    for (const profile of opt.profiles) lines.push(detailTable(byWay, profile), '');
    if (checks.length) {
      lines.push(`Targets at ${slow.label}, computed from the medians above:`, '', ...targetLines(checks), '');
    } else if (targetSet) {
      lines.push('Targets: not checked, the osteon way did not run.', '');
    }
    const failures = Object.entries(byWay).flatMap(([way, bp]) => Object.entries(bp).filter(([, s]) => s.failed).map(([pr, s]) => `${way} ${pr}: ${s.failed} of ${s.runs} runs failed (${s.errors[0]})`));
    if (failures.length) lines.push('Failed runs (left out of the medians):', '', ...failures.map((f) => `- ${f}`), '');
    const retried = Object.entries(runs).flatMap(([way, bp]) => Object.entries(bp).flatMap(([pr, rs]) => rs.filter((r) => r.retriedAfter).map(() => `${way} ${pr}`)));
    if (retried.length) {
      lines.push(`Loads that timed out after ${opt.timeoutMs / 1000} s and were run once more (the second attempt counts): ${retried.join(', ')}.`, '');
    }
    sections.push(lines.join('\n'));
    if (p === prepared[0] || p.id === 'bodyparts3d') {
      svgs.push({ id: p.id, svg: svgPlot({
        title: `${p.title}: triangles drawn over time`,
        subtitle: `headless Chromium ${env.chromium.split('.')[0]}, SwiftShader WebGL, cache disabled; median run of ${opt.runs} per way`,
        profiles: opt.profiles,
        results: byWay,
        totalTriangles: p.triangles,
      }) });
    }
    console.log(`\n${p.title}\n\n${tableText}\n`);
    if (checks.length) console.log(targetLines(checks).join('\n'));
  }

  fs.writeFileSync(opt.json, JSON.stringify({ started, env, versions, options: { ...opt }, prepared, results, summary }, (k, v) => (k === 'drawn' ? undefined : v), 1));
  log(`\nevery run: ${opt.json}`);

  const cmd = `bash bench/web/run.sh${process.argv.slice(2).length ? ` ${process.argv.slice(2).join(' ')}` : ''}`;
  const svgFor = svgs.find((s) => s.id === 'bodyparts3d') ?? svgs[0];
  if (opt.svg && svgFor) {
    fs.writeFileSync(opt.svg, svgFor.svg);
    log(`plot: ${opt.svg}`);
  }
  if (opt.write) {
    const body = [
      `## ${kSectionTitle}`,
      '',
      `Made by \`${cmd}\` (bench/web/load_bench.mjs; bench/README.md says what it does) on ${started.toISOString().slice(0, 10)}, ` +
        `osteon at ${env.checkout}.`,
      `Machine: ${env.cpu}, ${env.cores} cores (shared with other jobs; load average ${env.loadAverage.join(', ')} at the start), ` +
        `Chromium ${env.chromium} headless (Debian; ${kChromiumArgs.join(' ')}), WebGL: ${env.webgl}, Node ${env.node}; three ${versions.three}, ` +
        `@gltf-transform/cli ${versions['@gltf-transform/cli']}, gltfpack ${versions.gltfpack}, playwright-core ${versions['playwright-core']}.`,
      '',
      `Each way loads the skeleton from \`osteon serve\` on this machine in a fresh browser context, the network throttled by ` +
        `the DevTools protocol (Network.emulateNetworkConditions on the page and on every worker it starts) and the cache disabled, ` +
        `${opt.runs} run${opt.runs > 1 ? 's' : ''} per way and network profile, the ways interleaved; the table gives the median and, in ` +
        `brackets, the fastest and slowest run. Canvas ${env.canvas.width} x ${env.canvas.height} (the osteon viewer's, in a ` +
        `${kViewport.width} x ${kViewport.height} window); the peer pages (bench/web/pages/) use the viewer's renderer settings, lights, ` +
        `material and camera fit, and draw a frame whenever the scene changes, as the viewer does.`,
      '',
      '- **bytes transferred**: Network.loadingFinished encodedDataLength (headers included) summed over the page and its workers, ' +
        'plus the body of any request the browser did not report, from the server\'s log (a worker\'s own script is fetched before ' +
        'DevTools attaches to the worker). ' +
        'Every served file has a gzip -9 sibling where that saves at least 5%, which `osteon serve` sends (as nginx `gzip_static` does), ' +
        'so every way gets the same transport compression.',
      '- **first triangles / all drawn**: milliseconds from navigation start to the first animation frame whose scene holds a triangle, ' +
        'and to the first that holds all of them. A script injected before the page\'s own samples the page\'s count at the start of ' +
        'every animation frame: `window.bench.trianglesDrawn` on the peer pages, set when `renderer.render()` returns, and ' +
        '`window.osteon.trianglesDrawn` in the viewer, set when its render worker reports the frame drawn (instances counted in ' +
        'both), so a first frame\'s shader compilation and a frame delayed by a busy thread count. **triangles drawn** is that ' +
        'count at the end.',
      '- **TBT**: total blocking time, the part beyond 50 ms of every main-thread long task (PerformanceObserver `longtask`, ' +
        'registered before any page script) that started before everything was drawn.',
      '- **peak JS heap**: the largest sum over the page and its workers of V8\'s used heap plus ArrayBuffer and WebAssembly ' +
        'memory (`Runtime.getHeapUsage`: usedSize + backingStorageSize), sampled every 50 ms; MB = 2^20 bytes.',
      '- **Hausdorff**: one more, unthrottled load per way; the triangles in its three.js scene (world and instance matrices ' +
        'applied) are read back, written as PLY and measured by `osteon compare ORIGINAL DRAWN` against the original parts as ' +
        'osteon reads them (the source folder, node transforms applied, merged into one mesh): symmetric max, mean and RMS in mm; ' +
        'the scene is found through three.js\'s `__THREE_DEVTOOLS__` hook, installed in the page and in every worker before their ' +
        'scripts run (the viewer draws in a worker, on an OffscreenCanvas). The direct way\'s figure checks the read-back: ' +
        'three.js and osteon apply the node transforms in float.',
      '',
      ...sections,
      `![Triangles drawn over time](load_time.svg)`,
      '',
      `The plot (\`docs/load_time.svg\`, written by the same run) shows the ${svgFor ? svgFor.id : ''} skeleton: triangles drawn against ` +
        'time for the median run of each way (by all-drawn time), one panel per network profile; a dot marks the first triangles.',
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
