// SPDX-License-Identifier: Apache-2.0
// A decoder worker: a browser module worker (new Worker(url, { type: 'module' })) or a Node
// worker_threads Worker. It answers each message { id, bytes, name?, wasm? } with
// { id, mesh: { positions, indices, normals, vertexCount, triangleCount } }, the three arrays'
// buffers transferred (not copied), or with { id, error: 'osteon: ...' }. `bytes` is a
// Uint8Array or an ArrayBuffer (transfer it in); `wasm`, read from the first message only, is
// what createDecoder() takes (pool.mjs sends the module it compiled once for all workers).
//
// Based on: three.js DRACOLoader's worker (one decoder per worker, transferables both ways).

import { createDecoder } from './osteon_decoder.mjs';

let decoder = null;

async function answer({ id, bytes, name, wasm, options }) {
  try {
    decoder ??= createDecoder(wasm === undefined ? {} : { wasm });
    const mesh = (await decoder).decode(bytes, name);
    // 16-bit indices where every index fits: half the bytes to hand on, upload and hold. Here,
    // not in the wrapper, whose download is budgeted.
    if (options?.narrowIndices && mesh.vertexCount <= 65536) {
      mesh.indices = new Uint16Array(mesh.indices);
    }
    return [{ id, mesh }, [mesh.positions.buffer, mesh.indices.buffer, mesh.normals.buffer]];
  } catch (e) {
    const message = String(e?.message ?? e);
    return [{ id, error: message.startsWith('osteon:') ? message : `osteon: ${message}` }, []];
  }
}

if (typeof WorkerGlobalScope !== 'undefined' && globalThis instanceof WorkerGlobalScope) {
  globalThis.onmessage = async (event) => globalThis.postMessage(...(await answer(event.data)));
} else {
  const { parentPort } = await import('node:worker_threads');
  parentPort.on('message', async (data) => parentPort.postMessage(...(await answer(data))));
}
