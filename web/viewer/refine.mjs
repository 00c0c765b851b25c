// SPDX-License-Identifier: Apache-2.0
// Levels of detail, the decisions (docs/FORMAT.md "Levels of detail"): which level of each
// component the view needs, which one is drawn, which finer level is fetched next, and which
// resident level goes when memory runs short. Pure functions on plain data: levels.mjs holds the
// state they read and carries out what they return, and Node tests run them as they are.
//
// Screen-space error: a level's `error` (the manifest's measured distance of that level from full
// resolution, in the manifest's unit) projected to pixels where the instance is seen,
//
//   pixels = error * scale * heightPx / (2 * tan(fov / 2)) / max(distance, near)
//
// where `distance` runs from the camera to the instance's world bounding sphere (0 inside it,
// hence the clamp at the near plane), `scale` is the instance matrix's largest axis scale and
// `heightPx` the drawing buffer's height. A level whose projected error is at most the target (one
// pixel) cannot be told from the full one on screen. For every instance that is shown and inside
// the view frustum (and not wholly cut away by the clipping plane), the coarsest level meeting the
// target is taken, else the finest; a component, whose instances share one geometry, takes the
// finest its instances need. Instances off screen or hidden need nothing, and their component is
// drawn at its coarsest level, which frees its fine levels for eviction and its triangles for
// what is on screen.
//
// The memory budget counts what the GPU holds: every resident level's positions, normals and
// index buffer (twice where a mirrored batch draws a winding-flipped copy), and the triangles of
// the level each component draws times its instances. The coarsest levels always stay, whatever
// they cost; a finer level is fetched only if it fits, after evicting resident levels nobody
// draws on screen, the least recently seen first, and is never drawn where its triangles would
// not fit. Lowering the budget evicts at once, levels drawn on screen last.
//
// Priority: what is on screen and looks worst first, by the projected error of the level it is
// drawn at; the level fetched is the one the view needs (not every level on the way to it), or
// the finest that fits when that one does not.
//
// Based on: Clark 1976 and Luebke et al. 2002, "Level of Detail for 3D Graphics" (screen-space
// error); the 3D Tiles / Cesium geometric-error refinement (error over distance, a pixel target,
// a memory budget with least-recently-used eviction).

/// Pixels per unit of length at distance 1, for a view `heightPx` tall with a vertical field of
/// view of `fovDeg` degrees: heightPx / (2 tan(fov / 2)).
export function pixelsPerUnit(fovDeg, heightPx) {
  return heightPx / (2 * Math.tan((fovDeg * Math.PI) / 360));
}

/// A length `error` seen at `distance` (clamped at `near`), in pixels.
export function projectedError(error, distance, { fovDeg, heightPx, near }) {
  return (error * pixelsPerUnit(fovDeg, heightPx)) / Math.max(distance, near);
}

/// a * b for column-major 4x4 matrices (arrays of 16).
export function multiply4(a, b) {
  const out = new Array(16);
  for (let c = 0; c < 4; ++c) {
    for (let r = 0; r < 4; ++r) {
      out[c * 4 + r] = a[r] * b[c * 4] + a[4 + r] * b[c * 4 + 1] + a[8 + r] * b[c * 4 + 2] + a[12 + r] * b[c * 4 + 3];
    }
  }
  return out;
}

/// The six planes [a, b, c, d] of the frustum of a column-major projection * view matrix, unit
/// normals pointing inward (a point p is inside when a p.x + b p.y + c p.z + d >= 0 for all).
/// Based on: Gribb & Hartmann 2001, "Fast extraction of viewing frustum planes".
export function frustumPlanes(m) {
  const row = (i) => [m[i], m[4 + i], m[8 + i], m[12 + i]];
  const [r0, r1, r2, r3] = [row(0), row(1), row(2), row(3)];
  const planes = [];
  for (const [r, sign] of [[r0, 1], [r0, -1], [r1, 1], [r1, -1], [r2, 1], [r2, -1]]) {
    const p = r3.map((v, k) => v + sign * r[k]);
    const length = Math.hypot(p[0], p[1], p[2]) || 1;
    planes.push(p.map((v) => v / length));
  }
  return planes;
}

/// Whether a sphere { center, radius } lies wholly outside one of `planes`.
export function sphereOutside(planes, { center, radius }) {
  for (const p of planes) if (p[0] * center[0] + p[1] * center[1] + p[2] * center[2] + p[3] < -radius) return true;
  return false;
}

/// Each instance's world bounding sphere, from its component's box under its matrix:
/// [{ center, radius, scale }], `scale` the matrix's largest axis scale (lengths in the
/// component's frame grow by at most that much in the world).
export function instanceSpheres(manifest) {
  return manifest.instances.map((inst) => {
    const { bounds } = manifest.componentById.get(inst.component);
    const m = inst.matrix;
    const c = bounds.min.map((v, i) => (v + bounds.max[i]) / 2);
    const half = Math.hypot(...bounds.max.map((v, i) => (v - bounds.min[i]) / 2));
    const scale = Math.max(...[0, 4, 8].map((k) => Math.hypot(m[k], m[k + 1], m[k + 2])));
    const center = [0, 1, 2].map((r) => m[r] * c[0] + m[4 + r] * c[1] + m[8 + r] * c[2] + m[12 + r]);
    return { center, radius: half * scale, scale };
  });
}

/// What the view needs: a Map component id -> { pixels, target } for the components with an
/// instance on screen, where pixels[k] is level k's projected error at the instance that sees it
/// largest and target the coarsest level whose pixels are at most `maxPixelError` (else the
/// finest). `view`: { position [3], projection [16], view [16] (the camera's inverse world
/// matrix), fovDeg, near, heightPx, clip: { normal, constant } or null (what is kept:
/// normal . p + constant >= 0) }. `shown(instanceIndex)`: whether its part is shown.
/// `spheres`: instanceSpheres(manifest). Cost: instances x levels.
export function screenNeeds(manifest, spheres, view, { maxPixelError = 1, shown = () => true } = {}) {
  const planes = frustumPlanes(multiply4(view.projection, view.view));
  const perUnit = pixelsPerUnit(view.fovDeg, view.heightPx);
  const [px, py, pz] = view.position;
  const clip = view.clip;
  const needs = new Map();
  // Plain loops, no closures or temporary arrays an instance: the viewer plans on its main
  // thread, and a phone runs this cold (interpreted) once per view.
  const { instances } = manifest;
  for (let i = 0; i < instances.length; ++i) {
    const sphere = spheres[i];
    if (!shown(i) || sphereOutside(planes, sphere)) continue;
    const [cx, cy, cz] = sphere.center;
    if (clip) {
      const n = clip.normal;
      if (n[0] * cx + n[1] * cy + n[2] * cz + clip.constant < -sphere.radius) continue;
    }
    const dx = cx - px, dy = cy - py, dz = cz - pz;
    const distance = Math.max(Math.hypot(dx, dy, dz) - sphere.radius, view.near);
    const scale = (perUnit * sphere.scale) / distance;
    const id = instances[i].component;
    const { levels } = manifest.componentById.get(id);
    let need = needs.get(id);
    if (!need) {
      need = { pixels: new Array(levels.length).fill(0), target: 0 };
      needs.set(id, need);
    }
    const pixels = need.pixels;
    for (let k = 0; k < levels.length; ++k) pixels[k] = Math.max(pixels[k], levels[k].error * scale);
  }
  for (const need of needs.values()) {
    const k = need.pixels.findIndex((p) => p <= maxPixelError);
    need.target = k < 0 ? need.pixels.length - 1 : k;
  }
  return needs;
}

/// How many copies of its index buffer component `id` puts on the GPU: one per batch (scene.mjs:
/// one Mesh for a single instance; else a batch for the instances that keep the winding and one,
/// with a flipped copy, for the mirrored ones).
export function indexCopies(manifest, id) {
  const uses = manifest.instancesOf.get(id);
  if (uses.length <= 1) return 1;
  const mirrored = uses.filter((i) => manifest.instances[i].mirror).length;
  return (mirrored > 0 ? 1 : 0) + (mirrored < uses.length ? 1 : 0);
}

/// Bytes of one vertex index of a mesh of `vertices`, as the viewer's decodes hand indices over
/// (stream.mjs kDecodeOptions): 16 bits where every index fits, else 32.
export function indexBytes(vertices) {
  return vertices <= 65536 ? 2 : 4;
}

/// GPU bytes of a mesh of `vertices` and `triangles` drawn with `copies` index buffers: float
/// positions and normals, indices of indexBytes().
export function gpuBytes(vertices, triangles, copies) {
  return vertices * 24 + triangles * 3 * indexBytes(vertices) * copies;
}

/// The planner's record of one component (levels.mjs keeps them): { id, order (ties: manifest
/// order), levels (the manifest's, coarsest first), uses (instances), gpu (estimated GPU bytes
/// per level), resident: Map level -> { bytes, lastVisible }, drawn (level), failed: Set of
/// levels, pending: the level being fetched or null }.
export function createRecord(manifest, component) {
  const copies = indexCopies(manifest, component.id);
  return {
    id: component.id,
    order: component.index,
    levels: component.levels,
    uses: manifest.instancesOf.get(component.id).length,
    gpu: component.levels.map((l) => gpuBytes(l.vertices, l.triangles, copies)),
    resident: new Map(),
    drawn: 0,
    failed: new Set(),
    pending: null,
  };
}

const keyOf = (rec, level) => `${rec.id}\u0000${level}`;

// residentLevels' answer when only level l is resident and nothing is evicted, shared (callers
// only read it).
const kOnly = [];

// The resident levels of `rec` not in `evicted`, coarsest first. Planning asks this of every
// component several times a plan; most hold their coarsest level alone and nothing is evicted.
function residentLevels(rec, evicted) {
  if (rec.resident.size === 1 && evicted.size === 0) {
    const l = rec.resident.keys().next().value;
    return (kOnly[l] ??= Object.freeze([l]));
  }
  const out = [];
  for (const l of rec.resident.keys()) if (evicted.size === 0 || !evicted.has(keyOf(rec, l))) out.push(l);
  return out.length > 1 ? out.sort((a, b) => a - b) : out;
}

/// The resident levels that may be evicted, in the order they go: every level but the coarsest
/// (level 0 always stays), those not drawn on screen first (`drawnOf(rec)`: the level it draws;
/// on screen: `needs` has it), then the least recently visible, then the finest, then the
/// largest. Returns [{ rec, level, bytes, inUse }], skipping the keys in `evicted`.
export function evictionOrder(records, needs, drawnOf, evicted = new Set()) {
  const out = [];
  for (const rec of records) {
    for (const [level, entry] of rec.resident) {
      if (level === 0 || evicted.has(keyOf(rec, level))) continue;
      out.push({ rec, level, bytes: entry.bytes, lastVisible: entry.lastVisible, inUse: needs.has(rec.id) && drawnOf(rec) === level });
    }
  }
  return out.sort((a, b) => (a.inUse - b.inUse) || (a.lastVisible - b.lastVisible) || (b.level - a.level) ||
    (b.bytes - a.bytes) || (a.rec.order - b.rec.order));
}

/// The level each record draws, within `triangleBudget`: off screen its coarsest resident level;
/// on screen the coarsest resident level meeting its target (else its finest), or the finest
/// below that whose triangles fit, taking the components in order of their coarsest level's
/// projected error (largest first). Returns { drawn: Map id -> level, triangles }.
export function assignDrawn(records, needs, triangleBudget, evicted = new Set()) {
  const drawn = new Map();
  let triangles = 0;
  const onScreen = [];
  for (const rec of records) {
    const base = residentLevels(rec, evicted)[0] ?? 0;
    drawn.set(rec.id, base);
    triangles += rec.levels[base].triangles * rec.uses;
    const need = needs.get(rec.id);
    if (need) onScreen.push({ rec, worst: need.pixels[0] });  // the sort key read once
  }
  onScreen.sort((a, b) => (b.worst - a.worst) || (a.rec.order - b.rec.order));
  for (const { rec } of onScreen) {
    const resident = residentLevels(rec, evicted);
    const base = drawn.get(rec.id);
    const { target } = needs.get(rec.id);
    const want = resident.find((l) => l >= target) ?? resident[resident.length - 1];
    for (let i = resident.indexOf(want); i >= 0; --i) {
      const level = resident[i];
      const delta = (rec.levels[level].triangles - rec.levels[base].triangles) * rec.uses;
      if (level === base || triangles + delta <= triangleBudget) {
        drawn.set(rec.id, level);
        triangles += delta;
        break;
      }
    }
  }
  return { drawn, triangles };
}

/// The level to fetch for `rec` given its target, or -1: the coarsest level meeting the target
/// (none is resident, or nothing is wanted), else the finest finer than what is resident; never
/// a level that failed.
export function wantedLevel(rec, target, evicted = new Set()) {
  const resident = residentLevels(rec, evicted);
  if (resident.some((l) => l >= target)) return -1;
  const finest = resident.length ? resident[resident.length - 1] : -1;
  for (let l = target; l < rec.levels.length; ++l) if (!rec.failed.has(l)) return l;
  for (let l = target - 1; l > finest; --l) if (!rec.failed.has(l)) return l;
  return -1;
}

/// One round of planning. `records`: every component's record (createRecord); `needs`:
/// screenNeeds for the components that may refine; `budget`: { bytes, triangles }; `slots`: how
/// many fetches may start; beyond them, up to `moreSlots` more while the stream bytes in flight
/// (`streamBytes` already, plus each level's manifest `bytes`) stay within `smallBytes`: small
/// levels cost a round trip each more than their transfer, so more of them go at once, in the
/// same order; `reserved`: { bytes, triangles } already promised to fetches in flight.
/// Returns { drawn: Map id -> level, evict: [{ id, level, bytes }], fetch: [{ id, level, bytes,
/// streamBytes, triangles }] (by priority), bytes (resident after the evictions), triangles
/// (drawn) }.
/// Guarantees: resident bytes plus reserved never exceed budget.bytes because of a fine level
/// (levels drawn on screen are evicted only when the budget was lowered below what they hold);
/// drawn triangles exceed budget.triangles only by coarsest levels.
export function planLevels(records, needs, budget, { slots = 0, moreSlots = 0, streamBytes = 0, smallBytes = 0, reserved = { bytes: 0, triangles: 0 } } = {}) {
  const list = [...records];
  const evicted = new Set();
  const evict = [];
  let bytes = 0;
  for (const rec of list) for (const entry of rec.resident.values()) bytes += entry.bytes;
  const drop = (victim) => {
    evicted.add(keyOf(victim.rec, victim.level));
    evict.push({ id: victim.rec.id, level: victim.level, bytes: victim.bytes });
    bytes -= victim.bytes;
  };

  // The budget was lowered: evict until what is resident fits, levels nobody sees first.
  if (bytes > budget.bytes) {
    for (const victim of evictionOrder(list, needs, (rec) => rec.drawn)) {
      if (bytes <= budget.bytes) break;
      drop(victim);
    }
  }

  const { drawn, triangles } = assignDrawn(list, needs, budget.triangles, evicted);

  // Fetches, worst-looking first.
  const fetch = [];
  let reservedBytes = reserved.bytes;
  let reservedTriangles = reserved.triangles;
  const candidates = [];
  for (const rec of list) {
    const need = needs.get(rec.id);
    if (!need || rec.pending !== null) continue;
    const level = wantedLevel(rec, need.target, evicted);
    if (level > 0) candidates.push({ rec, level, pixels: need.pixels[drawn.get(rec.id)] });
  }
  candidates.sort((a, b) => (b.pixels - a.pixels) || (a.rec.order - b.rec.order));
  let inFlight = streamBytes;
  const admitted = (rec, level) => fetch.length < slots ||
    (fetch.length < slots + moreSlots && inFlight + rec.levels[level].bytes <= smallBytes);
  next: for (const { rec, level: want } of candidates) {
    if (fetch.length >= slots + moreSlots) break;
    const resident = residentLevels(rec, evicted);
    const finest = resident.length ? resident[resident.length - 1] : -1;
    const now = drawn.get(rec.id);
    for (let level = want; level > finest; --level) {
      if (rec.failed.has(level)) continue;
      // The next fetch in priority order goes, or none does: order is kept.
      if (!admitted(rec, level)) break next;
      const cost = rec.gpu[level];
      const delta = (rec.levels[level].triangles - rec.levels[now].triangles) * rec.uses;
      if (triangles + reservedTriangles + delta > budget.triangles) continue;
      let short = bytes + reservedBytes + cost - budget.bytes;
      const victims = [];
      if (short > 0) {
        for (const victim of evictionOrder(list, needs, (r) => drawn.get(r.id), evicted)) {
          if (short <= 0 || victim.inUse) break;
          victims.push(victim);
          short -= victim.bytes;
        }
        if (short > 0) continue;
      }
      victims.forEach(drop);
      reservedBytes += cost;
      reservedTriangles += Math.max(0, delta);
      inFlight += rec.levels[level].bytes;
      fetch.push({ id: rec.id, level, bytes: cost, streamBytes: rec.levels[level].bytes, triangles: Math.max(0, delta) });
      break;
    }
  }
  return { drawn, evict, fetch, bytes, triangles };
}

/// Whether every component on screen (`needs`) is drawn (`shownOf(rec)`: the level the renderer
/// shows) at its target level or finer, or at the finest level it has that did not fail.
export function isRefined(records, needs, shownOf) {
  for (const rec of records) {
    const need = needs.get(rec.id);
    if (!need) continue;
    const shown = shownOf(rec);
    if (shown >= need.target) continue;
    let finer = false;
    for (let l = shown + 1; l < rec.levels.length; ++l) finer ||= !rec.failed.has(l);
    if (finer) return false;
  }
  return true;
}
