// SPDX-License-Identifier: Apache-2.0
// Loading: the package's chunk files read as streams (stream.mjs), each component's first stream
// (its coarsest level) handed to the decoder workers (decoder/pool.mjs) the moment its bytes are
// in, and each decoded mesh passed on to the renderer, its buffers transferred, not copied. Once
// every component is drawn at its first level, the finer levels follow as the view asks for them
// (levels.mjs). Also the bookkeeping of what has loaded: the per-component fetch log, the counts
// in window.osteon, and the end of loading (every component drawn or failed, or nothing can be
// drawn). Every function takes the viewer's state (state.mjs).

import { createDecoderPool } from '../decoder/pool.mjs';
import { createLevelLoader } from './levels.mjs';
import { buildListsSoon, reportError, scheduleStatus, showInfo, updateStats, updateStatus } from './panel.mjs';
import { createChunkStream, kDecodeOptions, nextTask, planChunks } from './stream.mjs';
import { emit } from './state.mjs';
import { send } from './view.mjs';

const kChunksInFlight = 2;

/// Once the manifest is read: the totals in window.osteon, an empty fetch log entry per
/// component (its first stream), in fetch order, and the levels' loader.
export function startLog(state) {
  const { manifest, report } = state;
  report.manifestMs = performance.now();
  report.unit = manifest.unit;
  report.componentsTotal = manifest.components.length;
  report.instancesTotal = manifest.instances.length;
  report.bytesTotal = manifest.bytesTotal;
  report.chunksTotal = manifest.chunks.length;
  report.fetchLog = manifest.streamOrder.map((c) => ({
    id: c.id,
    chunk: c.first.chunk,
    file: c.first.file,
    offset: c.first.offset,
    bytes: c.first.bytes,
    fetchStart: null,
    fetchEnd: null,
    decodedAt: null,
    addedAt: null,
    error: null,
  }));
  for (const entry of report.fetchLog) state.logById.set(entry.id, entry);
  // Instances the manifest's check refused (a matrix with Infinity): the rest is drawn.
  for (const message of manifest.refused ?? []) reportError(state, message);
  state.levels = createLevelLoader(manifest, {
    report,
    base: state.boot.manifestUrl,
    budget: state.initialBudget,
    fetch: (url, init) => fetch(url, init),
    signal: state.stopStream.signal,
    stallMs: state.boot.stallMs,
    // The pool the first streams were decoded by; it stays for the levels.
    decode: async (buffer, label) => {
      const pool = await state.pool;
      if (state.boot.decoderError) throw new Error(`osteon: ${label}: ${state.boot.decoderError}`);
      return pool.decode(buffer, label, kDecodeOptions);
    },
    send: (message, transfer) => send(state, message, transfer),
    onError: (message) => {
      reportError(state, message);
      scheduleStatus(state);
    },
    onChange: () => levelsChanged(state),
  });
}

/// The levels' report changed: the bytes, the counts and the selected bone's info follow.
function levelsChanged(state) {
  const { report } = state;
  report.bytesLoaded = state.streamBytes + report.levelBytesLoaded;
  updateStats(state);
  if (state.selectedPart >= 0) showInfo(state);
}

/// Loading has ended at `at`: the decoder workers go, the status says so, the lists are built.
export function finish(state, at) {
  const { report } = state;
  if (report.done) return;
  report.allLoadedMs = at;
  report.done = true;
  // What the whole skeleton took: the first levels' chunks (finer levels may have come meanwhile).
  report.bytesAtSkeletonComplete = state.streamBytes;
  if (!state.fatal && report.componentsFailed === 0) report.skeletonCompleteMs = at;
  // The decoders stay while finer levels may be asked for.
  if (state.fatal || !state.levels?.hasLevels) for (const worker of state.boot?.decoders ?? []) worker.terminate();
  updateStatus(state);
  buildListsSoon(state);
  // Refinement's first plan (thousands of components in a dense skeleton) in a task of its own.
  if (!state.fatal && state.levels?.hasLevels) {
    nextTask().then(() => {
      if (!state.fatal) state.levels.start(at);
    });
  } else if (!state.fatal) {
    state.levels?.start(at);
  }
  // 'load' once every component is drawn or has failed; 'error' when nothing more can be drawn.
  emit(state, state.fatal ? 'error' : 'load', { ...progressOf(state), message: state.fatal ? state.report.errors.at(-1) : null });
}

/// The counts a 'progress' or 'load' event carries.
function progressOf(state) {
  const r = state.report;
  return {
    componentsLoaded: r.componentsLoaded,
    componentsFailed: r.componentsFailed,
    componentsTotal: r.componentsTotal,
    bytesLoaded: r.bytesLoaded,
    bytesTotal: r.bytesTotal,
    errors: r.errors.length,
  };
}

/// Components `ids` failed with `error` (one message for them all).
export function componentsFailed(state, ids, error) {
  if (state.fatal) return;
  state.levels?.firstFailed(ids);
  for (const id of ids) {
    const entry = state.logById.get(id);
    if (entry) entry.error = error;
    if (!state.settled.has(id)) {
      state.settled.add(id);
      state.report.componentsFailed++;
    }
  }
  reportError(state, error);
  scheduleStatus(state);
  emit(state, 'progress', progressOf(state));
  if (state.settled.size === state.report.componentsTotal) finish(state, performance.now());
}

/// The renderer drew components `ids` for the first time in its frame at `at`.
export function componentsDrawn(state, ids, at) {
  const { report } = state;
  for (const id of ids) {
    const entry = state.logById.get(id);
    if (entry) entry.addedAt = at;
    state.loaded.add(id);
    if (!state.settled.has(id)) {
      state.settled.add(id);
      report.componentsLoaded++;
    }
  }
  state.levels?.firstDrawn(ids);
  report.firstComponentMs ??= at;
  report.firstFrameMs ??= at;
  updateStats(state);
  if (state.selectedPart >= 0) showInfo(state);
  emit(state, 'progress', progressOf(state));
  if (state.settled.size === report.componentsTotal) finish(state, at);
}

/// The renderer's frame at `at` shows components at new levels ([[id, level]]).
export function levelsShown(state, changes, at) {
  state.levels?.shown(changes, at);
}

/// The renderer refused a finer level of component `id`: it fails alone, the level drawn stays.
export function levelFailed(state, id, level, error) {
  state.levels?.failedInRenderer(id, level, error);
}

/// Nothing can be drawn (`error`, at `at`): nothing more is fetched, and every component not yet
/// drawn counts as failed.
export function rendererFailed(state, error, at) {
  const { report } = state;
  if (state.fatal) return;
  // Loading has ended; only finer levels could still come: they stop, and the decoders go.
  if (report.done && state.levels?.hasLevels) {
    state.fatal = true;
    report.framePending = false;
    state.stopStream.abort();
    reportError(state, error);
    state.pool?.then((pool) => pool.terminate(), () => {});
    return;
  }
  if (report.done) return;
  state.fatal = true;
  report.framePending = false;
  state.stopStream.abort();
  reportError(state, error);
  report.componentsFailed = report.componentsTotal - report.componentsLoaded;
  finish(state, at);
}

/// Streams the chunks: each component decoded as soon as its bytes are in, each mesh passed on to
/// the renderer (its buffers transferred, not copied).
export async function startStream(state) {
  const { boot, logById, stopStream } = state;
  if (state.streaming || !state.manifest || state.fatal || state.report.done) return;
  state.streaming = true;
  let next = 0;
  const poolReady = boot.wasm.then((wasm) =>
    createDecoderPool({ workers: boot.decoders.length, wasm, createWorker: () => boot.decoders[next++] }));
  state.pool = poolReady;
  poolReady.catch((e) => {
    const message = String(e?.message ?? e);
    rendererFailed(state, message.startsWith('osteon:') ? message : `osteon: cannot start the decoder: ${message}`, performance.now());
  });
  // The bootstrap starts the first chunks itself (once three.js is in): the stream takes them up.
  await boot.chunksStarted;
  const stream = createChunkStream(planChunks(state.manifest, boot.manifestUrl), {
    limit: kChunksInFlight,
    stallMs: boot.stallMs,
    // The first chunks are already on their way (boot.js).
    fetchChunk: (chunk) => boot.chunks.get(chunk.index) ?? fetch(chunk.url, { signal: stopStream.signal }),
    signal: stopStream.signal,
    // A decoder worker that never started would never answer.
    decode: async (buffer, range) => {
      const pool = await poolReady;
      if (boot.decoderError) throw new Error(`osteon: ${range.label}: ${boot.decoderError}`);
      return pool.decode(buffer, range.label, kDecodeOptions);
    },
    onChunkStart: (chunk, at) => {
      const start = boot.chunkStarts.get(chunk.index) ?? at;
      for (const range of chunk.ranges) for (const c of range.components) logById.get(c.id).fetchStart = start;
    },
    onReceived: (range, at, bytesReceived) => {
      for (const c of range.components) logById.get(c.id).fetchEnd = at;
      state.streamBytes = bytesReceived;
      state.report.bytesLoaded = bytesReceived + (state.report.levelBytesLoaded ?? 0);
      scheduleStatus(state);
    },
    onDecoded: (range, mesh, at) => {
      for (const c of range.components) logById.get(c.id).decodedAt = at;
      if (state.fatal) return;
      const buffers = [mesh.positions?.buffer, mesh.indices?.buffer, mesh.normals?.buffer].filter(Boolean);
      const ids = range.components.map((c) => c.id);
      state.levels?.firstSent(ids, mesh);  // its GPU bytes, before the buffers go
      send(state, { type: 'mesh', ids, mesh }, buffers);
    },
    onFailed: (range, error) => componentsFailed(state, range.components.map((c) => c.id), error),
    onChunkError: (chunk, error) => reportError(state, error),
  });
  await stream.run();
  // Every first level is in hand before anything is drawn: the renderer is still making its
  // context, and the finer levels the opening view needs may come meanwhile (in time for its first
  // frame). Once frames are drawn they wait for the whole skeleton (finish), so as not to hold
  // its last bones back. The first plan in a task of its own, as in finish().
  if (!state.fatal && state.report.firstFrameMs === null && state.levels?.hasLevels) {
    nextTask().then(() => {
      if (!state.fatal && state.report.firstFrameMs === null) state.levels.allSent();
    });
  }
  // With levels of detail the pool stays: the finer levels are decoded by it too.
  if (state.fatal || !state.levels?.hasLevels) (await poolReady.catch(() => null))?.terminate();
}
