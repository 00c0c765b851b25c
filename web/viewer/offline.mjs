// SPDX-License-Identifier: Apache-2.0
// Offline use, the page's side (docs/DESIGN.md, "Offline use"): registers the package's service
// worker (sw.js, service_worker.js) and tells it what the page loaded before the worker was
// there to see it. The standalone page asks for it (its element carries `offline`); an element
// on another page only when it carries the attribute, since a worker, once registered, serves its
// scope on that origin long after the page has gone.
//
// Nothing here may hold back the first view: the registration waits for the element's 'load'
// (every component drawn at its first level, or failed), then for the refinement of the opening
// view to settle (the report's refineIdle, at most kRefineWaitMs), then for an idle moment, so
// the worker's install (it fetches the viewer's files, mostly from the HTTP cache) and its copies
// of whole chunks never compete with the manifest, the first chunks or the level fetches.
// Measured on BodyParts3D at 100 Mbit/s (bench/web): registered at 'load', 1.49 MB crossed the
// link before the view was refined, against 0.47 MB without a worker. Only http(s) secure contexts (https, or localhost)
// have service workers; elsewhere, and where the worker's script is on another origin (a
// worker must come from the page's), this does nothing. A failure to register is silent: the
// viewer works as it does without a worker.

import { whenIdle } from './stream.mjs';

// A content-hashed name (service_worker.js kHashed): the files the worker keeps.
const kHashed = /[/-][0-9a-f]{24}\.[a-z0-9]+$/;

/// The longest the registration waits for the opening view's refinement to settle.
const kRefineWaitMs = 30000;
/// Then the longest it waits for an idle moment.
const kIdleWaitMs = 2000;

/// Resolves once `host`'s report says the refinement in flight has settled (a package without
/// levels has nothing to refine), or after kRefineWaitMs.
function refineSettled(host) {
  const start = Date.now();
  return new Promise((resolve) => {
    const check = () => {
      const report = host.report;
      if (!report || report.refineIdle || Date.now() - start >= kRefineWaitMs) resolve();
      else setTimeout(check, 250);
    };
    check();
  });
}


/// The registration of `url`'s worker, shared by every element of the page, with what the page
/// loaded (resource timing entries' URLs) while the worker was not yet active.
const workers = new Map();  // worker URL -> { scope, active, pending: [url], observer }

function workerFor(url) {
  let entry = workers.get(url);
  if (entry) return entry;
  entry = { scope: new URL('./', url).href, active: null, pending: [], started: false };
  const post = (urls) => {
    const files = urls.filter((u) => u.startsWith(entry.scope) && kHashed.test(new URL(u).pathname));
    if (files.length) entry.active.postMessage({ type: 'osteon-keep', files });
  };
  entry.post = post;
  // From the page's start (buffered): the chunks and bundles fetched before the worker came.
  new PerformanceObserver((list) => {
    const urls = list.getEntries().map((e) => e.name);
    if (entry.active) post(urls);
    else entry.pending.push(...urls);
  }).observe({ type: 'resource', buffered: true });
  workers.set(url, entry);
  return entry;
}

/// The worker of `registration` once it is active.
function activeWorker(registration) {
  if (registration.active) return Promise.resolve(registration.active);
  return new Promise((resolve, reject) => {
    const worker = registration.installing ?? registration.waiting;
    if (!worker) return reject(new Error('no worker'));
    worker.addEventListener('statechange', () => {
      if (worker.state === 'activated') resolve(worker);
      else if (worker.state === 'redundant') reject(new Error('the worker failed to install'));
    });
  });
}

/// Makes the package of `host` (an <osteon-viewer>) available offline: registers `worker` (the
/// URL of sw.js) once `host` has loaded, then sends it the manifest the page read (`manifestUrl`,
/// `manifest`: a Promise of its text) and the content-hashed files the page fetched.
export function keepOffline(host, { worker, manifestUrl, manifest }) {
  if (typeof navigator === 'undefined' || !navigator.serviceWorker || !globalThis.isSecureContext) return;
  let url;
  try {
    url = new URL(worker);
  } catch (e) {
    return;
  }
  if (!/^https?:$/.test(url.protocol) || url.origin !== location.origin) return;
  const entry = workerFor(url.href);
  host.addEventListener('load', () => refineSettled(host).then(() => whenIdle(async () => {
    try {
      if (!entry.started) {
        entry.started = true;
        entry.registration = navigator.serviceWorker.register(url.href);
      }
      const active = await activeWorker(await entry.registration);
      entry.active = active;
      const text = await manifest;
      active.postMessage({ type: 'osteon-keep', manifest: { url: manifestUrl, text }, files: [] });
      entry.post(entry.pending.splice(0));
    } catch (e) {
      // Offline use is an extra: without it the viewer loads from the network, as ever.
    }
  }, kIdleWaitMs)), { once: true });
}
