// SPDX-License-Identifier: Apache-2.0
// The viewer offline (docs/DESIGN.md, "Offline use"): a package made by the real `osteon pack`,
// served by the real `osteon serve`, opened once in Debian's Chromium headless and refined by
// byte ranges; its service worker (sw.js) then keeps the viewer's files, the manifest and every
// chunk the page touched. With the server stopped and the context offline, a reload draws the
// whole skeleton at the same levels from the worker's caches alone; online again, a repacked
// package (a new manifest naming new chunks) is what the next reload shows. An element on
// another page registers no worker unless it carries `offline`. The offline load's screenshot is
// kept in build/test-artifacts/viewer/offline-load.png.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/offline.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { mkdirSync, mkdtempSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';

import {
  countDiffering,
  countForeground,
  launchBrowser,
  missingPrerequisite,
  openViewer,
  osteon,
  pack,
  serve,
  shootCanvas,
  viewerDir,
  waitLoaded,
  waitRefined,
} from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# offline browser tests skipped: ${skip}`);
const kDesktop = { viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 };

/// The chunk files the viewer fetched (whole or by range), as URLs under `base`.
function chunksTouched(state, base) {
  const files = new Set([...state.fetchLog, ...(state.levelLog ?? [])].map((e) => e.file));
  return [...files].map((f) => new URL(f, base).href).sort();
}

/// Waits until the page's service worker is active and its caches hold every URL of `urls`.
async function waitKept(page, urls) {
  await page.waitForFunction(async (wanted) => {
    const registration = await navigator.serviceWorker.getRegistration();
    if (registration?.active?.state !== 'activated') return false;
    for (const url of wanted) if (!(await caches.match(url))) return false;
    return true;
  }, urls, { timeout: 60000, polling: 250 });
}

describe('osteon viewer offline', { skip: skip ?? false }, () => {
  let work;
  let site;
  let server;
  let browser;

  before(async () => {
    work = mkdtempSync(path.join(tmpdir(), 'osteon-offline-'));
    site = path.join(work, 'site');
    mkdirSync(site);
    server = await serve(site);
    browser = await launchBrowser();
  });

  after(async () => {
    await browser?.close();
    await server?.close();
    if (work) rmSync(work, { recursive: true, force: true });
  });

  test('a package opened once draws whole offline, from its service worker; online, a repacked manifest is used', async () => {
    // The dense phantom with levels of detail in 20 KB chunks: the finer levels come by range.
    osteon('phantom', '--detail', '3', '-o', path.join(work, 'phantom'));
    const out = path.join(site, 'pkg');
    const m = pack([path.join(work, 'phantom')], out, ['--chunk-bytes', '20000']);
    assert.ok(m.components.some((c) => c.levels?.length >= 1), 'the package has levels of detail');
    const base = `${server.url}pkg/`;

    const context = await browser.newContext(kDesktop);
    const { page, problems } = await openViewer(context, base);
    await waitLoaded(page);
    const online = await waitRefined(page);
    assert.deepEqual(online.errors, []);
    assert.equal(online.componentsLoaded, m.components.length);
    assert.ok(online.levelLog.some((e) => e.status === 206), 'finer levels fetched by range');
    assert.equal(await page.evaluate(() => navigator.serviceWorker.controller), null, 'the first load is not controlled');
    const onlineShot = await shootCanvas(page, 'offline-before');

    // Kept: the viewer's files, the manifest and every chunk the page touched, whole.
    const viewerFiles = readdirSync(viewerDir).filter((f) => !f.endsWith('.gz') && f !== 'sw.js').map((f) => new URL(f, base).href);
    const chunks = chunksTouched(online, base);
    await waitKept(page, [...viewerFiles, `${base}manifest.json`, ...chunks]);
    const kept = await page.evaluate(async (url) => {
      const response = await caches.match(url);
      return { status: response.status, bytes: (await response.arrayBuffer()).byteLength };
    }, chunks.at(-1));
    const lastChunk = m.chunks.find((c) => new URL(c.file, base).href === chunks.at(-1));
    assert.deepEqual(kept, { status: 200, bytes: lastChunk.bytes }, 'a chunk read by range is kept whole');

    // Offline: no server, no network. The same page reloads from the worker's caches alone.
    const port = new URL(server.url).port;
    await server.close();
    server = null;
    await context.setOffline(true);
    problems.length = 0;
    await page.reload();
    await waitLoaded(page);
    const offline = await waitRefined(page);
    assert.ok(await page.evaluate(() => navigator.serviceWorker.controller !== null), 'the offline load is controlled');
    assert.deepEqual(offline.errors, []);
    assert.equal(offline.componentsFailed, 0);
    assert.equal(offline.componentsLoaded, online.componentsLoaded);
    assert.equal(offline.instancesDrawn, m.instances.length);
    assert.equal(offline.instancesDrawn, online.instancesDrawn);
    assert.deepEqual(offline.levelDrawn, online.levelDrawn, 'refined to the same levels, by ranges answered from the cache');
    assert.equal(offline.trianglesDrawn, online.trianglesDrawn);
    assert.ok(offline.levelLog.some((e) => e.status === 206), 'ranges answered as 206 slices');
    assert.ok(offline.levelsFailed === 0 || offline.levelsFailed === undefined, `${offline.levelsFailed} levels failed`);
    const offlineShot = await shootCanvas(page, 'offline-load');
    const drawn = await countForeground(context, offlineShot.png, { x: 0, y: 0 },
      { left: 0, top: 0, right: offlineShot.box.width, bottom: offlineShot.box.height }, online.background);
    assert.ok(drawn.fraction > 0.02, `${(drawn.fraction * 100).toFixed(1)}% of the view drawn offline`);
    const changed = await countDiffering(context, onlineShot.png, offlineShot.png);
    assert.ok(changed.differing / changed.pixels < 0.005, `${changed.differing} of ${changed.pixels} pixels differ from the online view`);
    assert.deepEqual(problems, []);

    // Online again, the package repacked in place (other chunk sizes: a new manifest, new chunk
    // names): the next reload reads the new manifest, not the kept one.
    const repacked = pack([path.join(work, 'phantom')], out, ['--chunk-bytes', '12000']);
    assert.notDeepEqual(repacked.chunks.map((c) => c.file), m.chunks.map((c) => c.file));
    server = await serve(site, port);
    assert.equal(`${server.url}pkg/`, base, 'the same origin');
    await context.setOffline(false);
    await page.reload();
    await waitLoaded(page);
    const again = await waitRefined(page);
    assert.deepEqual(again.errors, []);
    assert.equal(again.chunksTotal, repacked.chunks.length);
    const newFiles = new Set(repacked.chunks.map((c) => c.file));
    assert.ok(again.fetchLog.every((e) => newFiles.has(e.file)), 'every chunk read is the new manifest\'s');
    assert.equal(again.componentsLoaded, repacked.components.length);
    assert.ok(server.requests.some((r) => /^GET \/pkg\/manifest\.json 200/.test(r)), server.requests.join('\n'));
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('an element on another page registers no service worker unless it carries offline', async () => {
    osteon('phantom', '-o', path.join(work, 'small'));
    pack([path.join(work, 'small')], path.join(site, 'small'), ['--no-lod']);
    mkdirSync(path.join(site, 'embed'), { recursive: true });
    const page = (offline) => `<!doctype html><meta charset="utf-8">
<script type="module" src="../small/osteon-viewer.mjs"></script>
<osteon-viewer id="v" src="../small/" style="display:block;width:640px;height:480px"${offline ? ' offline' : ''}></osteon-viewer>`;
    writeFileSync(path.join(site, 'embed', 'plain.html'), page(false));
    writeFileSync(path.join(site, 'embed', 'offline.html'), page(true));
    const registrations = async (name, expected) => {
      const context = await browser.newContext(kDesktop);
      const p = await context.newPage();
      await p.goto(`${server.url}embed/${name}`);
      await p.waitForFunction(() => document.getElementById('v').report?.done === true, null, { timeout: 60000 });
      // Past the moment the element would register (its load, then an idle callback), or until
      // the registration expected is there.
      await p.waitForFunction(async (n) => {
        await new Promise((resolve) => requestIdleCallback(() => setTimeout(resolve, 200)));
        return (await navigator.serviceWorker.getRegistrations()).length >= n;
      }, expected, { timeout: 30000 });
      const scopes = await p.evaluate(async () => (await navigator.serviceWorker.getRegistrations()).map((r) => new URL(r.scope).pathname));
      await context.close();
      return scopes;
    };
    assert.deepEqual(await registrations('plain.html', 0), []);
    // With offline: the worker beside the element's script, its scope that folder (the package's).
    assert.deepEqual(await registrations('offline.html', 1), ['/small/']);
  });
});
