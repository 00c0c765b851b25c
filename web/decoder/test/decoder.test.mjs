// SPDX-License-Identifier: Apache-2.0
// The WebAssembly decoder against the native one: streams written by the native encoder (the
// `osteon` CLI) are decoded by the built module (build/wasm, what a page downloads) and by the
// CLI (`osteon decode` to binary PLY); positions must match bit for bit, indices exactly, normals
// within 1e-6. Then bad bytes, memory release, the worker pool, the size budget, and the decode
// speed on the dense ct-like meshes (printed, best of 5).
//
// Inputs are generated at test time into a temporary folder. Environment:
//   OSTEON_CLI          the native CLI (default: build/release/osteon, then build/osteon)
//   OSTEON_WASM_DIR     the built decoder (default: build/wasm; `npm run build:decoder`)
//   OSTEON_SHARED_DATA  the real meshes (default: ../shared/data beside the checkout)

import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { Worker } from 'node:worker_threads';
import { gzipSync } from 'node:zlib';

import { headerCounts, withChecksum, withCounts } from '../../test/ostm_bytes.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..', '..', '..');
const wasmDir = path.resolve(process.env.OSTEON_WASM_DIR ?? path.join(repo, 'build', 'wasm'));
const dataDir = path.resolve(process.env.OSTEON_SHARED_DATA ?? path.join(repo, '..', 'shared', 'data'));
const cli = process.env.OSTEON_CLI ??
  [path.join(repo, 'build', 'release', 'osteon'), path.join(repo, 'build', 'osteon')].find(existsSync);
// The decoder's download budget: 25,000 bytes (WASM plus wrapper, gzip -9), held by this test.
// Node's gzip -9 measures a few dozen bytes more than gzip(1)'s, which build.sh prints.
const kBudgetBytes = 25000;

// A few real meshes with what the phantom lacks: non-manifold edges, inconsistent orientation,
// many components, holes, every reader. The ct-like ones are also timed.
const kRealMeshes = [
  'MyoHub__myo_sim/meshes/ground_spine.stl',
  'MyoHub__myo_sim/meshes/arm_r_radius.stl',
  'aHer-dev__3DAnatomy/models/bones/FJ646_BP62321_FMA7875_Right_first_costal_cartilage.glb',
  'stity__spl-abdominal-atlas/Data/Model_691_Rib11.vtk',
  'cearto__zen__MeshsegBenchmark/data/off/101.off',
  'ingvilddevold__muscle-growth/data/VHF_surfaces/Left/VHF_Left_Cartilage_Talus_smooth.stl',
  // A smoothed isosurface's near-equilateral triangles: the apex prediction (stream version 4).
  'ingvilddevold__muscle-growth/data/VHF_surfaces/Left/VHF_Left_Bone_Navicular_smooth.stl',
];
const kTimedMeshes = ['ct-like/hip_mcs.ply', 'ct-like/skull_mc.ply'];

let work;
let decoder;
let wrapper;

function osteon(...args) {
  return execFileSync(cli, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}

/// Encodes `input` and decodes it natively: the stream's bytes and the native mesh.
function encodeAndDecodeNatively(input, name, encodeArgs = ['--bits', '14']) {
  const stream = path.join(work, `${name}.ostm`);
  const ply = path.join(work, `${name}.ply`);
  osteon('encode', input, '-o', stream, ...encodeArgs);
  const report = JSON.parse(osteon('decode', stream, '-o', ply, '--json'));
  return { bytes: readFileSync(stream), native: readPly(ply), report, stream };
}

/// Reads the binary little-endian PLY `osteon decode` writes: float x y z [nx ny nz], then
/// triangles as a uchar count and three int or uint indices.
function readPly(file) {
  const data = readFileSync(file);
  const end = data.indexOf('end_header\n') + 'end_header\n'.length;
  const header = data.subarray(0, end).toString('latin1');
  const vertices = Number(/element vertex (\d+)/.exec(header)[1]);
  const triangles = Number(/element face (\d+)/.exec(header)[1]);
  const hasNormals = header.includes('property float nx');
  assert.match(header, /format binary_little_endian 1\.0/);
  assert.match(header, /property list uchar u?int vertex_indices/);
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  const stride = hasNormals ? 24 : 12;
  const positions = new Float32Array(3 * vertices);
  const normals = hasNormals ? new Float32Array(3 * vertices) : null;
  for (let v = 0; v < vertices; ++v) {
    for (let k = 0; k < 3; ++k) {
      positions[3 * v + k] = view.getFloat32(end + v * stride + 4 * k, true);
      if (normals) normals[3 * v + k] = view.getFloat32(end + v * stride + 12 + 4 * k, true);
    }
  }
  const indices = new Uint32Array(3 * triangles);
  let at = end + vertices * stride;
  for (let t = 0; t < triangles; ++t, at += 13) {
    assert.equal(data[at], 3, `face ${t} is not a triangle`);
    for (let k = 0; k < 3; ++k) indices[3 * t + k] = view.getUint32(at + 1 + 4 * k, true);
  }
  return { positions, normals, indices, vertices, triangles };
}

function assertSameMesh(wasm, native, what) {
  assert.equal(wasm.vertexCount, native.vertices, `${what}: vertex count`);
  assert.equal(wasm.triangleCount, native.triangles, `${what}: triangle count`);
  assert.equal(wasm.positions.length, 3 * native.vertices);
  assert.equal(wasm.indices.length, 3 * native.triangles);
  assert.equal(wasm.normals.length, 3 * native.vertices);
  // Bit for bit: compare the float32 patterns, so -0 != +0 and NaN patterns count.
  const a = new Uint32Array(wasm.positions.buffer);
  const b = new Uint32Array(native.positions.buffer);
  const firstPosition = a.findIndex((bits, i) => bits !== b[i]);
  assert.equal(firstPosition, -1, `${what}: position coordinate ${firstPosition} differs: ` +
    `${wasm.positions[firstPosition]} (wasm) vs ${native.positions[firstPosition]} (native)`);
  const firstIndex = wasm.indices.findIndex((index, i) => index !== native.indices[i]);
  assert.equal(firstIndex, -1, `${what}: index ${firstIndex} differs`);
  assert.ok(native.normals, `${what}: the native decode wrote no normals`);
  let worst = 0;
  for (let i = 0; i < wasm.normals.length; ++i) {
    worst = Math.max(worst, Math.abs(wasm.normals[i] - native.normals[i]));
  }
  assert.ok(worst <= 1e-6, `${what}: normals differ by ${worst}`);
}

function assertOsteonError(fn, pattern, what) {
  assert.throws(fn, (e) => {
    assert.ok(e instanceof Error, `${what}: threw ${e}`);
    assert.match(e.message, /^osteon: /, `${what}: ${e.message}`);
    if (pattern) assert.match(e.message, pattern, what);
    return true;
  });
}

before(async () => {
  assert.ok(existsSync(path.join(wasmDir, 'osteon_decoder.wasm')),
    `${wasmDir}/osteon_decoder.wasm is missing: run \`npm run build:decoder\` in web/`);
  for (const file of ['osteon_decoder.mjs', 'worker.mjs', 'pool.mjs']) {
    // build.sh minifies the modules: the built copy must be at least as new as its source.
    assert.ok(statSync(path.join(wasmDir, file)).mtimeMs >= statSync(path.join(here, '..', file)).mtimeMs,
      `${wasmDir}/${file} is older than web/decoder/${file}: run \`npm run build:decoder\``);
  }
  assert.ok(cli && existsSync(cli),
    'the native CLI is missing: build it (cmake --build build/release) or set OSTEON_CLI');
  wrapper = await import(pathToFileURL(path.join(wasmDir, 'osteon_decoder.mjs')));
  decoder = await wrapper.createDecoder();
  work = mkdtempSync(path.join(tmpdir(), 'osteon-wasm-'));
  osteon('phantom', '-o', path.join(work, 'phantom'), '--detail', '2');
});

after(() => {
  if (work) rmSync(work, { recursive: true, force: true });
});

describe('the module', () => {
  test('exports the C ABI and imports only what the wrapper gives', () => {
    const module = new WebAssembly.Module(readFileSync(path.join(wasmDir, 'osteon_decoder.wasm')));
    const imports = WebAssembly.Module.imports(module).map((i) => `${i.module}.${i.name}`).sort();
    assert.deepEqual(imports, ['wasi_snapshot_preview1.proc_exit']);
    const exports = WebAssembly.Module.exports(module).map((e) => e.name);
    for (const name of ['osteon_decode', 'osteon_free', 'osteon_error', 'osteon_positions',
      'osteon_indices', 'osteon_normals', 'osteon_vertex_count', 'osteon_triangle_count',
      'osteon_alloc', 'osteon_free_bytes', 'memory', '_initialize']) {
      assert.ok(exports.includes(name), `missing export ${name}`);
    }
  });

  test(`wasm plus wrapper is at most ${kBudgetBytes} bytes gzipped`, (t) => {
    const sizes = {};
    for (const file of ['osteon_decoder.wasm', 'osteon_decoder.mjs', 'worker.mjs', 'pool.mjs']) {
      const bytes = readFileSync(path.join(wasmDir, file));
      sizes[file] = { raw: bytes.length, gzip: gzipSync(bytes, { level: 9 }).length };
      t.diagnostic(`${file}: ${sizes[file].raw} bytes, ${sizes[file].gzip} gzipped`);
    }
    const total = sizes['osteon_decoder.wasm'].gzip + sizes['osteon_decoder.mjs'].gzip;
    t.diagnostic(`wasm + wrapper: ${total} bytes gzipped (budget ${kBudgetBytes})`);
    assert.ok(total <= kBudgetBytes, `${total} bytes gzipped, over the ${kBudgetBytes} budget`);
  });
});

describe('decodes what the native decoder decodes', () => {
  test('every phantom part, and all parts as one multi-component mesh', () => {
    const folder = path.join(work, 'phantom');
    const parts = readdirSync(folder).filter((f) => f.endsWith('.stl')).sort();
    assert.ok(parts.length >= 10, `phantom wrote ${parts.length} parts`);
    for (const part of parts) {
      const { bytes, native } = encodeAndDecodeNatively(path.join(folder, part), part);
      assertSameMesh(decoder.decode(bytes, part), native, part);
    }
    const { bytes, native } = encodeAndDecodeNatively(folder, 'phantom_all');
    assertSameMesh(decoder.decode(bytes), native, 'all phantom parts');
  });

  test('coarse, fine and absolute-precision grids', () => {
    const part = path.join(work, 'phantom', 'skull.stl');
    for (const args of [['--bits', '8'], ['--bits', '24'], ['--precision', '0.05']]) {
      const what = `skull ${args.join(' ')}`;
      const { bytes, native } = encodeAndDecodeNatively(part, what.replace(/\W+/g, '_'), args);
      assertSameMesh(decoder.decode(bytes), native, what);
    }
  });

  test('real meshes: non-manifold, open, many components, every reader', (t) => {
    const present = kRealMeshes.filter((file) => existsSync(path.join(dataDir, file)));
    if (present.length === 0) return t.skip(`no meshes in ${dataDir}`);
    for (const file of present) {
      const { bytes, native } = encodeAndDecodeNatively(path.join(dataDir, file), path.basename(file));
      assertSameMesh(decoder.decode(bytes), native, file);
      t.diagnostic(`${file}: ${native.triangles} triangles, identical`);
    }
  });

  test('dense ct-like meshes, timed (best of 5)', async (t) => {
    const present = kTimedMeshes.filter((file) => existsSync(path.join(dataDir, file)));
    if (present.length === 0) return t.skip(`no ct-like meshes in ${dataDir}`);
    for (const file of present) {
      const { bytes, native, report } = encodeAndDecodeNatively(path.join(dataDir, file), path.basename(file));
      // A fresh instance: its first decode grows the memory, like a page's first mesh.
      const fresh = await wrapper.createDecoder();
      const times = [];
      let mesh;
      for (let run = 0; run < 5; ++run) {
        const start = performance.now();
        mesh = fresh.decode(bytes);
        times.push(performance.now() - start);
      }
      assertSameMesh(mesh, native, file);
      // The heap (web/decoder/bump_allocator.cpp) reuses the blocks the connectivity decoder
      // frees for the geometry's arrays: about 70 bytes a triangle at the peak, as with a
      // general-purpose malloc, where stacking every block would take about 88.
      const perTriangle = fresh.memoryBytes() / mesh.triangleCount;
      assert.ok(perTriangle < 75, `${file}: the decoder's heap peaked at ${perTriangle.toFixed(1)} bytes a triangle`);
      const best = Math.min(...times);
      t.diagnostic(`${file}: ${mesh.triangleCount} triangles, ${bytes.length} bytes; WASM decode ` +
        `best of 5 ${best.toFixed(1)} ms (${(mesh.triangleCount / best / 1e3).toFixed(1)} M ` +
        `triangles/s), first ${times[0].toFixed(1)} ms; native (one decode) ` +
        `${report.decode_ms.toFixed(1)} ms; heap ${(fresh.memoryBytes() / 1048576).toFixed(1)} MiB`);
    }
  });
});

describe('bad input', () => {
  let good;
  before(() => {
    good = encodeAndDecodeNatively(path.join(work, 'phantom', 'femur_l.stl'), 'bad_input_base').bytes;
  });

  test('empty, truncated, wrong magic, flipped bytes: an osteon: error naming the stream', () => {
    const reference = decoder.decode(good);
    assertOsteonError(() => decoder.decode(new Uint8Array(0), 'empty.ostm'),
      /^osteon: empty\.ostm: too short/, 'empty');
    for (const keep of [1, 10, 59, 64, good.length >> 1, good.length - 1]) {
      assertOsteonError(() => decoder.decode(good.subarray(0, keep), 'cut.ostm'),
        /^osteon: cut\.ostm: /, `truncated to ${keep} bytes`);
    }
    const wrongMagic = Uint8Array.from(good);
    wrongMagic[0] ^= 0xff;
    assertOsteonError(() => decoder.decode(wrongMagic), /magic/, 'wrong magic');
    for (const at of [70, good.length >> 1, good.length - 5, good.length - 1]) {
      const flipped = Uint8Array.from(good);
      flipped[at] ^= 0x10;
      assertOsteonError(() => decoder.decode(flipped), /checksum/, `byte ${at} flipped`);
    }
    assertOsteonError(() => decoder.decode('not bytes'), /Uint8Array/, 'a string');
    assert.deepEqual(decoder.decode(good), reference, 'the same mesh after the errors');
  });

  test('corrupt bytes behind a valid checksum: an error or a mesh, never a trap', () => {
    const reference = decoder.decode(good);
    let seed = 12345;
    const random = () => (seed = (Math.imul(seed, 1103515245) + 12345) >>> 0) / 2 ** 32;
    let errors = 0;
    for (let round = 0; round < 300; ++round) {
      const bytes = Uint8Array.from(good);
      const flips = 1 + Math.floor(random() * 4);
      for (let k = 0; k < flips; ++k) {
        bytes[8 + Math.floor(random() * (bytes.length - 12))] ^= 1 << Math.floor(random() * 8);
      }
      try {
        const mesh = decoder.decode(withChecksum(bytes));
        assert.equal(mesh.indices.length, 3 * mesh.triangleCount);
        for (const index of mesh.indices) assert.ok(index < mesh.vertexCount);
      } catch (e) {
        assert.match(e.message, /^osteon: osteon stream: /, `round ${round}: ${e.message}`);
        ++errors;
      }
    }
    assert.ok(errors > 0, 'no corruption was detected');
    assert.deepEqual(decoder.decode(good), reference, 'the same mesh after the corruption');
  });

  test('counts a stream cannot hold are refused before anything is allocated', async () => {
    // A fresh instance, so its memory shows what this decode asked for. The header's counts
    // (docs/FORMAT.md: two varints after the flags) claim up to 2^28 triangles, 3.2 GB of
    // indices, or 10 GB with the positions and normals: the decoder bounds them by the stream's
    // bytes (at most 1024 triangles a byte, no more vertices than three a triangle) and refuses,
    // as the native decoder does (the same source).
    const fresh = await wrapper.createDecoder();
    fresh.decode(good);
    const settled = fresh.memoryBytes();
    const withCountsOf = (vertices, triangles) => withCounts(good, vertices, triangles);
    // One triangle more than 1024 a byte of the stream that declares it (whose varints grow with
    // the count).
    let over = 1024 * good.length + 1;
    while (withCountsOf(3 * over, over).length * 1024 >= over) over = 1024 * withCountsOf(3 * over, over).length + 1;
    for (const [vertices, triangles] of [[0x20000000, 0x3fffffff], [0xffffffff, 0xffffffff], [3 * over, over], [0x10000000, 0x10000000 - 1]]) {
      const bytes = withCountsOf(vertices, triangles);
      assertOsteonError(() => fresh.decode(bytes, 'huge.ostm'),
        new RegExp(`^osteon: huge\\.ostm: implausible counts: ${vertices} vertices, ${triangles} triangles in ${bytes.length} bytes`),
        `${triangles} triangles`);
    }
    // More vertices than three a triangle.
    const { triangles } = headerCounts(good);
    assertOsteonError(() => fresh.decode(withCountsOf(3 * triangles + 1, triangles), 'huge.ostm'), /implausible counts/, 'vertices');
    assert.equal(fresh.memoryBytes(), settled, 'no memory grew for the refused streams');
  });

  test('ArrayBuffer input and views into a larger buffer', () => {
    const mesh = decoder.decode(good);
    const buffer = Uint8Array.from(good).buffer;
    assert.deepEqual(decoder.decode(buffer).indices, mesh.indices);
    const padded = new Uint8Array(good.length + 100);
    padded.set(good, 37);
    assert.deepEqual(decoder.decode(padded.subarray(37, 37 + good.length)).positions, mesh.positions);
  });
});

test('memory is released: repeated decodes do not grow the heap', async () => {
  // A fresh instance (16 MiB to start) and a 17k-triangle stream: a leaked mesh (~0.5 MB) or
  // input (~30 KB) per decode would grow the memory within these 200 decodes.
  const fresh = await wrapper.createDecoder();
  const { bytes } = encodeAndDecodeNatively(path.join(work, 'phantom'), 'repeat');
  for (let i = 0; i < 3; ++i) fresh.decode(bytes);
  const settled = fresh.memoryBytes();
  for (let i = 0; i < 200; ++i) fresh.decode(bytes);
  for (let i = 0; i < 200; ++i) assert.throws(() => fresh.decode(bytes.subarray(0, 1000)));
  assert.equal(fresh.memoryBytes(), settled);
});

test('the arrays own their buffers (transferable, not views of WebAssembly memory)', () => {
  const { bytes } = encodeAndDecodeNatively(path.join(work, 'phantom', 'rib_l1.stl'), 'own');
  const mesh = decoder.decode(bytes);
  for (const array of [mesh.positions, mesh.indices, mesh.normals]) {
    assert.equal(array.byteOffset, 0);
    assert.equal(array.byteLength, array.buffer.byteLength);
  }
  structuredClone(mesh, { transfer: [mesh.positions.buffer] });
  assert.equal(mesh.positions.length, 0, 'the transferred buffer is detached');
});

test('loads over HTTP, as a page does (fetch)', async () => {
  const wasm = readFileSync(path.join(wasmDir, 'osteon_decoder.wasm'));
  const server = createServer((request, response) => {
    if (request.url !== '/osteon_decoder.wasm') return response.writeHead(404).end();
    response.writeHead(200, { 'content-type': 'application/wasm' }).end(wasm);
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  const base = `http://127.0.0.1:${server.address().port}`;
  try {
    const remote = await wrapper.createDecoder({ wasm: `${base}/osteon_decoder.wasm` });
    const { bytes } = encodeAndDecodeNatively(path.join(work, 'phantom', 'skull.stl'), 'http');
    assert.deepEqual(remote.decode(bytes), decoder.decode(bytes));
    await assert.rejects(wrapper.createDecoder({ wasm: `${base}/missing.wasm` }),
      /^Error: osteon: cannot load .*HTTP 404/);
  } finally {
    server.close();
  }
});

test('worker pool: decodes in workers, transfers buffers, reports errors', async () => {
  const { createDecoderPool } = await import(pathToFileURL(path.join(wasmDir, 'pool.mjs')));
  const pool = await createDecoderPool({
    workers: 2,
    createWorker: () => new Worker(new URL(pathToFileURL(path.join(wasmDir, 'worker.mjs')))),
  });
  try {
    const folder = path.join(work, 'phantom');
    const parts = readdirSync(folder).filter((f) => f.endsWith('.stl')).sort().slice(0, 6);
    const streams = parts.map((part) => encodeAndDecodeNatively(path.join(folder, part), `pool_${part}`).bytes);
    const expected = streams.map((bytes) => decoder.decode(bytes));
    const inputs = streams.map((bytes) => Uint8Array.from(bytes));
    const meshes = await Promise.all(inputs.map((bytes, i) => pool.decode(bytes, parts[i])));
    meshes.forEach((mesh, i) => {
      assert.equal(inputs[i].byteLength, 0, 'the input buffer was transferred');
      assert.equal(mesh.triangleCount, expected[i].triangleCount);
      assert.deepEqual(mesh.indices, expected[i].indices);
      assert.deepEqual(mesh.positions, expected[i].positions);
      assert.deepEqual(mesh.normals, expected[i].normals);
    });
    await assert.rejects(pool.decode(streams[0].subarray(0, 100), 'short.ostm'),
      /^Error: osteon: short\.ostm: /);
    await assert.rejects(pool.decode(42), /^TypeError: osteon: /);
    // A view into a larger buffer is copied, not transferred.
    const padded = new Uint8Array(streams[1].length + 8);
    padded.set(streams[1], 8);
    const mesh = await pool.decode(padded.subarray(8), parts[1]);
    assert.equal(padded.byteLength, streams[1].length + 8);
    assert.deepEqual(mesh.indices, expected[1].indices);
    // narrowIndices: 16-bit indices where every vertex index fits, the same values.
    const narrow = await pool.decode(Uint8Array.from(streams[2]), parts[2], { narrowIndices: true });
    assert.ok(narrow.indices instanceof Uint16Array, `${parts[2]}: 16-bit indices`);
    assert.equal(narrow.indices.byteLength, narrow.indices.buffer.byteLength, 'the array owns its buffer');
    assert.deepEqual(Array.from(narrow.indices), Array.from(expected[2].indices));
    assert.deepEqual(narrow.positions, expected[2].positions);
  } finally {
    pool.terminate();
  }
});

test('worker pool: narrowIndices keeps 32-bit indices beyond 65,536 vertices', async (t) => {
  const large = kTimedMeshes.map((file) => path.join(dataDir, file)).find((file) => existsSync(file));
  if (!large) return t.skip(`no mesh of more than 65,536 vertices in ${dataDir}`);
  const { bytes, native } = encodeAndDecodeNatively(large, 'narrow_large');
  assert.ok(native.vertices > 65536);
  const { createDecoderPool } = await import(pathToFileURL(path.join(wasmDir, 'pool.mjs')));
  const pool = await createDecoderPool({
    workers: 1,
    createWorker: () => new Worker(new URL(pathToFileURL(path.join(wasmDir, 'worker.mjs')))),
  });
  try {
    const mesh = await pool.decode(bytes, 'narrow_large', { narrowIndices: true });
    assert.ok(mesh.indices instanceof Uint32Array, `a ${native.vertices}-vertex mesh keeps 32-bit indices`);
    assertSameMesh(mesh, native, 'narrow_large');
  } finally {
    pool.terminate();
  }
});
