// SPDX-License-Identifier: Apache-2.0
// <osteon-viewer src="package/">: the viewer as a custom element. Its open shadow root holds the
// viewer's markup and style (index.html's, the same), so several elements on one page keep their
// own ids, styles and state: each element makes one viewer (main.mjs createViewer) with its own
// state object (state.mjs), bootstrap (boot.js), render worker and decoder workers.
//
// The standalone page (index.html, the page every package carries) is this element filling the
// window: its inline bootstrap (boot.js bootPage) has started the element's downloads and workers
// while the page was being parsed, and left the boot on the element; the element takes it up
// when its src still names the same manifest. Anywhere else the element boots itself, once
// connected, with the viewer's other files (render worker, three.js part, decoder worker,
// WebAssembly decoder) taken from beside this script.
//
// Attributes (all optional but src; changes after the start apply at once):
//   src               a package folder ("pkg/") or its manifest's URL; a new src starts over
//   camera            "px,py,pz,tx,ty,tz" (position, target), optionally ",ux,uy,uz" (up) and
//                     ",fov" (degrees), or a share state's text (share.mjs)
//   view              a share state's text (share.mjs; docs/FORMAT.md "Share URL"): camera,
//                     selection, hidden or isolated parts, groups, clipping plane
//   background        the view's colour, "#rrggbb"
//   panel             "off" collapses the panel (its button opens it again); "on", the default
//   budget-mb         the levels of detail's memory budget, in 10^6 bytes (default 256)
//   budget-triangles  their triangle budget (default 4,000,000)
//   render            "page" keeps the renderer on the page's main thread
//   sync-hash         keep the view in the page's URL hash (the standalone page does)
//   offline           keep the package for use offline: registers the service worker beside this
//                     script (sw.js; its scope is that folder) once the skeleton has loaded
//                     (offline.mjs; the standalone page does)
// Events (CustomEvent, on the element): 'progress' and 'load' (detail: the counts), 'error'
// (nothing can be drawn: the manifest, WebGL or the decoder failed; detail.message), 'select' (detail: name, partName, part, group, source,
// triangles; name null when the selection is cleared), 'viewchange' (detail.view: the share text).
// Methods: select(name | null), frame(name?), hide(name), show(name), isolate(name), showAll(),
// each false for an unknown name or before the manifest is read; `ready` (a Promise of the
// report once the manifest is read), `report` (the loading state tests and benchmarks read; the
// standalone page's window.osteon), `viewState` (get and set: the share text).
//
// Based on: the HTML custom elements and declarative shadow DOM (<template shadowrootmode>).

import { manifestUrlOf, startBoot } from './boot.js';
import { createViewer } from './main.mjs';
import { keepOffline } from './offline.mjs';
import { parseCamera, parseViewState } from './share.mjs';
import { budgetOf } from './state.mjs';

// build.mjs defines these: the viewer's markup and style (index.html's shadow root) and the
// content-hashed names of the files beside this script.
/* global OSTEON_VIEWER_MARKUP, OSTEON_RENDER_WORKER_FILE, OSTEON_RENDER_THREE_FILE, OSTEON_DECODER_WORKER_FILE */
const kMarkup = typeof OSTEON_VIEWER_MARKUP === 'string' ? OSTEON_VIEWER_MARKUP : '';
const kFiles = {
  renderWorker: typeof OSTEON_RENDER_WORKER_FILE === 'string' ? OSTEON_RENDER_WORKER_FILE : './render_worker.mjs',
  renderThree: typeof OSTEON_RENDER_THREE_FILE === 'string' ? OSTEON_RENDER_THREE_FILE : './render_three.mjs',
  decoderWorker: typeof OSTEON_DECODER_WORKER_FILE === 'string' ? OSTEON_DECODER_WORKER_FILE : '../decoder/worker.mjs',
  wasm: './osteon_decoder.wasm',
};

// Where bootPage leaves the page's boot on the element (a symbol: no name to clash with).
const kBoot = Symbol.for('osteon.boot');

const backgroundOf = (value) => (/^#[0-9a-f]{6}$/i.test(value ?? '') ? value : null);

export class OsteonViewer extends HTMLElement {
  static observedAttributes = ['src', 'camera', 'view', 'background', 'panel', 'budget-mb', 'budget-triangles'];

  #root;
  #viewer = null;
  #startQueued = false;
  #hashListener = null;

  constructor() {
    super();
    // The standalone page's parser has made the shadow root already (declarative shadow DOM).
    this.#root = this.shadowRoot ?? this.attachShadow({ mode: 'open' });
    if (!this.#root.getElementById('canvas')) this.#root.innerHTML = kMarkup;
  }

  connectedCallback() {
    this.#queueStart();
  }

  disconnectedCallback() {
    // Moved within the page: connected again in the same task, and kept.
    queueMicrotask(() => {
      if (!this.isConnected) this.#stop();
    });
  }

  attributeChangedCallback(name, old, value) {
    const viewer = this.#viewer;
    if (!viewer || old === value) return;
    switch (name) {
      case 'src':
        this.#stop();
        this.#queueStart();
        break;
      case 'camera':
        if (value) viewer.setCamera(cameraPending(value));
        break;
      case 'view':
        if (value) viewer.setView(value);
        break;
      case 'background': {
        const color = backgroundOf(value);
        if (color) viewer.setBackground(color);
        break;
      }
      case 'panel':
        this.#applyPanel();
        break;
      default:  // the budget
        viewer.setBudget(budgetOf(this.getAttribute('budget-mb'), this.getAttribute('budget-triangles')));
    }
  }

  /// The loading state (state.mjs report), with its functions; null before the start.
  get report() {
    return this.#viewer?.report ?? null;
  }

  /// A Promise of the report, settled once the manifest is read (never, if it cannot be).
  get ready() {
    return this.#viewer?.ready ?? new Promise((resolve) => this.addEventListener('osteon-started', () => resolve(this.#viewer.ready), { once: true }));
  }

  /// The view as share text (share.mjs), or the view attribute before the manifest is read.
  get viewState() {
    return this.#viewer?.report.viewState() ?? this.getAttribute('view');
  }

  set viewState(text) {
    if (this.#viewer) this.#viewer.setView(String(text));
    else this.setAttribute('view', String(text));
  }

  select(name) { return this.report?.select(name) ?? false; }
  frame(name) { return this.report?.frame(name) ?? false; }
  hide(name) { return this.report?.hide(name) ?? false; }
  show(name) { return this.report?.show(name) ?? false; }
  isolate(name) { return this.report?.isolate(name) ?? false; }
  showAll() { return this.report?.showAll() ?? false; }

  #queueStart() {
    if (this.#startQueued || this.#viewer) return;
    this.#startQueued = true;
    // After the attributes set with the element (a parser, innerHTML or a script's setAttribute).
    queueMicrotask(() => {
      this.#startQueued = false;
      this.#start();
    });
  }

  #start() {
    if (!this.isConnected || this.#viewer || !this.getAttribute('src')) return;
    const manifestUrl = manifestUrlOf(this.getAttribute('src'), document.baseURI);
    const background = backgroundOf(this.getAttribute('background'));
    let boot = this[kBoot] ?? null;
    this[kBoot] = null;
    if (boot && boot.manifestUrl !== manifestUrl) {
      // The page's bootstrap started another package: its workers go, and a fresh canvas comes
      // (the old one belongs to its render worker).
      for (const worker of [boot.link, ...boot.decoders]) worker?.terminate?.();
      boot = null;
      this.#root.innerHTML = kMarkup;
    } else if (!boot && this.#root.getElementById('canvas').dataset.used) {
      this.#root.innerHTML = kMarkup;
    }
    const syncHash = this.hasAttribute('sync-hash');
    if (!boot) {
      const here = import.meta.url;
      boot = startBoot({
        canvas: this.#root.getElementById('canvas'),
        manifestUrl,
        files: Object.fromEntries(Object.entries(kFiles).map(([k, v]) => [k, new URL(v, here).href])),
        renderOnPage: this.getAttribute('render') === 'page',
        background: background ?? undefined,
      });
    }
    this.#root.getElementById('canvas').dataset.used = 'true';
    this.#viewer = createViewer({
      host: this,
      root: this.#root,
      boot,
      budget: budgetOf(this.getAttribute('budget-mb'), this.getAttribute('budget-triangles')),
      background,
      syncHash,
    });
    this.#applyPanel();
    if (this.hasAttribute('offline')) {
      keepOffline(this, { worker: new URL('./sw.js', import.meta.url).href, manifestUrl, manifest: boot.manifest });
    }
    const camera = this.getAttribute('camera');
    if (camera) this.#viewer.setCamera(cameraPending(camera));
    // The view attribute, unless the page's hash holds one (a shared link wins over the page's
    // default view).
    const view = this.getAttribute('view');
    if (view && !(syncHash && location.hash.length > 1)) this.#viewer.setView(view);
    if (syncHash) {
      this.#hashListener = () => {
        const text = location.hash.slice(1);
        if (text && text !== this.#viewer?.report.viewState()) this.#viewer?.setView(text);
      };
      window.addEventListener('hashchange', this.#hashListener);
    }
    this.dispatchEvent(new CustomEvent('osteon-started'));
  }

  #stop() {
    this.#viewer?.destroy();
    this.#viewer = null;
    if (this.#hashListener) window.removeEventListener('hashchange', this.#hashListener);
    this.#hashListener = null;
  }

  #applyPanel() {
    const off = this.getAttribute('panel') === 'off';
    this.#root.getElementById('panel').classList.toggle('collapsed', off);
    this.#root.getElementById('panel-toggle').setAttribute('aria-expanded', String(!off));
  }
}

/// The camera attribute as a pending view: its own form, or a share state's text.
function cameraPending(text) {
  if (text.includes('=')) {
    const { view, errors } = parseViewState(text);
    return { camera: view?.camera ?? null, errors: view?.camera ? errors : [...errors, `camera "${text}": no cam field`] };
  }
  const { camera, error } = parseCamera(text);
  return { camera, errors: error ? [error] : [] };
}

if (!customElements.get('osteon-viewer')) customElements.define('osteon-viewer', OsteonViewer);
