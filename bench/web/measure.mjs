// SPDX-License-Identifier: Apache-2.0
// One page load in headless Chromium, measured: the network throttled and the cache disabled
// through the DevTools protocol (on the page and on every worker it starts, so a decoder worker's
// own requests are throttled and counted too), service workers blocked, the CPU slowed for the
// phone profile (on the page only: Chromium refuses Emulation.setCPUThrottlingRate for workers),
// bytes from Network.loadingFinished, the page's measurement state (window.bench on the peer pages,
// window.osteon in the osteon viewer), a triangles-over-time series sampled on every animation
// frame (and, in a viewer with levels of detail, the largest screen-space error of a drawn bone),
// long tasks from a PerformanceObserver registered before any page script runs, and the JS heap
// of the page and its workers sampled every 50 ms. A load that runs past its time limit is
// reported with what it had reached by then, not dropped. Also extracts the triangles a page
// draws, in world space, for the Hausdorff check.

import { chromium } from 'playwright-core';

/// The network (and device) profiles. `label`: the tables' name, `short`: the plot's;
/// `cpuSlowdown`: Emulation.setCPUThrottlingRate's rate; `viewport`: the window, where it is not
/// the desktop one.
export const kProfiles = {
  slow: { label: '10 Mbit/s, 40 ms', short: '10 Mbit/s, 40 ms', latency: 40, bitsPerSecond: 10e6 },
  fast: { label: '100 Mbit/s, 10 ms', short: '100 Mbit/s, 10 ms', latency: 10, bitsPerSecond: 100e6 },
  phone: {
    label: 'phone: 9 Mbit/s, 170 ms, CPU / 4, 390 x 844',
    short: 'phone: 9 Mbit/s, 170 ms, CPU / 4',
    latency: 170,
    bitsPerSecond: 9e6,
    cpuSlowdown: 4,
    viewport: { width: 390, height: 844 },
  },
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
// A viewer with levels of detail has finished refining once it has been idle this long.
const kIdleMs = 300;
// The screen-space error is sampled at most this often (it walks every component).
const kErrorSampleMs = 100;

// Runs in every page before its own scripts: the long-task observer, the per-frame sampler of
// the triangles drawn (and of the largest screen-space error of a drawn bone, in pixels, where
// the viewer has levels of detail: window.osteon.levelPixels(id)[levelDrawn[id]], the drawn
// level's measured error projected at the view, over every component on screen), and three.js's
// devtools hook, through which every THREE.Scene a page creates announces itself (three.js
// dispatches 'observe' on window.__THREE_DEVTOOLS__ from the Scene constructor), so the scene of
// any three.js page, the osteon viewer included, can be read back without the page exporting it.
const kInitScript = `(() => {
  const probe = { longTasks: [], series: [], errorSeries: [], scenes: [] };
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
  let lastFrames = -1;
  let lastErrorAt = -Infinity;
  let lastError = null;
  probe.sampleError = (now, force) => {
    const o = window.osteon;
    if (!o || typeof o.levelPixels !== 'function' || !o.levelDrawn) return;
    // After each frame drawn, and until the viewer first has a value (it plans levels, and so
    // projects their errors, once the skeleton is complete).
    if (!force && ((o.frames === lastFrames && lastError !== null) || now - lastErrorAt < ${kErrorSampleMs})) return;
    lastFrames = o.frames;
    lastErrorAt = now;
    let worst = null;
    for (const id of Object.keys(o.levelDrawn)) {
      const px = o.levelPixels(id);
      const e = px && px[o.levelDrawn[id]];
      if (Number.isFinite(e) && (worst === null || e > worst)) worst = e;
    }
    if (worst !== null && worst !== lastError) { probe.errorSeries.push([now, worst]); lastError = worst; }
  };
  const sample = () => {
    const s = window.bench || window.osteon;
    const n = s && Number.isFinite(s.trianglesDrawn) ? s.trianglesDrawn : 0;
    const now = performance.now();
    if (n !== last) { probe.series.push([now, n]); last = n; }
    probe.sampleError(now, false);
    requestAnimationFrame(sample);
  };
  requestAnimationFrame(sample);
})();`;

export async function launchBrowser(executablePath) {
  return chromium.launch({ executablePath, headless: true, args: kChromiumArgs });
}

/// The page's measurement state in one shape, from the peer pages' window.bench or the osteon
/// viewer's window.osteon. The viewer's moments are read from its levels-of-detail fields
/// (firstFrameMs, skeletonCompleteMs, refinedMs, gpuBytes, budget, level counts) and, in a viewer
/// without them, from the older ones (firstComponentMs, allLoadedMs), so the bench runs either
/// way. `settled`: nothing more will change (the viewer's refineIdle, where it has one). With
/// `full`, also the level each component is drawn at (levelDrawn).
const readState = (full) => `(() => {
  const b = window.bench;
  if (b) return { kind: 'bench', done: !!b.done, settled: true, first: b.firstTrianglesMs, complete: b.allDrawnMs,
    refined: b.allDrawnMs, all: b.allDrawnMs, triangles: b.trianglesDrawn, rendered: b.trianglesRendered, frames: b.frames,
    gpuBytes: b.gpuBytes ?? null, gpuBytesPeak: b.gpuBytes ?? null, errors: (b.errors || []).map(String) };
  const o = window.osteon;
  if (!o) return null;
  const lod = 'refinedMs' in o;
  return { kind: 'osteon', done: !!o.done, settled: 'refineIdle' in o ? !!o.refineIdle : true, lod,
    first: o.firstFrameMs ?? o.firstComponentMs ?? null,
    complete: 'skeletonCompleteMs' in o ? o.skeletonCompleteMs : o.allLoadedMs ?? null,
    refined: lod ? o.refinedMs : o.allLoadedMs ?? null,
    firstRefined: o.firstRefinedMs ?? null,
    all: o.allLoadedMs ?? null,
    triangles: o.trianglesDrawn, errors: (o.errors || []).map((e) => String(e && e.message ? e.message : e)),
    components: o.componentsLoaded, componentsTotal: o.componentsTotal, frames: o.frames, manifestMs: o.manifestMs ?? null,
    firstFetchMs: o.fetchLog && o.fetchLog.length ? o.fetchLog.reduce((m, e) => Math.min(m, e.fetchStart ?? Infinity), Infinity) : null,
    bytesAtSkeletonComplete: o.bytesAtSkeletonComplete ?? null,
    gpuBytes: o.gpuBytes ?? null, gpuBytesPeak: o.gpuBytesPeak ?? o.gpuBytes ?? null, gpuTriangles: o.gpuTriangles ?? null,
    budget: o.budget ? { bytes: o.budget.bytes ?? null, triangles: o.budget.triangles ?? null } : null,
    maxPixelError: o.maxPixelError ?? null, levelsTotal: o.levelsTotal ?? null, levelsLoaded: o.levelsLoaded ?? null,
    levelsFailed: o.levelsFailed ?? null, evictions: o.evictions ?? null,
    levelDrawn: ${full ? 'o.levelDrawn ? { ...o.levelDrawn } : null' : 'undefined'} };
})()`;
const kReadState = readState(false);

// True once the page is done and (a viewer with levels of detail) has stayed idle kIdleMs; it
// records the moment it first saw the page done and idle as __benchProbe.endMs.
const kFinished = `(() => {
  const s = ${kReadState};
  const probe = window.__benchProbe;
  if (!s || !s.done || !s.settled) { probe.idleSince = null; return false; }
  const now = performance.now();
  probe.idleSince = probe.idleSince ?? now;
  if (now - probe.idleSince < ${kIdleMs} && s.kind === 'osteon' && s.lod) return false;
  probe.endMs = probe.idleSince;
  return true;
})()`;

/// Speaks CDP to the page and, through Target.setAutoAttach (non-flat sessions, so Playwright's
/// own session is left alone), to every worker: each is paused at start, gets the same cache,
/// network and CPU settings, then runs. Returns the probe; `cpu` says where the CPU slowdown
/// took (Emulation.setCPUThrottlingRate on the page; each worker that accepted it).
async function instrument(context, page, profile) {
  const cdp = await context.newCDPSession(page);
  // `inFlight`: per request still loading, the bytes received so far (Network.dataReceived), so a
  // load stopped at its time limit counts what it had downloaded.
  const net = { bytes: 0, requests: 0, failed: [], urls: new Map(), transfers: [], inFlight: new Map() };
  const cpu = { rate: profile?.cpuSlowdown ?? 1, page: null, workersAccepted: 0, workersRefused: 0, workerError: null };
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
  const cpuSetting = cpu.rate > 1 ? ['Emulation.setCPUThrottlingRate', { rate: cpu.rate }] : null;
  // Request ids are unique per target, so each is keyed with its session ('' for the page).
  const onNetwork = (method, params, session = '') => {
    const key = `${session}:${params.requestId}`;
    if (method === 'Network.requestWillBeSent') {
      net.urls.set(key, params.request.url);
    } else if (method === 'Network.dataReceived') {
      net.inFlight.set(key, (net.inFlight.get(key) ?? 0) + Math.max(0, params.encodedDataLength ?? 0));
    } else if (method === 'Network.loadingFinished') {
      net.inFlight.delete(key);
      // A worker started from a blob: URL reports -1: nothing came over the network.
      const bytes = Math.max(0, params.encodedDataLength);
      if (bytes === 0) return;
      net.bytes += bytes;
      net.requests += 1;
      net.transfers.push([new URL(net.urls.get(key) ?? 'unknown:', 'http://x/').pathname, bytes, session ? 'worker' : 'page']);
    } else if (method === 'Network.loadingFailed') {
      net.inFlight.delete(key);
      // ERR_CACHE_MISS answers a request made with cache: 'only-if-cached' (the viewer's offline
      // worker asks the HTTP cache first, then the network): a question, not a failure.
      if (!params.canceled && params.errorText !== 'net::ERR_CACHE_MISS') {
        net.failed.push(`${net.urls.get(key) ?? params.requestId}: ${params.errorText}`);
      }
    }
  };
  for (const method of ['Network.requestWillBeSent', 'Network.dataReceived', 'Network.loadingFinished', 'Network.loadingFailed']) {
    cdp.on(method, (p) => onNetwork(method, p));
  }

  // Resolves with the reply's result, or null when the target answered with an error or is gone
  // (the error's message goes to `onError`).
  const sendToWorker = (sessionId, method, params = {}, onError = () => {}) => {
    const id = nextId++;
    const pending = workers.get(sessionId);
    const reply = new Promise((resolve) => pending?.set(id, (result, error) => {
      if (error) onError(error.message ?? JSON.stringify(error));
      resolve(result);
    }));
    cdp.send('Target.sendMessageToTarget', { sessionId, message: JSON.stringify({ id, method, params }) }).catch(() => {
      pending?.get(id)?.(null);
    });
    return reply;
  };
  // The paused worker's settings go out together and it is resumed in the same breath: a target
  // runs its commands in the order they were sent, so the settings are in force before it runs,
  // and the pause is one round trip, not one per command (awaited one by one they held each
  // worker 30-200 ms on a loaded machine, a start the peers' pages, which use no workers, never
  // pay).
  cdp.on('Target.attachedToTarget', async (e) => {
    workers.set(e.sessionId, new Map());
    const replies = settings.map(([method, params]) => sendToWorker(e.sessionId, method, params));
    if (cpuSetting) {
      // Chromium answers "Operation is only supported for pages, not workers": the slowdown
      // reaches the page's main thread only, which the report says.
      replies.push(sendToWorker(e.sessionId, ...cpuSetting, (message) => { cpu.workerError ??= message; })
        .then((ok) => {
          if (ok) cpu.workersAccepted += 1;
          else cpu.workersRefused += 1;
        }));
    }
    if (e.targetInfo.type === 'worker') replies.push(sendToWorker(e.sessionId, 'Runtime.evaluate', { expression: kWorkerInitScript }));
    replies.push(sendToWorker(e.sessionId, 'Runtime.runIfWaitingForDebugger'));
    await Promise.all(replies);
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
        resolve(message.error ? null : message.result, message.error);
      }
    } else if (message.method) {
      onNetwork(message.method, message.params, e.sessionId);
    }
  });

  for (const [method, params] of settings) await cdp.send(method, params);
  if (cpuSetting) {
    cpu.page = await cdp.send(...cpuSetting).then(() => true, () => false);
  }
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
    cpu,
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
/// Returns { firstMs, completeMs, refinedMs, allMs, finished, timedOut, trianglesDrawn, bytes,
/// requests, tbtMs, longestTaskMs, longTasks, peakHeapBytes, gpuBytes, series, errorSeries,
/// errors, state, ... }. Moments are ms from navigation start; one the page did not reach is null.
/// A load still running at `timeoutMs` is stopped and returned with `timedOut` set and what it
/// had reached by then (its first frame, say); an uncaught exception or a page error ends it
/// with `errors`. With `extract`, also returns the drawn triangles ({ positions: Float32Array,
/// indices: Uint32Array }) in `drawn`.
export async function measureLoad(browser, url, { profile, viewport, timeoutMs, extract = false }) {
  // Service workers blocked: the viewer's offline copy of the package (its `offline` attribute),
  // fetched once loading has settled, is not part of a load, and landed in some loads' byte
  // counts and not others.
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1, serviceWorkers: 'block' });
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
    let timedOut = false;
    let failure = null;
    const started = Date.now();
    try {
      await page.goto(url, { waitUntil: 'commit', timeout: timeoutMs });
      await Promise.race([
        page.waitForFunction(kFinished, null, { timeout: Math.max(1, timeoutMs - (Date.now() - started)), polling: 100 }),
        uncaught,
      ]);
      // Two more frames, so the sampler has seen the last change drawn; then the long tasks
      // still being reported arrive.
      await page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve))));
      await page.waitForTimeout(kSettleMs);
    } catch (e) {
      if (/Timeout/i.test(e.name) || /Timeout \d+ms exceeded/.test(e.message)) {
        timedOut = true;
      } else {
        const state = await page.evaluate(kReadState).catch(() => null);
        failure = `${url}: ${e.message.split('\n')[0]}; state ${JSON.stringify(state)}; page errors: ${consoleErrors.slice(0, 3).join(' | ') || 'none'}`;
      }
    } finally {
      probe.stop();
    }
    // What the requests still loading had received (a load stopped at its limit).
    const inFlightBytes = [...probe.net.inFlight.values()].reduce((a, b) => a + b, 0);
    if (failure) throw new Error(failure);
    // A page too busy to answer within a few seconds more is reported as it was at the limit.
    const evaluate = (expr) => Promise.race([page.evaluate(expr), new Promise((_, reject) => setTimeout(() => reject(new Error('the page did not answer')), 15000))]);
    const state = await evaluate(readState(true)).catch(() => null);
    const sampled = await evaluate(`(() => {
      const p = window.__benchProbe;
      p.sampleError(performance.now(), true);
      return { longTasks: p.longTasks, series: p.series, errorSeries: p.errorSeries, endMs: p.endMs ?? null, now: performance.now(), observerError: p.observerError ?? null };
    })()`).catch(() => ({ longTasks: [], series: [], errorSeries: [], endMs: null, now: null }));
    if (!state && !timedOut) throw new Error(`${url}: the page has no window.bench or window.osteon`);
    const s = state ?? { errors: [], triangles: 0 };
    const { longTasks, series, errorSeries } = sampled;
    const errors = [...(s.errors ?? []), ...probe.net.failed.map((e) => `request failed: ${e}`)];
    // The moments are the page's own: when the frame that drew them had been rendered
    // (window.bench: renderer.render() returned; the viewer: its render worker's frame, on the
    // page's clock), so a frame the page's main thread learns of late is not counted late. The
    // sampler's series (the first animation frame whose count held a triangle, and, for a load
    // that finished, the first that held them all) is the fallback and what the plot shows.
    const finished = !timedOut && !!s.done;
    const firstFrame = series.find(([, n]) => n > 0);
    const allFrame = finished ? series.find(([, n]) => n >= s.triangles && n > 0) : null;
    const sampledFirstMs = firstFrame ? firstFrame[0] : null;
    const sampledAllMs = allFrame ? allFrame[0] : null;
    // Peers: every bone is drawn, at its only level, when everything is. The viewer: its own
    // moments (skeleton complete: every bone at some level; refined: every visible bone within
    // its pixel error or at its finest level); its "all drawn" is the sampled last change.
    const peer = s.kind === 'bench';
    const firstMs = s.first ?? sampledFirstMs;
    const allMs = peer ? (finished ? s.all ?? sampledAllMs : null) : sampledAllMs;
    const completeMs = peer ? allMs : s.complete ?? null;
    const refinedMs = peer ? allMs : s.refined ?? null;
    // Total blocking time: the part beyond 50 ms of every long task that started before the load
    // ended (all drawn; the viewer: refined or idle; else the time limit), from navigation start.
    const end = finished ? Math.max(allMs ?? 0, completeMs ?? 0, refinedMs ?? 0, sampled.endMs ?? 0) : Infinity;
    let tbt = 0;
    let longest = 0;
    let counted = 0;
    for (const [start, duration] of longTasks) {
      if (start > end) continue;
      tbt += Math.max(0, duration - 50);
      longest = Math.max(longest, duration);
      counted += 1;
    }
    const result = {
      finished,
      timedOut,
      timeLimitMs: timeoutMs,
      firstMs,
      completeMs,
      refinedMs,
      allMs,
      sampledFirstMs,
      sampledAllMs,
      pageFirstMs: s.first ?? null,
      pageCompleteMs: s.complete ?? null,
      pageRefinedMs: s.refined ?? null,
      pageAllMs: s.all ?? null,
      firstRefinedMs: s.firstRefined ?? null,
      hasLevels: !!s.lod,
      trianglesDrawn: s.triangles ?? 0,
      trianglesRendered: s.rendered ?? null,
      frames: s.frames ?? null,
      manifestMs: s.manifestMs ?? null,
      firstFetchMs: Number.isFinite(s.firstFetchMs) ? s.firstFetchMs : null,
      bytesAtSkeletonComplete: s.bytesAtSkeletonComplete ?? null,
      bytes: probe.net.bytes + (timedOut ? inFlightBytes : 0),
      inFlightBytes,
      requests: probe.net.requests,
      transfers: probe.net.transfers,
      tbtMs: tbt,
      longestTaskMs: longest,
      longTasks: counted,
      longTaskObserverError: sampled.observerError ?? null,
      peakHeapBytes: probe.heap.peak,
      heapSamples: probe.heap.samples,
      gpuBytes: s.gpuBytes ?? null,
      gpuBytesPeak: s.gpuBytesPeak ?? null,
      gpuTriangles: s.gpuTriangles ?? null,
      budget: s.budget ?? null,
      maxPixelError: s.maxPixelError ?? null,
      levelsTotal: s.levelsTotal ?? null,
      levelsLoaded: s.levelsLoaded ?? null,
      levelsFailed: s.levelsFailed ?? null,
      evictions: s.evictions ?? null,
      levelDrawn: s.levelDrawn ?? null,
      cpu: probe.cpu,
      series,
      errorSeries,
      errors,
      state: state ? { ...state, levelDrawn: undefined } : null,
    };
    if (extract && finished) result.drawn = await extractDrawn(page, probe);
    return result;
  } finally {
    await context.close();
  }
}

export async function canvasSize(browser, url, viewport, timeoutMs) {
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1 });
  try {
    const page = await context.newPage();
    await page.goto(url, { waitUntil: 'load', timeout: timeoutMs });
    await page.waitForFunction(() => {
      const c = document.querySelector('canvas') ?? document.querySelector('osteon-viewer')?.shadowRoot?.querySelector('canvas');
      return c && c.clientWidth > 0 && c.clientHeight > 0;
    }, null, { timeout: timeoutMs, polling: 100 });
    return await page.evaluate(() => {
      const c = document.querySelector('canvas') ?? document.querySelector('osteon-viewer')?.shadowRoot?.querySelector('canvas');
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
