// SPDX-License-Identifier: Apache-2.0
// A view shared by URL (share.mjs; docs/FORMAT.md "Share URL"), in Chromium: on the standalone
// page of the phantom (packed with levels of detail), orbit and zoom the camera with the mouse,
// select a bone with a click, hide one, cut with the clipping plane; the page's hash follows, and
// "Copy link" puts the same link on the clipboard (or, where the clipboard refuses, selects it in
// its field). Opened in a fresh browser context, the link restores the camera to 1e-6, the
// selection, the visible set and the plane, and draws the same picture; so does an
// <osteon-viewer view="..."> on another page. An isolation travels too; a hash with bad values
// loads the package with those values left out, each named in the page, and never throws.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/share.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { cpSync, mkdirSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { describe, test } from 'node:test';

import {
  countDiffering, missingPrerequisite, openViewer, phantomSite, settle, shootCanvas, viewerDir, waitLoaded, waitRefined,
} from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# share browser tests skipped: ${skip}`);
const kDesktop = { viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 };

/// The share text without its camera (restored views agree on the camera to rounding only).
const withoutCamera = (text) => text.replace(/^#/, '').split('&').filter((f) => !f.startsWith('cam=')).join('&');

/// The clipping plane's controls.
async function clipOf(page) {
  return {
    on: await page.locator('#clip-on').isChecked(),
    axis: await page.locator('#clip-axis').inputValue(),
    position: await page.locator('#clip-pos').inputValue(),
    flip: await page.locator('#clip-flip').isChecked(),
  };
}

function assertCameraClose(actual, expected, what) {
  for (const key of ['position', 'target', 'up']) {
    for (let i = 0; i < 3; ++i) {
      assert.ok(Math.abs(actual[key][i] - expected[key][i]) <= 1e-6, `${what}: camera ${key}[${i}] ${actual[key][i]} against ${expected[key][i]}`);
    }
  }
  assert.ok(Math.abs(actual.fov - expected.fov) <= 1e-6, `${what}: fov ${actual.fov} against ${expected.fov}`);
}

describe('a view shared by URL', { skip: skip ?? false }, () => {
  const site = phantomSite('osteon-share-', ['--chunk-bytes', '8000'], {
    afterPack: (work) => {
      cpSync(viewerDir, path.join(work, 'site', 'lib'), { recursive: true, filter: (f) => !/index\.html/.test(path.basename(f)) });
      mkdirSync(path.join(work, 'site', 'embed'));
    },
  });

  test('camera, selection, hidden parts and the clipping plane travel in the link, the hash and the view attribute', async () => {
    const context = await site.browser.newContext(kDesktop);
    await context.grantPermissions(['clipboard-read', 'clipboard-write'], { origin: site.server.url });
    const { page, problems } = await openViewer(context, `${site.server.url}p/`);
    const full = await waitLoaded(page);
    assert.deepEqual(full.errors, []);
    const fitted = await page.evaluate(() => window.osteon.cameraState());
    assert.equal(await page.evaluate(() => location.hash), '', 'the hash is written only once the view changes');

    // Orbit and zoom with the mouse.
    const box = await page.locator('#canvas').boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2 + 90, box.y + box.height / 2 + 35, { steps: 8 });
    await page.mouse.up();
    await page.mouse.wheel(0, -240);
    // The hash follows the controls.
    await page.waitForFunction(() => /^#v=1&cam=/.test(location.hash), null, { timeout: 5000 });
    // Then a camera of its own, set exactly (it stops the drag's momentum): off-axis, tilted up,
    // another field of view.
    const distance = Math.hypot(...fitted.position.map((v, i) => v - fitted.target[i]));
    const set = {
      position: [0.31, -0.83, 0.27].map((d, i) => fitted.target[i] + d * distance),
      target: fitted.target.map((v, i) => v + [0.013, -0.021, 0.05][i] * distance),
      up: [0.0995037190209989, 0, 0.9950371902099892],
      fov: 41.5,
    };
    await page.evaluate((c) => window.osteon.setViewState(`v=1&cam=${[...c.position, ...c.target, ...c.up, c.fov].join(',')}`), set);
    await settle(page);
    // Select the skull with a click, hide a femur, cut along Y.
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    await page.mouse.click(skull.x, skull.y);
    await page.waitForFunction(() => window.osteon.selected === 'skull');
    assert.equal(await page.evaluate(() => window.osteon.hide('femur_l')), true);
    await page.locator('#clip-on').check();
    await page.locator('#clip-axis').selectOption('1');
    await page.locator('#clip-pos').fill('620');
    await page.locator('#clip-flip').check();
    await settle(page);
    const original = await waitRefined(page);
    const camera = await page.evaluate(() => window.osteon.cameraState());
    assertCameraClose(camera, set, 'set');
    assert.equal(original.instancesDrawn, site.m.instances.length - 1);

    // The hash follows the view (debounced); "Copy link" puts the same link on the clipboard.
    await page.waitForFunction(() => {
      const fields = (text) => text.replace(/^#/, '').split('&').filter((f) => !f.startsWith('cam='));
      return fields(location.hash).join('&') === fields(window.osteon.viewState()).join('&');
    }, null, { timeout: 5000 });
    const hashCamera = await page.evaluate(() => location.hash.match(/cam=([^&]+)/)[1].split(',').map(Number));
    assertCameraClose({ position: hashCamera.slice(0, 3), target: hashCamera.slice(3, 6), up: hashCamera.slice(6, 9), fov: hashCamera[9] }, set, 'hash');
    await page.locator('#copy-link').click();
    await page.waitForFunction(() => document.querySelector('osteon-viewer').shadowRoot.getElementById('share-note').textContent === 'Link copied');
    const link = await page.locator('#share-link').inputValue();
    assert.equal(link, await page.evaluate(() => location.href));
    assert.equal(await page.evaluate(() => navigator.clipboard.readText()), link);
    const hash = new URL(link).hash;
    assert.match(hash, /^#v=1&cam=[^&]+&sel=skull&hide=femur_l&clip=1,620,1$/);
    const clip = await clipOf(page);
    assert.deepEqual(clip, { on: true, axis: '1', position: '620', flip: true });
    const shotA = await shootCanvas(page, 'share-original');

    // A fresh browser context opens the link: the same view.
    const fresh = await site.browser.newContext(kDesktop);
    const opened = await openViewer(fresh, link);
    await waitLoaded(opened.page);
    const restored = await waitRefined(opened.page);
    assert.deepEqual(restored.errors, []);
    assertCameraClose(await opened.page.evaluate(() => window.osteon.cameraState()), camera, 'link');
    assert.equal(restored.selected, 'skull');
    assert.equal(restored.instancesDrawn, original.instancesDrawn);
    assert.equal(restored.trianglesDrawn, original.trianglesDrawn);
    assert.deepEqual(await clipOf(opened.page), clip);
    assert.equal(withoutCamera(await opened.page.evaluate(() => window.osteon.viewState())), withoutCamera(hash));
    assert.equal(await opened.page.locator('#part-list li.hidden-part').filter({ hasText: 'femur_l' }).count(), 1);
    const shotB = await shootCanvas(opened.page, 'share-restored');
    const diff = await countDiffering(fresh, shotA.png, shotB.png);
    console.log(`# shared view: ${diff.differing} of ${diff.pixels} pixels differ from the original`);
    assert.ok(diff.differing < 0.005 * diff.pixels, `${diff.differing} pixels differ`);
    assert.deepEqual(opened.problems, []);

    // An isolation travels as the shorter list of the parts shown.
    await page.locator('#isolate').click();
    await page.waitForFunction(() => /&only=skull(&|$)/.test(location.hash));
    const isolated = await page.evaluate(() => location.href);
    const again = await openViewer(fresh, isolated);
    const isoState = await waitLoaded(again.page);
    assert.equal(isoState.instancesDrawn, 1);
    assert.equal(isoState.selected, 'skull');
    assert.deepEqual(isoState.errors, []);

    // The same text as an element's view attribute, on a page of its own.
    writeFileSync(path.join(site.work, 'site', 'embed', 'index.html'), `<!doctype html><meta charset="utf-8"><link rel="icon" href="data:,">
<style>body { margin: 0; } osteon-viewer { width: 1000px; height: 700px; }</style>
<script type="module" src="../lib/osteon-viewer.mjs"></script>
<osteon-viewer id="v" src="../p/" view="${hash.slice(1).replaceAll('&', '&amp;')}"></osteon-viewer>`);
    const embed = await fresh.newPage();
    const embedProblems = [];
    embed.on('pageerror', (e) => embedProblems.push(e.message));
    await embed.goto(`${site.server.url}embed/`);
    await embed.waitForFunction(() => document.getElementById('v').report?.done === true, null, { timeout: 60000 });
    const viaAttribute = await embed.evaluate(() => {
      const el = document.getElementById('v');
      return { camera: el.report.cameraState(), selected: el.report.selected, instances: el.report.instancesDrawn, view: el.viewState, errors: el.report.errors };
    });
    assertCameraClose(viaAttribute.camera, camera, 'view attribute');
    assert.equal(viaAttribute.selected, 'skull');
    assert.equal(viaAttribute.instances, original.instancesDrawn);
    assert.equal(withoutCamera(viaAttribute.view), withoutCamera(hash));
    assert.deepEqual(viaAttribute.errors, []);
    assert.deepEqual(await clipOf(embed), clip);
    // Its link opens the package's own page with the view; viewState sets a view too.
    assert.equal(await embed.evaluate(() => document.getElementById('v').report.viewState()), viaAttribute.view);
    await embed.evaluate((h) => { document.getElementById('v').viewState = h; }, new URL(isolated).hash.slice(1));
    assert.equal(await embed.evaluate(() => document.getElementById('v').report.instancesDrawn), 1);
    assert.equal(await embed.evaluate(() => location.hash), '', 'an embedded viewer leaves its page\'s hash alone');
    assert.deepEqual(embedProblems, []);
    assert.deepEqual(problems, []);
    await fresh.close();
    await context.close();
  });

  test('"Copy link" selects the link where the clipboard refuses it', async () => {
    const context = await site.browser.newContext(kDesktop);
    await context.addInitScript(() => {
      Object.defineProperty(navigator, 'clipboard', { value: { writeText: () => Promise.reject(new Error('denied')) } });
    });
    const { page, problems } = await openViewer(context, `${site.server.url}p/`);
    await waitLoaded(page);
    await page.evaluate(() => window.osteon.select('pelvis'));
    await page.locator('#copy-link').click();
    await page.waitForFunction(() => document.querySelector('osteon-viewer').shadowRoot.getElementById('share-note').textContent.includes('copy'));
    const selection = await page.evaluate(() => {
      const root = document.querySelector('osteon-viewer').shadowRoot;
      const field = root.getElementById('share-link');
      return { focused: root.activeElement === field, start: field.selectionStart, end: field.selectionEnd, length: field.value.length, value: field.value };
    });
    assert.equal(selection.focused, true);
    assert.deepEqual([selection.start, selection.end], [0, selection.length]);
    assert.match(selection.value, /#v=1&cam=[^&]+&sel=pelvis$/);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test('bad values in the hash are left out, each named, and the rest of the view applies', async () => {
    const context = await site.browser.newContext(kDesktop);
    const bad = [
      '#v=1&cam=1,2,nope,4,5,6&sel=no_such_bone&hide=femur_l,%E0%A4%A&clip=7,500,0&off=no_group',
      '#v=9&sel=skull',
      '#cam=1,2,3&sel=skull',
      '#v=1&cam=0,0,0,0,0,0&clip=1,5000,0&only=',
      '#%%%&&==&v=1',
    ];
    for (const hash of bad) {
      const { page, problems } = await openViewer(context, `${site.server.url}p/${hash}`);
      const state = await waitLoaded(page);
      assert.deepEqual(problems, [], hash);
      assert.equal(state.componentsLoaded, site.m.components.length, hash);
      const viewErrors = state.errors.filter((e) => e.startsWith('osteon: view: '));
      assert.equal(viewErrors.length, state.errors.length, `${hash}: only view messages: ${state.errors}`);
      assert.ok(viewErrors.length >= 1, `${hash}: a message`);
      assert.equal(await page.locator('#errors').isVisible(), true, hash);
      if (hash.startsWith('#v=1&cam=1,2')) {
        // The femur is hidden; the camera, the unknown bone, the bad name, the plane and the group are named.
        assert.equal(state.instancesDrawn, site.m.instances.length - 1);
        for (const word of ['camera "1,2,nope', 'no part "no_such_bone"', 'not URL-encoded', 'clip "7,500,0"', 'no group "no_group"']) {
          assert.ok(viewErrors.some((e) => e.includes(word)), `${word} in ${viewErrors}`);
        }
        assert.equal(state.selected, null);
        assert.equal(await page.locator('#clip-on').isChecked(), false);
      } else {
        assert.equal(state.instancesDrawn, site.m.instances.length, hash);
        assert.equal(state.selected, null, hash);
      }
      await page.close();
    }
    await context.close();
  });
});
