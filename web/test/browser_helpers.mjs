// SPDX-License-Identifier: Apache-2.0
// What the viewer's browser tests share: where the CLI, the built viewer, the real data and the
// browser are; packing with the real `osteon pack`; serving with the real `osteon serve`;
// launching Debian's Chromium headless (WebGL through SwiftShader, no GPU needed); and counting the
// pixels of a screenshot that differ from the background.
//
// Environment:
//   OSTEON_CLI          the native CLI (default: build/release/osteon, then build/osteon)
//   OSTEON_VIEWER_DIR   the built viewer (default: build/viewer; `npm run build:viewer`)
//   OSTEON_SHARED_DATA  the real meshes (default: ../shared/data beside the checkout)
//   OSTEON_CHROMIUM     the browser (default: /usr/bin/chromium, Debian's; never downloaded)

import { execFileSync, spawn } from 'node:child_process';
import { cpSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before } from 'node:test';
import { fileURLToPath } from 'node:url';
import { gzipSync } from 'node:zlib';

import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
export const repo = path.resolve(here, '..', '..');
export const cli = process.env.OSTEON_CLI ??
  [path.join(repo, 'build', 'release', 'osteon'), path.join(repo, 'build', 'osteon')].find(existsSync);
export const viewerDir = path.resolve(process.env.OSTEON_VIEWER_DIR ?? path.join(repo, 'build', 'viewer'));
export const dataDir = path.resolve(process.env.OSTEON_SHARED_DATA ?? path.join(repo, '..', 'shared', 'data'));
export const chromiumPath = process.env.OSTEON_CHROMIUM ?? '/usr/bin/chromium';
export const artifacts = path.join(repo, 'build', 'test-artifacts', 'viewer');

/// Why the browser tests cannot run here, or null.
export function missingPrerequisite() {
  if (!cli || !existsSync(cli)) return 'the osteon CLI is not built (set OSTEON_CLI or build build/release)';
  if (!existsSync(path.join(viewerDir, 'index.html'))) return `${viewerDir}/index.html is missing: run npm run build:viewer`;
  if (!existsSync(chromiumPath)) return `no browser at ${chromiumPath} (apt-get install chromium, or set OSTEON_CHROMIUM)`;
  return null;
}

export function osteon(...args) {
  return execFileSync(cli, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'], maxBuffer: 64 << 20 });
}

let viewerOption;
/// Whether this CLI's `osteon pack` copies the viewer itself (--viewer DIR).
function packHasViewerOption() {
  viewerOption ??= osteon('pack', '--help').includes('--viewer');
  return viewerOption;
}

/// Packs `inputs` into `out` with the real CLI and puts the built viewer beside the manifest
/// (with `--viewer` when the CLI has it, else copied here the way pack does: every file, relative
/// paths kept). Returns the parsed manifest.json.
export function pack(inputs, out, extra = []) {
  const viewerArgs = packHasViewerOption() ? ['--viewer', viewerDir] : [];
  osteon('pack', ...inputs, '-o', out, ...extra, ...viewerArgs);
  if (!viewerArgs.length) cpSync(viewerDir, out, { recursive: true });
  if (!existsSync(path.join(out, 'index.html'))) throw new Error(`osteon pack left no index.html in ${out}`);
  return JSON.parse(readFileSync(path.join(out, 'manifest.json'), 'utf8'));
}

/// Starts `osteon serve root --port 0` (or `port`: the same origin again after a close) and
/// resolves to { url, requests, close } once it prints its address. `requests` collects the
/// request lines it logs (one per request, on stderr).
export function serve(root, port = 0) {
  const child = spawn(cli, ['serve', root, '--port', String(port)], { stdio: ['ignore', 'pipe', 'pipe'] });
  const requests = [];
  let stderrTail = '';
  child.stderr.setEncoding('utf8');
  child.stderr.on('data', (chunk) => {
    stderrTail = (stderrTail + chunk).slice(-4000);
    requests.push(...chunk.split('\n').filter(Boolean));
  });
  return new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => {
      child.kill();
      reject(new Error(`osteon serve printed no address in 10 s: ${out}${stderrTail}`));
    }, 10000);
    child.stdout.setEncoding('utf8');
    child.stdout.on('data', (chunk) => {
      out += chunk;
      const match = /(http:\/\/[^\s]+:\d+\/)/.exec(out);
      if (!match) return;
      clearTimeout(timer);
      resolve({
        url: match[1],
        requests,
        close: () => new Promise((done) => {
          if (child.exitCode !== null) return done();
          child.once('exit', done);
          child.kill('SIGTERM');
        }),
      });
    });
    child.once('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`osteon serve exited (${code}): ${stderrTail}`));
    });
  });
}

/// Debian's Chromium, headless, drawing WebGL with SwiftShader (the software GPU it ships).
export function launchBrowser() {
  return chromium.launch({
    executablePath: chromiumPath,
    headless: true,
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
  });
}

/// The phantom packed and served for a describe block: registers a before() hook that writes
/// `osteon phantom` (with `phantomArgs`) into a new temporary folder named from `prefix`, runs
/// `beforePack(work)` (e.g. to write a names file), packs it into site/p with `packArgs` (or
/// `packArgs(work)`: options naming files there), runs
/// `afterPack(work, m)` (e.g. to add more to the site), serves site and launches the browser, and an
/// after() hook that closes them and removes the folder. Returns { work, server, browser, m } (m:
/// the manifest), filled in by the before() hook.
export function phantomSite(prefix, packArgs = [], { phantomArgs = [], beforePack = () => {}, afterPack = () => {} } = {}) {
  const site = { work: null, server: null, browser: null, m: null };
  before(async () => {
    site.work = mkdtempSync(path.join(tmpdir(), prefix));
    osteon('phantom', '-o', path.join(site.work, 'phantom'), ...phantomArgs);
    await beforePack(site.work);
    site.m = pack([path.join(site.work, 'phantom')], path.join(site.work, 'site', 'p'),
      typeof packArgs === 'function' ? packArgs(site.work) : packArgs);
    await afterPack(site.work, site.m);
    site.server = await serve(path.join(site.work, 'site'));
    site.browser = await launchBrowser();
  });
  after(async () => {
    await site.browser?.close();
    await site.server?.close();
    if (site.work) rmSync(site.work, { recursive: true, force: true });
  });
  return site;
}

/// Opens `url` and collects the page's console errors and uncaught exceptions. `beforeLoad(page)`
/// runs first (e.g. to throttle the network).
export async function openViewer(context, url, beforeLoad = async () => {}) {
  const page = await context.newPage();
  await beforeLoad(page);
  const problems = [];
  page.on('pageerror', (e) => problems.push(`pageerror: ${e.message}`));
  page.on('console', (m) => {
    if (m.type() === 'error') problems.push(`console: ${m.text()}`);
  });
  await page.goto(url);
  return { page, problems };
}

/// Waits until the viewer has loaded (or failed) every component and its list of bones is whole,
/// then for two more frames so the last component is on screen.
export async function waitLoaded(page, timeout = 60000) {
  await page.waitForFunction(() => window.osteon?.done === true && window.osteon.listsBuilt === true, null, { timeout });
  await settle(page);
  return page.evaluate(() => {
    const { screenPositionOf, screenBoundsOf, select, frame, ...plain } = window.osteon;
    return JSON.parse(JSON.stringify(plain));
  });
}

/// Waits until levels of detail have settled for the current view (nothing in flight, nothing
/// waiting for a frame, nothing more that fits the budget) and the frames are drawn; returns
/// window.osteon's plain fields.
export async function waitRefined(page, timeout = 30000) {
  for (let i = 0; i < 20; ++i) {
    await page.waitForFunction(() => window.osteon?.refineIdle === true && !window.osteon.framePending, null, { timeout });
    await settle(page);
    if (await page.evaluate(() => window.osteon.refineIdle && !window.osteon.framePending)) break;
  }
  return page.evaluate(() => JSON.parse(JSON.stringify(window.osteon)));
}

/// Waits for the frames a change asked for to be drawn: until the renderer (a worker) has drawn
/// every change the page sent it, then until the frame counter stops moving over two animation
/// frames, since OrbitControls' damping draws a few more.
export async function settle(page) {
  let frames = -1;
  for (let i = 0; i < 50; ++i) {
    await page.waitForFunction(() => !window.osteon.framePending, null, { timeout: 10000 });
    const now = await page.evaluate(() => new Promise((resolve) =>
      requestAnimationFrame(() => requestAnimationFrame(() => resolve(window.osteon.framePending ? -1 : window.osteon.frames)))));
    if (now === frames && now >= 0) return;
    frames = now;
  }
}

/// A screenshot of the 3D view, saved as build/test-artifacts/viewer/<name>.png. Returns the PNG,
/// the canvas's client rectangle and the background colour.
export async function shootCanvas(page, name) {
  mkdirSync(artifacts, { recursive: true });
  const canvas = page.locator('#canvas');
  const box = await canvas.boundingBox();
  // The overlays (progress text, buttons) are hidden: the pixels counted are the 3D view's alone.
  const png = await canvas.screenshot({
    path: path.join(artifacts, `${name}.png`),
    style: '#status, #view-buttons, #tools { visibility: hidden !important; }',
  });
  return { png, box };
}

/// Decodes `pngs` (PNG Buffers) in the browser itself (a blank page's canvas, so the tests need no
/// image library) into { width, height, data } (the RGBA Uint8ClampedArray) each, and returns what
/// `fn(images, arg)` returns, run in the page. `fn` travels as its source text: it must use only its
/// arguments. `target` is a browser context (a blank page is opened and closed) or a page to decode on.
export async function withPixels(target, pngs, fn, arg) {
  const given = typeof target.evaluate === 'function';
  const page = given ? target : await target.newPage();
  try {
    return await page.evaluate(async ({ encoded, source, arg }) => {
      const decode = async (data) => {
        const image = new Image();
        image.src = `data:image/png;base64,${data}`;
        await image.decode();
        const c = document.createElement('canvas');
        c.width = image.width;
        c.height = image.height;
        const g = c.getContext('2d');
        g.drawImage(image, 0, 0);
        return { width: image.width, height: image.height, data: g.getImageData(0, 0, image.width, image.height).data };
      };
      const images = await Promise.all(encoded.map(decode));
      return new Function(`return (${source});`)()(images, arg);
    }, { encoded: pngs.map((png) => png.toString('base64')), source: fn.toString(), arg });
  } finally {
    if (!given) await page.close();
  }
}

/// Counts the pixels of `png` (a screenshot of a region at client `origin`) inside `rect` (client
/// coordinates, clipped to the image) whose colour differs from `background` ('#rrggbb') by more
/// than 24 in some channel, decoded by withPixels. Returns { pixels, differing, fraction, luminance }
/// (the mean luminance, 0..255, of the differing pixels: how brightly lit what is drawn there is).
/// `rect` may be an array of rectangles: then an array of those, from one decode of the image.
export function countForeground(context, png, origin, rect, background) {
  return withPixels(context, [png], ([image], { origin, rects, background }) => {
    const count = (rect) => {
      const x0 = Math.max(0, Math.floor(rect.left - origin.x));
      const y0 = Math.max(0, Math.floor(rect.top - origin.y));
      const x1 = Math.min(image.width, Math.ceil(rect.right - origin.x));
      const y1 = Math.min(image.height, Math.ceil(rect.bottom - origin.y));
      if (x1 <= x0 || y1 <= y0) return { pixels: 0, differing: 0, fraction: 0, luminance: 0 };
      const bg = [1, 3, 5].map((i) => parseInt(background.slice(i, i + 2), 16));
      const px = image.data;
      let differing = 0;
      let light = 0;
      for (let y = y0; y < y1; ++y) {
        for (let x = x0; x < x1; ++x) {
          const i = 4 * (y * image.width + x);
          if (Math.abs(px[i] - bg[0]) > 24 || Math.abs(px[i + 1] - bg[1]) > 24 || Math.abs(px[i + 2] - bg[2]) > 24) {
            ++differing;
            light += 0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2];
          }
        }
      }
      const pixels = (x1 - x0) * (y1 - y0);
      return { pixels, differing, fraction: differing / pixels, luminance: differing ? light / differing : 0 };
    };
    return Array.isArray(rects) ? rects.map(count) : count(rects);
  }, { origin, rects: rect, background });
}

/// Counts the pixels where two screenshots of the same size (PNGs) differ by more than `tolerance`
/// in some channel, decoded by withPixels. Returns { pixels, differing }.
export function countDiffering(context, pngA, pngB, tolerance = 24) {
  return withPixels(context, [pngA, pngB], ([a, b], tolerance) => {
    const pa = a.data;
    const pb = b.data;
    if (pa.length !== pb.length) throw new Error(`the screenshots differ in size (${pa.length / 4} and ${pb.length / 4} pixels)`);
    let differing = 0;
    for (let i = 0; i < pa.length; i += 4) {
      if (Math.abs(pa[i] - pb[i]) > tolerance || Math.abs(pa[i + 1] - pb[i + 1]) > tolerance || Math.abs(pa[i + 2] - pb[i + 2]) > tolerance) ++differing;
    }
    return { pixels: pa.length / 4, differing };
  }, tolerance);
}

/// Rewrites a package packed with --no-lod as version 2 (the format before levels of detail):
/// manifest.json and its .gz. Returns the manifest.
export function asVersion2(dir) {
  const file = path.join(dir, 'manifest.json');
  const json = JSON.parse(readFileSync(file, 'utf8'));
  if (json.components.some((c) => c.levels)) throw new Error(`${dir}: has levels of detail, not a version 2 package`);
  json.version = 2;
  const text = JSON.stringify(json);
  writeFileSync(file, text);
  writeFileSync(`${file}.gz`, gzipSync(text, { level: 9 }));
  return json;
}

/// The chunk files of a package folder (c/*.ostc), by name.
export function chunkFiles(dir) {
  return readdirSync(path.join(dir, 'c')).filter((f) => f.endsWith('.ostc')).sort();
}

/// Overwrites `count` bytes in the middle of bytes [offset, offset + length) of `file` with their
/// complement (so they surely change).
export function corruptRange(file, offset, length, count = 16) {
  const bytes = readFileSync(file);
  const start = offset + Math.max(0, Math.floor(length / 2) - count / 2);
  for (let i = start; i < Math.min(offset + length, start + count); ++i) bytes[i] ^= 0xff;
  writeFileSync(file, bytes);
}

/// Records the page's main-thread long tasks (PerformanceObserver 'longtask', registered before
/// any page script) in window.__longTasks as [start, duration] pairs.
export async function observeLongTasks(context) {
  await context.addInitScript(() => {
    window.__longTasks = [];
    new PerformanceObserver((list) => {
      for (const e of list.getEntries()) window.__longTasks.push([e.startTime, e.duration]);
    }).observe({ type: 'longtask', buffered: true });
  });
}

/// Total blocking time until `until` (ms from navigation): the part beyond 50 ms of every long
/// task that started before it.
export async function totalBlockingTime(page, until) {
  const tasks = await page.evaluate(() => window.__longTasks ?? []);
  return tasks.filter(([start]) => start <= until).reduce((sum, [, duration]) => sum + Math.max(0, duration - 50), 0);
}
