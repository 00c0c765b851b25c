// SPDX-License-Identifier: Apache-2.0
// Levels of detail on the page: what is resident, what is in flight, and carrying out the
// planner's decisions (refine.mjs). Once every component is drawn at its first (coarsest) level,
// each camera move, visibility change or finished fetch re-plans: the levels the view needs are
// fetched by byte range (stream.mjs fetchRange), a few at a time, decoded by the decoder pool and
// sent to the renderer, which swaps the component's geometry on all its batches; levels nobody
// sees are evicted (their geometry disposed in the renderer) when memory runs short.
//
// The page's own state is the truth for planning: a level counts as resident (its GPU bytes in
// the budget) from the moment its mesh is sent, before the renderer has added it, so nothing can
// overshoot the budget in between. What the renderer actually shows comes back with its frames
// (`shown`), and the report's level map and refinement moments follow those.
//
// Failures stay small: a level whose fetch or decode fails is reported (naming its chunk file,
// component, level and byte range), never asked for again, and the level drawn before it stays.
// A fetch that stalls (no byte for `stallMs`, stream.mjs kStallMs, while waiting for the answer
// or within its body) is aborted and fails that level alone, with no retry: its slot goes to the
// next level the view needs, so the queue never waits on one host forever.
//
// No DOM and no three.js: Node tests run it with fake fetch, decode and renderer.

import { createChunkCache, fetchRange, nextTask } from './stream.mjs';
import { createRecord, evictionOrder, gpuBytes, indexCopies, instanceSpheres, isRefined, planLevels, screenNeeds } from './refine.mjs';

/// What a phone can hold (both are settable: URL parameters, window.osteon.setBudget).
export const kDefaultBudget = { bytes: 256e6, triangles: 4e6 };
const kInFlight = 3;           // level fetches at once: a few, so the view's order is kept,
const kMaxInFlight = 8;        // or up to this many while their bytes together stay within
const kSmallInFlightBytes = 64 << 10;  // this: about a round trip's worth at 10 Mbit/s, 40 ms
const kCacheBytes = 8 << 20;   // whole chunks kept where a host ignores Range

/// A loader for `manifest` (manifest.mjs). Options:
///   fetch(url, init) -> Promise<Response>   decode(buffer, label) -> Promise<mesh>
///   send(message, transfer)                  to the renderer ('level' and 'lod' messages,
///                                            render_worker.mjs lists them)
///   onError(message)  onChange()  (the report changed)  now()  signal  budget  base (the
///   manifest's URL, for the chunks' URLs)  report (an object to write the report's fields into)
///   inFlight (default 3; more while they are small: kMaxInFlight)  cacheBytes (whole chunks kept where a host ignores Range; 8 MiB)
///   stallMs (default kStallMs: a level fetch with no byte for this long fails)
/// Returns { report, hasLevels, firstSent, firstDrawn, firstFailed, allSent, start, setView, shown,
/// failedInRenderer, setBudget, setMaxPixelError, levelPixels, plan }; `report` holds the fields
/// window.osteon shows (see state.mjs).
export function createLevelLoader(manifest, options) {
  const { decode, send, signal } = options;
  const fetchFn = options.fetch;
  const now = options.now ?? (() => performance.now());
  const onError = options.onError ?? (() => {});
  const onChange = options.onChange ?? (() => {});
  const cache = createChunkCache(options.cacheBytes ?? kCacheBytes);
  const limit = options.inFlight ?? kInFlight;
  const spheres = instanceSpheres(manifest);
  const records = new Map();     // component id -> record (refine.mjs createRecord), once its first level is sent
  const live = new Set();        // component ids drawn at their first level: these refine
  const pending = new Map();     // key -> { rec, level, bytes, triangles } fetches and decodes in flight
  const logOf = new Map();       // key -> the latest report.levelLog entry
  let view = null;
  let shownPart = () => true;
  let lastNeeds = new Map();
  let needsStale = true;         // the view, the target, what is shown or what is live changed
  let lastStarted = 0;
  let started = false;
  let fetching = false;          // finer levels may be fetched: every first level is in hand (allSent) or drawn (start)
  let timer = null;
  const hasLevels = manifest.components.some((c) => c.levels.length > 1);

  // Written into options.report when given (the page's: window.osteon shows these fields).
  const report = Object.assign(options.report ?? {}, {
    levelsTotal: manifest.components.reduce((n, c) => n + c.levels.length, 0),
    levelsLoaded: 0,           // resident levels (first ones included)
    levelsFailed: 0,
    levelDrawn: {},            // component id -> the level the renderer shows (0: coarsest)
    levelWanted: {},           // component id -> the level the view needs, for those on screen
    levelLog: [],              // per level fetch: { id, level, chunk, file, offset, bytes, fetchStart, fetchEnd, status, received, requests, decodedAt, shownAt, evictedAt, dropped, error }
    levelBytesLoaded: 0,       // bytes the level fetches brought over the network
    gpuBytes: 0,               // resident levels' positions, normals and index buffers
    gpuTriangles: 0,           // the drawn levels' triangles times their instances (the budget's count)
    gpuBytesPeak: 0,           // since the budget was last set
    gpuTrianglesPeak: 0,
    budget: { ...kDefaultBudget, ...options.budget },
    maxPixelError: 1,
    evictions: 0,
    refinedMs: null,           // every bone on screen within maxPixelError or at its finest level (null again after a move that needs more)
    firstRefinedMs: null,
    refineIdle: !hasLevels,    // nothing in flight, nothing waiting for a frame, nothing more that fits
  });

  const keyOf = (id, level) => `${id}\u0000${level}`;
  const labelOf = (rec, level) => {
    const l = rec.levels[level];
    return `${l.file} (component ${rec.id}, level ${level + 1} of ${rec.levels.length}, bytes ${l.offset}-${l.offset + l.bytes})`;
  };
  const reserved = () => {
    let bytes = 0;
    let triangles = 0;
    let streamBytes = 0;
    for (const p of pending.values()) {
      bytes += p.bytes;
      triangles += p.triangles;
      streamBytes += p.streamBytes ?? 0;
    }
    return { bytes, triangles, streamBytes };
  };
  const peaks = () => {
    report.gpuBytesPeak = Math.max(report.gpuBytesPeak, report.gpuBytes);
    report.gpuTrianglesPeak = Math.max(report.gpuTrianglesPeak, report.gpuTriangles);
  };

  // Idle: nothing in flight, the last plan started nothing, and the renderer shows what the page
  // means it to draw (a level that arrived after the view stopped needing it is held, not shown).
  function updateIdle() {
    let shownAsPlanned = true;
    for (const id of live) {
      const rec = records.get(id);
      if (rec && rec.drawn !== (report.levelDrawn[id] ?? 0)) shownAsPlanned = false;
    }
    report.refineIdle = !hasLevels || (started && pending.size === 0 && lastStarted === 0 && shownAsPlanned);
  }

  function checkRefined(at) {
    if (!started) return;
    const refined = isRefined([...records.values()].filter((r) => live.has(r.id)), lastNeeds, (rec) => report.levelDrawn[rec.id] ?? 0);
    if (!refined) {
      report.refinedMs = null;
    } else if (report.refinedMs === null) {
      report.refinedMs = at;
      report.firstRefinedMs ??= at;
    }
  }

  function schedule() {
    if (timer !== null || !fetching) return;
    timer = setTimeout(() => {
      timer = null;
      plan();
    }, 0);
  }

  function evictNow(rec, level) {
    const entry = rec.resident.get(level);
    if (!entry || level === 0) return;
    rec.resident.delete(level);
    report.gpuBytes -= entry.bytes;
    report.levelsLoaded--;
    report.evictions++;
    const log = logOf.get(keyOf(rec.id, level));
    if (log) log.evictedAt = now();
  }

  /// One round: the view's needs, the planner's decisions, carried out.
  function plan() {
    if (!fetching || signal?.aborted) return;
    // A plan after a fetch has ended sees the view of the plan before: its needs stay.
    if (view && needsStale) {
      const needs = screenNeeds(manifest, spheres, view, { maxPixelError: report.maxPixelError, shown: shownPart });
      // Before every bone is drawn, those on their way to the renderer refine too.
      for (const id of needs.keys()) if (!(live.has(id) || (!started && records.has(id)))) needs.delete(id);
      lastNeeds = needs;
      needsStale = false;
    }
    const slots = Math.max(0, limit - pending.size);
    const { bytes, triangles, streamBytes } = reserved();
    const result = planLevels(records.values(), lastNeeds, report.budget, {
      slots, moreSlots: Math.max(0, Math.max(limit, kMaxInFlight) - pending.size - slots), streamBytes, smallBytes: kSmallInFlightBytes,
      reserved: { bytes, triangles },
    });
    const show = [];
    for (const [id, level] of result.drawn) {
      const rec = records.get(id);
      if (rec.drawn !== level) {
        rec.drawn = level;
        show.push([id, level]);
      }
    }
    const evict = [];
    for (const { id, level } of result.evict) {
      evictNow(records.get(id), level);
      evict.push([id, level]);
    }
    // Shown first, then evicted: the renderer never draws a disposed geometry.
    if (show.length || evict.length) send({ type: 'lod', show, evict });
    const at = now();
    report.levelWanted = {};
    for (const [id, need] of lastNeeds) {
      const rec = records.get(id);
      const entry = rec.resident.get(rec.drawn);
      if (entry) entry.lastVisible = at;
      report.levelWanted[id] = need.target;
    }
    report.gpuTriangles = result.triangles;
    peaks();
    lastStarted = result.fetch.length;
    for (const f of result.fetch) load(records.get(f.id), f);
    const before = [report.refinedMs, report.refineIdle];
    checkRefined(at);
    updateIdle();
    // Most plans (every frame of a camera move) change nothing the page shows: no DOM work then.
    if (show.length || evict.length || result.fetch.length || before[0] !== report.refinedMs || before[1] !== report.refineIdle) onChange();
  }

  /// Fetches, decodes and sends level `f.level` of `rec`.
  async function load(rec, f) {
    const { level } = f;
    const key = keyOf(rec.id, level);
    const l = rec.levels[level];
    const chunk = manifest.chunks[l.chunk];
    pending.set(key, f);
    rec.pending = level;
    const log = {
      id: rec.id, level, chunk: l.chunk, file: l.file, offset: l.offset, bytes: l.bytes,
      fetchStart: now(), fetchEnd: null, status: null, received: 0, requests: 0, decodedAt: null, shownAt: null, evictedAt: null, dropped: false, error: null,
    };
    report.levelLog.push(log);
    logOf.set(key, log);
    try {
      // The fetch starts in a task of its own: on a slow phone a fetch() is tens of milliseconds
      // of this thread, and with the plan that asked for it, one long task.
      await nextTask();
      if (signal?.aborted) return;
      log.fetchStart = now();
      let got;
      try {
        got = await fetchRange({ url: options.base === undefined ? chunk.file : new URL(chunk.file, options.base).href, file: chunk.file, bytes: chunk.bytes },
          l.offset, l.bytes, { fetch: fetchFn, cache, signal, stallMs: options.stallMs });
      } finally {
        log.fetchEnd = now();
      }
      log.status = got.status;
      log.received = got.received;
      log.requests = got.requests;
      report.levelBytesLoaded += got.received;
      const mesh = await decode(got.data.buffer, labelOf(rec, level));
      log.decodedAt = now();
      pending.delete(key);
      rec.pending = null;
      if (signal?.aborted) return;
      const bytes = meshBytes(mesh, indexCopies(manifest, rec.id));
      if (!makeRoom(bytes)) {
        log.dropped = true;  // the budget was lowered while it was on its way
        return;
      }
      rec.resident.set(level, { bytes, lastVisible: now() });
      report.gpuBytes += bytes;
      report.levelsLoaded++;
      peaks();
      const buffers = [mesh.positions?.buffer, mesh.indices?.buffer, mesh.normals?.buffer].filter(Boolean);
      send({ type: 'level', ids: [rec.id], level, mesh }, buffers);
    } catch (e) {
      const text = String(e?.message ?? e);
      // The decoder's messages already read 'osteon: <label>: ...'.
      fail(rec, level, text.startsWith('osteon:') ? text : `osteon: ${labelOf(rec, level)}: ${text}`);
    } finally {
      if (pending.get(key) === f) pending.delete(key);
      if (rec.pending === level) rec.pending = null;
      plan();
      onChange();  // the bytes loaded, at least
    }
  }

  /// Room for `bytes` more within the budget, evicting levels nobody sees; false if there is none.
  function makeRoom(bytes) {
    const budget = report.budget.bytes;
    const { bytes: promised } = reserved();
    if (report.gpuBytes + promised + bytes <= budget) return true;
    const victims = [];
    let short = report.gpuBytes + promised + bytes - budget;
    for (const v of evictionOrder(records.values(), lastNeeds, (r) => r.drawn)) {
      if (short <= 0 || v.inUse) break;
      victims.push(v);
      short -= v.bytes;
    }
    if (short > 0) return false;
    const evict = victims.map((v) => {
      evictNow(v.rec, v.level);
      return [v.rec.id, v.level];
    });
    if (evict.length) send({ type: 'lod', show: [], evict });
    return true;
  }

  function fail(rec, level, message) {
    if (signal?.aborted) return;
    rec.failed.add(level);
    const log = logOf.get(keyOf(rec.id, level));
    if (log) log.error = message;
    report.levelsFailed++;
    onError(message);
  }

  return {
    report,
    hasLevels,

    /// A component's first stream was decoded and goes to the renderer now (call before its
    /// buffers are transferred away).
    firstSent(ids, mesh) {
      for (const id of ids) {
        const rec = createRecord(manifest, manifest.componentById.get(id));
        const bytes = meshBytes(mesh, indexCopies(manifest, id));
        rec.resident.set(0, { bytes, lastVisible: -Infinity });
        records.set(id, rec);
        report.gpuBytes += bytes;
        report.levelsLoaded++;
      }
      peaks();
    },

    /// The renderer drew these components for the first time (at their first level).
    firstDrawn(ids) {
      needsStale = true;
      for (const id of ids) {
        live.add(id);
        report.levelDrawn[id] = 0;
        const rec = records.get(id);
        if (rec) report.gpuTriangles += rec.levels[0].triangles * rec.uses;
      }
      peaks();
    },

    /// The renderer refused a component's first level: it holds nothing of it.
    firstFailed(ids) {
      for (const id of ids) {
        const rec = records.get(id);
        if (!rec) continue;
        records.delete(id);
        report.gpuBytes -= rec.resident.get(0)?.bytes ?? 0;
        report.levelsLoaded--;
      }
    },

    /// Every component's first level is decoded and on its way to the renderer (or failed) before
    /// the renderer has drawn anything: the finer levels the view needs are fetched from now, so
    /// that they may be in its first frame (with a software GPU, or a slow one, the first frame
    /// waits for the WebGL context long after the first levels are in). Refinement proper
    /// (refinedMs, refineIdle) starts once they are drawn (start).
    allSent() {
      if (fetching || signal?.aborted || !hasLevels) return;
      fetching = true;
      needsStale = true;
      plan();
    },

    /// Every component is drawn (or failed) at its first level: refinement starts.
    start(at) {
      if (started || signal?.aborted) return;
      started = true;
      fetching = true;
      needsStale = true;
      if (!hasLevels) {
        report.refinedMs = at;
        report.firstRefinedMs = at;
        updateIdle();
        return;
      }
      plan();
      if (report.refinedMs !== null) report.refinedMs = report.firstRefinedMs = at;
    },

    /// The camera as the renderer will draw it (refine.mjs screenNeeds' `view`) and which
    /// instances are shown; plans at once, so that a level already resident is swapped in by the
    /// same frame that shows its component on screen.
    setView(next, shown) {
      view = next;
      needsStale = true;
      if (shown) shownPart = shown;
      if (fetching && hasLevels) plan();
    },

    /// The renderer's frame at `at` shows these [id, level] changes.
    shown(changes, at) {
      for (const [id, level] of changes) {
        report.levelDrawn[id] = level;
        const log = logOf.get(keyOf(id, level));
        if (log && log.shownAt === null) log.shownAt = at;
      }
      checkRefined(at);
      updateIdle();
      onChange();
    },

    /// The renderer refused level `level` of component `id` (`message`): it counts as failed.
    failedInRenderer(id, level, message) {
      const rec = records.get(id);
      if (!rec) return;
      evictNow(rec, level);
      report.evictions--;  // not an eviction
      fail(rec, level, message);
      schedule();
    },

    /// Sets the memory budget ({ bytes, triangles }, either may be left out); evicts at once
    /// what no longer fits. Returns the budget.
    setBudget(budget = {}) {
      const next = { ...report.budget };
      for (const k of ['bytes', 'triangles']) if (Number.isFinite(budget[k]) && budget[k] >= 0) next[k] = budget[k];
      report.budget = next;
      report.gpuBytesPeak = report.gpuBytes;
      report.gpuTrianglesPeak = report.gpuTriangles;
      plan();
      report.gpuBytesPeak = report.gpuBytes;
      report.gpuTrianglesPeak = report.gpuTriangles;
      return { ...next };
    },

    /// The target of the screen-space error, in pixels (default 1).
    setMaxPixelError(px) {
      if (Number.isFinite(px) && px > 0) report.maxPixelError = px;
      needsStale = true;
      plan();
      return report.maxPixelError;
    },

    /// Each level's projected error in pixels for component `id` at the last view (its
    /// instance seen largest), or null when it is not on screen.
    levelPixels(id) {
      return lastNeeds.get(id)?.pixels.slice() ?? null;
    },

    plan,
  };
}

/// GPU bytes of a decoded mesh drawn with `copies` index buffers (refine.mjs gpuBytes).
function meshBytes(mesh, copies) {
  return gpuBytes((mesh.positions?.length ?? 0) / 3, (mesh.indices?.length ?? 0) / 3, copies);
}
