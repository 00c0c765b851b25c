// SPDX-License-Identifier: Apache-2.0
// The osteon WebAssembly decoder: src/codec_decode.cpp and the decoders it calls, compiled by
// web/decoder/build.sh to a standalone module with an explicit export list (no Emscripten glue),
// instantiated here. Works in a browser page, a browser worker and Node (>= 18).
//
//   import { createDecoder } from './osteon_decoder.mjs';
//   const decoder = await createDecoder();
//   const { positions, indices, normals, vertexCount, triangleCount } = decoder.decode(bytes);
//
// The arrays are copies out of WebAssembly memory, each owning its ArrayBuffer, so a worker can
// transfer them. Every failure throws an Error whose message starts with "osteon:" and, for bad
// streams, carries the C++ decoder's message (what is wrong and at which byte).
//
// Based on: meshoptimizer's js/meshopt_decoder.mjs (a hand-written wrapper instead of Emscripten's
// generated JavaScript).

const kDefaultWasm = 'osteon_decoder.wasm';

/// Compiles the decoder's module from `wasm`: a URL or a path relative to this file (default
/// 'osteon_decoder.wasm' beside it; file: URLs are read with node:fs), its bytes, or a module.
export async function compileDecoder(wasm) {
  if (wasm instanceof WebAssembly.Module) return wasm;
  if (ArrayBuffer.isView(wasm) || wasm instanceof ArrayBuffer) return WebAssembly.compile(wasm);
  const url = new URL(wasm ?? kDefaultWasm, import.meta.url);
  if (url.protocol === 'file:') {
    const { readFile } = await import('node:fs/promises');
    return WebAssembly.compile(await readFile(url));
  }
  const response = await fetch(url);
  if (!response.ok) throw new Error(`osteon: cannot load ${url}: HTTP ${response.status}`);
  return WebAssembly.compile(await response.arrayBuffer());
}

/// Creates a decoder. `options.wasm`: what compileDecoder takes (a pool compiles once and hands
/// the WebAssembly.Module to every worker).
export async function createDecoder(options = {}) {
  let module;
  try {
    module = await compileDecoder(options.wasm);
  } catch (e) {
    if (String(e?.message).startsWith('osteon:')) throw e;
    throw new Error(`osteon: cannot load the decoder: ${e?.message ?? e}`);
  }
  let exports = null;

  // The only import the module has (build.sh fails when the list changes): the exit an abort()
  // takes (out of memory, a failed libc++ check).
  const imports = {
    wasi_snapshot_preview1: {
      proc_exit(code) {
        throw new Error(`the decoder aborted (exit ${code})`);
      },
    },
  };
  function instance() {
    if (!exports) {
      exports = new WebAssembly.Instance(module, imports).exports;
      exports._initialize();
    }
    return exports;
  }

  function cString(ex, ptr) {
    const heap = new Uint8Array(ex.memory.buffer);
    let end = ptr;
    while (heap[end]) ++end;
    return new TextDecoder().decode(heap.subarray(ptr, end));
  }

  function copyOut(ex, Type, ptr, length) {
    return new Type(ex.memory.buffer, ptr >>> 0, length).slice();
  }

  /// Decodes one osteon stream (a Uint8Array or an ArrayBuffer). `name` opens error messages
  /// ("osteon: hip.ostm: checksum mismatch ..."). Throws Error('osteon: ...') on bad bytes.
  function decode(bytes, name = 'osteon stream') {
    if (bytes instanceof ArrayBuffer) bytes = new Uint8Array(bytes);
    if (!(bytes instanceof Uint8Array)) {
      throw new TypeError('osteon: decode() takes a Uint8Array or an ArrayBuffer');
    }
    const label = new TextEncoder().encode(`${name}\0`);
    const ex = instance();
    let input = 0;
    let handle = 0;
    try {
      input = ex.osteon_alloc(bytes.length + label.length) >>> 0;
      if (!input) throw new Error(`osteon: ${name}: out of WebAssembly memory for the input`);
      const heap = new Uint8Array(ex.memory.buffer);
      heap.set(bytes, input);
      heap.set(label, input + bytes.length);
      handle = ex.osteon_decode(input, bytes.length, input + bytes.length) >>> 0;
      if (!handle) throw new Error(`osteon: ${name}: out of WebAssembly memory`);
      const error = ex.osteon_error(handle) >>> 0;
      if (error) throw new Error(`osteon: ${cString(ex, error)}`);
      const vertexCount = ex.osteon_vertex_count(handle) >>> 0;
      const triangleCount = ex.osteon_triangle_count(handle) >>> 0;
      return {
        positions: copyOut(ex, Float32Array, ex.osteon_positions(handle), 3 * vertexCount),
        indices: copyOut(ex, Uint32Array, ex.osteon_indices(handle), 3 * triangleCount),
        normals: copyOut(ex, Float32Array, ex.osteon_normals(handle), 3 * vertexCount),
        vertexCount,
        triangleCount,
      };
    } catch (e) {
      if (!String(e?.message).startsWith('osteon:')) {
        // A trap or an abort leaves the instance's heap in an unknown state: start afresh.
        exports = null;
        throw new Error(`osteon: ${name}: the decoder failed: ${e?.message ?? e}`);
      }
      throw e;
    } finally {
      if (exports) {
        if (handle) exports.osteon_free(handle);
        if (input) exports.osteon_free_bytes(input);
      }
    }
  }

  return {
    decode,
    /// The size of the WebAssembly memory in bytes (it grows to the largest mesh decoded so far).
    memoryBytes: () => instance().memory.buffer.byteLength,
  };
}
