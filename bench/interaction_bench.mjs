// SPDX-License-Identifier: Apache-2.0
// What a teacher's interactions cost in the viewer on a dense skeleton: a pick, a measurement
// (two picks and the figure), an opacity change and a colour-by change, each until its answer or
// its frame, in headless Chromium with software WebGL (SwiftShader), against a plain redraw.
//
//   node bench/interaction_bench.mjs [--data DIR] [--out DIR] [--repeat N] [--write docs/BENCHMARKS.md]
//
// The skeleton: ct-like/skull_mc.ply and ct-like/hip_mcs.ply (1.5 M + 1.06 M triangles, CT
// marching-cubes surfaces) packed together with `osteon pack --no-lod` (so every triangle is drawn)
// and served with `osteon serve`.
// Once every component is drawn at full resolution, N times each (medians reported):
//   - pick: window.osteon.pickAt at a point on a bone, until the render worker's answer;
//   - measurement: window.osteon.measureAt between two such points, until the figure;
//   - redraw: a camera nudge, until its frame is drawn (what any visible change pays);
//   - opacity: window.osteon.setPartStyle with every part at 0.5, then back, until the frame;
//   - colour: window.osteon.setPartStyle with new colours, until the frame.
// With each frame, the worker's time to apply the change and to issue the frame. Wall clock on a
// shared machine with a software GPU: quote ratios and medians.
//
// --write replaces only the text between this benchmark's markers in that file.

import { execFileSync } from 'node:child_process';
import { existsSync, rmSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { parseCommandLine } from './lib/args.mjs';
import { writeSection } from './lib/section.mjs';
import { median } from './lib/stats.mjs';
import { cli, launchBrowser, openViewer, serve, viewerDir, waitLoaded, waitRefined } from '../web/test/browser_helpers.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..');
const { values } = parseCommandLine({
  usage: 'node bench/interaction_bench.mjs [options]',
  about: 'Pick, measurement, opacity and colour changes on a 2.5 M-triangle skeleton in Chromium; prints a Markdown table.',
  options: {
    data: { type: 'string', arg: 'DIR', help: 'the real meshes (default: ../shared/data)' },
    out: { type: 'string', arg: 'DIR', help: 'scratch folder (default: build/interaction-bench)' },
    repeat: { type: 'string', arg: 'N', help: 'repetitions of each interaction (default 15)' },
    write: { type: 'string', arg: 'FILE', help: 'replace this benchmark\'s section of FILE (docs/BENCHMARKS.md)' },
  },
});
const data = path.resolve(values.data ?? path.join(repo, '..', 'shared', 'data'));
const out = path.resolve(values.out ?? path.join(repo, 'build', 'interaction-bench'));
const repeat = Number(values.repeat ?? 15);
const inputs = ['skull_mc.ply', 'hip_mcs.ply'].map((f) => path.join(data, 'ct-like', f));
if (!inputs.every(existsSync)) {
  console.error(`osteon: ${inputs.join(', ')}: missing: nothing to measure`);
  process.exit(0);
}

const kHeading = '## Interactions on a dense skeleton (bench/interaction_bench.mjs)';
const kBegin = '<!-- bench/interaction_bench.mjs: begin (written by the script; edits here are overwritten) -->';
const kEnd = '<!-- bench/interaction_bench.mjs: end -->';

const site = path.join(out, 'site');
rmSync(site, { recursive: true, force: true });
execFileSync(cli, ['pack', ...inputs, '-o', site, '--no-lod', '--viewer', viewerDir], { stdio: 'ignore' });  // every triangle drawn
const server = await serve(site);
const browser = await launchBrowser();
let rows;
let triangles;
try {
  const context = await browser.newContext({ viewport: { width: 1280, height: 800 } });
  const { page, problems } = await openViewer(context, server.url);
  const report = await waitLoaded(page, 300000);
  await waitRefined(page, 300000);
  triangles = report.trianglesDrawn;
  rows = await page.evaluate(async (n) => {
    const o = window.osteon;
    const frame = () => new Promise((resolve) => {
      const check = () => (o.framePending ? requestAnimationFrame(check) : resolve());
      requestAnimationFrame(check);
    });
    // Points on bones: picks on a coarse grid of the view, the ones that hit.
    const hits = [];
    for (let y = -0.6; y <= 0.6 && hits.length < 8; y += 0.2) {
      for (let x = -0.6; x <= 0.6 && hits.length < 8; x += 0.2) {
        const answer = await o.pickAt([x, y]);
        if (answer.part >= 0) hits.push([x, y]);
      }
    }
    if (hits.length < 2) throw new Error('osteon: no point of the view is on a bone');
    // The picking trees (built in the render worker's idle time once the skeleton is drawn).
    for (let k = 0; k < 600; ++k) {
      const { trees } = await o.pickAt(hits[0]);
      if (trees.built > 0 && trees.waiting === 0) break;
      await new Promise((resolve) => setTimeout(resolve, 100));
    }
    const time = async (step) => {
      const times = [];
      for (let k = 0; k < n; ++k) {
        const t0 = performance.now();
        await step(k);
        times.push(performance.now() - t0);
      }
      return times;
    };
    const parts = (await (await fetch('manifest.json')).json()).parts.length;
    const camera = o.cameraState();
    const rows = { opacityApply: [], colourApply: [], redrawRender: [], opacityRender: [], colourRender: [] };
    return Object.assign(rows, {
      pick: await time((k) => o.pickAt(hits[k % hits.length])),
      measure: await time((k) => o.measureAt(hits[k % hits.length], hits[(k + 1) % hits.length])),
      redraw: await time(async (k) => {
        const c = structuredClone(camera);
        c.position[0] += (k % 2 ? 1 : -1) * 1e-3 * Math.hypot(...c.position);
        o.setViewState(`v=1&cam=${[...c.position, ...c.target, ...c.up, c.fov].join(',')}`);
        await frame();
        rows.redrawRender.push(o.renderMs);
      }),
      opacity: await time(async (k) => {
        o.setPartStyle({ opacity: k % 2 ? null : new Array(parts).fill(0.5) });
        await frame();
        if (o.partsMs !== null) rows.opacityApply.push(o.partsMs);
        rows.opacityRender.push(o.renderMs);
      }),
      colour: await time(async (k) => {
        const colors = [];
        for (let p = 0; p < parts; ++p) colors.push((k * 0.13 + p * 0.31) % 1, 0.5, 0.7);
        o.setPartStyle({ colors });
        await frame();
        if (o.partsMs !== null) rows.colourApply.push(o.partsMs);
        rows.colourRender.push(o.renderMs);
      }),
      parts,
    });
  }, repeat);
  if (problems.length) throw new Error(`osteon: the page reported: ${problems.join('; ')}`);
} finally {
  await browser.close();
  await server.close();
}

const f = (v) => v.toFixed(1);
const cell = (values) => (values?.length ? f(median(values)) : '—');
const line = (name, times, apply, render) => `| ${name} | ${f(median(times))} | ${f(Math.max(...times))} | ${cell(apply)} | ${cell(render)} |`;
const body = [
  `Command: \`node bench/interaction_bench.mjs --write docs/BENCHMARKS.md\`. Skeleton: ct-like/skull_mc.ply`,
  `+ hip_mcs.ply, ${(triangles ?? 0).toLocaleString('en-US')} triangles drawn, ${rows.parts} parts, packed by \`osteon pack --no-lod\``,
  `and served by \`osteon serve\`; headless Chromium, 1280×800, WebGL through SwiftShader (a software`,
  `GPU on a shared machine: absolute times are this machine's, and a frame of every triangle is`,
  `SwiftShader's work, which any visible change pays). "Applied" is report.partsMs, the render`,
  `worker's time to apply the change; "render()" report.renderMs, its time to issue the frame (CPU`,
  `side). ${repeat} repetitions each, medians.`,
  '',
  '| interaction | until answered or drawn, median (ms) | max (ms) | applied in the render worker (ms) | render() (ms) |',
  '|---|---:|---:|---:|---:|',
  line('pick (answer from the render worker)', rows.pick),
  line('measurement (two picks and the figure)', rows.measure),
  line('redraw after a camera nudge', rows.redraw, null, rows.redrawRender),
  line('opacity change (every part 0.5, and back)', rows.opacity, rows.opacityApply, rows.opacityRender),
  line('colour-by change', rows.colour, rows.colourApply, rows.colourRender),
].join('\n');
console.log(`${kHeading}\n\n${body}`);
if (values.write) writeSection(path.resolve(repo, values.write), { heading: kHeading, begin: kBegin, end: kEnd, body, tag: 'interaction_bench' });
