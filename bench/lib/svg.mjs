// SPDX-License-Identifier: Apache-2.0
// Just enough SVG for the benchmarks' plots (bench/paper's figures, bench/web's load-time plot):
// line and step charts with linear or log axes, grouped bar charts (optionally stacked, optionally
// hatched), legends and panels side by side in one document. No plotting library: the files are
// plain SVG 1.1 that any browser and GitHub render.

export const kColors = {
  osteon: '#1f5fa8',
  draco: '#d95f02',
  human: '#4d4d4d',
  grey: '#8c8c8c',
  green: '#1b9e77',
};

const kFont = 'Helvetica, Arial, sans-serif';

const esc = (s) => String(s).replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');

/// One SVG element: el('rect', { x: 1, fill: 'red' }) or el('text', { x: 1 }, 'label').
/// Numbers are rounded to 0.1 px; attributes that are null or undefined are left out.
function el(tag, attrs, content) {
  const a = Object.entries(attrs)
    .filter(([, v]) => v != null)
    .map(([k, v]) => `${k}="${typeof v === 'number' ? Number(v.toFixed(1)) : esc(v)}"`)
    .join(' ');
  return content == null ? `<${tag} ${a}/>` : `<${tag} ${a}>${esc(content)}</${tag}>`;
}

/// Text in the plots' font; `size` in px, other attributes as el's.
export const text = (x, y, content, size, attrs = {}) =>
  el('text', { x, y, 'font-size': size, 'font-family': kFont, ...attrs }, content);

/// A vertical axis title, rotated, centred on y.
const yTitle = (x, y, title) =>
  text(x, y, title, 12, { 'text-anchor': 'middle', transform: `rotate(-90 ${x} ${y})` });

/// Number on an axis: short, exponent form for decades on log axes.
function tickLabel(v, log) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (log && (a < 1e-2 || a >= 1e5)) {
    const e = Math.round(Math.log10(a));
    if (Math.abs(a / 10 ** e - 1) < 1e-9) return `1e${e}`;
    return v.toExponential(0);
  }
  if (a >= 1000) return Math.round(v).toLocaleString('en-US');
  return String(Number(v.toPrecision(3)));
}

/// The tick step of a linear axis over [lo, hi]: the smallest 1, 2 or 5 times a power of ten that
/// gives at most 7 steps.
function linearStep(lo, hi) {
  const span = hi - lo;
  const p = 10 ** Math.floor(Math.log10(span / 6));
  return [1, 2, 5, 10].map((m) => m * p).find((s) => span / s <= 7);
}

/// [lo, hi] widened outwards to whole tick steps, so that a linear axis starts and ends on a tick
/// (for a range that several panels share, or that should not be padded); [lo, lo + 1] when empty.
export function niceRange(lo, hi) {
  if (!(hi > lo)) return [lo, lo + 1];
  let step = linearStep(lo, hi);
  for (;;) {
    const nice = [Math.floor(lo / step + 1e-9) * step, Math.ceil(hi / step - 1e-9) * step]
      .map((v) => Number(v.toPrecision(12)));
    const next = linearStep(...nice);
    if (next <= step) return nice;
    step = next;
  }
}

/// Ticks for [lo, hi]: decades (and 2, 5 between them when few) on a log axis, 1-2-5 steps on a
/// linear one.
function ticks(lo, hi, log) {
  if (log) {
    const out = [];
    const e0 = Math.floor(Math.log10(lo));
    const e1 = Math.ceil(Math.log10(hi));
    const few = e1 - e0 <= 2;
    for (let e = e0; e <= e1; ++e) {
      for (const m of few ? [1, 2, 5] : [1]) {
        const v = m * 10 ** e;
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) out.push(v);
      }
    }
    return out;
  }
  const step = linearStep(lo, hi);
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) {
    out.push(Number(v.toPrecision(12)));
  }
  return out;
}

/// Axis range: the data's, padded on a linear axis, widened to the nearest 1, 2 or 5 times a
/// power of ten on a log axis.
function range(values, log, includeZero) {
  let lo = Math.min(...values);
  let hi = Math.max(...values);
  if (log) {
    const steps = (e) => [1, 2, 5, 10].map((m) => m * 10 ** e);
    lo = steps(Math.floor(Math.log10(lo))).filter((v) => v <= lo * (1 + 1e-9)).at(-1);
    hi = steps(Math.floor(Math.log10(hi))).find((v) => v >= hi * (1 - 1e-9));
    return [lo, hi];
  }
  if (includeZero) lo = Math.min(0, lo);
  const pad = (hi - lo) * 0.05 || Math.abs(hi) * 0.1 || 1;
  return [includeZero && lo === 0 ? 0 : lo - pad, hi + pad];
}

/// A series' marker at (x, y): a circle, square or triangle; nothing for 'none'.
function marker(shape, x, y, color) {
  const r = 3.5;
  if (shape === 'none') return '';
  if (shape === 'square') {
    return el('rect', { x: x - r, y: y - r, width: 2 * r, height: 2 * r, fill: color });
  }
  if (shape === 'triangle') {
    const d = `M${x.toFixed(1)},${(y - r * 1.2).toFixed(1)} L${(x + r * 1.1).toFixed(1)},` +
      `${(y + r * 0.8).toFixed(1)} L${(x - r * 1.1).toFixed(1)},${(y + r * 0.8).toFixed(1)} Z`;
    return el('path', { d, fill: color });
  }
  return el('circle', { cx: x, cy: y, r, fill: color });
}

/// A legend: per series a line swatch (dashed as the series, with its marker) and its name, in a
/// column from (x, y) down or, with `row`, in one row centred on x (names estimated at 6 px a
/// character).
export function legend(series, { x, y, row = false }) {
  const width = (s) => 32 + 6 * s.name.length + 20;
  let lx = row ? x - series.reduce((a, s) => a + width(s), 0) / 2 : x;
  return series.map((s, i) => {
    const sx = row ? lx : x;
    const sy = row ? y : y + 17 * i;
    if (row) lx += width(s);
    return [
      el('line', { x1: sx, y1: sy, x2: sx + 26, y2: sy, stroke: s.color, 'stroke-width': 1.8,
        'stroke-dasharray': s.dash }),
      marker(s.marker ?? 'circle', sx + 13, sy, s.color),
      text(sx + 32, sy + 4, s.name, 11),
    ].filter(Boolean).join('\n');
  }).join('\n');
}

/// A line chart in a box of `width` x `height` at (x0, y0). Series: { name, color, dash,
/// marker ('circle', 'square', 'triangle' or 'none'), step, points: [[x, y]] } (points with a
/// null y are skipped; a step series holds each y until the next point's x; a series of one point
/// is its marker alone). Options: title, xLabel, yLabel, xLog, yLog, xRange and yRange ([lo, hi];
/// else the data's, padded), xTicks and yTicks (explicit), legend: 'right' | null.
export function lineChart(o) {
  const { x0 = 0, y0 = 0, width, height } = o;
  const m = { left: 68, right: o.legend === 'right' ? 190 : 16, top: 34, bottom: 46 };
  const pw = width - m.left - m.right;
  const ph = height - m.top - m.bottom;
  const left = x0 + m.left;
  const top = y0 + m.top;
  const finite = (p) => p[1] != null && Number.isFinite(p[1]);
  const pts = o.series.flatMap((s) => s.points.filter(finite));
  const [xl, xh] = o.xRange ?? range(pts.map((p) => p[0]), o.xLog, false);
  const [yl, yh] = o.yRange ?? range(pts.map((p) => p[1]), o.yLog, !o.yLog);
  const unit = (v, lo, hi, log) => (log ? Math.log(v / lo) / Math.log(hi / lo) : (v - lo) / (hi - lo));
  const sx = (x) => left + pw * unit(x, xl, xh, o.xLog);
  const sy = (y) => top + ph * (1 - unit(y, yl, yh, o.yLog));
  const out = [text(left, y0 + 20, o.title ?? '', 14, { 'font-weight': 'bold' })];
  for (const t of o.yTicks ?? ticks(yl, yh, o.yLog)) {
    const y = sy(t);
    out.push(el('line', { x1: left, y1: y, x2: left + pw, y2: y, stroke: '#e3e3e3' }));
    out.push(text(left - 6, y + 4, tickLabel(t, o.yLog), 11, { 'text-anchor': 'end' }));
  }
  for (const t of o.xTicks ?? ticks(xl, xh, o.xLog)) {
    const x = sx(t);
    out.push(el('line', { x1: x, y1: top, x2: x, y2: top + ph, stroke: '#eeeeee' }));
    out.push(text(x, top + ph + 16, tickLabel(t, o.xLog), 11, { 'text-anchor': 'middle' }));
  }
  out.push(el('rect', { x: left, y: top, width: pw, height: ph, fill: 'none', stroke: '#444' }));
  if (o.xLabel) {
    out.push(text(left + pw / 2, y0 + height - 8, o.xLabel, 12, { 'text-anchor': 'middle' }));
  }
  if (o.yLabel) out.push(yTitle(x0 + 14, top + ph / 2, o.yLabel));
  for (const s of o.series) {
    const p = s.points.filter(finite);
    if (p.length === 0) continue;
    if (p.length > 1) {
      const xy = (x, y) => `${sx(x).toFixed(1)},${sy(y).toFixed(1)}`;
      const d = p.map((q, i) => (i === 0 ? `M${xy(...q)}`
        : s.step ? `L${xy(q[0], p[i - 1][1])} L${xy(...q)}` : `L${xy(...q)}`)).join(' ');
      out.push(el('path', { d, fill: 'none', stroke: s.color, 'stroke-width': 1.8,
        'stroke-dasharray': s.dash }));
    }
    if (s.marker !== 'none') {
      for (const q of p) out.push(marker(s.marker ?? 'circle', sx(q[0]), sy(q[1]), s.color));
    }
  }
  if (o.legend === 'right') out.push(legend(o.series, { x: left + pw + 14, y: top + 6 }));
  return out.join('\n');
}

/// A grouped bar chart. groups: [{ label, sublabel, bars: [{ value, color, hatch, label } or
/// { stack: [{ value, color, hatch }], label }] }]; a stacked bar draws its segments on top of
/// one another. Options: title, yLabel, yMax, legend: [{ name, color, hatch }], legendWidth.
export function barChart(o) {
  const { x0 = 0, y0 = 0, width, height } = o;
  const m = { left: 68, right: o.legend ? o.legendWidth ?? 200 : 16, top: 34, bottom: 58 };
  const pw = width - m.left - m.right;
  const ph = height - m.top - m.bottom;
  const left = x0 + m.left;
  const top = y0 + m.top;
  const totals = o.groups.flatMap((g) => g.bars.map((b) => (b.stack
    ? b.stack.reduce((a, s) => a + (s.value ?? 0), 0) : b.value ?? 0)));
  const yh = o.yMax ?? range([0, ...totals], false, true)[1];
  const sy = (v) => top + ph * (1 - v / yh);
  const out = [text(left, y0 + 20, o.title ?? '', 14, { 'font-weight': 'bold' })];
  for (const t of ticks(0, yh, false)) {
    const y = sy(t);
    out.push(el('line', { x1: left, y1: y, x2: left + pw, y2: y, stroke: '#e3e3e3' }));
    out.push(text(left - 6, y + 4, tickLabel(t, false), 11, { 'text-anchor': 'end' }));
  }
  const gw = pw / o.groups.length;
  o.groups.forEach((g, gi) => {
    const bw = Math.min(34, (gw * 0.84) / g.bars.length);
    const gx = left + gi * gw + (gw - bw * g.bars.length) / 2;
    g.bars.forEach((b, bi) => {
      const x = gx + bi * bw;
      let base = 0;
      for (const s of b.stack ?? [b]) {
        if (s.value == null) continue;
        const box = { x, y: sy(base + s.value), width: bw - 2,
          height: Math.max(0, sy(base) - sy(base + s.value)) };
        const color = s.color ?? b.color;
        out.push(el('rect', { ...box, fill: color, stroke: color }));
        if (s.hatch) out.push(el('rect', { ...box, fill: 'url(#hatch)', opacity: 0.5 }));
        base += s.value;
      }
      if (b.label != null) {
        out.push(text(x + bw / 2 - 1, sy(base) - 4, b.label, 9, { 'text-anchor': 'middle' }));
      }
    });
    const cx = left + (gi + 0.5) * gw;
    out.push(text(cx, top + ph + 16, g.label, 11.5, { 'text-anchor': 'middle' }));
    if (g.sublabel) {
      out.push(text(cx, top + ph + 30, g.sublabel, 10, { 'text-anchor': 'middle', fill: '#555' }));
    }
  });
  out.push(el('rect', { x: left, y: top, width: pw, height: ph, fill: 'none', stroke: '#444' }));
  if (o.yLabel) out.push(yTitle(x0 + 14, top + ph / 2, o.yLabel));
  if (o.legend) {
    const lx = left + pw + 14;
    o.legend.forEach((l, i) => {
      const y = top + 6 + 17 * i;
      const box = { x: lx, y: y - 8, width: 14, height: 12 };
      out.push(el('rect', { ...box, fill: l.color }));
      if (l.hatch) out.push(el('rect', { ...box, fill: 'url(#hatch)', opacity: 0.5 }));
      out.push(text(lx + 20, y + 2, l.name, 11));
    });
  }
  return out.join('\n');
}

/// One SVG document around panels (strings from lineChart, barChart, legend, text) and optional
/// note lines at the bottom. It defines the hatch pattern the bar charts use.
export function svgDocument(width, height, panels, notes = []) {
  const lines = notes.map((n, i) =>
    text(10, height - 8 - 14 * (notes.length - 1 - i), n, 10.5, { fill: '#555' }));
  return `<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="${width}" height="${height}" viewBox="0 0 ${width} ${height}">
<defs><pattern id="hatch" width="6" height="6" patternUnits="userSpaceOnUse" patternTransform="rotate(45)">
<line x1="0" y1="0" x2="0" y2="6" stroke="#555" stroke-width="2"/></pattern></defs>
<rect width="100%" height="100%" fill="white"/>
${panels.join('\n')}
${lines.join('\n')}
</svg>
`;
}
