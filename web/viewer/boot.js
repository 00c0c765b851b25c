// SPDX-License-Identifier: Apache-2.0
// The viewer's bootstrap: startBoot() starts everything one viewer's first bones need, at once and
// in parallel, before the rest of the viewer's code (main.mjs, element.mjs) has arrived:
//   - manifest.json (or the manifest the element's src names), and once it is in, the first two
//     chunk files (the stream keeps two in flight);
//   - the WebAssembly decoder, fetched and compiled (off the main thread: WebAssembly.compile is
//     asynchronous);
//   - the render worker (render_worker.mjs; on the standalone page inlined in the page), given the
//     canvas as an OffscreenCanvas (in the next animation frame) and the manifest: it creates the
//     WebGL context while three.js downloads, and draws the first frames without three.js
//     (first_frames.mjs);
//   - three.js's part of the renderer (render_three.mjs), fetched here and handed to the render
//     worker as text: fetched by the worker, it would wait for the worker's own script to arrive
//     and start (a round trip or more);
//   - the decoder workers (hardware threads - 1, 1 to 4), so their script is in by the time the
//     first component is.
// Two callers, one code. The standalone page (index.html) runs bootPage() from an inline classic
// script (build.mjs bundles this module with that call into the page, minified), right after its
// <osteon-viewer> element, whose shadow root the parser has already made (declarative shadow
// DOM): the page's downloads start while it is still being parsed. The element, on any other page
// (or on the standalone page when the page's boot is for another package), calls startBoot()
// itself once it is connected, with the files resolved beside its own script.
// The viewer (main.mjs) picks up what is in flight from the boot object:
//   { manifestUrl, manifest: Promise<text>, manifestJson: Promise<its JSON.parse>, chunks: Map chunk index -> Promise<Response>,
//     chunkStarts: Map chunk index -> performance.now() when its fetch started, chunksStarted
//     (a Promise: settled once the first chunks are on their way, or will not be),
//     wasm: Promise<WebAssembly.Module>, decoders: [Worker], decoderError, link (the render
//     worker, or a MessagePort to the renderer when it runs on the page), rendererPort (that case
//     only: the renderer's end), offscreen, messages (what the renderer said before main.mjs set
//     `deliver`, its handler), rendererStarted (a Promise: settled by the renderer's first
//     message, or the worker's failure), rendererError, renderWorkerFile, page (true: started by
//     bootPage) }
// Where a canvas cannot be handed to a worker (no OffscreenCanvas; or render="page"), the
// renderer runs on the page's main thread instead: main.mjs starts it on `rendererPort`.
//
// No dependencies but stream.mjs's stall deadline (bundled in): this must run before anything
// else has downloaded.
import { fetchWithin, kStallMs, readWithin, within } from './stream.mjs';
import { cssSize, drawingBufferSize, viewPixelRatio } from './view_size.mjs';

/// The manifest's URL for an element's `src`: a package folder ("pkg/", "pkg") or a manifest's own
/// URL (ending in .json), relative to `base`.
export function manifestUrlOf(src, base) {
  const url = new URL(src || 'manifest.json', base);
  if (!/\.json$/i.test(url.pathname)) {
    if (!url.pathname.endsWith('/')) url.pathname += '/';
    url.pathname += 'manifest.json';
  }
  return url.href;
}

/// How long the render worker waits for the canvas at most when no animation frame comes (a page
/// opened in a background tab).
const kCanvasHandOverMs = 100;

/// The largest manifest.json the viewer reads (docs/FORMAT.md, "manifest.json"): its parse is one
/// task on the page's thread, tens of milliseconds a megabyte.
export const kMaxManifestBytes = 16 << 20;

/// The manifest's text, read no further than kMaxManifestBytes (refused by its Content-Length
/// before the body is read, when the host sends one), each piece within `stallMs` of the last.
async function readManifestText(response, name, stallMs) {
  const tooLarge = (bytes) => new Error(`osteon: ${name}: ${bytes} bytes, this viewer reads at most ${kMaxManifestBytes}`);
  const declared = Number(response.headers.get('Content-Length'));
  // Content-Length counts the bytes on the wire: a compressed body may hold more.
  if (!response.headers.get('Content-Encoding') && declared > kMaxManifestBytes) {
    response.body && response.body.cancel().catch(() => {});
    throw tooLarge(declared);
  }
  if (!response.body || !response.body.getReader) return within(response.text(), stallMs);
  const reader = response.body.getReader();
  const pieces = [];
  let size = 0;
  for (;;) {
    const { done, value } = await readWithin(reader, stallMs);
    if (done) break;
    size += value.length;
    if (size > kMaxManifestBytes) {
      reader.cancel().catch(() => {});
      throw tooLarge(`more than ${size}`);
    }
    pieces.push(value);
  }
  return new TextDecoder().decode(await new Blob(pieces).arrayBuffer());
}

/// Starts one viewer's downloads and workers; returns the boot object (above). `canvas`: the
/// viewer's canvas element; `manifestUrl`: absolute; `files`: the absolute URLs of the viewer's
/// files { renderWorker, renderThree, decoderWorker, wasm } and, optionally, `renderWorkerCode`
/// (the render worker's script, started from a blob: URL without a round trip); `renderOnPage`:
/// keep the renderer on the page's main thread; `background`: the view's colour, '#rrggbb';
/// `stallMs`: how long any of the viewer's requests may send no byte before it fails (default
/// kStallMs; the manifest's: 'osteon: manifest.json: no byte for 15 s', and nothing is drawn).
export function startBoot({ canvas, manifestUrl: manifestHref, files, renderOnPage = false, background, stallMs = kStallMs }) {
  const manifestUrl = new URL(manifestHref);
  const manifestName = manifestUrl.pathname.split('/').pop() || manifestUrl.href;
  const boot = {
    manifestUrl: manifestUrl.href,
    renderWorkerFile: files.renderWorker,
    chunks: new Map(),
    chunkStarts: new Map(),
    messages: [],
    rendererError: null,
    decoders: [],
    decoderError: null,
    stallMs,  // the stream and the levels (streaming.mjs) wait as long
    timings: {},  // when the manifest's answer, its text and three.js's text arrived here (window.osteon.timings)
  };
  const text = (e) => String((e && e.message) || e);
  // The renderer's messages: kept until main.mjs sets boot.deliver, then handed to it.
  const deliver = (message) => (boot.deliver ? boot.deliver(message) : boot.messages.push(message));

  boot.manifest = fetchWithin(fetch, manifestUrl, { priority: 'high' }, stallMs).then(
    async (response) => {
      boot.timings.manifestResponse = performance.now();
      if (!response.ok) throw new Error(`osteon: ${manifestName}: HTTP ${response.status}`);
      let manifestText;
      try {
        manifestText = await readManifestText(response, manifestName, stallMs);
      } catch (e) {
        throw e && e.stalled ? new Error(`osteon: ${manifestName}: ${e.message}`) : e;
      }
      boot.timings.manifest = performance.now();
      return manifestText;
    },
    (e) => {
      throw new Error(`osteon: ${manifestName}: ${e && e.stalled ? e.message : `fetch failed: ${text(e)}`}`);
    },
  );
  boot.manifest.catch(() => {});  // main.mjs reports it
  // The first two chunks that hold first streams (a component's coarsest level, or its only
  // one; finer levels come later, by byte range), as soon as the manifest names them, beside
  // three.js if it is still on its way: the renderer draws its first frames without three.js
  // (first_frames.mjs), so the bones, not the code, are what the first frame waits for. (main.mjs
  // checks the manifest in full; here only the file names are checked, as the fetch needs them.)
  // Parsed once, here: main.mjs checks this same object (a dense skeleton's manifest is a
  // megabyte, tens of milliseconds a parse on a slow phone).
  boot.manifestJson = boot.manifest.then((manifestText) => JSON.parse(manifestText));
  boot.manifestJson.catch(() => {});  // main.mjs reports it
  boot.chunksStarted = boot.manifestJson.then((json) => {
    const chunks = json.chunks;
    const first = new Set(json.components.map((c) => (c.levels && c.levels.length ? c.levels[0].chunk : c.chunk)));
    for (const k of [...first].sort((a, b) => a - b).slice(0, 2)) {
      if (!chunks[k] || !/^c\/[0-9a-f]{24}\.ostc$/.test(chunks[k].file)) continue;
      const response = fetch(new URL(chunks[k].file, manifestUrl));
      response.catch(() => {});  // streaming.mjs reports it, naming the chunk's components
      boot.chunks.set(k, response);
      boot.chunkStarts.set(k, performance.now());
    }
  }).catch(() => {});
  boot.wasm = fetch(files.wasm, { priority: 'high' })
    .then((response) => {
      if (!response.ok) throw new Error(`osteon: cannot load osteon_decoder.wasm: HTTP ${response.status}`);
      return response.arrayBuffer();
    })
    .then((bytes) => WebAssembly.compile(bytes));
  boot.wasm.catch(() => {});  // main.mjs reports it

  let link = null;
  const init = {
    type: 'init',
    pixelRatio: viewPixelRatio(),
    pageOrigin: performance.timeOrigin,
    base: files.renderThree,  // the three.js part's fallback import is resolved against it
    background,
  };
  // The canvas's size, for a renderer on the page (reading it lays the page out: tens of
  // milliseconds with the panel).
  const measure = () => Object.assign(init, cssSize(canvas.getBoundingClientRect()));
  boot.offscreen = false;
  if (canvas.transferControlToOffscreen && !renderOnPage) {
    let worker = null;
    try {
      // The worker's script is inlined in the standalone page (build.mjs): it starts now, not a
      // round trip later. A content security policy may refuse blob: workers; then, and on other
      // pages, it comes from its file.
      if (files.renderWorkerCode) {
        try {
          worker = new Worker(URL.createObjectURL(new Blob([files.renderWorkerCode], { type: 'text/javascript' })), { type: 'module' });
        } catch (e) {
          worker = null;
        }
      }
      worker ??= moduleWorker(files.renderWorker);
    } catch (e) {
      // No module workers, say: the renderer runs on the page instead (below).
      worker?.terminate();
      worker = null;
    }
    if (worker) {
      link = worker;
      worker.addEventListener('error', (e) => {
        boot.rendererError = `osteon: the render worker failed: ${e.message || 'its script could not be loaded'}`;
        deliver({ type: 'fatal', error: boot.rendererError, at: performance.now() });
      });
      // Not measured here: reading the canvas's size lays the page out, a seventh of a second of
      // this script on a slow phone. The page's first 'size' message (main.mjs, before any mesh)
      // gives the worker the real one; until then it holds the canvas's own (300 x 150).
      init.width = Math.max(1, canvas.width);
      init.height = Math.max(1, canvas.height);
      // The render worker fetches three.js's part itself: the thread that reads a body inflates
      // it, and on a slow phone three.js's 550 KB took this thread for a fifth of a second.
      init.fetchThree = true;
      worker.postMessage(init);
      // The canvas follows in the next animation frame, not with 'init': handing it over lays
      // the page out first (style and layout, a quarter of a second on a slow phone with the
      // panel), and in this script that would be added to the bootstrap's own task. In the
      // frame's callback it is the layout the frame does anyway. The worker is starting
      // meanwhile, and fetching three.js.
      // (A timer too: a page opened in a background tab gets no animation frame until shown.)
      let handed = false;
      const handOver = () => {
        if (handed) return;
        handed = true;
        let offscreen;
        try {
          offscreen = canvas.transferControlToOffscreen();
        } catch (e) {
          boot.rendererError = `osteon: cannot hand the canvas to the render worker: ${text(e)}`;
          deliver({ type: 'fatal', error: boot.rendererError, at: performance.now() });
          return;
        }
        // The drawing buffer at its size before the context is made on it: resized at the first
        // frame instead (from 300 x 150), it was made again then, a round trip to the GPU
        // process that took a quarter of a second with a software GPU. The page was laid out
        // by the hand-over just now, so reading the size costs nothing; it is computed as the
        // page's 'size' messages are (view_size.mjs), so the first frame keeps it.
        const rect = canvas.getBoundingClientRect();
        if (rect.width > 0 && rect.height > 0) Object.assign(offscreen, drawingBufferSize(cssSize(rect), init.pixelRatio));
        worker.postMessage({ type: 'canvas', canvas: offscreen }, [offscreen]);
      };
      requestAnimationFrame(handOver);
      setTimeout(handOver, kCanvasHandOverMs);
      boot.offscreen = true;
    }
  }
  if (!boot.offscreen) {
    // The renderer will run here; its messages wait on the channel until main.mjs starts it.
    const channel = new MessageChannel();
    link = channel.port1;
    boot.rendererPort = channel.port2;
    measure();
    link.postMessage(init);
  }
  boot.link = link;
  // Settled by the renderer's first message (its 'started'), or by its failure.
  boot.rendererStarted = new Promise((resolve) => {
    link.onmessage = (e) => {
      resolve();
      deliver(e.data);
    };
    if (boot.offscreen) link.addEventListener('error', () => resolve());
  });

  // The decoder workers after the render worker: theirs is not the first script needed.
  const workers = Math.max(1, Math.min(4, (navigator.hardwareConcurrency || 2) - 1));
  for (let i = 0; i < workers; ++i) {
    try {
      const worker = moduleWorker(files.decoderWorker);
      // A worker that cannot start answers nothing; streaming.mjs refuses to wait on it.
      worker.addEventListener('error', (e) => {
        boot.decoderError ??= `the decoder worker failed: ${e.message || 'its script could not be loaded'}`;
      });
      boot.decoders.push(worker);
    } catch (e) {
      boot.decoderError ??= `cannot start a decoder worker: ${text(e)}`;
    }
  }

  boot.manifest.then(
    (manifest) => link.postMessage({ type: 'manifest', text: manifest }),
    (e) => link.postMessage({ type: 'manifest', error: text(e) }),
  );
  // A renderer on this page gets three.js's part from here, as its text.
  if (!boot.offscreen) {
    fetch(files.renderThree, { priority: 'high' }).then(async (response) => {
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      const code = await response.text();
      boot.timings.threeFetched = performance.now();
      return code;
    }).then(
      (code) => link.postMessage({ type: 'three', text: code }),
      (e) => link.postMessage({ type: 'three', error: text(e) }),
    );
  }
  return boot;
}

/// A module worker running the script at `url`. A worker's script must come from the page's own
/// origin: for an element whose files are on another (a CDN), the worker starts from a blob: URL
/// that imports the script (which that host must then serve with CORS).
function moduleWorker(url) {
  try {
    return new Worker(url, { type: 'module' });
  } catch (e) {
    if (new URL(url).origin === location.origin) throw e;
    const code = `import ${JSON.stringify(url)};`;
    return new Worker(URL.createObjectURL(new Blob([code], { type: 'text/javascript' })), { type: 'module' });
  }
}

/// The standalone page's bootstrap (index.html, inline, after its <osteon-viewer>): the page's URL
/// parameters become the element's attributes (?manifest=URL its src, ?budgetMB= and
/// ?budgetTriangles= its budget, ?render=page; ?stallMs=, how long a request may send nothing,
/// goes to the boot: tests of stalling hosts set it short), the boot is started for the element and left on
/// it for its script to pick up, and window.osteon shows the element's report.
/* global OSTEON_RENDER_WORKER_CODE, OSTEON_RENDER_WORKER_FILE, OSTEON_RENDER_THREE_FILE, OSTEON_DECODER_WORKER_FILE */
export function bootPage() {
  const params = new URLSearchParams(location.search);
  const element = document.querySelector('osteon-viewer');
  let root = element.shadowRoot;
  if (!root) {
    // A browser without declarative shadow DOM left the markup in a <template>.
    const template = element.querySelector('template');
    root = element.attachShadow({ mode: 'open' });
    root.append(template.content);
    template.remove();
  }
  const src = manifestUrlOf(params.get('manifest') || element.getAttribute('src') || 'manifest.json', location.href);
  element.setAttribute('src', src);
  for (const [param, attribute] of [['budgetMB', 'budget-mb'], ['budgetTriangles', 'budget-triangles'], ['render', 'render']]) {
    if (params.has(param)) element.setAttribute(attribute, params.get(param));
  }
  const file = (name) => new URL(name, location.href).href;
  const boot = startBoot({
    canvas: root.getElementById('canvas'),
    manifestUrl: src,
    files: {
      renderWorker: file(OSTEON_RENDER_WORKER_FILE),
      renderWorkerCode: OSTEON_RENDER_WORKER_CODE,
      renderThree: file(OSTEON_RENDER_THREE_FILE),
      decoderWorker: file(OSTEON_DECODER_WORKER_FILE),
      wasm: file('osteon_decoder.wasm'),
    },
    renderOnPage: element.getAttribute('render') === 'page',
    background: element.getAttribute('background') || undefined,
    stallMs: Number(params.get('stallMs')) > 0 ? Number(params.get('stallMs')) : undefined,
  });
  boot.page = true;
  element[Symbol.for('osteon.boot')] = boot;
  Object.defineProperty(window, 'osteon', { configurable: true, get: () => element.report });
}

