// SPDX-License-Identifier: Apache-2.0
// bench/web's outputs: per-way statistics over the runs, the Markdown table and target checks,
// the SVG plot of triangles drawn over time (the paper's Fig. 12: one line per way, one panel per
// network profile), and the docs/BENCHMARKS.md section.

import fs from 'node:fs';

import { spread } from '../lib/stats.mjs';
import { legend, lineChart, niceRange, svgDocument, text as svgText } from '../lib/svg.mjs';

const kWayNames = {
  direct: 'direct: original files',
  draco: 'Draco glTF',
  gltfpack: 'gltfpack -cc -mi',
  osteon: 'osteon',
};
const kWayColors = { direct: '#7f7f7f', draco: '#1f77b4', gltfpack: '#2ca02c', osteon: '#e8590c' };
export const kSectionTitle = 'Browser load time (bench/web)';

/// Median, min and max of one metric over a way's runs.
const stat = (runs, key) => spread(runs.map((r) => r[key]));

/// Summarises the runs of one way under one profile. The plotted series is the run whose
/// all-drawn time is the median one (the lower of the two middle runs for an even count).
export function summarise(runs) {
  const ok = runs.filter((r) => !r.errors.length && Number.isFinite(r.allMs));
  const sorted = [...ok].sort((a, b) => a.allMs - b.allMs);
  return {
    runs: runs.length,
    failed: runs.length - ok.length,
    errors: [...new Set(runs.flatMap((r) => r.errors))],
    bytes: stat(ok, 'bytes'),
    firstMs: stat(ok, 'firstMs'),
    allMs: stat(ok, 'allMs'),
    tbtMs: stat(ok, 'tbtMs'),
    peakHeapBytes: stat(ok, 'peakHeapBytes'),
    trianglesDrawn: stat(ok, 'trianglesDrawn'),
    requests: stat(ok, 'requests'),
    frames: stat(ok, 'frames'),
    longTasks: stat(ok, 'longTasks'),
    manifestMs: stat(ok, 'manifestMs'),
    firstFetchMs: stat(ok, 'firstFetchMs'),
    series: sorted.length ? sorted[(sorted.length - 1) >> 1].series : [],
  };
}

const grouped = (n) => Math.round(n).toLocaleString('en-US');
const ms = (s) => (Number.isFinite(s.median) ? grouped(s.median) : 'n/a');
const range = (s) => (s.n > 1 ? ` (${grouped(s.min)}–${grouped(s.max)})` : '');
function mm(x) {
  if (!Number.isFinite(x)) return 'n/a';
  if (x === 0) return '0';
  return x >= 1e-3 ? x.toPrecision(3) : x.toExponential(1);
}

/// The table of one dataset: a row per way and profile.
export function table(dataset, results, hausdorff, profiles) {
  const lines = [
    '| way | network | bytes transferred | first triangles ms | all drawn ms | TBT ms | peak JS heap MB | triangles drawn | Hausdorff max / mean / RMS mm |',
    '|---|---|---:|---:|---:|---:|---:|---:|---:|',
  ];
  for (const profile of profiles) {
    for (const [way, byProfile] of Object.entries(results)) {
      const s = byProfile[profile.id];
      if (!s) continue;
      const h = hausdorff[way];
      const hText = h && !h.error ? `${mm(h.max)} / ${mm(h.mean)} / ${mm(h.rms)}` : h?.error ? 'failed' : 'n/a';
      if (!s.bytes.n) {
        lines.push(`| ${way} | ${profile.label} | failed: ${s.errors[0] ?? 'no run finished'} | | | | | | ${hText} |`);
        continue;
      }
      lines.push(`| ${way} | ${profile.label} | ${grouped(s.bytes.median)} | ${ms(s.firstMs)}${range(s.firstMs)} | ` +
        `${ms(s.allMs)}${range(s.allMs)} | ${ms(s.tbtMs)}${range(s.tbtMs)} | ` +
        `${(s.peakHeapBytes.median / 1048576).toFixed(1)} | ${grouped(s.trianglesDrawn.median)} | ${hText} |`);
    }
  }
  return lines.join('\n');
}

/// Where the time goes, per way under one profile (medians): requests made, frames the page drew
/// during the load, main-thread long tasks, and for the osteon viewer when its manifest was parsed
/// and its first component requested.
export function detailTable(results, profile) {
  const lines = [
    `| way (${profile.label}) | requests | frames drawn | long tasks | manifest parsed ms | first component requested ms |`,
    '|---|---:|---:|---:|---:|---:|',
  ];
  for (const [way, byProfile] of Object.entries(results)) {
    const s = byProfile[profile.id];
    if (!s || !s.bytes.n) continue;
    const v = (x) => (Number.isFinite(x.median) ? grouped(x.median) : '');
    lines.push(`| ${way} | ${v(s.requests)} | ${v(s.frames)} | ${v(s.longTasks)} | ${v(s.manifestMs)} | ${v(s.firstFetchMs)} |`);
  }
  return lines.join('\n');
}

/// The load-time targets on one dataset at the slow profile, computed from the medians. Returns
/// [{ text, met: true | false | null (cannot tell) , detail }].
export function targets(results, profileId) {
  const get = (way, key) => results[way]?.[profileId]?.[key]?.median;
  const o = (key) => get('osteon', key);
  const checks = [];
  const cmp = (text, ok, detail) => checks.push({ text, met: ok, detail });
  const have = (...vals) => vals.every((v) => Number.isFinite(v));
  for (const peer of ['draco', 'gltfpack']) {
    const a = o('firstMs'), b = get(peer, 'firstMs');
    cmp(`osteon's first triangles at most 1/4 as late as ${peer}'s`, have(a, b) ? a <= b / 4 : null,
      have(a, b) ? `${grouped(a)} ms vs ${grouped(b)} ms (ratio ${(a / b).toFixed(3)})` : 'not measured');
  }
  for (const peer of ['draco', 'gltfpack']) {
    const a = o('allMs'), b = get(peer, 'allMs');
    cmp(`osteon finishes no later than ${peer}`, have(a, b) ? a <= b : null,
      have(a, b) ? `${grouped(a)} ms vs ${grouped(b)} ms` : 'not measured');
  }
  for (const peer of ['draco', 'gltfpack']) {
    const a = o('bytes'), b = get(peer, 'bytes');
    cmp(`osteon transfers fewer bytes than ${peer}`, have(a, b) ? a < b : null,
      have(a, b) ? `${grouped(a)} vs ${grouped(b)} bytes` : 'not measured');
  }
  for (const peer of ['direct', 'draco', 'gltfpack']) {
    const a = o('tbtMs'), b = get(peer, 'tbtMs');
    cmp(`osteon's total blocking time lower than ${peer}'s`, have(a, b) ? a < b : null,
      have(a, b) ? `${grouped(a)} ms vs ${grouped(b)} ms` : 'not measured');
  }
  return checks;
}

export function targetLines(checks) {
  return checks.map((c) => `- ${c.met === true ? '**met**' : c.met === false ? '**not met**' : '**not measured**'}: ${c.text} (${c.detail})`);
}

/// The plot: one panel per profile, triangles drawn (thousands) against seconds from navigation
/// start, a step line per way (its median run: the count at the start of each animation frame that
/// changed it), a dot where its first triangles appeared. The panels share the triangle axis.
export function svgPlot({ title, subtitle, profiles, results, totalTriangles }) {
  const panelW = 520, panelH = 370, top = 52;
  const width = profiles.length * panelW;
  const height = top + panelH + 48;
  const ways = Object.keys(results);
  let maxTri = totalTriangles;
  for (const way of ways) for (const p of profiles) {
    for (const [, n] of results[way][p.id]?.series ?? []) maxTri = Math.max(maxTri, n);
  }
  const yRange = niceRange(0, maxTri / 1000);
  const panels = profiles.map((p, pi) => {
    const series = [];
    let tMax = 0;
    for (const way of ways) {
      const s = results[way][p.id]?.series ?? [];
      if (!s.length) continue;
      tMax = Math.max(tMax, s[s.length - 1][0] / 1000);
      // A step line: the count holds until a frame changes it; it ends at the frame that drew all.
      const points = [[0, 0], ...s.map(([t, n]) => [t / 1000, n / 1000])];
      series.push({ name: kWayNames[way], color: kWayColors[way], marker: 'none', step: true, points });
      const first = s.find(([, n]) => n > 0);
      if (first) series.push({ color: kWayColors[way], points: [[first[0] / 1000, first[1] / 1000]] });
    }
    return lineChart({ x0: pi * panelW, y0: top, width: panelW, height: panelH, title: p.label,
      xLabel: 'seconds from navigation start', yLabel: pi === 0 ? 'thousand triangles drawn' : '',
      xRange: niceRange(0, Math.max(tMax * 1.05, 0.1)), yRange, series });
  });
  const key = legend(ways.map((way) => ({ name: kWayNames[way], color: kWayColors[way], marker: 'none' })),
    { x: width / 2, y: top + panelH + 14, row: true });
  const heading = [svgText(width / 2, 24, title, 16, { 'text-anchor': 'middle', 'font-weight': 'bold' }),
    svgText(width / 2, 42, subtitle, 12, { 'text-anchor': 'middle', fill: '#555' })];
  return svgDocument(width, height, [...heading, ...panels, key],
    ['a dot marks the first frame with triangles; a line ends at the first frame with all of them']);
}

/// Replaces this benchmark's section of `file` (from its "## " heading to the next "## " heading
/// or the end), or appends it at the end; every other section is left as it is.
export function writeSection(file, body) {
  const text = fs.existsSync(file) ? fs.readFileSync(file, 'utf8') : '# Benchmarks\n';
  const heading = `## ${kSectionTitle}`;
  const start = text.indexOf(`\n${heading}\n`);
  let updated;
  if (start < 0) {
    updated = `${text.replace(/\n*$/, '\n')}\n${body.replace(/\n*$/, '\n')}`;
  } else {
    const next = text.indexOf('\n## ', start + heading.length + 1);
    const tail = next < 0 ? '' : text.slice(next);
    updated = `${text.slice(0, start + 1)}${body.replace(/\n*$/, '\n')}${tail}`;
  }
  fs.writeFileSync(file, updated);
}
