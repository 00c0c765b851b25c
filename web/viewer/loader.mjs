// SPDX-License-Identifier: Apache-2.0
// OsteonLoader: an osteon package (docs/FORMAT.md, "Package") as a three.js Group, for pages that
// have their own three.js scene. It is the viewer's own loading code, not a second one: the
// manifest is read and checked by manifest.mjs, the chunk files are read as streams by
// stream.mjs, the meshes decoded by the WebAssembly decoder in its worker pool
// (decoder/pool.mjs), and the draw objects made by scene.mjs (a Mesh per component one instance
// uses, an InstancedMesh for the instances that keep the winding and one drawn from a
// winding-flipped index copy for the mirrored ones). What is added here is the three.js Loader
// face (load / loadAsync / LoadingManager), names and part data on the objects, events, the
// choice of levels, time-outs and the decoder's lifetime.
//
//   const loader = new OsteonLoader().setDecoderPath('/osteon/');
//   const skeleton = loader.load('packages/hip/', (group) => {}, onProgress, onError);
//   scene.add(skeleton);                                 // bones appear as they are decoded
//   skeleton.addEventListener('component', (e) => {});  // one event per component and level
//
// Levels of detail ('progressive', the default): every component at its coarsest level first
// (the package's first chunks, read whole), then each component that has finer levels at its
// full level, fetched by HTTP Range (the ranges of one chunk closer than 64 KiB in one request)
// and swapped in on all its draw objects at once. 'coarsest' stops after the first step;
// 'finest' fetches the full level of every component and nothing else.
//
// Failures: any stream that cannot be fetched or decoded, a manifest that is missing, not JSON
// or refused by the checks, a decoder or worker that cannot be loaded, a request (the manifest's,
// a chunk's or a level's byte range) that sends no byte for 15 s (stream.mjs kStallMs, as in the
// viewer), and no progress for `timeout` ms end the load with an Error('osteon: <file>: <field or
// byte range>: <what>'); its fetches are aborted, and the decoder workers are terminated once no
// other load uses them. What was added to the group before stays.
//
// Based on: three.js DRACOLoader (decoder path, worker limit, dispose) and TextureLoader
// (load() returns the object at once; it is filled in as data arrives).

import { Group, Loader } from 'three';

import { compileDecoder } from '../decoder/osteon_decoder.mjs';
import { createDecoderPool } from '../decoder/pool.mjs';
import { findPart, parseManifest } from './manifest.mjs';
import { createPackageScene } from './scene.mjs';
import { createChunkStream, kDecodeOptions, kStallMs, planSpans, readWithin, within } from './stream.mjs';

const kLevels = new Set(['progressive', 'coarsest', 'finest']);
const kDefaultTimeout = 30000;          // ms without a byte or a decode: the load fails
const kMaxManifestBytes = 64 << 20;
const kMaxSpanBytes = 1 << 30;          // one request's bytes, allocated before they arrive
const kChunksInFlight = 2;

/// The Group a package loads into: the draw objects as children, and the package's tables.
export class OsteonGroup extends Group {
  constructor() {
    super();
    this.isOsteonGroup = true;
    this.type = 'OsteonGroup';
    /// The parsed manifest (manifest.mjs parseManifest), null until it has arrived.
    this.manifest = null;
    /// The manifest's parts: { id, name, displayName, group, source, triangles, prototype, color }.
    this.parts = [];
    /// The manifest's URL.
    this.url = '';
    this._scene = null;
    this._geometries = new Set();
    this._stop = null;
  }

  /// The part under a Raycaster intersection ({ object, instanceId }) of one of this group's
  /// objects, or null.
  partAt(intersection) {
    if (!this._scene || !intersection?.object) return null;
    const id = this._scene.partOf(intersection);
    return id >= 0 ? this.parts[id] : null;
  }

  /// A part by display name, name or source file (any case), or null.
  findPart(query) {
    return this.manifest ? findPart(this.manifest, query) : null;
  }

  /// Shows the parts for which `visible(part)` holds, hides the others (hidden instances are
  /// packed out of their InstancedMesh: instanceId then counts the visible ones; userData.parts
  /// follows).
  setPartVisibility(visible) {
    if (!this._scene) return;
    this._scene.setVisibility((id) => visible(this.parts[id]));
    for (const object of this.children) describeSlots(object, this.manifest);
  }

  /// Stops loading into this group, and frees its geometries and materials on the GPU.
  dispose() {
    this._stop?.('disposed');
    for (const geometry of this._geometries) geometry.dispose();
    for (const material of this._scene?.materials ?? []) material.dispose();
    this._geometries.clear();
    this.clear();
  }
}

/// userData of an object made by scene.mjs: the parts per instanceId (names and ids), its
/// instances' indices in manifest.instances, and the part's manifest fields for a Mesh.
function describeSlots(object, manifest) {
  const batch = object.userData.batch;
  if (!batch) return;
  const instances = batch.instanced ? batch.slots : batch.instances;
  const parts = instances.map((i) => manifest.parts[manifest.instances[i].part]);
  object.userData.instances = [...instances];
  object.userData.parts = parts.map((p) => p.name);
  object.userData.partIds = parts.map((p) => p.id);
}

function describe(object, manifest, component, level) {
  const batch = object.userData.batch;
  // Kept out of JSON (clone(), toJSON()): the batch refers back to the object.
  Object.defineProperty(object.userData, 'batch', { value: batch, enumerable: false, writable: true, configurable: true });
  const first = manifest.parts[manifest.instances[batch.instances[0]].part];
  // Named after the parts it draws, so getObjectByName() finds a part drawn alone.
  object.name = [...new Set(batch.instances.map((i) => manifest.parts[manifest.instances[i].part].name))].join(', ');
  object.userData.component = component.id;
  object.userData.mirror = batch.mirror;
  object.userData.level = level;
  object.userData.levels = component.levels.length;
  if (!batch.instanced) {
    object.userData.part = { ...first, color: first.color && [...first.color] };
    object.userData.instance = batch.instances[0];
  }
  describeSlots(object, manifest);
}

function message(e) {
  const text = String(e?.message ?? e);
  return text.startsWith('osteon:') ? text : `osteon: ${text}`;
}

/// A response body that counts what arrives (`onBytes(bytes passed on)`) and, from `skip`,
/// passes at most `length` bytes on (null: all); `onEnd()` once it has ended.
function countedBody(body, skip, length, onEnd, onBytes) {
  let seen = 0;
  let passed = 0;
  return body.pipeThrough(new TransformStream({
    transform(piece, controller) {
      const from = Math.max(0, skip - seen);
      seen += piece.length;
      if (from >= piece.length) return onBytes(0);
      let part = from ? piece.subarray(from) : piece;
      if (length !== null && passed + part.length > length) part = part.subarray(0, length - passed);
      passed += part.length;
      onBytes(part.length);
      controller.enqueue(part);
      if (length !== null && passed >= length) {
        onEnd();
        controller.terminate();
      }
    },
    flush: onEnd,
  }));
}

export class OsteonLoader extends Loader {
  constructor(manager) {
    super(manager);
    this.decoderPath = '';
    this.workerLimit = undefined;
    this.levels = 'progressive';
    this.timeout = kDefaultTimeout;
    this._module = null;       // Promise<WebAssembly.Module>
    this._pool = null;         // Promise<pool>
    this._workers = [];        // the Worker objects of the current pool
    this._loads = new Set();   // loads in flight
    this._poisoned = false;    // a load failed: the pool goes once no load uses it
  }

  /// The folder (URL) holding osteon_decoder.wasm and decoder-worker.js; default: beside this
  /// module. A worker script on another origin is started through a blob: module that imports it
  /// (the host must allow CORS).
  setDecoderPath(path) {
    this.decoderPath = path;
    this._module = null;
    if (this._loads.size === 0) this._terminate();
    return this;
  }

  /// At most `n` decoder workers (default: hardware threads - 1, 1 to 4). Takes effect for the
  /// next pool: at once when no load is in flight.
  setWorkerLimit(n) {
    this.workerLimit = Math.max(1, Math.floor(n));
    if (this._loads.size === 0) this._terminate();
    return this;
  }

  /// Which levels of detail to load: 'progressive' (coarsest first, then the full level
  /// replacing it), 'coarsest' or 'finest'.
  setLevels(levels) {
    if (!kLevels.has(levels)) throw new TypeError(`osteon: setLevels: expected one of ${[...kLevels].join(', ')}, got ${JSON.stringify(levels)}`);
    this.levels = levels;
    return this;
  }

  /// A load that receives no byte and finishes no decode for `ms` fails (default 30000).
  setTimeout(ms) {
    this.timeout = ms;
    return this;
  }

  /// Fetches and compiles the decoder and starts its workers now.
  preload() {
    this._getPool().catch(() => {});
    return this;
  }

  /// Loads the package at `url` (its folder, or its manifest.json). Returns the OsteonGroup at
  /// once; its objects are added as their components are decoded. onLoad(group) once every
  /// component is in at the levels asked for; onProgress(ProgressEvent { loaded, total }: chunk
  /// bytes); onError(Error). The group dispatches 'manifest', 'component', 'load' and 'error'
  /// events (web/README.md).
  load(url, onLoad, onProgress, onError) {
    const group = new OsteonGroup();
    let manifestUrl;
    try {
      manifestUrl = this._manifestUrl(url);
    } catch (e) {
      const error = new Error(`osteon: ${url}: not a URL: ${e?.message ?? e}`);
      queueMicrotask(() => (onError ? onError(error) : console.error(error)));
      return group;
    }
    group.url = manifestUrl;
    const load = {
      url: manifestUrl,
      group,
      controller: new AbortController(),
      done: false,
      activity: performance.now(),
      fetching: new Map(),   // url -> how many requests
      decoding: 0,
      loaded: 0,
      total: 0,
      timer: null,
    };
    load.fail = (e) => this._finish(load, e, onLoad, onError);
    group._stop = (why) => load.fail(new Error(`osteon: ${manifestUrl}: ${why}`));
    this._loads.add(load);
    this.manager.itemStart(manifestUrl);
    const every = Math.max(10, Math.min(1000, this.timeout / 4));
    load.timer = setInterval(() => this._watch(load), every);
    this._run(load, onProgress).then(() => this._finish(load, null, onLoad, onError), load.fail);
    return group;
  }

  /// Ends every load in flight with Error('osteon: <url>: aborted').
  abort() {
    for (const load of [...this._loads]) load.fail(new Error(`osteon: ${load.url}: aborted`));
    return this;
  }

  /// Aborts the loads in flight and terminates the decoder workers.
  dispose() {
    this.abort();
    this._terminate();
    this._module = null;
    return this;
  }

  _manifestUrl(url) {
    const base = globalThis.document?.baseURI ?? globalThis.location?.href;
    const resolved = new URL(this.manager.resolveURL(`${this.path}${url}`), base);
    if (/\.json$/i.test(resolved.pathname)) return resolved.href;
    if (!resolved.pathname.endsWith('/')) resolved.pathname += '/';
    return new URL('manifest.json', resolved).href;
  }

  _decoderUrl(file) {
    const base = globalThis.document?.baseURI ?? globalThis.location?.href;
    return this.decoderPath ? new URL(file, new URL(this.decoderPath, base)).href : null;
  }

  _spawn(url) {
    let worker;
    if (url && new URL(url).origin !== globalThis.location?.origin) {
      const shim = URL.createObjectURL(new Blob([`import ${JSON.stringify(url)};`], { type: 'text/javascript' }));
      worker = new Worker(shim, { type: 'module' });
    } else {
      // Written out so that bundlers (Vite, webpack) find the worker beside this module.
      worker = url ? new Worker(url, { type: 'module' }) : new Worker(new URL('./decoder-worker.js', import.meta.url), { type: 'module' });
    }
    const where = url ?? new URL('./decoder-worker.js', import.meta.url).href;
    worker.addEventListener('error', (e) => {
      const why = e?.message || 'it did not start (is the file there, served as JavaScript?)';
      this._poisoned = true;
      for (const load of [...this._loads]) load.fail(new Error(`osteon: ${where}: the decoder worker failed: ${why}`));
      this._terminate();
    });
    this._workers.push(worker);
    return worker;
  }

  _getPool() {
    if (!this._pool) {
      const wasm = this._decoderUrl('osteon_decoder.wasm') ?? new URL('./osteon_decoder.wasm', import.meta.url).href;
      const workerUrl = this._decoderUrl('decoder-worker.js');
      this._module ??= compileDecoder(wasm).catch((e) => {
        this._module = null;
        const text = String(e?.message ?? e);
        throw new Error(text.startsWith('osteon:') ? text : `osteon: ${wasm}: cannot load the decoder: ${text}`);
      });
      const pool = this._module.then((module) =>
        createDecoderPool({ workers: this.workerLimit, wasm: module, createWorker: () => this._spawn(workerUrl) }));
      pool.catch(() => {
        if (this._pool === pool) this._pool = null;
      });
      this._pool = pool;
    }
    return this._pool;
  }

  _terminate() {
    const pool = this._pool;
    this._pool = null;
    this._poisoned = false;
    pool?.then((p) => p.terminate(), () => {});
    for (const worker of this._workers) worker.terminate();
    this._workers = [];
  }

  _finish(load, error, onLoad, onError) {
    if (load.done) return;
    load.done = true;
    clearInterval(load.timer);
    load.controller.abort();
    this._loads.delete(load);
    if (error) {
      this._poisoned = true;
      error = error instanceof Error && String(error.message).startsWith('osteon:') ? error : new Error(message(error));
    }
    // A failed load may leave a decoder busy or broken: the workers go once nothing uses them.
    if (this._poisoned && this._loads.size === 0) this._terminate();
    if (error) {
      load.group.dispatchEvent({ type: 'error', error });
      this.manager.itemError(load.url);
      this.manager.itemEnd(load.url);
      if (onError) onError(error);
      else console.error(error);
      return;
    }
    load.group.dispatchEvent({ type: 'load' });
    if (onLoad) onLoad(load.group);
    this.manager.itemEnd(load.url);
  }

  /// Fails a load that has had no byte and no decode for `timeout` ms, naming what it waits for.
  _watch(load) {
    if (load.done || performance.now() - load.activity <= this.timeout) return;
    const seconds = `${(this.timeout / 1000).toFixed(this.timeout < 1000 ? 2 : 0)} s`;
    const [waiting] = load.fetching.keys();
    if (waiting) load.fail(new Error(`osteon: ${waiting}: no data for ${seconds} (timeout)`));
    else if (load.decoding) load.fail(new Error(`osteon: ${load.url}: the decoder answered nothing for ${seconds} (timeout)`));
    else load.fail(new Error(`osteon: ${load.url}: no progress for ${seconds} (timeout)`));
  }

  _fetch(load, url, init = {}) {
    return fetch(url, {
      ...init,
      headers: { ...this.requestHeader, ...init.headers },
      credentials: this.withCredentials ? 'include' : 'same-origin',
      signal: load.controller.signal,
    });
  }

  _busy(load, url, delta) {
    const n = (load.fetching.get(url) ?? 0) + delta;
    if (n > 0) load.fetching.set(url, n);
    else load.fetching.delete(url);
  }

  async _fetchManifest(load) {
    const { url } = load;
    this._busy(load, url, 1);
    try {
      let response;
      try {
        // A stall fails the load, whose end aborts the request.
        response = await within(this._fetch(load, url), kStallMs);
      } catch (e) {
        throw new Error(`osteon: ${url}: ${e?.stalled ? e.message : `fetch failed: ${e?.message ?? e}`}`);
      }
      if (!response.ok) throw new Error(`osteon: ${url}: HTTP ${response.status}${response.statusText ? ` ${response.statusText}` : ''}`);
      const pieces = [];
      let size = 0;
      const reader = response.body.getReader();
      for (;;) {
        let piece;
        try {
          piece = await readWithin(reader, kStallMs);
        } catch (e) {
          throw new Error(`osteon: ${url}: the download broke off after ${size} bytes: ${e?.message ?? e}`);
        }
        if (piece.done) break;
        load.activity = performance.now();
        size += piece.value.length;
        if (size > kMaxManifestBytes) {
          reader.cancel().catch(() => {});
          throw new Error(`osteon: ${url}: larger than ${kMaxManifestBytes} bytes: not a manifest`);
        }
        pieces.push(piece.value);
      }
      const bytes = new Uint8Array(size);
      let at = 0;
      for (const piece of pieces) {
        bytes.set(piece, at);
        at += piece.length;
      }
      let json;
      try {
        json = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(bytes));
      } catch (e) {
        throw new Error(`osteon: ${url}: not JSON: ${e?.message ?? e}`);
      }
      let manifest;
      try {
        manifest = parseManifest(json);
      } catch (e) {
        // manifest.mjs names the field; the file is named by its URL here.
        throw new Error(message(e).replace(/^osteon: manifest\.json:/, `osteon: ${url}:`));
      }
      // An instance the viewer leaves out and reports (a matrix with Infinity) ends a load here,
      // as any failure does: the group is all or nothing.
      if (manifest.refused.length) throw new Error(manifest.refused[0].replace(/^osteon: manifest\.json:/, `osteon: ${url}:`));
      return manifest;
    } finally {
      this._busy(load, url, -1);
    }
  }

  /// The Response createChunkStream reads for a span (stream.mjs planSpans): its bytes alone,
  /// counted as they arrive. A host that ignores Range and sends the whole chunk (200) is read
  /// up to the span's end and cut off.
  async _fetchSpan(load, span, onProgress) {
    const range = `bytes=${span.start}-${span.start + span.bytes - 1}`;
    // The request counts as waiting (for the time-out's message) until its body has ended.
    this._busy(load, span.url, 1);
    let open = true;
    const close = () => {
      if (open) this._busy(load, span.url, -1);
      open = false;
    };
    let response;
    try {
      response = await this._fetch(load, span.url, span.whole ? {} : { headers: { Range: range } });
    } catch (e) {
      close();
      throw e;
    }
    if (!response.ok) {
      close();
      return response;
    }
    let skip = 0;
    let length = null;
    if (!span.whole && response.status === 206) {
      const sent = /^bytes (\d+)-/.exec(response.headers.get('Content-Range') ?? '');
      if (sent && Number(sent[1]) !== span.start) {
        close();
        throw new Error(`the host sent ${response.headers.get('Content-Range')}, not ${range}`);
      }
    } else if (!span.whole) {
      skip = span.start;
      length = span.bytes;
    }
    if (!response.body) {
      const all = new Uint8Array(await response.arrayBuffer().finally(close));
      load.activity = performance.now();
      const body = length === null ? all : all.subarray(skip, skip + length);
      load.loaded += body.length;
      onProgress?.(body.length);
      return new Response(body);
    }
    return new Response(countedBody(response.body, skip, length, close, (useful) => {
      load.activity = performance.now();
      load.loaded += useful;
      if (useful) onProgress?.(useful);
    }));
  }

  async _run(load, onProgress) {
    const { group } = load;
    const pool = this._getPool();
    pool.catch(load.fail);
    const manifest = await this._fetchManifest(load);
    if (load.done) return;
    group.manifest = manifest;
    group.parts = manifest.parts;
    group.name = decodeURIComponent(new URL('.', load.url).pathname.split('/').filter(Boolean).pop() ?? '');
    const scene = createPackageScene(manifest, group);
    group._scene = scene;
    group.dispatchEvent({ type: 'manifest', manifest });

    const finest = (c) => c.levels[c.levels.length - 1];
    // [components, the stream of each]: one createChunkStream run per phase, in turn.
    const phases = this.levels === 'coarsest' ? [[manifest.components, (c) => c.first]]
      : this.levels === 'finest' ? [[manifest.components, finest]]
        : [[manifest.components, (c) => c.first], [manifest.components.filter((c) => c.levels.length > 1), finest]];
    // A stream's bytes are allocated before they arrive: a manifest may not ask for too many.
    for (const [components, streamOf] of phases) {
      for (const c of components) {
        const stream = streamOf(c);
        if (stream.bytes > kMaxSpanBytes) {
          const field = stream.level === c.levels.length - 1 ? `components[${c.index}].bytes` : `components[${c.index}].levels[${stream.level}].bytes`;
          throw new Error(`osteon: ${load.url}: ${field}: ${stream.bytes} bytes, more than this loader reads in one stream (${kMaxSpanBytes})`);
        }
      }
    }
    const order = new Map(manifest.streamOrder.map((c, i) => [c.id, i]));
    const plans = phases.map(([components, streamOf]) => ({
      spans: planSpans(manifest, load.url, [...components].sort((a, b) => order.get(a.id) - order.get(b.id)), streamOf),
    }));
    load.total = plans.reduce((sum, p) => sum + p.spans.reduce((s, span) => s + span.bytes, 0), 0);
    const lastLevel = (c) => (this.levels === 'coarsest' ? 0 : c.levels.length - 1);
    const progress = () => {
      if (!onProgress) return;
      const init = { lengthComputable: true, loaded: load.loaded, total: load.total };
      onProgress(typeof ProgressEvent === 'function' ? new ProgressEvent('progress', init) : { type: 'progress', ...init });
    };
    const objectsOf = new Map();  // component id -> its draw objects

    const added = (range, mesh) => {
      if (load.done) return;
      range.components.forEach((component, k) => {
        const level = range.levels[k];
        let objects = objectsOf.get(component.id);
        if (!objects) {
          objects = scene.addComponent(component.id, mesh, level);
          objectsOf.set(component.id, objects);
          for (const object of objects) describe(object, manifest, component, level);
        } else {
          scene.addLevel(component.id, level, mesh);
          scene.showLevel(component.id, level);
          for (const object of objects) object.userData.level = level;
        }
        for (const object of objects) group._geometries.add(object.geometry);
        const final = level === lastLevel(component);
        if (final) ++load.componentsDone;
        group.dispatchEvent({
          type: 'component',
          component: component.id,
          level,
          levels: component.levels.length,
          final,
          objects,
          parts: [...new Set(objects.flatMap((o) => o.userData.parts))],
          loaded: load.componentsDone,
          total: manifest.components.length,
        });
      });
    };

    // stream.mjs names a chunk as the manifest does (c/<h>.ostc); a page may load several packages.
    const chunkUrlIn = (text) => text.replace(/^osteon: (c\/[0-9a-f]{24}\.ostc)/, (_, file) => `osteon: ${new URL(file, load.url).href}`);
    load.componentsDone = 0;
    for (const { spans } of plans) {
      if (load.done) return;
      const stream = createChunkStream(spans, {
        limit: kChunksInFlight,
        signal: load.controller.signal,
        fetchChunk: (span) => this._fetchSpan(load, span, progress),
        decode: async (buffer, range) => {
          const decoder = await pool;
          ++load.decoding;
          try {
            return await decoder.decode(buffer, range.label, kDecodeOptions);
          } finally {
            --load.decoding;
            load.activity = performance.now();
          }
        },
        onDecoded: added,
        onFailed: (range, text) => load.fail(new Error(chunkUrlIn(text))),
        onChunkError: (span, text) => load.fail(new Error(chunkUrlIn(text))),
      });
      await stream.run();
    }
  }
}
