// SPDX-License-Identifier: Apache-2.0
// Streams a package's chunk files (docs/FORMAT.md, "Package", versions 2 and 3): the chunks that
// hold the components' first streams (their coarsest levels) are fetched in the manifest's order
// with at most two in flight, each read as a stream, and every component is copied out and handed
// to the decoder the moment its last byte has arrived, so the first bones are drawn while the rest
// of the chunk is still on the wire. The finer levels come later, one byte range at a time
// (fetchRange, below; levels.mjs asks for them).
//
// Why chunks and a stream reader: a skeleton has hundreds of small components (BodyParts3D: 237 of
// 2.7 KB on average). One request each costs a round trip per six components on HTTP/1.1, which
// dominated the load on a 40 ms link; a few large files read as streams cost a round trip each
// and lose nothing in progressiveness. Two chunks in flight keep the link busy across the gap
// between one chunk's end and the next one's first byte without splitting the bandwidth further.
//
// Failures stay as small as the data allows: a chunk that cannot be fetched, that ends early, or
// whose answer or body stalls (kStallMs without a byte), fails only the components whose bytes had not all
// arrived (each one reported, naming the chunk file); one that sends more than the manifest says
// is read no further than that, and reported; a stream the decoder rejects fails its component
// alone. The rest goes on.
//
// No DOM and no three.js: Node tests run it with fake fetch and decode.

/// Resolves in a later task, so that the page can answer input and paint in between: long work
/// on the main thread (a dense skeleton's manifest, its thousands of first streams) is cut into
/// slices of a few tens of milliseconds with this between them. scheduler.yield() where the
/// browser has it (the continuation runs before other tasks of its priority), else a zero timeout.
export function nextTask() {
  const scheduler = globalThis.scheduler;
  if (typeof scheduler?.yield === 'function') return scheduler.yield();
  return new Promise((resolve) => setTimeout(resolve, 0));
}

/// Runs `run` when the browser is idle, or after `timeoutMs` at the latest (requestIdleCallback;
/// a zero timeout where there is none).
export function whenIdle(run, timeoutMs) {
  if (typeof requestIdleCallback === 'function') requestIdleCallback(run, { timeout: timeoutMs });
  else setTimeout(run, 0);
}

/// The fetch plan of a parsed manifest (manifest.mjs): the chunks that hold components' first
/// streams (`component.first`: the coarsest level, or the only one), in the manifest's order,
/// each with its distinct byte ranges sorted by where they end (the order the bytes complete
/// them). Components with byte-identical streams share one range (docs/FORMAT.md: dedup) and are
/// decoded once. Returns [{ index, file, url, bytes, ranges: [{ offset, bytes, end,
/// components: [component, ...], label }] }]; `url` is resolved against `base`.
export function planChunks(manifest, base) {
  const plans = manifest.chunks.map((chunk) => ({
    index: chunk.index,
    file: chunk.file,
    url: base === undefined ? chunk.file : new URL(chunk.file, base).href,
    bytes: chunk.bytes,
    ranges: new Map(),
  }));
  for (const component of manifest.streamOrder) {
    // A hand-made manifest (tests) may lack `first`: then the component's own range is its stream.
    const first = component.first ?? component;
    const plan = plans[first.chunk];
    const key = `${first.offset}:${first.bytes}`;
    let range = plan.ranges.get(key);
    if (!range) {
      range = { offset: first.offset, bytes: first.bytes, end: first.offset + first.bytes, components: [] };
      plan.ranges.set(key, range);
    }
    range.components.push(component);
  }
  return plans
    .filter((plan) => plan.ranges.size > 0)  // finer levels only, or nothing: not streamed whole
    .map((plan) => {
      const ranges = [...plan.ranges.values()].sort((a, b) => a.end - b.end || a.offset - b.offset);
      for (const range of ranges) range.label = rangeLabel(plan.file, range);
      return { ...plan, ranges };
    });
}

/// How a range is named in messages: "c/<h>.ostc (component c7, bytes 120-2338)".
function rangeLabel(file, range) {
  const ids = range.components.map((c) => c.id);
  return `${file} (component${ids.length > 1 ? 's' : ''} ${ids.join(', ')}, bytes ${range.offset}-${range.end})`;
}

/// Loads the chunks of `plan` (planChunks). Options:
///   fetchChunk(chunk) -> Promise<Response>        fetch(); its body is read as a stream
///   decode(buffer, range) -> Promise<mesh>        buffer: an ArrayBuffer of the range's bytes
///                                                 alone (transfer it); throws on a bad stream
///   onChunkStart(chunk, time)
///   onReceived(range, time, bytesReceived)       the range's last byte arrived; bytesReceived
///                                                 counts every chunk's bytes so far
///   onDecoded(range, mesh, time)                  a throw here fails the range too
///   onFailed(range, message, time)                'osteon: c/<h>.ostc (component c7, ...): ...'
///   onChunkError(chunk, message)                  a chunk longer than the manifest says (its
///                                                 ranges were all delivered; they decode or not)
///   limit (default 2), now (default performance.now), signal (an AbortSignal: once aborted, no
///   further chunk is started; pass it to fetch() too, to cut the ones in flight),
///   stallMs (default kStallMs): a request whose answer (its headers) or next piece of body
///   takes longer than this is given up, failing the chunk's remaining ranges ('...: no byte for
///   15 s'), and the lane goes on to the next chunk
/// run() resolves when every range is decoded or has failed; it never rejects for one failure.
/// How long a chunk's body may send nothing before it is given up: a server that stalls
/// mid-body would otherwise hold one of the two lanes, and the components behind it, forever.
export const kStallMs = 15000;

/// What every decode of a component asks the decoder for: indices in 16 bits where they fit (a
/// component of at most 65,536 vertices; pack's pieces of at most 80,000 triangles have about
/// half as many), half of what 32 bits cost to hand to the renderer, upload and hold on the GPU
/// (refine.mjs indexBytes).
export const kDecodeOptions = { narrowIndices: true };

/// `promise`, or a rejection with Error('no byte for <ms / 1000> s') (its `stalled` set) once `ms`
/// pass without it settling; `onStall()` then gives up what it waits for (aborts the request,
/// cancels the reader). Every fetch of the viewer waits through this: for the answer's headers
/// (fetchWithin) and for each piece of its body (readWithin).
export function within(promise, ms, onStall = () => {}) {
  let timer;
  const stalled = new Promise((resolve, reject) => {
    timer = setTimeout(() => {
      // Rejected first: giving up ends the pending wait, which must not win the race.
      const error = new Error(`no byte for ${ms / 1000} s`);
      error.stalled = true;
      reject(error);
      onStall();
    }, ms);
  });
  return Promise.race([promise, stalled]).finally(() => clearTimeout(timer));
}

/// reader.read(), or a rejection once `ms` pass without an answer (the reader is then cancelled).
export function readWithin(reader, ms) {
  return within(reader.read(), ms, () => reader.cancel().catch(() => {}));
}

/// fetchFn(url, init), or a rejection once `ms` pass without the answer's headers (the request
/// is then aborted; `init.signal` still aborts it too). The body's pieces: readWithin.
export function fetchWithin(fetchFn, url, init, ms) {
  const controller = new AbortController();
  const outer = init?.signal;
  if (outer?.aborted) controller.abort(outer.reason);
  else outer?.addEventListener('abort', () => controller.abort(outer.reason), { once: true });
  return within(fetchFn(url, { ...init, signal: controller.signal }), ms, () => controller.abort());
}

/// A response's body, each piece within `ms` of the last (readWithin), read no further than past
/// `limit` bytes (a longer one is cancelled there). Returns { body (a Uint8Array), cut (true when
/// it was longer than `limit`) }.
async function readBodyWithin(response, ms, limit) {
  const reader = response.body?.getReader?.();
  // No streams (a test's fake response): the whole body at once, within `ms` still.
  if (!reader) return { body: new Uint8Array(await within(response.arrayBuffer(), ms)), cut: false };
  const pieces = [];
  let size = 0;
  let cut = false;
  for (;;) {
    const { done, value } = await readWithin(reader, ms);
    if (done) break;
    pieces.push(value);
    size += value.length;
    if (size > limit) {
      reader.cancel().catch(() => {});
      cut = true;
      break;
    }
  }
  const body = new Uint8Array(size);
  let at = 0;
  for (const piece of pieces) {
    body.set(piece, at);
    at += piece.length;
  }
  return { body, cut };
}

// The most ranges handed to the decoder in one task, and the longest such a slice runs.
const kRangesPerSlice = 16;
const kSliceMs = 15;

export function createChunkStream(plan, options) {
  const {
    fetchChunk,
    decode,
    onChunkStart = () => {},
    onReceived = () => {},
    onDecoded = () => {},
    onFailed = () => {},
    onChunkError = () => {},
  } = options;
  const limit = Math.max(1, options.limit ?? 2);
  const now = options.now ?? (() => performance.now());
  const stallMs = options.stallMs ?? kStallMs;
  let bytesReceived = 0;
  const decodes = [];

  function fail(range, what) {
    onFailed(range, `osteon: ${range.label}: ${what}`, now());
  }

  function startDecode(range, buffer) {
    decodes.push(Promise.resolve()
      .then(() => decode(buffer, range))
      .then((mesh) => onDecoded(range, mesh, now()))
      .catch((e) => {
        const text = String(e?.message ?? e);
        // The decoder's messages already read 'osteon: <label>: ...'.
        onFailed(range, text.startsWith('osteon:') ? text : `osteon: ${range.label}: ${text}`, now());
      }));
  }

  async function loadChunk(chunk) {
    onChunkStart(chunk, now());
    let next = 0;  // ranges[0 .. next) have all their bytes
    const failRest = (what) => {
      for (; next < chunk.ranges.length; ++next) fail(chunk.ranges[next], what);
    };
    let response;
    const answer = Promise.resolve().then(() => fetchChunk(chunk));
    try {
      response = await within(answer, stallMs);
    } catch (e) {
      // An answer that comes after all is not read.
      if (e?.stalled) answer.then((late) => late.body?.cancel?.().catch(() => {}), () => {});
      return failRest(e?.stalled ? e.message : `fetch failed: ${e?.message ?? e}`);
    }
    if (!response.ok) return failRest(`HTTP ${response.status}${response.statusText ? ` ${response.statusText}` : ''}`);

    const buffer = new Uint8Array(chunk.bytes);
    let received = 0;
    let overflow = false;
    // Each range whose bytes are all in goes to the decoder, in slices (kRangesPerSlice ranges or
    // kSliceMs, then the next task): one network read can complete a hundred small components,
    // and handing each over (a copy, a message to a worker) held a slow phone's page for a
    // fifth of a second.
    const take = async (piece) => {
      const fits = Math.min(piece.length, chunk.bytes - received);
      if (fits < piece.length) overflow = true;
      buffer.set(fits === piece.length ? piece : piece.subarray(0, fits), received);
      received += fits;
      bytesReceived += fits;
      let start = now();
      let count = 0;
      while (next < chunk.ranges.length && chunk.ranges[next].end <= received) {
        if (count === kRangesPerSlice || now() - start >= kSliceMs) {
          await nextTask();
          start = now();
          count = 0;
        }
        const range = chunk.ranges[next++];
        count++;
        onReceived(range, now(), bytesReceived);
        // A copy of the range alone: its buffer goes to a decoder worker and the chunk's stays.
        startDecode(range, buffer.slice(range.offset, range.end).buffer);
      }
    };
    try {
      const reader = response.body?.getReader?.();
      if (!reader) {
        // No streams (an old browser, or a test's fake response): the whole body at once.
        await take(new Uint8Array(await response.arrayBuffer()));
      } else {
        for (;;) {
          const { done, value } = await readWithin(reader, stallMs);
          if (done) break;
          await take(value);
          if (overflow) {
            reader.cancel().catch(() => {});
            break;
          }
        }
      }
    } catch (e) {
      return failRest(`the download broke off after ${received} of ${chunk.bytes} bytes: ${e?.message ?? e}`);
    }
    if (overflow) onChunkError(chunk, `osteon: ${chunk.file}: more than the ${chunk.bytes} bytes the manifest says`);
    if (received < chunk.bytes) failRest(`${received} bytes, the manifest says ${chunk.bytes}`);
  }

  async function run() {
    let next = 0;
    // Each lane takes the next chunk when its current one has all its bytes: decoding never holds
    // the network back.
    async function lane() {
      while (next < plan.length && !options.signal?.aborted) await loadChunk(plan[next++]);
    }
    await Promise.all(Array.from({ length: Math.min(limit, plan.length) }, lane));
    await Promise.all(decodes);
  }

  return { run };
}

/// A few whole chunk files, the most recently used kept within `maxBytes`: where a host answers a
/// Range request with the whole file (200), the other levels in that chunk are sliced from here
/// instead of being downloaded again. get(file) -> Uint8Array or undefined; put(file, bytes).
export function createChunkCache(maxBytes) {
  const files = new Map();  // file -> bytes, least recently used first
  let total = 0;
  return {
    get(file) {
      const bytes = files.get(file);
      if (bytes) {
        files.delete(file);
        files.set(file, bytes);
      }
      return bytes;
    },
    put(file, bytes) {
      if (bytes.length > maxBytes || files.has(file)) return;
      files.set(file, bytes);
      total += bytes.length;
      for (const [name, old] of files) {
        if (total <= maxBytes) break;
        files.delete(name);
        total -= old.length;
      }
    },
    get bytes() { return total; },
  };
}

/// Fetches bytes [offset, offset + bytes) of a chunk file with a `Range: bytes=a-b` request.
/// Chunks are immutable (content-hashed names), so a host that ignores Range and answers 200
/// with the whole file is as good, only slower: the file is kept in `cache` (createChunkCache)
/// and sliced. An answer that covers less than asked (a 206 may; one in Chromium, most likely from
/// its HTTP cache, ended at byte 4096 of the chunk, 393 bytes into a 5,988-byte range) is
/// continued from where it stopped, by at most two more requests that bypass the browser's cache. `chunk`: { url, file, bytes } (its
/// size per the manifest). Resolves to { data (a Uint8Array that owns its buffer,
/// transferable), status: 206, 200 or 'cache', received (bytes that came over the network),
/// requests (how many were made) };
/// throws Error('HTTP 404 ...' / 'fetch failed: ...' / 'no byte for 15 s' / what was wrong with
/// the answer) for the caller to name the range. Each request's headers, and each piece of its
/// body, must come within `stallMs` (default kStallMs; fetchWithin, readWithin): a stalled
/// request is aborted and the range fails, not tried again.
export async function fetchRange(chunk, offset, bytes, { fetch, cache, signal, stallMs = kStallMs } = {}) {
  const cached = cache?.get(chunk.file);
  if (cached) return { data: cached.slice(offset, offset + bytes), status: 'cache', received: 0, requests: 0 };
  const data = new Uint8Array(bytes);
  let have = 0;
  let received = 0;
  let attempt = 0;
  for (; attempt < 3 && have < bytes; ++attempt) {
    const from = offset + have;
    const to = offset + bytes - 1;
    let response;
    try {
      const init = { headers: { Range: `bytes=${from}-${to}` }, signal };
      if (attempt > 0) init.cache = 'no-store';
      response = await fetchWithin(fetch, chunk.url, init, stallMs);
    } catch (e) {
      throw e?.stalled ? e : new Error(`fetch failed: ${e?.message ?? e}`);
    }
    if (!response.ok) {
      response.body?.cancel?.().catch(() => {});
      throw new Error(`HTTP ${response.status}${response.statusText ? ` ${response.statusText}` : ''}`);
    }
    if (response.status === 206) {
      const range = /^bytes (\d+)-(\d+)\//.exec(response.headers?.get?.('Content-Range') ?? '');
      // What matters is where the answer starts; how far it goes is what arrived (a body cut short
      // under a header that promised more is continued like a shorter range).
      if (range && (Number(range[1]) !== from || Number(range[2]) > to)) {
        response.body?.cancel?.().catch(() => {});
        throw new Error(`the host sent ${range[0].slice(0, -1)}, not bytes ${from}-${to}`);
      }
    }
    // A whole file (200) may be as long as the chunk, a range (206) as long as what is missing.
    const limit = response.status === 206 ? bytes - have : chunk.bytes;
    let body;
    let cut;
    try {
      ({ body, cut } = await readBodyWithin(response, stallMs, limit));
    } catch (e) {
      throw e?.stalled ? e : new Error(`the download broke off: ${e?.message ?? e}`);
    }
    received += body.length;
    if (cut) throw new Error(response.status === 206 ? `more than ${limit} bytes in the answer, the range has ${limit}` : `more than ${limit} bytes, the manifest says ${limit}`);
    if (response.status !== 206) {
      if (body.length !== chunk.bytes) throw new Error(`${body.length} bytes, the manifest says ${chunk.bytes}`);
      cache?.put(chunk.file, body);
      return { data: body.slice(offset, offset + bytes), status: 200, received, requests: attempt + 1 };
    }
    if (body.length > bytes - have) throw new Error(`${body.length} bytes in the answer, the range has ${bytes - have}`);
    data.set(body, have);
    have += body.length;
    if (body.length === 0) break;
  }
  if (have < bytes) throw new Error(`${have} bytes in the answers, the range has ${bytes}`);
  return { data, status: 206, received, requests: attempt };
}

/// The fetch plan for one stream of each of `components` (manifest.mjs components; `streamOf(c)`
/// picks the level: { chunk, offset, bytes, level }), shaped as planChunks' so createChunkStream
/// reads it: per chunk file, its needed byte ranges sorted by offset and grouped into spans, two
/// ranges closer than `maxGap` bytes (default 64 KiB) going into one span, so one request brings
/// both and the bytes between are read and dropped. A span is fetched with one `Range` request and
/// read as a stream like a whole chunk (a span covering its whole chunk needs no Range). Ranges
/// with byte-identical streams are decoded once, as in planChunks. Returns [{ index, file, url,
/// bytes (the span's length), start (its first byte in the chunk), whole, ranges: [{ offset, end
/// (relative to `start`), bytes, components, levels (each component's level index), label }] }];
/// labels name the chunk, components, level and absolute bytes: "c/<h>.ostc (component c7, level
/// 3 of 3, bytes 120-2338)".
export function planSpans(manifest, base, components, streamOf, maxGap = 65536) {
  const byChunk = new Map();  // chunk index -> Map key -> range
  for (const component of components) {
    const stream = streamOf(component);
    const key = `${stream.offset}:${stream.bytes}`;
    if (!byChunk.has(stream.chunk)) byChunk.set(stream.chunk, new Map());
    const ranges = byChunk.get(stream.chunk);
    let range = ranges.get(key);
    if (!range) {
      range = { offset: stream.offset, bytes: stream.bytes, end: stream.offset + stream.bytes, components: [], levels: [] };
      ranges.set(key, range);
    }
    range.components.push(component);
    range.levels.push(stream.level ?? component.levels.indexOf(stream));
  }
  const spans = [];
  for (const [index, ranges] of [...byChunk].sort((a, b) => a[0] - b[0])) {
    const chunk = manifest.chunks[index];
    const sorted = [...ranges.values()].sort((a, b) => a.offset - b.offset || a.end - b.end);
    let group = [];
    const close = () => {
      const start = group[0].offset;
      const end = Math.max(...group.map((r) => r.end));
      for (const r of group) {
        const c = r.components[0];
        const level = c.levels.length > 1 ? `, level ${r.levels[0] + 1} of ${c.levels.length}` : '';
        const ids = r.components.map((x) => x.id).join(', ');
        r.label = `${chunk.file} (component${r.components.length > 1 ? 's' : ''} ${ids}${level}, bytes ${r.offset}-${r.end})`;
        r.offset -= start;
        r.end -= start;
      }
      spans.push({
        index,
        file: chunk.file,
        url: base === undefined ? chunk.file : new URL(chunk.file, base).href,
        bytes: end - start,
        start,
        whole: start === 0 && end === chunk.bytes,
        ranges: group.sort((a, b) => a.end - b.end || a.offset - b.offset),
      });
      group = [];
    };
    for (const range of sorted) {
      if (group.length && range.offset - Math.max(...group.map((r) => r.end)) > maxGap) close();
      group.push(range);
    }
    if (group.length) close();
  }
  return spans;
}
