// SPDX-License-Identifier: Apache-2.0
// WebAssembly decode times for bench/codec_bench: osteon's decoder (web/decoder/osteon_decoder.mjs),
// Draco's (npm draco3d) and meshoptimizer 1.x's (npm meshoptimizer, which also codes: below), the
// versions bench/package.json pins, in one Node process.
//
//   node bench/codec_wasm.mjs [--repeat N] [--min-ms MS] [--decoder DIR] FILE...
//
// FILE ending in .ostm is decoded by osteon, .drc by Draco, .mvb coded and decoded by
// meshoptimizer (loadMeshopt). Prints one JSON object:
//   { node, draco3d: {version} | {unavailable}, osteon: {module} | {unavailable},
//     meshoptimizer: {version, vertex_codec, level} | {unavailable},
//     results: [{ file, codec, ms, runs, triangles, vertices[, bytes][, sha256] }
//               | { file, codec, error }] }
// (bytes: meshoptimizer's gzipped stream; sha256: osteon's decoded positions, indices and
// normals, each array's bytes hashed, for the bench to compare with the native decoder's.)
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

import { createHash } from 'node:crypto';
import { readFile } from 'node:fs/promises';
import { gunzipSync, gzipSync } from 'node:zlib';
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

/// meshoptimizer 1.x (the npm package bench/package.json pins): a FILE ending in .mvb is the
/// vertex and index buffers codec_bench hands its meshoptimizer 0.18 column (u32 vertex count,
/// u32 index count, u32 stride, the quantized vertices, the u32 indices; after vertex cache and
/// fetch optimisation), coded here with the newest vertex codec (version 1) at its best level (3)
/// and the index codec, then gzip -9, as a page would fetch it; each decode (gunzip, then the
/// WebAssembly decoders, with SIMD where Node has it) must give back the very buffers.
async function loadMeshopt() {
  const require = createRequire(import.meta.url);
  let MeshoptEncoder;
  let MeshoptDecoder;
  let version;
  try {
    ({ MeshoptEncoder } = await import('meshoptimizer/encoder'));
    ({ MeshoptDecoder } = await import('meshoptimizer/decoder'));
    // The package's exports leave out package.json: read it beside the resolved entry point.
    const entry = require.resolve('meshoptimizer');
    version = JSON.parse(await readFile(path.join(path.dirname(entry), 'package.json'))).version;
  } catch (e) {
    const why = e.message.split('\n')[0];
    return { unavailable: `npm meshoptimizer not installed (cd bench && npm ci): ${why}` };
  }
  await MeshoptEncoder.ready;
  await MeshoptDecoder.ready;
  const kLevel = 3;
  const kVertexVersion = 1;
  function split(raw) {
    const header = new Uint32Array(raw.buffer, raw.byteOffset, 3);
    const [vertexCount, indexCount, stride] = header;
    const vertices = raw.subarray(12, 12 + vertexCount * stride);
    const indices = raw.subarray(12 + vertexCount * stride, 12 + vertexCount * stride + indexCount * 4);
    return { vertexCount, indexCount, stride, vertices, indices };
  }
  /// The gzipped stream of one .mvb file: a 12-byte header (vertex count, index count, encoded
  /// vertex bytes), the encoded vertices, the encoded indices.
  function encode(raw) {
    const { vertexCount, indexCount, stride, vertices, indices } = split(raw);
    const vbuf = MeshoptEncoder.encodeVertexBufferLevel(vertices.slice(), vertexCount, stride,
      kLevel, kVertexVersion);
    const ibuf = MeshoptEncoder.encodeIndexBuffer(indices.slice(), indexCount, 4);
    const stream = new Uint8Array(12 + vbuf.length + ibuf.length);
    new Uint32Array(stream.buffer, 0, 3).set([vertexCount, indexCount, vbuf.length]);
    stream.set(vbuf, 12);
    stream.set(ibuf, 12 + vbuf.length);
    return { stream: gzipSync(stream, { level: 9 }), stride };
  }
  function decodeWith(stride) {
    return (gz) => {
      const raw = gunzipSync(gz);
      const [vertexCount, indexCount, vbytes] = new Uint32Array(raw.buffer, raw.byteOffset, 3);
      const vertices = new Uint8Array(vertexCount * stride);
      const indices = new Uint32Array(indexCount);
      MeshoptDecoder.decodeVertexBuffer(vertices, vertexCount, stride, raw.subarray(12, 12 + vbytes));
      MeshoptDecoder.decodeIndexBuffer(new Uint8Array(indices.buffer), indexCount, 4,
        raw.subarray(12 + vbytes));
      return { triangles: indexCount / 3, vertices: vertexCount, decoded: { vertices, indices } };
    };
  }
  function measure(raw, repeat, minMs) {
    const { stream, stride } = encode(raw);
    const decode = decodeWith(stride);
    const original = split(raw);
    const back = decode(stream).decoded;
    // The index codec may rotate a triangle's corners (its winding kept): compare up to that.
    const coded = new Uint32Array(original.indices.slice().buffer);
    let same = Buffer.compare(Buffer.from(back.vertices), Buffer.from(original.vertices)) === 0 &&
      back.indices.length === coded.length;
    for (let t = 0; same && t < coded.length; t += 3) {
      const [a, b, c] = [coded[t], coded[t + 1], coded[t + 2]];
      const [x, y, z] = [back.indices[t], back.indices[t + 1], back.indices[t + 2]];
      same = (x === a && y === b && z === c) || (x === b && y === c && z === a) ||
        (x === c && y === a && z === b);
    }
    if (!same) throw new Error('meshoptimizer: the decoded buffers differ from the coded ones');
    const timed = timeDecodes((bytes) => {
      const { triangles, vertices } = decode(bytes);
      return { triangles, vertices };
    }, stream, repeat, minMs);
    return { bytes: stream.length, ...timed };
  }
  return { version, measure, level: kLevel, vertexVersion: kVertexVersion };
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
        return { triangles: mesh.triangleCount, vertices: mesh.vertexCount, mesh };
      },
    };
  } catch (e) {
    return { unavailable: `cannot load ${module}: ${e.message}` };
  }
}

/// The SHA-256 of each array a decode returned (the bytes of its float32 or uint32 elements),
/// in hex: bench/codec_bench compares them with the native decoder's.
function digests(mesh) {
  const hex = (array) => createHash('sha256')
    .update(new Uint8Array(array.buffer, array.byteOffset, array.byteLength)).digest('hex');
  return { positions: hex(mesh.positions), indices: hex(mesh.indices), normals: hex(mesh.normals) };
}

function timeDecodes(decode, bytes, repeat, minMs) {
  let best = Infinity;
  let total = 0;
  let runs = 0;
  let last;
  for (; runs < repeat || (total < minMs && runs < 200); ++runs) {
    const start = performance.now();
    last = decode(bytes);
    const ms = performance.now() - start;
    best = Math.min(best, ms);
    total += ms;
  }
  const { mesh, ...counts } = last;
  return { ms: best, runs, ...counts, ...(mesh ? { sha256: digests(mesh) } : {}) };
}

async function main() {
  const args = parseOptions();
  const draco = await loadDraco();
  const osteon = await loadOsteon(args.decoder);
  const meshopt = await loadMeshopt();
  const results = [];
  for (const file of args.files) {
    if (file.endsWith('.mvb')) {
      if (meshopt.unavailable) {
        results.push({ file, codec: 'meshopt', error: meshopt.unavailable });
        continue;
      }
      try {
        const raw = new Uint8Array(await readFile(file));
        results.push({ file, codec: 'meshopt', ...meshopt.measure(raw, args.repeat, args.minMs) });
      } catch (e) {
        results.push({ file, codec: 'meshopt', error: String(e?.message ?? e) });
      }
      continue;
    }
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
    meshoptimizer: meshopt.unavailable ? { unavailable: meshopt.unavailable }
      : { version: meshopt.version, vertex_codec: meshopt.vertexVersion, level: meshopt.level },
    timing: `wall clock (performance.now), best of >= ${args.repeat} decodes, >= ${args.minMs} ms`,
    results,
  };
  process.stdout.write(`${JSON.stringify(out)}\n`);
}

main().catch((e) => {
  process.stderr.write(`codec_wasm: ${e?.stack ?? e}\n`);
  process.exit(1);
});
