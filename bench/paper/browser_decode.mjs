// SPDX-License-Identifier: Apache-2.0
// Decompression time in a real browser: Debian's Chromium, headless, driven by npm playwright-core
// (bench/package.json pins it; no browser is downloaded: the one at --chromium is used), loading a
// page that runs osteon's WebAssembly decoder (build/wasm, web/decoder/build.sh's output) and,
// for reference, Draco's (npm draco3d) on the same mesh.
//
//   node bench/paper/browser_decode.mjs [--runs N] [--min-ms MS] [--wasm-dir DIR] [--chromium PATH]
//                                       FILE...
//
// FILE ending in .ostm is decoded by osteon, .drc by Draco. Prints one JSON object:
//   { browser, playwright_core, user_agent, osteon_module, draco3d, timing,
//     results: [{ file, codec, bytes, triangles, vertices, first_ms, median_ms, min_ms, max_ms,
//                 runs, times_ms }] }
//
// What is timed, for both decoders: the decode call on the page's main thread, bytes already in
// memory, up to typed arrays in JavaScript: osteon's decoder.decode(bytes) (positions, indices
// and the smooth normals it computes, copied out of WebAssembly memory) and Draco's
// DecodeArrayToMesh + GetTrianglesUInt32Array + GetAttributeDataArrayForAllPoints (positions and
// indices copied out, no normals), the way three.js's DRACOLoader uses it. Each file gets a fresh
// page (a fresh module instance): the first decode (compilation tiers, memory growth) is reported
// on its own as first_ms; median_ms is the median of the decodes that follow: at least N, and at
// least MS ms of them (default 1500; small meshes get many more, so that the median is the
// optimised code's, not the baseline tier's on its way up). Clock:
// performance.now(), which Chromium coarsens to 0.1 ms on a page that is not cross-origin
// isolated (far below the times measured here).
//
// The page is served from memory through Playwright's request routing (no server, no port): the
// timing starts after the bytes arrived, so the transport does not matter.

import { existsSync, readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { root } from './lib.mjs';
import { parseCommandLine } from '../lib/args.mjs';
import { spread } from '../lib/stats.mjs';

const kOrigin = 'http://osteon.bench';
const kChromiumArgs = [
  // Headless WebGL through SwiftShader is not needed to decode, but the same flags keep this page
  // in the configuration bench/web uses for rendering.
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
];

const kMime = {
  '.html': 'text/html; charset=utf-8',
  '.mjs': 'text/javascript',
  '.js': 'text/javascript',
  '.wasm': 'application/wasm',
};

const kPage = `<!doctype html><meta charset="utf-8"><title>osteon decode timing</title>
<script>
// Times one file: fetch its bytes once, then 1 + runs decodes; returns the times and the counts
// the decoder reported (the driver checks them against the encoder's).
window.timeDecodes = async function ({ url, codec, runs, minMs }) {
  const bytes = new Uint8Array(await (await fetch(url)).arrayBuffer());
  let decode;
  if (codec === 'osteon') {
    const { createDecoder } = await import('/wasm/osteon_decoder.mjs');
    const decoder = await createDecoder();
    decode = () => {
      const m = decoder.decode(bytes, url);
      return { triangles: m.triangleCount, vertices: m.vertexCount };
    };
  } else {
    await new Promise((resolve, reject) => {
      const s = document.createElement('script');
      s.src = '/draco/draco_decoder_nodejs.js';
      s.onload = resolve;
      s.onerror = () => reject(new Error('cannot load draco_decoder_nodejs.js'));
      document.head.appendChild(s);
    });
    const wasmBinary = await (await fetch('/draco/draco_decoder.wasm')).arrayBuffer();
    const M = await DracoDecoderModule({ wasmBinary });
    decode = () => {
      const decoder = new M.Decoder();
      const mesh = new M.Mesh();
      try {
        const status = decoder.DecodeArrayToMesh(bytes, bytes.byteLength, mesh);
        if (!status.ok() || mesh.ptr === 0) throw new Error('draco: ' + status.error_msg());
        const triangles = mesh.num_faces();
        const vertices = mesh.num_points();
        let ptr = M._malloc(triangles * 12);
        decoder.GetTrianglesUInt32Array(mesh, triangles * 12, ptr);
        const indices = new Uint32Array(M.HEAPU32.buffer, ptr, triangles * 3).slice();
        M._free(ptr);
        const attribute = decoder.GetAttribute(mesh, decoder.GetAttributeId(mesh, M.POSITION));
        ptr = M._malloc(vertices * 12);
        decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, M.DT_FLOAT32, vertices * 12, ptr);
        const positions = new Float32Array(M.HEAPF32.buffer, ptr, vertices * 3).slice();
        M._free(ptr);
        return { triangles: indices.length / 3, vertices: positions.length / 3 };
      } finally {
        M.destroy(mesh);
        M.destroy(decoder);
      }
    };
  }
  // At least 1 + runs decodes and at least minMs of decoding after the first (at most 400):
  // a small mesh decodes in a few ms, and its first dozen decodes still run partly in the
  // baseline tier, so a fixed count would time the tier-up rather than the decoder.
  const times = [];
  let counts;
  let total = 0;
  for (let i = 0; i <= runs || (total < minMs && i <= 400); ++i) {
    const start = performance.now();
    counts = decode();
    const ms = performance.now() - start;
    times.push(ms);
    if (i > 0) total += ms;
  }
  return { bytes: bytes.byteLength, times, ...counts };
};
</script>`;

function findWasmDir(dir) {
  const dirs = dir ? [dir] : [process.env.OSTEON_WASM_DIR, path.join(root, 'build', 'wasm')]
    .filter(Boolean);
  const found = dirs.find((d) => existsSync(path.join(d, 'osteon_decoder.mjs')) &&
                                 existsSync(path.join(d, 'osteon_decoder.wasm')));
  if (!found) {
    throw new Error(`no built WASM decoder in ${dirs.join(', ')} ` +
      '(cd web && npm ci && npm run build:decoder)');
  }
  return found;
}

async function main() {
  const usage = 'node bench/paper/browser_decode.mjs [options] FILE.ostm|FILE.drc ...';
  const { values: args, positionals } = parseCommandLine({
    usage,
    about: 'Times osteon\'s (.ostm) and Draco\'s (.drc) WebAssembly decoders in headless Chromium;\n' +
      'prints JSON.',
    positionals: true,
    options: {
      runs: { type: 'string', arg: 'N', default: '9', help: 'decodes after the first, at least (default 9)' },
      'min-ms': { type: 'string', arg: 'MS', default: '1500',
        help: 'milliseconds of decoding after the first, at least (default 1500)' },
      'wasm-dir': { type: 'string', arg: 'DIR', help: 'the built decoder (default $OSTEON_WASM_DIR, else build/wasm)' },
      chromium: { type: 'string', arg: 'PATH',
        help: 'Chromium (default $OSTEON_CHROMIUM, else /usr/bin/chromium; never downloaded)' },
    },
  });
  const runs = Number(args.runs);
  const minMs = Number(args['min-ms']);
  if (!(runs >= 1) || !(minMs >= 0) || positionals.length === 0) throw new Error(`usage: ${usage}`);
  const chromium = args.chromium ?? process.env.OSTEON_CHROMIUM ?? '/usr/bin/chromium';
  if (!existsSync(chromium)) throw new Error(`no Chromium at ${chromium} (apt-get install chromium)`);
  const wasmDir = findWasmDir(args['wasm-dir']);
  const require = createRequire(path.join(root, 'bench', 'package.json'));
  let playwright;
  let dracoDir;
  try {
    playwright = require('playwright-core');
    dracoDir = path.dirname(require.resolve('draco3d/package.json'));
  } catch (e) {
    throw new Error(`npm packages missing (cd bench && npm ci): ${e.message.split('\n')[0]}`);
  }
  const dracoVersion = require('draco3d/package.json').version;
  const playwrightVersion = require('playwright-core/package.json').version;
  const files = positionals.map((f) => path.resolve(f));
  for (const f of files) {
    if (!f.endsWith('.ostm') && !f.endsWith('.drc')) throw new Error(`${f}: want .ostm or .drc`);
    if (!existsSync(f)) throw new Error(`${f}: no such file`);
  }

  const browser = await playwright.chromium.launch({
    executablePath: chromium, headless: true, args: kChromiumArgs,
  });
  const results = [];
  let userAgent = '';
  try {
    const context = await browser.newContext();
    // Everything the page asks for comes from memory or disk here: the page, the decoders, and
    // /f/<i> for the i-th file.
    await context.route(`${kOrigin}/**`, async (route) => {
      const url = new URL(route.request().url());
      let file = null;
      let body = null;
      if (url.pathname === '/') body = kPage;
      else if (url.pathname.startsWith('/wasm/')) file = path.join(wasmDir, path.basename(url.pathname));
      else if (url.pathname.startsWith('/draco/')) file = path.join(dracoDir, path.basename(url.pathname));
      else if (url.pathname.startsWith('/f/')) file = files[Number(url.pathname.slice(3))];
      if (body == null && (!file || !existsSync(file))) return route.fulfill({ status: 404, body: '' });
      const type = body != null ? kMime['.html']
        : kMime[path.extname(file)] ?? 'application/octet-stream';
      return route.fulfill({ status: 200, contentType: type, body: body ?? readFileSync(file) });
    });
    for (let i = 0; i < files.length; ++i) {
      const codec = files[i].endsWith('.ostm') ? 'osteon' : 'draco';
      const page = await context.newPage();
      const errors = [];
      page.on('pageerror', (e) => errors.push(e.message));
      try {
        await page.goto(`${kOrigin}/`);
        userAgent = await page.evaluate(() => navigator.userAgent);
        const r = await page.evaluate((a) => window.timeDecodes(a),
          { url: `/f/${i}`, codec, runs, minMs });
        const [first, ...rest] = r.times;
        const s = spread(rest);
        results.push({
          file: files[i], codec, bytes: r.bytes, triangles: r.triangles, vertices: r.vertices,
          first_ms: first, median_ms: s.median, min_ms: s.min, max_ms: s.max, runs: s.n,
          times_ms: r.times,
        });
      } catch (e) {
        results.push({ file: files[i], codec, error: `${e.message.split('\n')[0]}${
          errors.length ? ` (page: ${errors.join('; ')})` : ''}` });
      } finally {
        await page.close();
      }
      process.stderr.write(`browser_decode: ${path.basename(files[i])} done\n`);
    }
  } finally {
    await browser.close();
  }
  const out = {
    browser: `${chromium} ${browser.version()}`,
    playwright_core: playwrightVersion,
    user_agent: userAgent,
    osteon_module: path.relative(root, path.join(wasmDir, 'osteon_decoder.wasm')),
    draco3d: dracoVersion,
    timing: `main-thread decode, performance.now(); first decode of a fresh page, then the median of ${
      runs} or more (at least ${minMs} ms of decoding, at most 400)`,
    results,
  };
  process.stdout.write(`${JSON.stringify(out)}\n`);
}

main().catch((e) => {
  process.stderr.write(`browser_decode: ${e?.message ?? e}\n`);
  process.exit(1);
});
