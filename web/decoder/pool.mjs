// SPDX-License-Identifier: Apache-2.0
// A small pool of decoder workers (worker.mjs): the WebAssembly module is compiled once and handed
// to every worker; each decode goes to the worker with the fewest jobs in flight; the stream's
// buffer is transferred in and the mesh's buffers transferred back.
//
//   const pool = await createDecoderPool({ workers: 4 });
//   const mesh = await pool.decode(bytes, 'hip.ostm');   // bytes' buffer is transferred away
//   pool.terminate();
//
// Based on: three.js DRACOLoader's worker pool (least-loaded worker, transferables both ways).

import { compileDecoder } from './osteon_decoder.mjs';

/// Creates `workers` workers (default: hardware threads - 1, at most 4). `createWorker()` makes one
/// (default: a browser module Worker on worker.mjs beside this file; in Node pass
/// () => new Worker(new URL('./worker.mjs', import.meta.url)) from node:worker_threads).
/// `wasm` is what compileDecoder takes (a URL, bytes or a WebAssembly.Module; default the
/// osteon_decoder.wasm beside osteon_decoder.mjs).
export async function createDecoderPool(options = {}) {
  const count = options.workers ??
    Math.max(1, Math.min(4, (globalThis.navigator?.hardwareConcurrency ?? 2) - 1));
  const spawn = options.createWorker ??
    (() => new Worker(new URL('./worker.mjs', import.meta.url), { type: 'module' }));
  const wasm = await compileDecoder(options.wasm);

  const pending = new Map();  // id -> { resolve, reject, worker }
  let nextId = 0;
  const workers = Array.from({ length: count }, () => {
    const worker = { handle: spawn(), jobs: 0, sentModule: false };
    const onMessage = (data) => {
      const job = pending.get(data.id);
      if (!job) return;
      pending.delete(data.id);
      worker.jobs--;
      if (data.error) job.reject(new Error(data.error));
      else job.resolve(data.mesh);
    };
    const onError = (e) => {
      for (const [id, job] of pending) {
        if (job.worker !== worker) continue;
        pending.delete(id);
        job.reject(new Error(`osteon: decoder worker failed: ${e?.message || e?.type || e}`));
      }
      worker.jobs = 0;
    };
    if (worker.handle.addEventListener) {  // browser Worker
      worker.handle.addEventListener('message', (event) => onMessage(event.data));
      worker.handle.addEventListener('error', onError);
    } else {  // node:worker_threads Worker
      worker.handle.on('message', onMessage);
      worker.handle.on('error', onError);
    }
    return worker;
  });

  return {
    /// Decodes on the least busy worker. `bytes` (a Uint8Array or an ArrayBuffer) is transferred
    /// when it spans its whole buffer, which is then detached here (pass a copy to keep it); a
    /// view into a larger buffer is copied. `options.narrowIndices`: indices as a Uint16Array
    /// where the mesh has at most 65,536 vertices. Rejects with Error('osteon: ...').
    decode(bytes, name, options) {
      if (bytes instanceof ArrayBuffer) bytes = new Uint8Array(bytes);
      if (!(bytes instanceof Uint8Array)) {
        return Promise.reject(new TypeError('osteon: decode() takes a Uint8Array or an ArrayBuffer'));
      }
      if (bytes.byteOffset !== 0 || bytes.byteLength !== bytes.buffer.byteLength) bytes = bytes.slice();
      const worker = workers.reduce((a, b) => (b.jobs < a.jobs ? b : a));
      const id = nextId++;
      const buffer = bytes.buffer;
      const message = { id, bytes, name, options };
      if (!worker.sentModule) {
        message.wasm = wasm;
        worker.sentModule = true;
      }
      return new Promise((resolve, reject) => {
        pending.set(id, { resolve, reject, worker });
        worker.jobs++;
        try {
          worker.handle.postMessage(message, buffer instanceof ArrayBuffer ? [buffer] : []);
        } catch (e) {
          pending.delete(id);
          worker.jobs--;
          reject(new Error(`osteon: cannot post to the decoder worker: ${e.message}`));
        }
      });
    },
    terminate() {
      for (const worker of workers) worker.handle.terminate();
      for (const job of pending.values()) job.reject(new Error('osteon: decoder pool terminated'));
      pending.clear();
    },
  };
}
