// SPDX-License-Identifier: Apache-2.0
// Builds what the npm package publishes (web/package.json "files"), into web/dist/ (ignored by
// git): `npm run build:package`, and `npm pack` runs it first (prepack).
//
//   dist/loader.js            OsteonLoader (viewer/loader.mjs) with the modules it shares with the
//                             viewer (manifest, stream, scene, decoder pool and wrapper) bundled
//                             in; three is left an import (a peer dependency)
//   dist/loader.d.ts          its types (viewer/loader.d.ts)
//   dist/decoder-worker.js    the decoder worker (decoder/worker.mjs with the wrapper)
//   dist/osteon_decoder.wasm  the WebAssembly decoder (build/wasm/, `npm run build:decoder`)
//   dist/osteon-viewer.mjs    <osteon-viewer> (viewer/element.mjs), with its types
//                             (viewer/element.d.ts): the viewer's own build (viewer/build.mjs,
//                             into a temporary folder), so the element in the package is the
//                             standalone page's: osteon-viewer.mjs re-exports element-<h>.js,
//                             which starts render-worker-<h>.js, render-three-<h>.js and
//                             decoder-worker-<h>.js and fetches osteon_decoder.wasm, all beside it
//                             (three.js bundled in: the element draws in its own worker)
//
// Each bundle is minified ES2022 (the module a page or a bundler gets is the one measured by
// bench/npm_package_size.mjs). The decoder's Node-only branches (node:fs for file: URLs,
// node:worker_threads) are replaced by modules that throw: the package is for browsers. Every
// worker and WebAssembly URL in the bundles is written `new URL('./<file>', import.meta.url)`
// with a file that is in dist/, the form bundlers (Vite, webpack 5) follow to copy the files.
// Prints each file's size and its gzip -9 size.

import { spawnSync } from 'node:child_process';
import { copyFileSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { gzipSync } from 'node:zlib';

import * as esbuild from 'esbuild';

const web = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(web, '..');
const out = path.resolve(process.env.OSTEON_PACKAGE_OUT ?? path.join(web, 'dist'));
const wasmDir = path.resolve(process.env.OSTEON_WASM_DIR ?? path.join(repo, 'build', 'wasm'));
const wasm = path.join(wasmDir, 'osteon_decoder.wasm');

if (!existsSync(wasm)) {
  console.error(`osteon: ${wasm} is missing: run npm run build:decoder first`);
  process.exit(1);
}

/// node:* imports (taken only under Node) become modules that throw when imported.
const browserOnly = {
  name: 'browser-only',
  setup(build) {
    build.onResolve({ filter: /^node:/ }, (args) => ({ path: args.path, namespace: 'browser-only' }));
    build.onLoad({ filter: /.*/, namespace: 'browser-only' }, (args) => ({
      contents: `throw new Error(${JSON.stringify(`osteon: ${args.path} is not available in the browser build`)});`,
      loader: 'js',
    }));
  },
};

/// The pool's default worker (`new Worker(new URL('./worker.mjs', import.meta.url))`, unused by
/// the loader, which passes its own) is the package's decoder-worker.js: bundlers that follow
/// that form (Vite, webpack 5) would otherwise look for a dist/worker.mjs that is not there.
const poolWorker = {
  name: 'pool-worker',
  setup(build) {
    build.onLoad({ filter: /decoder[\\/]pool\.mjs$/ }, (args) => {
      const text = readFileSync(args.path, 'utf8');
      const from = "new URL('./worker.mjs', import.meta.url)";
      if (!text.includes(from)) throw new Error(`osteon: ${args.path}: no ${from} to point at decoder-worker.js`);
      return { contents: text.replaceAll(from, "new URL('./decoder-worker.js', import.meta.url)"), loader: 'js' };
    });
  },
};

/// The worker's Node branch (`await import('node:worker_threads')`) goes: a top-level await is
/// refused by bundlers that build workers as classic scripts (Vite's default).
const workerBrowserOnly = {
  name: 'worker-browser-only',
  setup(build) {
    build.onLoad({ filter: /decoder[\\/]worker\.mjs$/ }, (args) => {
      const text = readFileSync(args.path, 'utf8');
      const from = "const { parentPort } = await import('node:worker_threads');";
      if (!text.includes(from)) throw new Error(`osteon: ${args.path}: no ${from} to take out`);
      const to = "const parentPort = null; throw new Error('osteon: this decoder worker runs in browsers');";
      return { contents: text.replace(from, to), loader: 'js' };
    });
  },
};

const common = {
  bundle: true,
  format: 'esm',
  platform: 'browser',
  target: 'es2022',
  minify: true,
  legalComments: 'none',
  external: ['three'],
  plugins: [browserOnly, poolWorker, workerBrowserOnly],
  logLevel: 'warning',
  banner: { js: '// SPDX-License-Identifier: Apache-2.0\n// osteon (https://github.com/osteon): built by web/build_package.mjs' },
};

rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });
const entries = [
  [path.join(web, 'viewer', 'loader.mjs'), 'loader.js'],
  [path.join(web, 'decoder', 'worker.mjs'), 'decoder-worker.js'],
];
for (const [entry, name] of entries) {
  await esbuild.build({ ...common, entryPoints: [entry], outfile: path.join(out, name) });
}

// The element: the viewer's build, less the standalone page and the gzip copies.
const viewerOut = mkdtempSync(path.join(tmpdir(), 'osteon-viewer-'));
try {
  const built = spawnSync(process.execPath, [path.join(web, 'viewer', 'build.mjs')], {
    env: { ...process.env, OUT: viewerOut, WASM: wasm },
    stdio: ['ignore', 'ignore', 'inherit'],
  });
  if (built.status !== 0) {
    console.error('osteon: the viewer build (viewer/build.mjs) failed: the package needs its element');
    process.exit(1);
  }
  for (const name of readdirSync(viewerOut)) {
    if (name === 'index.html' || name.endsWith('.gz') || name === 'osteon_decoder.wasm') continue;
    copyFileSync(path.join(viewerOut, name), path.join(out, name));
    entries.push([null, name]);
  }
} finally {
  rmSync(viewerOut, { recursive: true, force: true });
}
copyFileSync(wasm, path.join(out, 'osteon_decoder.wasm'));
copyFileSync(path.join(web, 'viewer', 'loader.d.ts'), path.join(out, 'loader.d.ts'));
copyFileSync(path.join(web, 'viewer', 'element.d.ts'), path.join(out, 'osteon-viewer.d.ts'));

for (const name of [...entries.map(([, n]) => n), 'osteon_decoder.wasm']) {
  const bytes = readFileSync(path.join(out, name));
  console.log(`osteon: dist/${name} ${bytes.length} bytes, gzip -9 ${gzipSync(bytes, { level: 9 }).length}`);
}
