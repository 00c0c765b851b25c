// SPDX-License-Identifier: Apache-2.0
// The package's service worker: build.mjs bundles it as sw.js, at the package's root, so that its
// scope is the package folder. It keeps what a viewer of the package needs to open again with no
// network (docs/DESIGN.md, "Offline use"; docs/FORMAT.md, "sw.js"):
//   - at install, the viewer's files (build.mjs lists them with their SHA-256, OSTEON_PRECACHE),
//     each checked against that list, in a cache of this build's: `osteon-viewer <scope> <build>`.
//     A listed file the host answers 404 is left out (the npm package has no index.html);
//   - a content-hashed file (c/<h>.ostc, <name>-<h>.js: a 24 hex digit run before the extension):
//     cache first, since its name changes whenever its bytes do. Missing, it comes from the
//     network and is kept whole in `osteon-package <scope>` once its bytes' SHA-256 matches its
//     name (a cut or corrupted answer is never kept);
//   - a Range request for such a file (the viewer's finer levels): answered from the kept whole
//     file, a 206 slice of it. Missing, the range goes to the network as asked (the viewer waits
//     for its range, not for the whole file) and the whole file is fetched beside it, once, and
//     kept: a chunk touched once is whole offline, at the cost of its bytes (at most the package's
//     --chunk-bytes, 512 KiB by default) fetched one more time;
//   - anything else in scope (index.html, manifest.json, osteon_decoder.wasm): network first,
//     revalidated by the host's ETag as without a worker, so a repacked package shows at once;
//     the kept copy (a manifest's last answer, the viewer's file) only when the network fails.
//     Navigations to the folder fall back to the kept index.html whatever their query;
//   - the page tells the worker (a message { type: 'osteon-keep', manifest: { url, text }, files:
//     [url] }, offline.mjs) what it loaded before the worker controlled it: the manifest it read
//     and the content-hashed files it fetched, which are then fetched (mostly from the HTTP
//     cache) and kept the same way.
// Bounded: `osteon-package` holds at most kMaxPackageBytes of files; past that the first kept go
// first (manifests stay: they are small). The browser may still evict the origin's caches under
// storage pressure; the viewer then loads from the network as it does without a worker.
// Activation removes this scope's viewer caches of other builds; skipWaiting takes over from an
// older build at once (its rules are the same; its files are all content-hashed or revalidated).
// The worker never takes over a page already open (no clients.claim()): a page's loads never
// change under it halfway through.
//
// Based on: the Service Workers specification (install, activate, fetch, Cache) and RFC 9110
// section 14 (Range, Content-Range, 416).

/* global OSTEON_PRECACHE */
const kPrecache = typeof OSTEON_PRECACHE === 'object' ? OSTEON_PRECACHE : { build: 'source', files: {} };
const kMaxPackageBytes = 256 << 20;
// A content-hashed name: the hash (24 hex digits) after a '/' or '-', before the extension.
const kHashed = /[/-]([0-9a-f]{24})\.[a-z0-9]+$/;

const scope = self.registration.scope;
const viewerCache = `osteon-viewer ${scope} ${kPrecache.build}`;
const packageCache = `osteon-package ${scope}`;

const hashOf = (url) => kHashed.exec(new URL(url).pathname)?.[1] ?? null;
const isManifest = (url) => /\.json$/i.test(new URL(url).pathname);

/// The first 24 hex digits of the SHA-256 of `bytes`.
async function sha24(bytes) {
  const digest = new Uint8Array(await crypto.subtle.digest('SHA-256', bytes));
  return [...digest.subarray(0, 12)].map((b) => b.toString(16).padStart(2, '0')).join('');
}

/// What is kept of a file: its bytes and type, none of the host's other headers.
function storedResponse(bytes, type) {
  return new Response(bytes, {
    headers: { 'Content-Type': type || 'application/octet-stream', 'Content-Length': String(bytes.byteLength) },
  });
}

self.addEventListener('install', (event) => {
  event.waitUntil((async () => {
    const cache = await caches.open(viewerCache);
    await Promise.all(Object.entries(kPrecache.files).map(async ([name, sha]) => {
      const url = new URL(name, self.location).href;
      if (await cache.match(url)) return;  // an install tried again
      // Content-hashed names may come from the HTTP cache; the others are revalidated.
      const response = await fetch(url, { cache: hashOf(url) ? 'default' : 'no-cache' });
      if (response.status === 404) return;
      if (!response.ok) throw new Error(`osteon: ${name}: HTTP ${response.status}`);
      const bytes = await response.arrayBuffer();
      if (await sha24(bytes) !== sha) throw new Error(`osteon: ${name}: not the file this worker was built with`);
      await cache.put(url, storedResponse(bytes, response.headers.get('Content-Type')));
    }));
    await self.skipWaiting();
  })());
});

self.addEventListener('activate', (event) => {
  event.waitUntil((async () => {
    const mine = `osteon-viewer ${scope} `;
    for (const name of await caches.keys()) {
      if (name.startsWith(mine) && name !== viewerCache) await caches.delete(name);
    }
  })());
});

// The package cache's size, counted once per start of the worker, then kept up to date; puts
// and evictions run one at a time.
let packageBytes = null;
let packageQueue = Promise.resolve();

/// Keeps `response` (storedResponse) under `url` in the package cache, evicting the first kept
/// files while it holds more than kMaxPackageBytes.
function putPackage(url, response) {
  packageQueue = packageQueue.then(async () => {
    const cache = await caches.open(packageCache);
    const sizeOf = (r) => Number(r?.headers.get('Content-Length')) || 0;
    if (packageBytes === null) {
      packageBytes = 0;
      for (const key of await cache.keys()) packageBytes += sizeOf(await cache.match(key));
    }
    const added = sizeOf(response);
    const replaced = sizeOf(await cache.match(url));
    try {
      await cache.put(url, response);
    } catch (e) {
      return;  // over the browser's quota: not kept; the viewer works from the network
    }
    packageBytes += added - replaced;
    if (packageBytes <= kMaxPackageBytes) return;
    for (const key of await cache.keys()) {  // in the order they were kept
      if (packageBytes <= kMaxPackageBytes) break;
      if (key.url === url || isManifest(key.url)) continue;
      packageBytes -= sizeOf(await cache.match(key));
      await cache.delete(key);
    }
  }).catch(() => {});
  return packageQueue;
}

/// A kept copy of `url`: the package cache's, else this build's viewer cache's.
async function keptCopy(url, options) {
  return (await (await caches.open(packageCache)).match(url, options)) ??
    (await (await caches.open(viewerCache)).match(url, options));
}

// The content-hashed files being fetched whole, by URL: each is fetched once.
const keeping = new Map();

/// Fetches the content-hashed file `url` whole (or reads `response`, its answer already in) and
/// keeps it if its bytes' SHA-256 matches its name. Never rejects.
function keepWhole(url, response = null) {
  if (keeping.has(url)) return keeping.get(url);
  const work = (async () => {
    if (!response && await keptCopy(url)) return;
    // From the HTTP cache when it holds the whole file; else one plain request. (A default fetch
    // over a partial cache entry, left by the viewer's ranges, would complete it with range
    // requests of its own.)
    const answer = response ??
      await fetch(url, { cache: 'only-if-cached', mode: 'same-origin' }).then((r) => (r.status === 200 ? r : null), () => null) ??
      await fetch(url, { cache: 'no-store' });
    if (answer.status !== 200) return;
    const bytes = await answer.arrayBuffer();
    if (await sha24(bytes) !== hashOf(url)) return;
    await putPackage(url, storedResponse(bytes, answer.headers.get('Content-Type')));
  })().catch(() => {}).finally(() => keeping.delete(url));
  keeping.set(url, work);
  return work;
}

/// The answer to `Range: header` from a kept whole file, as osteon serve answers it: a single
/// range is a 206 slice, one past the end 416; several ranges, or a value that does not parse,
/// the whole file.
async function slice(response, header) {
  const blob = await response.blob();
  const type = response.headers.get('Content-Type') || 'application/octet-stream';
  const size = blob.size;
  const whole = () => new Response(blob, { headers: { 'Content-Type': type, 'Content-Length': String(size) } });
  const m = /^bytes=(\d*)-(\d*)$/.exec(header.trim());
  if (!m || (!m[1] && !m[2])) return whole();
  let first;
  let last;
  if (!m[1]) {
    const n = Number(m[2]);
    if (n === 0 || size === 0) return new Response(null, { status: 416, headers: { 'Content-Range': `bytes */${size}` } });
    first = Math.max(0, size - n);
    last = size - 1;
  } else {
    first = Number(m[1]);
    last = m[2] ? Number(m[2]) : size - 1;
    if (last < first) return whole();
    if (first >= size) return new Response(null, { status: 416, headers: { 'Content-Range': `bytes */${size}` } });
    last = Math.min(last, size - 1);
  }
  return new Response(blob.slice(first, last + 1), {
    status: 206,
    headers: { 'Content-Type': type, 'Content-Range': `bytes ${first}-${last}/${size}`, 'Content-Length': String(last - first + 1) },
  });
}

/// Cache first, for content-hashed files.
async function hashedFile(event) {
  const { request } = event;
  const range = request.headers.get('Range');
  const kept = await keptCopy(request.url);
  if (kept) return range ? slice(kept, range) : kept;
  if (range) {
    event.waitUntil(keepWhole(request.url));
    return fetch(request);
  }
  const response = await fetch(request);
  if (response.status === 200) event.waitUntil(keepWhole(request.url, response.clone()));
  return response;
}

/// Network first, for everything else in scope: the kept copy when the network fails.
async function networkFirst(event) {
  const { request } = event;
  try {
    const response = await fetch(request);
    if (response.status === 200 && isManifest(request.url) && !request.headers.has('Range')) {
      const copy = response.clone();
      event.waitUntil(copy.arrayBuffer().then((bytes) => putPackage(request.url, storedResponse(bytes, 'application/json'))).catch(() => {}));
    }
    return response;
  } catch (e) {
    const url = new URL(request.url);
    let kept = await keptCopy(url.href, { ignoreSearch: true });
    if (!kept && request.mode === 'navigate' && (url.href.split(/[?#]/)[0] === scope || url.pathname.endsWith('/index.html'))) {
      kept = await keptCopy(new URL('index.html', scope).href);
    }
    if (!kept) throw e;
    const range = request.headers.get('Range');
    return range ? slice(kept, range) : kept;
  }
}

self.addEventListener('fetch', (event) => {
  const { request } = event;
  if (request.method !== 'GET' || !request.url.startsWith(scope)) return;
  event.respondWith(hashOf(request.url) ? hashedFile(event) : networkFirst(event));
});

self.addEventListener('message', (event) => {
  const data = event.data;
  if (!data || data.type !== 'osteon-keep') return;
  const work = [];
  const manifest = data.manifest;
  if (manifest && typeof manifest.url === 'string' && typeof manifest.text === 'string' &&
      manifest.url.startsWith(scope) && isManifest(manifest.url)) {
    work.push(putPackage(manifest.url, storedResponse(new TextEncoder().encode(manifest.text), 'application/json')));
  }
  for (const url of Array.isArray(data.files) ? data.files : []) {
    if (typeof url === 'string' && url.startsWith(scope) && hashOf(url)) work.push(keepWhole(url));
  }
  event.waitUntil(Promise.all(work));
});
