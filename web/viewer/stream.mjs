// SPDX-License-Identifier: Apache-2.0
// Streams a package's components: fetched in the manifest's stream_order with a bounded number of
// requests in flight, each handed to the decoder the moment its bytes have arrived, and reported
// the moment it is decoded, so the page draws bone by bone instead of waiting for the last one.
// A failed fetch or decode is reported and the rest goes on.
//
// The bound keeps a slow connection busy without letting a big package open hundreds of requests
// at once (browsers queue beyond ~6 per host on HTTP/1.1 anyway, and the order would be lost);
// a fetch slot is freed when the bytes have arrived, not when they are decoded, so decoding never
// holds the network back. No DOM and no three.js: Node tests run it with fake fetch and decode.

/// Loads every item of `items` ({ id, url, file, bytes } in fetch order). Callbacks:
///   fetchBytes(item) -> Promise<Uint8Array>      (throws on HTTP errors)
///   decode(bytes, item) -> Promise<mesh>         (throws on bad streams)
///   onDecoded(item, mesh, entry), onFailed(item, error, entry), onFetched(item, entry)
/// `entry` is the item's log record { id, file, bytes, fetchStart, fetchEnd, decodedAt, error }
/// (times from `now()`, default performance.now()); log() returns every record in fetch order.
/// Resolves when every item is decoded or has failed; never rejects for one item's failure.
export function createComponentStream(items, options) {
  const { fetchBytes, decode, onDecoded = () => {}, onFailed = () => {}, onFetched = () => {} } = options;
  const limit = Math.max(1, options.limit ?? 6);
  const now = options.now ?? (() => performance.now());
  const entries = items.map((item) => ({
    id: item.id,
    file: item.file,
    bytes: item.bytes,
    fetchStart: null,
    fetchEnd: null,
    decodedAt: null,
    error: null,
  }));

  async function loadOne(index) {
    const item = items[index];
    const entry = entries[index];
    entry.fetchStart = now();
    let bytes;
    try {
      bytes = await fetchBytes(item);
    } catch (e) {
      entry.fetchEnd = now();
      entry.error = message(e, item);
      onFailed(item, entry.error, entry);
      return { decoded: null };
    }
    entry.fetchEnd = now();
    entry.receivedBytes = bytes.byteLength;
    onFetched(item, entry);
    // The decode runs on after this slot is released: wrapped in an object, since an async
    // function returning a promise would make the caller wait for the decode too.
    const decoded = Promise.resolve().then(() => decode(bytes, item)).then(
      (mesh) => {
        entry.decodedAt = now();
        onDecoded(item, mesh, entry);
      },
      (e) => {
        entry.decodedAt = now();
        entry.error = message(e, item);
        onFailed(item, entry.error, entry);
      },
    ).catch((e) => {
      // A throwing onDecoded (e.g. the GPU upload failed) is that component's failure too.
      entry.error = message(e, item);
      onFailed(item, entry.error, entry);
    });
    return { decoded };
  }

  async function run() {
    const decodes = [];
    let next = 0;
    async function lane() {
      while (next < items.length) {
        const index = next++;
        decodes.push((await loadOne(index)).decoded);
      }
    }
    await Promise.all(Array.from({ length: Math.min(limit, items.length) }, lane));
    await Promise.all(decodes);
  }

  return { run, log: () => entries };
}

function message(e, item) {
  const text = String(e?.message ?? e);
  return text.startsWith('osteon:') ? text : `osteon: ${item.file}: ${text}`;
}

/// fetch() for one component: the bytes, checked against the size the manifest gives (a truncated
/// or replaced file is named here, before the decoder sees it). Errors name the file.
export async function fetchComponent(item, fetchImpl = fetch) {
  let response;
  try {
    response = await fetchImpl(item.url);
  } catch (e) {
    throw new Error(`osteon: ${item.file}: fetch failed: ${e?.message ?? e}`);
  }
  if (!response.ok) throw new Error(`osteon: ${item.file}: HTTP ${response.status}${response.statusText ? ` ${response.statusText}` : ''}`);
  const bytes = new Uint8Array(await response.arrayBuffer());
  if (item.bytes !== undefined && bytes.byteLength !== item.bytes) {
    throw new Error(`osteon: ${item.file}: ${bytes.byteLength} bytes, the manifest says ${item.bytes}`);
  }
  return bytes;
}
