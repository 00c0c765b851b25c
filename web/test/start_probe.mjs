// SPDX-License-Identifier: Apache-2.0
// Where the viewer's start goes (docs/DESIGN.md, "The first frame"): loads one or more package
// folders, each served by the real `osteon serve`, in Debian's Chromium headless (SwiftShader
// WebGL), the network throttled through the DevTools protocol (Network.emulateNetworkConditions,
// cache disabled), a fresh browser context per load, and prints the median over the runs of each
// step of the start, in ms from navigation start: the page's HTML in, the bootstrap run (its
// manifest request), the manifest's response ended (resource timing) and its text read on the
// page, the render worker started, its WebGL context made, three.js's text in, the first chunk
// asked for and in, the WebAssembly decoder in, the first and the last first-level component
// decoded, three.js loaded, its view made, its shaders compiled, the first frames' program linked,
// the first frame (window.osteon.firstFrameMs: its draw returned, which is before the frame is on
// screen), the skeleton complete (skeletonCompleteMs), the finer levels' first fetch and when the
// last one was in, decoded and drawn, and refined for the opening view (firstRefinedMs). Several folders are loaded in turn, run by run (A B A B ...), so a change in
// the machine's load falls on all of them alike: pack the same data with two viewer builds
// (`osteon pack ... --viewer DIR`) and compare.
//
//   node web/test/start_probe.mjs [--runs 5] [--query ?render=page] [--slow] DIR [DIR...]
//
// The default network is bench/web's "fast" profile (100 Mbit/s, 10 ms); --slow is its "slow"
// one (10 Mbit/s, 40 ms). One load of each folder before the runs warms the browser (its GPU
// process and its compiled code) and is not counted. A load that has not finished (done, refined,
// no frame pending) after PROBE_TIMEOUT_MS (60000) fails the run with the viewer's state.
// Environment: see browser_helpers.mjs.

import path from 'node:path';

import { launchBrowser, serve } from './browser_helpers.mjs';

const kViewport = { width: 1280, height: 800 };

function parseOptions(argv) {
  const opt = { runs: 5, query: '', latency: 10, bitsPerSecond: 100e6, dirs: [], timeoutMs: Number(process.env.PROBE_TIMEOUT_MS ?? 60000) };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    if (a === '--runs') opt.runs = Number(argv[++i]);
    else if (a === '--query') opt.query = argv[++i];
    else if (a === '--slow') Object.assign(opt, { latency: 40, bitsPerSecond: 10e6 });
    else if (a.startsWith('--')) throw new Error(`start_probe: unknown option ${a}`);
    else opt.dirs.push(path.resolve(a));
  }
  if (!opt.dirs.length) throw new Error('start_probe: give one or more package folders');
  return opt;
}

// The steps, in the order of a start; each reads one load's record (below).
const kSteps = [
  ['html', 'page HTML in', (s) => s.html],
  ['boot', 'bootstrap ran', (s) => s.res.manifest?.start],
  ['manifestEnd', 'manifest response end', (s) => s.res.manifest?.end],
  ['manifest', 'manifest in', (s) => s.timings.manifest],
  ['started', 'worker started', (s) => s.timings.started],
  ['startDelay', '  (after the bootstrap)', (s) => s.timings.started - s.res.manifest?.start],
  ['canvas', 'canvas in the worker', (s) => s.timings.canvas],
  ['context', 'context ready', (s) => s.timings.context],
  ['threeFetched', 'three.js fetched', (s) => s.timings.threeFetched],
  ['chunk', 'first chunk asked', (s) => s.res.chunk?.start],
  ['chunkEnd', 'first chunk in', (s) => s.res.chunk?.end],
  ['wasmEnd', 'wasm in', (s) => s.res.wasm?.end],
  ['decoded', 'first mesh decoded', (s) => s.decoded[0]],
  ['decodedAll', 'last first level decoded', (s) => s.decoded[1]],
  ['three', 'three.js loaded', (s) => s.timings.three],
  ['view', 'view made', (s) => s.timings.view],
  ['compiled', 'shaders compiled', (s) => s.timings.compiled],
  ['firstFrames', 'first-frame program', (s) => s.timings.firstFrames],
  ['firstFrame', 'first frame', (s) => s.firstFrameMs],
  ['complete', 'skeleton complete', (s) => s.skeletonCompleteMs],
  ['levelAsked', 'first finer level asked', (s) => s.levels[0]],
  ['levelsIn', 'last finer level in', (s) => s.levels[1]],
  ['levelsDecoded', 'last finer level decoded', (s) => s.levels[2]],
  ['levelsShown', 'last finer level drawn', (s) => s.levels[3]],
  ['refined', 'refined (first)', (s) => s.firstRefinedMs],
];

// One load's record, read in the page once it has finished.
function readState() {
  const o = window.osteon;
  const nav = performance.getEntriesByType('navigation')[0];
  // When the first request of each kind started and ended (resource timing).
  const res = {};
  const kinds = [['manifest', /manifest\.json$/], ['three', /render-three-/], ['wasm', /\.wasm$/], ['chunk', /\/c\/[0-9a-f]+\.ostc$/]];
  for (const e of performance.getEntriesByType('resource')) {
    const kind = kinds.find(([, re]) => re.test(new URL(e.name).pathname));
    if (kind && !res[kind[0]]) res[kind[0]] = { start: e.startTime, end: e.responseEnd };
  }
  return {
    html: nav ? nav.responseEnd : null,
    res,
    timings: { ...o.timings },
    // The first and the last component decoded (on the page, before going to the renderer).
    decoded: [Math.min(...o.fetchLog.map((e) => e.decodedAt ?? Infinity)), Math.max(...o.fetchLog.map((e) => e.decodedAt ?? -Infinity))],
    // The finer levels' fetches (levels.mjs levelLog): the first asked for, and when the last one
    // was in, decoded and drawn.
    levels: [Math.min(...o.levelLog.map((e) => e.fetchStart)), ...['fetchEnd', 'decodedAt', 'shownAt'].map((k) => Math.max(...o.levelLog.map((e) => e[k] ?? -Infinity)))],
    firstFrameMs: o.firstFrameMs,
    skeletonCompleteMs: o.skeletonCompleteMs,
    firstRefinedMs: o.firstRefinedMs ?? null,
    renderer: o.renderer,
    errors: o.errors.map(String),
  };
}

async function loadOnce(browser, url, opt) {
  const context = await browser.newContext({ viewport: kViewport, deviceScaleFactor: 1 });
  try {
    const page = await context.newPage();
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e.message ?? e)));
    const cdp = await context.newCDPSession(page);
    await cdp.send('Network.enable');
    await cdp.send('Network.setCacheDisabled', { cacheDisabled: true });
    const bytesPerSecond = opt.bitsPerSecond / 8;
    await cdp.send('Network.emulateNetworkConditions', {
      offline: false, latency: opt.latency, downloadThroughput: bytesPerSecond, uploadThroughput: bytesPerSecond,
    });
    await page.goto(url, { waitUntil: 'commit', timeout: opt.timeoutMs });
    // Polled through the DevTools protocol in the page's own world: Playwright's waitForFunction
    // and evaluate would first inject its utility script, a long parse on the page's main thread
    // just as the viewer starts, which holds back the render worker's start (it needs the main
    // thread to receive its first message).
    const evaluate = async (expression) => {
      const reply = await cdp.send('Runtime.evaluate', { expression, returnByValue: true });
      if (reply.exceptionDetails) throw new Error(reply.exceptionDetails.exception?.description ?? reply.exceptionDetails.text);
      return reply.result.value;
    };
    const deadline = Date.now() + opt.timeoutMs;
    const finished = '(() => { const o = window.osteon; return !!(o && o.done && (o.refineIdle ?? true) && !o.framePending); })()';
    while (!(await evaluate(finished))) {
      if (Date.now() > deadline) {
        const o = await evaluate('JSON.stringify((({ done, refineIdle, framePending, componentsLoaded, componentsTotal, frames, timings, errors, levelsLoaded, firstFrameMs, skeletonCompleteMs }) => ({ done, refineIdle, framePending, componentsLoaded, componentsTotal, frames, timings, errors, levelsLoaded, firstFrameMs, skeletonCompleteMs }))(window.osteon))');
        throw new Error(`${url}: not loaded in ${opt.timeoutMs} ms: ${o}`);
      }
      await new Promise((resolve) => setTimeout(resolve, 100));
    }
    const state = await evaluate(`(${readState})()`);
    state.errors.push(...errors);
    return state;
  } finally {
    await context.close();
  }
}

function median(values) {
  const v = values.filter(Number.isFinite).sort((a, b) => a - b);
  if (!v.length) return null;
  return v.length % 2 ? v[(v.length - 1) / 2] : (v[v.length / 2 - 1] + v[v.length / 2]) / 2;
}

async function main() {
  const opt = parseOptions(process.argv.slice(2));
  const servers = [];
  const browser = await launchBrowser();
  try {
    const sites = [];
    for (const dir of opt.dirs) {
      // Served from the folder above, under the folder's name: a package must work under a prefix.
      const server = await serve(path.dirname(dir));
      servers.push(server);
      sites.push({ dir, url: `${server.url}${path.basename(dir)}/index.html${opt.query}`, loads: [] });
    }
    for (const site of sites) await loadOnce(browser, site.url, opt);  // warm-up, not counted
    for (let run = 0; run < opt.runs; ++run) {
      for (const site of sites) {
        const s = await loadOnce(browser, site.url, opt);
        if (s.errors.length) console.log(`# ${site.dir}: errors: ${s.errors.join(' | ')}`);
        site.loads.push(s);
        console.log(`# ${path.basename(site.dir)} run ${run + 1}: ${kSteps.map(([k, , f]) => `${k} ${Math.round(f(s) ?? NaN)}`).join(', ')}`);
      }
    }
    const network = `${opt.bitsPerSecond / 1e6} Mbit/s, ${opt.latency} ms`;
    console.log(`\nmedians of ${opt.runs} loads, ms from navigation start (${network}${opt.query ? `, ${opt.query}` : ''}; renderer: ${sites.map((s) => s.loads[0]?.renderer).join(', ')})`);
    const width = Math.max(...kSteps.map(([, label]) => label.length));
    const names = sites.map((s) => path.basename(s.dir));
    const colWidth = Math.max(8, ...names.map((n) => n.length));
    console.log(`${''.padEnd(width)}  ${names.map((n) => n.padStart(colWidth)).join('  ')}`);
    for (const [, label, f] of kSteps) {
      const cells = sites.map((s) => {
        const m = median(s.loads.map(f));
        return (m === null ? '-' : m.toFixed(0)).padStart(colWidth);
      });
      console.log(`${label.padEnd(width)}  ${cells.join('  ')}`);
    }
  } finally {
    await browser.close();
    for (const server of servers) await server.close();
  }
}

main().catch((e) => {
  console.error(`osteon: ${e?.stack ?? e}`);
  process.exit(1);
});
