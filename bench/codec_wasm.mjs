// SPDX-License-Identifier: Apache-2.0
// WebAssembly decode times for bench/codec_bench: osteon's decoder (web/decoder/osteon_decoder.mjs)
// and Draco's (npm draco3d, the version bench/package.json pins), in one Node process.
//
//   node bench/codec_wasm.mjs [--repeat N] [--min-ms MS] [--decoder DIR] FILE...
//
// FILE ending in .ostm is decoded by osteon, .drc by Draco. Prints one JSON object:
//   { node, draco3d: {version} | {unavailable}, osteon: {module} | {unavailable},
//     results: [{ file, codec, ms, runs, triangles, vertices } | { file, codec, error }] }
// A decoder that cannot be loaded leaves its files with `error` and names the reason in
// `unavailable`. The osteon decoder is the first of --decoder DIR, $OSTEON_WASM_DIR, build/wasm
// (web/decoder/build.sh's output) and web/decoder that holds osteon_decoder.mjs and .wasm.
//
// What one decode is, for both: bytes in, then positions (float32 x3) and triangle indices (uint32
// x3) copied out of WebAssembly memory into JavaScript typed arrays, the way three.js's
// DRACOLoader reads Draco and osteon_decoder.mjs returns its mesh. osteon's decode also computes
// smooth vertex normals (its stream carries none) and copies them out too; Draco's computes none
// (the page would).
// Times are wall clock (performance.now), the best of at least N decodes and of at least MS ms of
// decoding per file; the first decode of each file (compilation tiers, memory growth) counts
// like the others, and is usually the slowest.

import { readFile } from 'node:fs/promises';
import { existsSync } from 'node:fs';
import { createRequire } from 'node:module';
import { fileURLToPath, pathToFileURL } from 'node:url';
import path from 'node:path';

import { parseCommandLine } from './lib/args.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.join(here, '..');
// Where a built decoder (osteon_decoder.mjs with osteon_decoder.wasm beside it) is looked for:
// --decoder DIR, else $OSTEON_WASM_DIR, else web/decoder/build.sh's default output (build/wasm),
// else web/decoder.
const kDecoderDirs = [process.env.OSTEON_WASM_DIR, path.join(root, 'build', 'wasm'),
  path.join(root, 'web', 'decoder')].filter(Boolean);

function parseOptions() {
  const usage = 'node bench/codec_wasm.mjs [--repeat N] [--min-ms MS] [--decoder DIR] FILE...';
  const { values, positionals } = parseCommandLine({
    usage,
    about: 'WebAssembly decode times of .ostm (osteon) and .drc (Draco) files in Node; prints JSON.',
    positionals: true,
    options: {
      repeat: { type: 'string', default: '5', arg: 'N', help: 'decodes per file, at least (default 5)' },
      'min-ms': { type: 'string', default: '200', arg: 'MS',
        help: 'milliseconds of decoding per file, at least (default 200)' },
      decoder: { type: 'string', arg: 'DIR',
        help: 'the built osteon decoder (default $OSTEON_WASM_DIR, build/wasm, web/decoder)' },
    },
  });
  const args = { repeat: Number(values.repeat), minMs: Number(values['min-ms']),
    decoder: values.decoder ?? null, files: positionals };
  if (!(args.repeat >= 1) || !(args.minMs >= 0)) throw new Error(`usage: ${usage}`);
  return args;
}

/// Draco's decoder, used the way three.js's DRACOLoader uses it.
async function loadDraco() {
  const require = createRequire(import.meta.url);
  let draco3d;
  let version;
  try {
    draco3d = require('draco3d');
    version = require('draco3d/package.json').version;
  } catch (e) {
    const why = e.message.split('\n')[0];
    return { unavailable: `npm draco3d not installed (cd bench && npm ci): ${why}` };
  }
  const M = await draco3d.createDecoderModule({});
  function decode(bytes) {
    const decoder = new M.Decoder();
    const mesh = new M.Mesh();
    try {
      const status = decoder.DecodeArrayToMesh(bytes, bytes.byteLength, mesh);
      if (!status.ok() || mesh.ptr === 0) throw new Error(`draco: ${status.error_msg()}`);
      const triangles = mesh.num_faces();
      const vertices = mesh.num_points();
      const indexBytes = triangles * 3 * 4;
      let ptr = M._malloc(indexBytes);
      decoder.GetTrianglesUInt32Array(mesh, indexBytes, ptr);
      const indices = new Uint32Array(M.HEAPU32.buffer, ptr, triangles * 3).slice();
      M._free(ptr);
      const attribute = decoder.GetAttribute(mesh, decoder.GetAttributeId(mesh, M.POSITION));
      const positionBytes = vertices * 3 * 4;
      ptr = M._malloc(positionBytes);
      decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, M.DT_FLOAT32, positionBytes, ptr);
      const positions = new Float32Array(M.HEAPF32.buffer, ptr, vertices * 3).slice();
      M._free(ptr);
      return { triangles: indices.length / 3, vertices: positions.length / 3 };
    } finally {
      M.destroy(mesh);
      M.destroy(decoder);
    }
  }
  return { version, decode };
}

async function loadOsteon(dir) {
  const dirs = dir ? [dir] : kDecoderDirs;
  const found = dirs.find((d) => existsSync(path.join(d, 'osteon_decoder.mjs')) &&
                                 existsSync(path.join(d, 'osteon_decoder.wasm')));
  if (!found) {
    return { unavailable: `decoder not built (no osteon_decoder.wasm beside osteon_decoder.mjs in ${
      dirs.map((d) => path.relative(root, d) || '.').join(', ')}; bash web/decoder/build.sh)` };
  }
  const module = path.join(found, 'osteon_decoder.mjs');
  try {
    const { createDecoder } = await import(pathToFileURL(module).href);
    const decoder = await createDecoder();
    return {
      module: module.startsWith(root + path.sep) ? path.relative(root, module) : module,
      decode(bytes) {
        const mesh = decoder.decode(bytes);
        return { triangles: mesh.triangleCount, vertices: mesh.vertexCount };
      },
    };
  } catch (e) {
    return { unavailable: `cannot load ${module}: ${e.message}` };
  }
}

function timeDecodes(decode, bytes, repeat, minMs) {
  let best = Infinity;
  let total = 0;
  let runs = 0;
  let counts;
  for (; runs < repeat || (total < minMs && runs < 200); ++runs) {
    const start = performance.now();
    counts = decode(bytes);
    const ms = performance.now() - start;
    best = Math.min(best, ms);
    total += ms;
  }
  return { ms: best, runs, ...counts };
}

async function main() {
  const args = parseOptions();
  const draco = await loadDraco();
  const osteon = await loadOsteon(args.decoder);
  const results = [];
  for (const file of args.files) {
    const codec = file.endsWith('.drc') ? 'draco' : file.endsWith('.ostm') ? 'osteon' : null;
    const decoder = codec === 'draco' ? draco : codec === 'osteon' ? osteon : null;
    if (!decoder) {
      results.push({ file, codec, error: 'unknown extension (want .drc or .ostm)' });
    } else if (decoder.unavailable) {
      results.push({ file, codec, error: decoder.unavailable });
    } else {
      try {
        const bytes = new Uint8Array(await readFile(file));
        const timed = timeDecodes(decoder.decode, bytes, args.repeat, args.minMs);
        results.push({ file, codec, ...timed });
      } catch (e) {
        results.push({ file, codec, error: String(e?.message ?? e) });
      }
    }
  }
  const describe = (d, key) => (d.unavailable ? { unavailable: d.unavailable } : { [key]: d[key] });
  const out = {
    node: process.version,
    draco3d: describe(draco, 'version'),
    osteon: describe(osteon, 'module'),
    timing: `wall clock (performance.now), best of >= ${args.repeat} decodes, >= ${args.minMs} ms`,
    results,
  };
  process.stdout.write(`${JSON.stringify(out)}\n`);
}

main().catch((e) => {
  process.stderr.write(`codec_wasm: ${e?.stack ?? e}\n`);
  process.exit(1);
});
