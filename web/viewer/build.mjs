// SPDX-License-Identifier: Apache-2.0
// Builds the viewer into build/viewer/ (repository root; `osteon pack` copies that folder into every
// package):
//   index.html                       the page, naming the bundles below
//   viewer-<h>.js, viewer-<h>.css    the page's script (three.js, the viewer, the decoder pool) and style
//   decoder-worker-<h>.js            the decoder worker (web/decoder/worker.mjs and the wrapper)
//   osteon_decoder.wasm              the WebAssembly decoder (build/wasm, from npm run build:decoder)
//   *.gz                             gzip -9 copies of the text files and the wasm, which
//                                    `osteon serve` sends to clients that accept gzip
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

const files = new Map();  // output name -> bytes
const worker = await bundle('../decoder/worker.mjs');
const workerName = hashed('decoder-worker', 'js', worker);
files.set(workerName, worker);
const script = await bundle('main.mjs', { define: { OSTEON_WORKER_FILE: JSON.stringify(workerName) } });
const scriptName = hashed('viewer', 'js', script);
files.set(scriptName, script);
const style = await bundle('viewer.css');
const styleName = hashed('viewer', 'css', style);
files.set(styleName, style);
files.set('osteon_decoder.wasm', readFileSync(wasmPath));

let html = readFileSync(join(here, 'index.html'), 'utf8');
for (const [marker, name] of [['%VIEWER_JS%', scriptName], ['%VIEWER_CSS%', styleName]]) {
  if (!html.includes(marker)) fail(`web/viewer/index.html lacks the marker ${marker}`);
  html = html.replaceAll(marker, name);
}
files.set('index.html', Buffer.from(html));

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
  // index.html is 3 KB: not worth a second copy.
  if (name !== 'index.html') writeFileSync(join(out, `${name}.gz`), gz);
  total += bytes.length;
  totalGz += gz.length;
  rows.push([name, bytes.length, gz.length]);
}
const width = Math.max(...rows.map((r) => r[0].length));
for (const [name, size, gz] of rows) {
  console.log(`osteon: ${out}/${name.padEnd(width)} ${String(size).padStart(8)} bytes, gzip -9 ${String(gz).padStart(7)}`);
}
console.log(`osteon: viewer download (all files, gzip -9): ${totalGz} bytes (${total} uncompressed)`);
