// SPDX-License-Identifier: Apache-2.0
// bench/web's outputs: per-way statistics over the runs, the Markdown table and target checks,
// the SVG plot of triangles drawn over time (the paper's Fig. 12: one line per way, one panel per
// profile) with, for osteon, the screen-space error of what it draws, and the docs/BENCHMARKS.md
// section.
//
// A load that ran past the time limit is not dropped: the moments it had not reached count as
// later than the limit ("did not finish in N s"), so a median over runs where most finished is
// still a time, and one where most did not says so.

import fs from 'node:fs';

import { spread } from '../lib/stats.mjs';
import { legend, lineChart, niceRange, svgDocument, text as svgText } from '../lib/svg.mjs';

export const kWayNames = {
  direct: 'direct: original files',
  draco: 'Draco glTF',
  gltfpack: 'gltfpack -cc -mi',
  'gltfpack-cz': 'gltfpack -cz -mi',
  osteon: 'osteon',
};
const kWayColors = { direct: '#7f7f7f', draco: '#1f77b4', gltfpack: '#2ca02c', 'gltfpack-cz': '#9467bd', osteon: '#e8590c' };
export const kSectionTitle = 'Browser load time (bench/web)';
const kPeers = ['direct', 'draco', 'gltfpack', 'gltfpack-cz'];

/// Median, min and max of one metric over a way's runs (runs without it left out).
const stat = (runs, key) => spread(runs.map((r) => r[key]));

/// Median, min and max of a moment over runs where a run that stopped at the time limit before
/// reaching it counts as +Infinity (later than any time) and a finished run without it (a
/// viewer that went idle before refining) is left out. Returns { median, min, max, n (runs
/// counted), unfinished (how many of them are +Infinity) }; median is +Infinity when at least
/// half did not get there.
export function censored(runs, key) {
  const v = runs.map((r) => (Number.isFinite(r[key]) ? r[key] : r.timedOut ? Infinity : NaN)).filter((x) => !Number.isNaN(x));
  v.sort((a, b) => a - b);
  if (!v.length) return { median: NaN, min: NaN, max: NaN, n: 0, unfinished: 0 };
  const m = v.length >> 1;
  const median = v.length % 2 ? v[m] : v[m - 1] === Infinity || v[m] === Infinity ? Infinity : (v[m - 1] + v[m]) / 2;
  return { median, min: v[0], max: v[v.length - 1], n: v.length, unfinished: v.filter((x) => x === Infinity).length };
}

/// Summarises the runs of one way under one profile. The plotted series is the run whose
/// refined (osteon) or all-drawn time is the median one (the lower of the two middle runs for an
/// even count; a run that did not finish sorts last).
export function summarise(runs) {
  const ok = runs.filter((r) => !r.errors.length);
  const endOf = (r) => (Number.isFinite(r.refinedMs) ? r.refinedMs : Number.isFinite(r.allMs) ? r.allMs : Infinity);
  const sorted = [...ok].sort((a, b) => endOf(a) - endOf(b));
  const middle = sorted.length ? sorted[(sorted.length - 1) >> 1] : null;
  const budgets = ok.map((r) => r.budget?.bytes).filter(Number.isFinite);
  return {
    runs: runs.length,
    failed: runs.length - ok.length,
    unfinished: ok.filter((r) => !r.finished).length,
    timeLimitMs: Math.max(0, ...runs.map((r) => r.timeLimitMs ?? 0)),
    errors: [...new Set(runs.flatMap((r) => r.errors))],
    bytes: stat(ok, 'bytes'),
    firstMs: censored(ok, 'firstMs'),
    completeMs: censored(ok, 'completeMs'),
    refinedMs: censored(ok, 'refinedMs'),
    allMs: censored(ok, 'allMs'),
    tbtMs: stat(ok, 'tbtMs'),
    longestTaskMs: stat(ok, 'longestTaskMs'),
    peakHeapBytes: stat(ok, 'peakHeapBytes'),
    gpuBytes: stat(ok, 'gpuBytes'),
    gpuBytesPeak: stat(ok, 'gpuBytesPeak'),
    budgetBytes: budgets.length ? Math.min(...budgets) : NaN,
    trianglesDrawn: stat(ok, 'trianglesDrawn'),
    drawnErrorBound: stat(ok, 'drawnErrorBound'),
    requests: stat(ok, 'requests'),
    frames: stat(ok, 'frames'),
    longTasks: stat(ok, 'longTasks'),
    manifestMs: stat(ok, 'manifestMs'),
    firstFetchMs: stat(ok, 'firstFetchMs'),
    bytesAtSkeletonComplete: stat(ok, 'bytesAtSkeletonComplete'),
    levelsLoaded: stat(ok, 'levelsLoaded'),
    levelsTotal: stat(ok, 'levelsTotal'),
    evictions: stat(ok, 'evictions'),
    hasLevels: ok.some((r) => r.hasLevels),
    cpu: ok[0]?.cpu ?? null,
    series: middle ? middle.series : [],
    seriesFinished: middle ? !!middle.finished : true,
    errorSeries: middle ? middle.errorSeries ?? [] : [],
  };
}

const grouped = (n) => Math.round(n).toLocaleString('en-US');
const seconds = (msValue) => `${Math.round(msValue / 1000)} s`;
const megabytes = (b) => (Number.isFinite(b) ? (b / 1048576).toFixed(1) : '-');

/// A moment's cell: the median and the range, "did not finish in N s" when the median is past
/// the limit, "-" when no run reached it and none was cut short.
function momentCell(s, limitMs) {
  if (s.median === Infinity) return `did not finish in ${seconds(limitMs)}`;
  if (!Number.isFinite(s.median)) return '-';
  const hi = s.max === Infinity ? `>${grouped(limitMs)}` : grouped(s.max);
  return `${grouped(s.median)}${s.n > 1 ? ` (${grouped(s.min)}–${hi})` : ''}`;
}
const ms = (s) => (Number.isFinite(s.median) ? grouped(s.median) : 'n/a');
const range = (s) => (s.n > 1 ? ` (${grouped(s.min)}–${grouped(s.max)})` : '');
function mm(x) {
  if (!Number.isFinite(x)) return 'n/a';
  if (x === 0) return '0';
  return x >= 1e-3 ? x.toPrecision(3) : x.toExponential(1);
}

/// The table of one dataset: a row per way and profile. `hausdorff`: the read-back measurement
/// per way ({ max, mean, rms } mm, { error }, or { skipped }).
export function table(dataset, results, hausdorff, profiles) {
  const lines = [
    '| way | profile | bytes transferred | first frame ms | skeleton complete ms | refined / all drawn ms | TBT ms | longest task ms | ' +
      'peak JS heap MB | GPU MB | triangles drawn | error bound drawn mm | Hausdorff max / mean / RMS mm |',
    '|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|',
  ];
  for (const profile of profiles) {
    for (const [way, byProfile] of Object.entries(results)) {
      const s = byProfile[profile.id];
      if (!s) continue;
      const h = hausdorff[way];
      const hText = h && Number.isFinite(h.max) ? `${mm(h.max)} / ${mm(h.mean)} / ${mm(h.rms)}` : h?.error ? 'failed' : '-';
      if (!s.bytes.n) {
        lines.push(`| ${way} | ${profile.label} | failed: ${(s.errors[0] ?? 'no run finished').replace(/\|/g, '/').slice(0, 200)} | | | | | | | | | | ${hText} |`);
        continue;
      }
      const unfinished = s.unfinished ? ` (${s.unfinished} of ${s.runs} did not finish in ${seconds(s.timeLimitMs)})` : '';
      const gpu = Number.isFinite(s.gpuBytesPeak.median) ? s.gpuBytesPeak : s.gpuBytes;
      lines.push(`| ${way}${unfinished} | ${profile.label} | ${grouped(s.bytes.median)} | ${momentCell(s.firstMs, s.timeLimitMs)} | ` +
        `${momentCell(s.completeMs, s.timeLimitMs)} | ${momentCell(way === 'osteon' ? s.refinedMs : s.allMs, s.timeLimitMs)} | ` +
        `${ms(s.tbtMs)}${range(s.tbtMs)} | ${ms(s.longestTaskMs)} | ${megabytes(s.peakHeapBytes.median)} | ${megabytes(gpu.median)} | ` +
        `${grouped(s.trianglesDrawn.median)} | ${mm(s.drawnErrorBound.median)} | ${hText} |`);
    }
  }
  return lines.join('\n');
}

/// Where the time goes, per way under one profile (medians): requests made, frames the page drew
/// during the load, main-thread long tasks, for the osteon viewer when its manifest was parsed,
/// its first component requested, the bytes it had when the skeleton was complete, and its levels
/// (resident of all, evictions) against its GPU budget.
export function detailTable(results, profile) {
  const lines = [
    `| way (${profile.label}) | requests | frames drawn | long tasks | manifest parsed ms | first component requested ms | ` +
      'bytes at skeleton complete | levels resident / total | evictions | GPU budget MB |',
    '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|',
  ];
  for (const [way, byProfile] of Object.entries(results)) {
    const s = byProfile[profile.id];
    if (!s || !s.bytes.n) continue;
    const v = (x) => (Number.isFinite(x.median) ? grouped(x.median) : '');
    const levels = Number.isFinite(s.levelsTotal.median) ? `${v(s.levelsLoaded)} / ${v(s.levelsTotal)}` : '';
    lines.push(`| ${way} | ${v(s.requests)} | ${v(s.frames)} | ${v(s.longTasks)} | ${v(s.manifestMs)} | ${v(s.firstFetchMs)} | ` +
      `${v(s.bytesAtSkeletonComplete)} | ${levels} | ${v(s.evictions)} | ${Number.isFinite(s.budgetBytes) ? megabytes(s.budgetBytes) : ''} |`);
  }
  return lines.join('\n');
}

/// Is `a` at most `factor` times `b`, for moments that may be +Infinity (past the time limit
/// `limitMs`)? true, false, or null when the limit hides the answer.
function atMost(a, factor, b, limitMs) {
  if (!Number.isFinite(a) && a !== Infinity) return null;
  if (!Number.isFinite(b) && b !== Infinity) return null;
  if (a !== Infinity && b !== Infinity) return a <= factor * b;
  if (a === Infinity && b === Infinity) return null;
  if (b === Infinity) return a <= factor * limitMs ? true : null;  // b is past the limit
  return factor * b < limitMs ? false : null;                      // a is past the limit
}
const moment = (x, limitMs) => (x === Infinity ? `did not finish in ${seconds(limitMs)}` : Number.isFinite(x) ? `${grouped(x)} ms` : 'not measured');

/// The targets set on dataset `id` ('bodyparts3d' or, standing in for it, the phantom; 'dense'),
/// computed from the medians of `results` (summarise's, by way and profile). Returns
/// [{ text, met: true | false | null (cannot tell), detail }], empty where none is set.
export function targets(id, results, profiles) {
  const has = (pr) => profiles.some((p) => p.id === pr);
  const get = (way, pr, key) => results[way]?.[pr]?.[key]?.median;
  const limit = (way, pr) => results[way]?.[pr]?.timeLimitMs ?? NaN;
  const checks = [];
  const check = (text, a, factor, b, limitMs, what) => checks.push({
    text, met: atMost(a, factor, b, limitMs),
    detail: `${moment(a, limitMs)} vs ${what} ${moment(b, limitMs)}${Number.isFinite(a) && Number.isFinite(b) && b > 0 ? ` (ratio ${(a / b).toFixed(3)})` : ''}`,
  });
  // osteon's "all drawn": refined (every visible bone within 1 px or at its finest level), or
  // all drawn in a viewer without levels of detail (refinedMs then falls back to allLoadedMs).
  if (id === 'bodyparts3d' && has('fast') && results.osteon) {
    const L = limit('osteon', 'fast');
    check("100 Mbit/s: osteon's refined / all drawn no later than gltfpack -cz's all drawn",
      get('osteon', 'fast', 'refinedMs'), 1, get('gltfpack-cz', 'fast', 'allMs'), L, 'gltfpack -cz');
    check("100 Mbit/s: osteon's first frame at most 0.6x gltfpack -cz's all drawn (one file: its first frame is its all drawn)",
      get('osteon', 'fast', 'firstMs'), 0.6, get('gltfpack-cz', 'fast', 'allMs'), L, 'gltfpack -cz');
  }
  if (id === 'bodyparts3d' && has('slow') && results.osteon) {
    const L = limit('osteon', 'slow');
    const peers = kPeers.filter((w) => results[w]?.slow).map((w) => [w, get(w, 'slow', 'allMs')]).filter(([, v]) => !Number.isNaN(v));
    const fastest = peers.sort((x, y) => x[1] - y[1])[0];
    check("10 Mbit/s: osteon's first frame at most 0.4x the fastest peer's all drawn",
      get('osteon', 'slow', 'firstMs'), 0.4, fastest?.[1] ?? NaN, L, fastest ? `${fastest[0]} (the fastest peer)` : 'the fastest peer');
  }
  if (id === 'dense' && has('slow') && results.osteon) {
    const L = limit('osteon', 'slow');
    for (const peer of ['draco', 'gltfpack-cz']) {
      check(`10 Mbit/s: osteon's skeleton complete within 1/10 of ${peer}'s first frame`,
        get('osteon', 'slow', 'completeMs'), 0.1, get(peer, 'slow', 'firstMs'), L, peer);
    }
    for (const peer of ['draco', 'gltfpack-cz']) {
      check(`10 Mbit/s: osteon's refined no later than ${peer}'s all drawn`,
        get('osteon', 'slow', 'refinedMs'), 1, get(peer, 'slow', 'allMs'), L, peer);
    }
    budgetCheck(checks, '10 Mbit/s', results.osteon.slow);
  }
  if (id === 'dense' && has('phone') && results.osteon) {
    const s = results.osteon.phone;
    const longest = s.longestTaskMs;
    checks.push({
      text: 'phone: no long task over 200 ms',
      met: Number.isFinite(longest.median) ? longest.median <= 200 : null,
      detail: Number.isFinite(longest.median) ? `longest task ${grouped(longest.median)} ms (median of the runs; largest ${grouped(longest.max)} ms)` : 'not measured',
    });
    const c = s.completeMs.median;
    checks.push({
      text: 'phone: the skeleton loads (complete) within the time limit',
      met: Number.isFinite(c) ? true : c === Infinity ? false : null,
      detail: moment(c, s.timeLimitMs),
    });
    budgetCheck(checks, 'phone', s);
  }
  return checks;
}

function budgetCheck(checks, where, s) {
  const peak = s?.gpuBytesPeak?.median;
  const budget = s?.budgetBytes;
  checks.push({
    text: `${where}: osteon's peak GPU bytes within its budget`,
    met: Number.isFinite(peak) && Number.isFinite(budget) ? peak <= budget : null,
    detail: Number.isFinite(peak) && Number.isFinite(budget) ? `${grouped(peak)} of ${grouped(budget)} bytes`
      : 'not measured (the viewer reports no gpuBytes or budget)',
  });
}

export function targetLines(checks) {
  return checks.map((c) => `- ${c.met === true ? '**met**' : c.met === false ? '**not met**' : '**cannot tell**'}: ${c.text} (${c.detail})`);
}

/// The plot: per dataset a row of panels, one per profile, triangles drawn against seconds from
/// navigation start, a step line per way (its median run: the count at the start of each
/// animation frame that changed it), a dot where its first frame appeared; below it, where the
/// viewer reported one, a row with osteon's largest screen-space error of a drawn bone (pixels,
/// log scale) over the same time. The panels of a row share the vertical axis.
/// `rows`: [{ title, results (by way and profile), totalTriangles }].
export function svgPlot({ title, subtitle, profiles, rows }) {
  // One panel is drawn wider, so the title and the legend fit.
  const panelW = profiles.length === 1 ? 900 : 520, panelH = 340, top = 52;
  const width = profiles.length * panelW;
  const parts = [];
  let y = top;
  const notes = ['a dot marks the first frame; a line ends at the first frame with all of its triangles (osteon: its last change), ' +
    'or at the time limit for a load that did not finish'];
  for (const row of rows) {
    const ways = Object.keys(row.results);
    let maxTri = row.totalTriangles;
    for (const way of ways) for (const p of profiles) {
      for (const [, n] of row.results[way][p.id]?.series ?? []) maxTri = Math.max(maxTri, n);
    }
    const scale = maxTri > 5e6 ? 1e6 : 1e3;
    const yRange = niceRange(0, maxTri / scale);
    const xRangeOf = (p) => {
      let t = 0;
      for (const way of ways) {
        const r = row.results[way][p.id];
        const s = r?.series ?? [];
        if (s.length) t = Math.max(t, s[s.length - 1][0] / 1000);
        if (r && !r.seriesFinished) t = Math.max(t, r.timeLimitMs / 1000);
        for (const [u] of row.results[way][p.id]?.errorSeries ?? []) t = Math.max(t, u / 1000);
      }
      return niceRange(0, Math.max(t * 1.05, 0.1));
    };
    profiles.forEach((p, pi) => {
      const series = [];
      for (const way of ways) {
        const r = row.results[way][p.id];
        const s = r?.series ?? [];
        if (!s.length) continue;
        const points = [[0, 0], ...s.map(([t, n]) => [t / 1000, n / scale])];
        // A load stopped at the time limit: its line runs on to the limit.
        if (!r.seriesFinished) points.push([r.timeLimitMs / 1000, points.at(-1)[1]]);
        series.push({ name: kWayNames[way], color: kWayColors[way], marker: 'none', step: true, points });
        const first = s.find(([, n]) => n > 0);
        if (first) series.push({ color: kWayColors[way], points: [[first[0] / 1000, first[1] / scale]] });
      }
      parts.push(lineChart({ x0: pi * panelW, y0: y, width: panelW, height: panelH, title: `${row.title}, ${p.short ?? p.label}`,
        xLabel: 'seconds from navigation start', yLabel: pi === 0 ? `${scale === 1e6 ? 'million' : 'thousand'} triangles drawn` : '',
        xRange: xRangeOf(p), yRange, series }));
    });
    y += panelH;
    const errors = profiles.map((p) => (row.results.osteon?.[p.id]?.errorSeries ?? []).filter(([, e]) => e > 0));
    if (errors.some((e) => e.length)) {
      const all = errors.flat().map(([, e]) => e);
      const lo = 10 ** Math.floor(Math.log10(Math.min(...all, 1)));
      const hi = 10 ** Math.ceil(Math.log10(Math.max(...all, 1) * 1.01));
      profiles.forEach((p, pi) => {
        const e = errors[pi];
        // A step line from the first sample (the viewer plans levels once the skeleton is complete).
        const series = e.length ? [{ name: 'osteon: largest screen-space error drawn', color: kWayColors.osteon, marker: 'none', step: true,
          points: e.map(([t, v]) => [t / 1000, v]) }, { color: kWayColors.osteon, points: [[e.at(-1)[0] / 1000, e.at(-1)[1]]] }] : [];
        parts.push(lineChart({ x0: pi * panelW, y0: y, width: panelW, height: panelH * 0.7, title: `osteon's error, ${p.short ?? p.label}`,
          xLabel: 'seconds from navigation start', yLabel: pi === 0 ? 'largest error of a drawn bone, px' : '',
          xRange: xRangeOf(p), yLog: true, yRange: [lo, hi], series }));
      });
      y += panelH * 0.7;
    } else if (row.results.osteon) {
      notes.push(`${row.title}: no screen-space error curve (the viewer exposes no levelPixels / levelDrawn to sample)`);
    }
  }
  const ways = [...new Set(rows.flatMap((r) => Object.keys(r.results)))];
  const key = legend(ways.map((way) => ({ name: kWayNames[way], color: kWayColors[way], marker: 'none' })),
    { x: width / 2, y: y + 14, row: true });
  const height = y + 30 + 14 * notes.length + 8;
  const heading = [svgText(width / 2, 24, title, 16, { 'text-anchor': 'middle', 'font-weight': 'bold' }),
    svgText(width / 2, 42, subtitle, 12, { 'text-anchor': 'middle', fill: '#555' })];
  return svgDocument(width, height, [...heading, ...parts, key], notes);
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
