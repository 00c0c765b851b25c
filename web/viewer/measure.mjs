// SPDX-License-Identifier: Apache-2.0
// Measuring on the surface: with the Measure tool on (overlay.mjs), each tap places a point where
// the ray meets a bone (the renderer's 'picked' answer carries the point, in the package's
// coordinates). Two points give their distance, in the manifest's unit, with its error bound; a
// third gives the angle at the middle point as well. The next tap starts a new measurement (so
// does Enter); Esc or Clear removes them all.
//
// The error bound of a distance: each decoded point lies within its part's error bound of the
// point the package was made from (manifest.json's error_bound, the largest coordinate error of a
// decoded component; a part's bound is the largest of its instances'), so the distance between
// two of them is off by at most the sum of the two bounds. That is the bound of the decoded mesh
// against the source mesh; where on the bone a tap lands is the user's own error.

import { findPart, formatLength } from './manifest.mjs';
import { annotations, drawOverlay, setHint } from './overlay.mjs';

/// The error bound of part `partId` (the largest of its instances'), 0 for -1 (no part).
export function partErrorBound(manifest, partId) {
  if (!(partId >= 0) || !manifest.instancesOfPart[partId]) return 0;
  return manifest.instancesOfPart[partId].reduce((max, i) => Math.max(max, manifest.instances[i].errorBound), 0);
}

const sub = (a, b) => a.map((v, i) => v - b[i]);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

/// The distance from `a` to `b` ([x, y, z]) in `unit`, with `errorBound` (the sum of the two
/// points' bounds): { distance, errorBound, unit, text ("12.3 mm ± 0.0500 mm") }.
export function distanceOf(a, b, errorBound, unit) {
  const distance = Math.hypot(...sub(a, b));
  return { distance, errorBound, unit, text: `${formatLength(distance, unit)} ± ${formatLength(errorBound, unit)}` };
}

/// The angle at `b` between the rays to `a` and to `c`, in degrees (atan2 of the cross and dot
/// products: as exact near 0 and 180 as near 90): { angleDeg, text ("90.0°") }; angleDeg null
/// when `b` is one of the others.
export function angleOf(a, b, c) {
  const u = sub(a, b);
  const v = sub(c, b);
  if (Math.hypot(...u) === 0 || Math.hypot(...v) === 0) return { angleDeg: null, text: 'no angle: two points coincide' };
  const angleDeg = (Math.atan2(Math.hypot(...cross(u, v)), dot(u, v)) * 180) / Math.PI;
  return { angleDeg, text: `${angleDeg.toFixed(1)}°` };
}

/// The part whose box holds `point` (the smallest such box), or -1: the part of a point given
/// without one.
function partAt(manifest, point) {
  let best = -1;
  let bestVolume = Infinity;
  manifest.partBounds.forEach((box, id) => {
    const slack = partErrorBound(manifest, id);
    if (!point.every((v, i) => v >= box.min[i] - slack && v <= box.max[i] + slack)) return;
    const volume = box.max.reduce((product, v, i) => product * (v - box.min[i]), 1);
    if (volume < bestVolume) [best, bestVolume] = [id, volume];
  });
  return best;
}

/// A point as the API takes it: [x, y, z] (its part: the one whose box holds it) or { point,
/// part } (a part id, or a name as findPart reads it). Returns { point, part (id or -1) } or
/// null when it is not three finite numbers.
function pointOf(manifest, value) {
  const point = Array.isArray(value) ? value : value?.point;
  if (!Array.isArray(point) || point.length !== 3 || !point.every(Number.isFinite)) return null;
  if (Array.isArray(value) || value.part === undefined || value.part === null) return { point, part: partAt(manifest, point) };
  const part = Number.isInteger(value.part) ? manifest.parts[value.part] : findPart(manifest, value.part);
  return { point, part: part ? part.id : -1 };
}

/// What measurement `m` ({ points, parts }) says: { kind, points, parts (names, null for none),
/// distance, errorBound, unit, text } for two points; for three also angleDeg, and text the
/// angle's. The lengths are those of the first segment (a to b); `segments` lists both.
export function describeMeasurement(manifest, m) {
  const bound = (i) => partErrorBound(manifest, m.parts[i]);
  const segments = [];
  for (let i = 0; i + 1 < m.points.length; ++i) segments.push(distanceOf(m.points[i], m.points[i + 1], bound(i) + bound(i + 1), manifest.unit));
  const out = {
    kind: m.points.length === 3 ? 'angle' : m.points.length === 2 ? 'distance' : 'point',
    points: m.points,
    parts: m.parts.map((id) => (id >= 0 ? manifest.parts[id].name : null)),
    ...(segments[0] ?? { distance: null, errorBound: null, unit: manifest.unit, text: '' }),
  };
  if (m.points.length === 3) {
    Object.assign(out, angleOf(...m.points));
    out.segments = segments;
  }
  return out;
}

/// The labels overlay.mjs draws for `m`: a length per segment, the angle for three points.
function labelsOf(manifest, m) {
  const d = describeMeasurement(manifest, m);
  return { segments: (d.segments ?? (d.kind === 'distance' ? [d] : [])).map((s) => s.text), angle: d.kind === 'angle' ? d.text : null };
}

/// window.osteon.measure(a, b) -> { distance, errorBound, unit, text } and measure(a, b, c) ->
/// { angleDeg, text }; each point [x, y, z] or { point, part } (pointOf). Null for a bad point
/// or before the manifest is read. Draws nothing.
export function measure(state, ...values) {
  const { manifest } = state;
  if (!manifest || (values.length !== 2 && values.length !== 3)) return null;
  const points = values.map((v) => pointOf(manifest, v));
  if (points.some((p) => !p)) return null;
  if (points.length === 3) return angleOf(...points.map((p) => p.point));
  const [a, b] = points;
  return distanceOf(a.point, b.point, partErrorBound(manifest, a.part) + partErrorBound(manifest, b.part), manifest.unit);
}

/// Adds point `point` on part `part` to the measurement taking points (a new one after three, or
/// when none is). Returns the measurement.
export function addMeasurePoint(state, point, part) {
  const a = annotations(state);
  a.describe ??= (m) => labelsOf(state.manifest, m);
  if (!a.current) {
    a.current = { points: [], parts: [] };
    a.measurements.push(a.current);
  }
  const m = a.current;
  m.points.push(point.slice(0, 3));
  m.parts.push(part);
  if (m.points.length === 3) a.current = null;
  const d = describeMeasurement(state.manifest, m);
  setHint(state, m.points.length === 1 ? 'Tap a second point.' : d.kind === 'angle' ? `Angle ${d.text}` : `Distance ${d.text}; tap a third point for the angle.`);
  drawOverlay(state);
  return m;
}

/// The renderer's answer to a tap with the Measure tool on.
export function measurePicked(state, message) {
  if (!message.point) {
    setHint(state, message.part >= 0 ? 'The renderer gave no surface point for this tap.' : 'No bone there: tap on a bone.');
    return;
  }
  addMeasurePoint(state, message.point, message.part);
}

/// Measures between the picks `hits` ('picked' answers, or null): as if tapped with the tool, so
/// the measurement shows. Returns its describeMeasurement, or null when a pick found no point.
export function measureHits(state, hits) {
  if (!state.manifest || hits.length < 2 || hits.length > 3 || hits.some((h) => !h?.point)) return null;
  const a = annotations(state);
  a.current = null;
  let m = null;
  for (const h of hits) m = addMeasurePoint(state, h.point, h.part);
  a.current = null;
  return describeMeasurement(state.manifest, m);
}

/// Ends the measurement taking points: the next tap starts a new one.
export function finishMeasurement(state) {
  annotations(state).current = null;
}

/// Removes every measurement; false when there was none.
export function clearMeasurements(state) {
  const a = annotations(state);
  const had = a.measurements.length > 0;
  a.measurements = [];
  a.current = null;
  drawOverlay(state);
  return had;
}

/// The measurements, as the export and window.osteon.notes() list them.
export function measurementsView(state) {
  return state.manifest ? annotations(state).measurements.map((m) => describeMeasurement(state.manifest, m)) : [];
}
