// SPDX-License-Identifier: Apache-2.0
// One page load in headless Chromium, measured: the network throttled and the cache disabled
// through the DevTools protocol (on the page and on every worker it starts, so a decoder worker's
// own requests are throttled and counted too), bytes from Network.loadingFinished, the page's
// measurement state (window.bench on the peer pages, window.osteon in the osteon viewer), a
// triangles-over-time series sampled on every animation frame, long tasks from a
// PerformanceObserver registered before any page script runs, and the JS heap of the page and its
// workers sampled every 50 ms. Also extracts the triangles a page draws, in world space, for the
// Hausdorff check.

import { chromium } from 'playwright-core';

export const kProfiles = {
  slow: { label: '10 Mbit/s, 40 ms', latency: 40, bitsPerSecond: 10e6 },
  fast: { label: '100 Mbit/s, 10 ms', latency: 10, bitsPerSecond: 100e6 },
};

/// Chromium's flags: WebGL through SwiftShader (there is no GPU), exact heap figures.
export const kChromiumArgs = [
  '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader',
  '--ignore-gpu-blocklist',
  '--enable-precise-memory-info',
];

const kHeapIntervalMs = 50;
// Long tasks are reported a little after they end; this long after the last frame they are in.
const kSettleMs = 300;

// Runs in every page before its own scripts: the long-task observer, the per-frame sampler of
// the triangles drawn, and three.js's devtools hook, through which every THREE.Scene a page
// creates announces itself (three.js dispatches 'observe' on window.__THREE_DEVTOOLS__ from the
// Scene constructor), so the scene of any three.js page, the osteon viewer included, can be read
// back without the page exporting it.
const kInitScript = `(() => {
  const probe = { longTasks: [], series: [], scenes: [] };
  window.__benchProbe = probe;
  try {
    new PerformanceObserver((list) => {
      for (const e of list.getEntries()) probe.longTasks.push([e.startTime, e.duration]);
    }).observe({ type: 'longtask', buffered: true });
  } catch (e) {
    probe.observerError = String(e);
  }
  const hook = new EventTarget();
  hook.addEventListener('observe', (e) => { if (e.detail && e.detail.isScene) probe.scenes.push(e.detail); });
  window.__THREE_DEVTOOLS__ = hook;
  let last = -1;
  const sample = () => {
    const s = window.bench || window.osteon;
    const n = s && Number.isFinite(s.trianglesDrawn) ? s.trianglesDrawn : 0;
    if (n !== last) { probe.series.push([performance.now(), n]); last = n; }
    requestAnimationFrame(sample);
  };
  requestAnimationFrame(sample);
})();`;

export async function launchBrowser(executablePath) {
  return chromium.launch({ executablePath, headless: true, args: kChromiumArgs });
}

/// The page's measurement state in one shape: the peer pages' window.bench or the osteon
/// viewer's window.osteon (firstComponentMs / allLoadedMs).
const kReadState = `(() => {
  const b = window.bench;
  if (b) return { kind: 'bench', done: !!b.done, first: b.firstTrianglesMs, all: b.allDrawnMs,
    triangles: b.trianglesDrawn, rendered: b.trianglesRendered, frames: b.frames, errors: (b.errors || []).map(String) };
  const o = window.osteon;
  if (o) return { kind: 'osteon', done: !!o.done, first: o.firstComponentMs ?? null, all: o.allLoadedMs ?? null,
    triangles: o.trianglesDrawn, errors: (o.errors || []).map((e) => String(e && e.message ? e.message : e)),
    components: o.componentsLoaded, componentsTotal: o.componentsTotal, frames: o.frames, manifestMs: o.manifestMs ?? null,
    firstFetchMs: o.fetchLog && o.fetchLog.length ? o.fetchLog.reduce((m, e) => Math.min(m, e.fetchStart ?? Infinity), Infinity) : null };
  return null;
})()`;

/// Speaks CDP to the page and, through Target.setAutoAttach (non-flat sessions, so Playwright's
/// own session is left alone), to every worker: each is paused at start, gets the same cache and
/// throttling settings, then runs.
async function instrument(context, page, profile) {
  const cdp = await context.newCDPSession(page);
  const net = { bytes: 0, requests: 0, failed: [], urls: new Map(), transfers: [] };
  const workers = new Map(); // sessionId -> pending replies
  let nextId = 1;

  const settings = [
    ['Network.enable', {}],
    ['Network.setCacheDisabled', { cacheDisabled: true }],
  ];
  if (profile) {
    const bytesPerSecond = profile.bitsPerSecond / 8;
    settings.push(['Network.emulateNetworkConditions', {
      offline: false, latency: profile.latency, downloadThroughput: bytesPerSecond, uploadThroughput: bytesPerSecond,
    }]);
  }
  // Request ids are unique per target, so each is keyed with its session ('' for the page).
  const onNetwork = (method, params, session = '') => {
    const key = `${session}:${params.requestId}`;
    if (method === 'Network.requestWillBeSent') {
      net.urls.set(key, params.request.url);
    } else if (method === 'Network.loadingFinished') {
      // A worker started from a blob: URL reports -1: nothing came over the network.
      const bytes = Math.max(0, params.encodedDataLength);
      if (bytes === 0) return;
      net.bytes += bytes;
      net.requests += 1;
      net.transfers.push([new URL(net.urls.get(key) ?? 'unknown:', 'http://x/').pathname, bytes, session ? 'worker' : 'page']);
    } else if (method === 'Network.loadingFailed' && !params.canceled) {
      net.failed.push(`${net.urls.get(key) ?? params.requestId}: ${params.errorText}`);
    }
  };
  for (const method of ['Network.requestWillBeSent', 'Network.loadingFinished', 'Network.loadingFailed']) {
    cdp.on(method, (p) => onNetwork(method, p));
  }

  const sendToWorker = (sessionId, method, params = {}) => {
    const id = nextId++;
    const pending = workers.get(sessionId);
    const reply = new Promise((resolve) => pending?.set(id, resolve));
    cdp.send('Target.sendMessageToTarget', { sessionId, message: JSON.stringify({ id, method, params }) }).catch(() => {
      pending?.get(id)?.(null);
    });
    return reply;
  };
  cdp.on('Target.attachedToTarget', async (e) => {
    workers.set(e.sessionId, new Map());
    for (const [method, params] of settings) await sendToWorker(e.sessionId, method, params);
    if (e.targetInfo.type === 'worker') await sendToWorker(e.sessionId, 'Runtime.evaluate', { expression: kWorkerInitScript });
    await sendToWorker(e.sessionId, 'Runtime.runIfWaitingForDebugger');
  });
  cdp.on('Target.detachedFromTarget', (e) => {
    const pending = workers.get(e.sessionId);
    if (pending) for (const resolve of pending.values()) resolve(null);
    workers.delete(e.sessionId);
  });
  cdp.on('Target.receivedMessageFromTarget', (e) => {
    const message = JSON.parse(e.message);
    if (message.id !== undefined) {
      const pending = workers.get(e.sessionId);
      const resolve = pending?.get(message.id);
      if (resolve) {
        pending.delete(message.id);
        resolve(message.error ? null : message.result);
      }
    } else if (message.method) {
      onNetwork(message.method, message.params, e.sessionId);
    }
  });

  for (const [method, params] of settings) await cdp.send(method, params);
  await cdp.send('Target.setAutoAttach', { autoAttach: true, waitForDebuggerOnStart: true, flatten: false });

  // Heap: V8's used heap plus ArrayBuffer / WebAssembly memory backing stores (where decoded
  // meshes live), page and workers summed, sampled every 50 ms; the peak is kept.
  const heap = { peak: 0, samples: 0 };
  let busy = false;
  const timer = setInterval(async () => {
    if (busy) return;
    busy = true;
    try {
      const usages = await Promise.all([
        cdp.send('Runtime.getHeapUsage').catch(() => null),
        ...[...workers.keys()].map((s) => sendToWorker(s, 'Runtime.getHeapUsage')),
      ]);
      let total = 0;
      for (const u of usages) if (u) total += u.usedSize + (u.backingStorageSize || 0);
      heap.peak = Math.max(heap.peak, total);
      heap.samples += 1;
    } finally {
      busy = false;
    }
  }, kHeapIntervalMs);

  return {
    cdp,
    net,
    heap,
    stop: () => clearInterval(timer),
    workerSessions: () => [...workers.keys()],
    /// Evaluates `expression` in a worker; resolves with its value (JSON), rejects on an exception.
    async evaluateInWorker(sessionId, expression) {
      const reply = await sendToWorker(sessionId, 'Runtime.evaluate', { expression, returnByValue: true, awaitPromise: true });
      if (!reply) throw new Error('the worker is gone');
      if (reply.exceptionDetails) throw new Error(reply.exceptionDetails.exception?.description ?? reply.exceptionDetails.text);
      return reply.result.value;
    },
  };
}

/// Loads `url` once under `profile` (null: unthrottled) in a fresh context and measures it.
/// Returns { firstMs, allMs, trianglesDrawn, bytes, requests, tbtMs, longTasks, peakHeapBytes,
/// series, errors, state } or throws on a timeout. With `extract`, also returns the drawn
/// triangles ({ positions: Float32Array, indices: Uint32Array }) in `drawn`.
export async function measureLoad(browser, url, { profile, viewport, timeoutMs, extract = false }) {
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1 });
  try {
    await context.addInitScript(kInitScript);
    const page = await context.newPage();
    const consoleErrors = [];
    // An uncaught exception ends the wait at once instead of at the timeout.
    let rejectOnError;
    const uncaught = new Promise((_, reject) => {
      rejectOnError = reject;
    });
    uncaught.catch(() => {});
    page.on('pageerror', (e) => {
      consoleErrors.push(String(e.message || e));
      rejectOnError(new Error(`uncaught exception in the page: ${e.message || e}`));
    });
    page.on('console', (m) => {
      if (m.type() === 'error') consoleErrors.push(m.text());
    });
    const probe = await instrument(context, page, profile);
    try {
      await page.goto(url, { waitUntil: 'commit', timeout: timeoutMs });
      await Promise.race([
        page.waitForFunction(`(() => { const s = ${kReadState}; return s && s.done; })()`, null, {
          timeout: timeoutMs,
          polling: 100,
        }),
        uncaught,
      ]);
      // Two more frames, so the sampler has seen the last change drawn; then the long tasks
      // still being reported arrive.
      await page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve))));
      await page.waitForTimeout(kSettleMs);
    } catch (e) {
      const state = await page.evaluate(kReadState).catch(() => null);
      throw new Error(`${url}: ${e.message.split('\n')[0]}; state ${JSON.stringify(state)}; page errors: ${consoleErrors.slice(0, 3).join(' | ') || 'none'}`);
    } finally {
      probe.stop();
    }
    const state = await page.evaluate(kReadState);
    const { longTasks, series } = await page.evaluate(() => ({
      longTasks: window.__benchProbe.longTasks,
      series: window.__benchProbe.series,
    }));
    const errors = [...state.errors, ...probe.net.failed.map((e) => `request failed: ${e}`)];
    // On screen: the first animation frame whose scene held a triangle, and the first that held
    // them all (the sampler runs at the start of each frame, before the page's own render in it).
    const firstFrame = series.find(([, n]) => n > 0);
    const allFrame = series.find(([, n]) => n >= state.triangles && n > 0);
    const allMs = allFrame ? allFrame[0] : null;
    // Total blocking time: the part beyond 50 ms of every long task that started before
    // everything was on screen (from navigation start).
    let tbt = 0;
    for (const [start, duration] of longTasks) if (start <= (allMs ?? Infinity)) tbt += Math.max(0, duration - 50);
    const result = {
      firstMs: firstFrame ? firstFrame[0] : null,
      allMs,
      pageFirstMs: state.first,
      pageAllMs: state.all,
      trianglesDrawn: state.triangles,
      trianglesRendered: state.rendered ?? null,
      frames: state.frames ?? null,
      manifestMs: state.manifestMs ?? null,
      firstFetchMs: Number.isFinite(state.firstFetchMs) ? state.firstFetchMs : null,
      bytes: probe.net.bytes,
      requests: probe.net.requests,
      transfers: probe.net.transfers,
      tbtMs: tbt,
      longTasks: longTasks.length,
      peakHeapBytes: probe.heap.peak,
      heapSamples: probe.heap.samples,
      series,
      errors,
      state,
    };
    if (extract) result.drawn = await extractDrawn(page, probe);
    return result;
  } finally {
    await context.close();
  }
}

/// The canvas size of a page (the osteon viewer's: every peer page is given the same size).
export async function canvasSize(browser, url, viewport, timeoutMs) {
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1 });
  try {
    const page = await context.newPage();
    await page.goto(url, { waitUntil: 'load', timeout: timeoutMs });
    await page.waitForFunction(() => {
      const c = document.querySelector('canvas');
      return c && c.clientWidth > 0 && c.clientHeight > 0;
    }, null, { timeout: timeoutMs, polling: 100 });
    return await page.evaluate(() => {
      const c = document.querySelector('canvas');
      // A canvas of its own: the page's may have been handed to a worker (OffscreenCanvas).
      const probe = document.createElement('canvas');
      const gl = probe.getContext('webgl2') || probe.getContext('webgl');
      const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
      return {
        width: c.clientWidth,
        height: c.clientHeight,
        renderer: info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : null,
      };
    });
  } finally {
    await context.close();
  }
}

// Installs three.js's devtools hook in a worker before its scripts run (the osteon viewer renders
// in a worker, on an OffscreenCanvas), so its scenes can be read back like the page's.
const kWorkerInitScript = `(() => {
  const probe = { scenes: [] };
  self.__benchProbe = probe;
  const hook = new EventTarget();
  hook.addEventListener('observe', (e) => { if (e.detail && e.detail.isScene) probe.scenes.push(e.detail); });
  self.__THREE_DEVTOOLS__ = hook;
})()`;

// The number of meshes in the largest THREE.Scene of a page or worker (0 when none).
const kCountMeshes = `(() => {
  const scenes = (self.__benchProbe && self.__benchProbe.scenes) || [];
  let best = 0;
  for (const s of scenes) { let n = 0; s.traverse((o) => { if (o.isMesh) n += 1; }); best = Math.max(best, n); }
  return best;
})()`;

// Every triangle the largest THREE.Scene of this page or worker draws, in world space: visible
// meshes (their ancestors visible too), index and draw range honoured, instanced meshes once per
// instance (instance matrix, then the object's world matrix), quantized or interleaved attributes
// read through three.js's own accessors. Returns base64 of float32 positions and uint32 indices.
const kExtract = `(() => {
  const scenes = self.__benchProbe.scenes;
  const count = (s) => { let n = 0; s.traverse((o) => { if (o.isMesh) n += 1; }); return n; };
  const scene = scenes.reduce((a, b) => (count(b) > count(a) ? b : a));
  scene.updateMatrixWorld(true);
  const pos = [];
  const idx = [];
  let base = 0;
  scene.traverseVisible((o) => {
    if (!o.isMesh || !o.geometry) return;
    const g = o.geometry;
    const p = g.getAttribute('position');
    if (!p) return;
    const index = g.index;
    const total = index ? index.count : p.count;
    const start = Math.max(0, g.drawRange.start);
    const end = Math.min(total, g.drawRange.start + g.drawRange.count);
    const instances = o.isInstancedMesh ? o.count : 1;
    const m = o.matrixWorld.clone();
    const im = m.clone();
    const v = m.clone();
    const e = v.elements;
    for (let k = 0; k < instances; ++k) {
      if (o.isInstancedMesh) {
        o.getMatrixAt(k, im);
        v.multiplyMatrices(m, im);
      } else {
        v.copy(m);
      }
      for (let i = 0; i < p.count; ++i) {
        const x = p.getX(i), y = p.getY(i), z = p.getZ(i);
        pos.push(e[0] * x + e[4] * y + e[8] * z + e[12], e[1] * x + e[5] * y + e[9] * z + e[13], e[2] * x + e[6] * y + e[10] * z + e[14]);
      }
      for (let c = start; c + 2 < end; c += 3) {
        for (let j = 0; j < 3; ++j) idx.push(base + (index ? index.getX(c + j) : c + j));
      }
      base += p.count;
    }
  });
  const b64 = (typed) => {
    const bytes = new Uint8Array(typed.buffer);
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return btoa(s);
  };
  return { positions: b64(new Float32Array(pos)), indices: b64(new Uint32Array(idx)) };
})()`;

/// The triangles a page draws: read from the largest three.js scene of the page or of any of its
/// workers (whichever has the most meshes).
async function extractDrawn(page, probe) {
  const places = [{ where: 'page', run: (expr) => page.evaluate(expr) }];
  for (const sessionId of probe.workerSessions()) {
    places.push({ where: `worker ${sessionId.slice(0, 8)}`, run: (expr) => probe.evaluateInWorker(sessionId, expr) });
  }
  let best = null;
  let bestCount = 0;
  for (const place of places) {
    const n = await place.run(kCountMeshes).catch(() => 0);
    if (n > bestCount) {
      best = place;
      bestCount = n;
    }
  }
  if (!best) throw new Error('no THREE.Scene with meshes in the page or its workers (three.js without its devtools hook?)');
  const { positions, indices } = await best.run(kExtract);
  const decode = (s, Type) => {
    const bytes = new Uint8Array(Buffer.from(s, 'base64')); // a copy: its own, aligned buffer
    return new Type(bytes.buffer);
  };
  return { positions: decode(positions, Float32Array), indices: decode(indices, Uint32Array), where: best.where };
}
