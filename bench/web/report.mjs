// SPDX-License-Identifier: Apache-2.0
// bench/web's outputs: per-way statistics over the runs, the Markdown table and target checks,
// the SVG plot of triangles drawn over time (the paper's Fig. 12: one line per way, one panel per
// network profile), and the docs/BENCHMARKS.md section.

import fs from 'node:fs';

export const kWayNames = {
  direct: 'direct: original files',
  draco: 'Draco glTF',
  gltfpack: 'gltfpack -cc -mi',
  osteon: 'osteon',
};
const kWayColors = { direct: '#7f7f7f', draco: '#1f77b4', gltfpack: '#2ca02c', osteon: '#e8590c' };
export const kSectionTitle = 'Browser load time (bench/web)';

export function median(values) {
  const v = values.filter((x) => Number.isFinite(x)).sort((a, b) => a - b);
  if (!v.length) return NaN;
  const mid = v.length >> 1;
  return v.length % 2 ? v[mid] : (v[mid - 1] + v[mid]) / 2;
}

/// Median, min and max of one metric over a way's runs.
function stat(runs, key) {
  const values = runs.map((r) => r[key]).filter((x) => Number.isFinite(x));
  return { median: median(values), min: Math.min(...values), max: Math.max(...values), n: values.length };
}

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

/// The targets on one dataset at the slow profile, computed from the medians. Returns
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

function escapeXml(s) {
  return String(s).replace(/[<>&"]/g, (c) => ({ '<': '&lt;', '>': '&gt;', '&': '&amp;', '"': '&quot;' })[c]);
}

/// A "nice" axis step (1, 2 or 5 times a power of ten) giving about `count` ticks up to `max`.
function niceStep(max, count) {
  const raw = max / count;
  const power = 10 ** Math.floor(Math.log10(raw));
  for (const m of [1, 2, 5, 10]) if (m * power >= raw) return m * power;
  return 10 * power;
}

/// The plot: one panel per profile, triangles drawn (thousands) against seconds from navigation
/// start, a step line per way (its median run: the count at the start of each animation frame that
/// changed it), a dot where its first triangles appeared.
export function svgPlot({ title, subtitle, profiles, results, totalTriangles }) {
  const panelW = 460, panelH = 300, left = 70, right = 20, top = 84, gap = 40, bottom = 100;
  const width = left + profiles.length * panelW + (profiles.length - 1) * gap + right;
  const height = top + panelH + bottom;
  const ways = Object.keys(results);
  const out = [];
  out.push(`<svg xmlns="http://www.w3.org/2000/svg" width="${width}" height="${height}" viewBox="0 0 ${width} ${height}" font-family="Helvetica, Arial, sans-serif" font-size="13">`);
  out.push(`<rect width="${width}" height="${height}" fill="#ffffff"/>`);
  out.push(`<text x="${width / 2}" y="24" text-anchor="middle" font-size="16" font-weight="bold">${escapeXml(title)}</text>`);
  out.push(`<text x="${width / 2}" y="44" text-anchor="middle" fill="#555">${escapeXml(subtitle)}</text>`);
  out.push(`<text x="${width / 2}" y="${height - 40}" text-anchor="middle" fill="#555">a dot marks the first frame with triangles; a line ends at the first frame with all of them</text>`);
  let maxTri = totalTriangles;
  for (const way of ways) for (const p of profiles) {
    for (const [, n] of results[way][p.id]?.series ?? []) maxTri = Math.max(maxTri, n);
  }
  const yStep = niceStep(maxTri / 1000, 5);
  const yMax = Math.ceil(maxTri / 1000 / yStep) * yStep;
  profiles.forEach((p, pi) => {
    const x0 = left + pi * (panelW + gap);
    let tMax = 0;
    for (const way of ways) {
      const s = results[way][p.id];
      if (!s) continue;
      const series = s.series;
      if (series.length) tMax = Math.max(tMax, series[series.length - 1][0] / 1000);
    }
    tMax = Math.max(tMax * 1.05, 0.1);
    const xStep = niceStep(tMax, 6);
    const xMax = Math.ceil(tMax / xStep) * xStep;
    const X = (t) => x0 + (t / xMax) * panelW;
    const Y = (n) => top + panelH - (n / 1000 / yMax) * panelH;
    out.push(`<g>`);
    out.push(`<text x="${x0 + panelW / 2}" y="${top - 10}" text-anchor="middle" font-weight="bold">${escapeXml(p.label)}</text>`);
    for (let v = 0; v <= yMax + 1e-9; v += yStep) {
      const y = Y(v * 1000);
      out.push(`<line x1="${x0}" x2="${x0 + panelW}" y1="${y.toFixed(1)}" y2="${y.toFixed(1)}" stroke="#e4e4e4"/>`);
      out.push(`<text x="${x0 - 6}" y="${(y + 4).toFixed(1)}" text-anchor="end" fill="#333">${grouped(v)}</text>`);
    }
    for (let t = 0; t <= xMax + 1e-9; t += xStep) {
      const x = X(t);
      out.push(`<line x1="${x.toFixed(1)}" x2="${x.toFixed(1)}" y1="${top}" y2="${top + panelH}" stroke="#f0f0f0"/>`);
      out.push(`<text x="${x.toFixed(1)}" y="${top + panelH + 18}" text-anchor="middle" fill="#333">${+t.toFixed(3)}</text>`);
    }
    out.push(`<rect x="${x0}" y="${top}" width="${panelW}" height="${panelH}" fill="none" stroke="#888"/>`);
    out.push(`<text x="${x0 + panelW / 2}" y="${top + panelH + 38}" text-anchor="middle">seconds from navigation start</text>`);
    if (pi === 0) {
      out.push(`<text transform="translate(${x0 - 52} ${top + panelH / 2}) rotate(-90)" text-anchor="middle">thousand triangles drawn</text>`);
    }
    for (const way of ways) {
      const s = results[way][p.id];
      if (!s || !s.series.length) continue;
      // A step line: the count holds until a frame changes it; it ends at the frame that drew all.
      let d = `M${X(0).toFixed(1)},${Y(0).toFixed(1)}`;
      let prev = 0;
      for (const [t, n] of s.series) {
        const x = X(t / 1000).toFixed(1);
        d += ` L${x},${Y(prev).toFixed(1)} L${x},${Y(n).toFixed(1)}`;
        prev = n;
      }
      out.push(`<path d="${d}" fill="none" stroke="${kWayColors[way]}" stroke-width="2.2" stroke-linejoin="round"/>`);
      const first = s.series.find(([, n]) => n > 0);
      if (first) out.push(`<circle cx="${X(first[0] / 1000).toFixed(1)}" cy="${Y(first[1]).toFixed(1)}" r="3.5" fill="${kWayColors[way]}"/>`);
    }
    out.push(`</g>`);
  });
  // Legend, centred below the panels (text width estimated at 7.2 px a character).
  const ly = height - 12;
  const widths = ways.map((way) => 34 + kWayNames[way].length * 7.2 + 28);
  let lx = (width - widths.reduce((a, b) => a + b, 0)) / 2;
  ways.forEach((way, i) => {
    out.push(`<line x1="${lx.toFixed(1)}" x2="${(lx + 26).toFixed(1)}" y1="${ly - 4}" y2="${ly - 4}" stroke="${kWayColors[way]}" stroke-width="3"/>`);
    out.push(`<text x="${(lx + 34).toFixed(1)}" y="${ly}">${escapeXml(kWayNames[way])}</text>`);
    lx += widths[i];
  });
  out.push(`</svg>`);
  return `${out.join('\n')}\n`;
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
