// SPDX-License-Identifier: Apache-2.0
// Builds the viewer into build/viewer/ (repository root; `osteon pack` copies that folder into every
// package):
//   index.html                       the standalone page: one <osteon-viewer> filling the window,
//                                    its shadow root declared in the page with the style
//                                    (viewer.css) inlined, and the bootstrap (boot.js bootPage)
//                                    inlined, minified: nothing blocks it from starting the
//                                    downloads the first bones need
//   element-<h>.js                   the <osteon-viewer> element (element.mjs and the modules it
//                                    wires: the viewer, panel, camera controls, picking, streams,
//                                    the bootstrap, the markup and style): the page's script, and
//                                    the one file another page imports to embed viewers
//   osteon-viewer.mjs                the element under a name that does not change (re-exports
//                                    element-<h>.js), for a package's exports
//   render-worker-<h>.js             the render worker (render_worker.mjs), small so that it starts
//                                    early; also inlined in index.html, whose bootstrap starts it
//                                    from a blob: URL (this file is for other pages, and for
//                                    pages that refuse blob: workers)
//   render-three-<h>.js              what it imports next: three.js's renderer and the scene
//                                    (render_three.mjs)
//   decoder-worker-<h>.js            the decoder worker (web/decoder/worker.mjs and the wrapper)
//   osteon_decoder.wasm              the WebAssembly decoder (build/wasm, from npm run build:decoder)
//   sw.js                            the service worker (service_worker.js) that keeps the package
//                                    for use offline, under a name that does not change (a
//                                    worker's URL is its identity); it carries the SHA-256 of every
//                                    other file above, which it fetches and checks at install, so
//                                    it changes whenever the viewer does
//   *.gz                             gzip -9 copies of every file, which `osteon serve` sends to
//                                    clients that accept gzip
// <h> is the first 24 hex digits of the SHA-256 of the file's bytes (as the package's component
// files): `osteon serve` sends names with a 16+ hex digit run as immutable, so browsers cache the
// bundles forever and fetch them again only when they change. The output is deterministic: the
// same sources give the same bytes (esbuild is deterministic; gzip carries no time stamp).
//
//   node web/viewer/build.mjs              (or: cd web && npm run build:viewer)
//   OUT=dir WASM=file node ...             output folder, the decoder module to ship
//
// When build/wasm/osteon_decoder.wasm is missing, web/decoder/build.sh builds it first.

import { spawnSync } from 'node:child_process';
import { createHash } from 'node:crypto';
import { existsSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { gzipSync } from 'node:zlib';

import * as esbuild from 'esbuild';

const here = dirname(fileURLToPath(import.meta.url));
const root = resolve(here, '../..');
const out = resolve(root, process.env.OUT ?? 'build/viewer');
const wasmPath = resolve(root, process.env.WASM ?? 'build/wasm/osteon_decoder.wasm');

function fail(message) {
  console.error(`osteon: ${message}`);
  process.exit(1);
}

function hashed(name, ext, bytes) {
  return `${name}-${createHash('sha256').update(bytes).digest('hex').slice(0, 24)}.${ext}`;
}

/// Bundles one entry point in memory; returns its bytes (one output file).
async function bundle(entry, options = {}) {
  const result = await esbuild.build({
    entryPoints: [join(here, entry)],
    bundle: true,
    minify: true,
    format: entry.endsWith('.css') ? undefined : 'esm',
    target: entry.endsWith('.css') ? ['chrome100', 'firefox100', 'safari15'] : 'es2022',
    platform: 'browser',
    // The decoder's wrapper and worker also run under Node, where they reach node:fs and
    // node:worker_threads by dynamic import; those branches never run in a browser.
    external: ['node:*'],
    legalComments: 'eof',
    write: false,
    logLevel: 'warning',
    ...options,
  });
  if (result.outputFiles.length !== 1) fail(`${entry}: expected one output file, got ${result.outputFiles.length}`);
  return Buffer.from(result.outputFiles[0].contents);
}

if (!existsSync(wasmPath)) {
  if (process.env.WASM) fail(`${wasmPath} does not exist`);
  console.log(`osteon: ${wasmPath} is missing: building the decoder first (npm run build:decoder)`);
  const r = spawnSync('bash', [join(root, 'web/decoder/build.sh')], { stdio: 'inherit' });
  if (r.status !== 0 || !existsSync(wasmPath)) fail('the decoder build failed; the viewer needs osteon_decoder.wasm');
}

// The page's script takes 'three' from three_page.mjs (three's source modules it uses), not from
// three's single-file build, which would bring 255 KB of renderer the page never runs.
const threePage = {
  name: 'three-page',
  setup(build) {
    build.onResolve({ filter: /^three$/ }, () => ({ path: join(here, 'three_page.mjs') }));
  },
};

const files = new Map();  // output name -> bytes
/// Bundles `entry` with `define`, stores it as <name>-<hash>.js and returns that name. Each name
/// is defined into the bundles that load it, so a change anywhere renames everything upstream.
async function add(entry, name, define = {}, plugins = []) {
  const bytes = await bundle(entry, {
    define: Object.fromEntries(Object.entries(define).map(([k, v]) => [k, JSON.stringify(v)])),
    plugins,
  });
  const file = hashed(name, 'js', bytes);
  files.set(file, bytes);
  return file;
}
const decoderWorker = await add('../decoder/worker.mjs', 'decoder-worker');
const renderThree = await add('render_three.mjs', 'render-three');
const renderWorker = await add('render_worker.mjs', 'render-worker', { OSTEON_RENDER_THREE_FILE: `./${renderThree}` });
files.set('osteon_decoder.wasm', readFileSync(wasmPath));

// The style and the bootstrap go inside the page: a stylesheet would hold the bootstrap back
// until it had arrived (scripts wait for the style sheets before them), costing a round trip.
const style = (await bundle('viewer.css')).toString().trim();
let html = readFileSync(join(here, 'index.html'), 'utf8');
// The element's shadow root, as the page declares it: the element's markup on other pages.
const shadow = /<template shadowrootmode="open">([\s\S]*)<\/template><\/osteon-viewer>/.exec(html);
if (!shadow) fail('web/viewer/index.html lacks <osteon-viewer><template shadowrootmode="open">...</template></osteon-viewer>');
const markup = shadow[1].replace('%VIEWER_CSS%', () => style).replace(/>\s+</g, '><').trim();
const fileNames = {
  OSTEON_RENDER_WORKER_FILE: `./${renderWorker}`,
  OSTEON_RENDER_THREE_FILE: `./${renderThree}`,
  OSTEON_DECODER_WORKER_FILE: `./${decoderWorker}`,
};
const script = await add('element.mjs', 'element', { ...fileNames, OSTEON_VIEWER_MARKUP: markup }, [threePage]);
files.set('osteon-viewer.mjs', Buffer.from(`// SPDX-License-Identifier: Apache-2.0\n// The <osteon-viewer> element (web/viewer/element.mjs).\nexport * from './${script}';\n`));

// The page's bootstrap: boot.js's bootPage, called at once, as a classic script.
const boot = (await bundle('boot.js', {
  stdin: { contents: "import { bootPage } from './boot.js';\nbootPage();\n", resolveDir: here, loader: 'js' },
  entryPoints: undefined,
  format: 'iife',
  target: 'es2020',
  legalComments: 'none',
  define: Object.fromEntries(Object.entries({
    ...fileNames,
    OSTEON_RENDER_WORKER_CODE: files.get(renderWorker).toString(),
  }).map(([k, v]) => [k, JSON.stringify(v)])),
})).toString().trim()
  // Escaped so that the page's <script> cannot end inside it.
  .replaceAll('</', '<\\/');
if (/<\/(script|style)/i.test(boot + style)) fail('the inlined style or bootstrap contains a closing tag');
for (const [marker, text] of [['%VIEWER_JS%', script], ['%VIEWER_CSS%', style], ['%BOOT_JS%', boot]]) {
  if (!html.includes(marker)) fail(`web/viewer/index.html lacks the marker ${marker}`);
  html = html.replaceAll(marker, () => text);
}
files.set('index.html', Buffer.from(html));

// The service worker, with the list of the files it keeps at install (name -> the first 24 hex
// digits of its SHA-256) and a name for that list (the caches of another build are removed).
const precache = Object.fromEntries([...files].map(([name, bytes]) => [name, createHash('sha256').update(bytes).digest('hex').slice(0, 24)]));
const build = createHash('sha256').update(JSON.stringify(precache)).digest('hex').slice(0, 24);
files.set('sw.js', await bundle('service_worker.js', {
  format: 'iife',
  define: { OSTEON_PRECACHE: JSON.stringify({ build, files: precache }) },
}));

// A package's own names (docs/FORMAT.md): the viewer must not shadow them.
for (const name of files.keys()) {
  if (name === 'manifest.json' || name.startsWith('c/')) fail(`the viewer may not write ${name}`);
}

// A fresh folder each time: stale hashed bundles would otherwise be copied into every package.
rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });
let total = 0;
let totalGz = 0;
const rows = [];
for (const [name, bytes] of files) {
  writeFileSync(join(out, name), bytes);
  const gz = gzipSync(bytes, { level: 9 });
  writeFileSync(join(out, `${name}.gz`), gz);
  // The standalone page's download: the render worker's file is fetched only where blob: workers
  // are refused (it is in the page), the stable-named entry only by other pages, the service
  // worker once the skeleton has loaded.
  if (name !== renderWorker && name !== 'osteon-viewer.mjs' && name !== 'sw.js') {
    total += bytes.length;
    totalGz += gz.length;
  }
  rows.push([name, bytes.length, gz.length]);
}
const width = Math.max(...rows.map((r) => r[0].length));
for (const [name, size, gz] of rows) {
  console.log(`osteon: ${out}/${name.padEnd(width)} ${String(size).padStart(8)} bytes, gzip -9 ${String(gz).padStart(7)}`);
}
console.log(`osteon: viewer download (every file but ${renderWorker}, inlined in the page, osteon-viewer.mjs and sw.js; gzip -9): ${totalGz} bytes (${total} uncompressed)`);
