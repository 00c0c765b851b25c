// SPDX-License-Identifier: Apache-2.0
// A capped cut (cap.mjs), in Chromium: the phantom, seen straight from the front, cut through the
// middle by the clipping plane across Y. With "Cap the cut" on (the default), the sections the
// plane makes through the bones are filled, flat, in the bones' colour (the highlighted bone's in
// the highlight colour); with it off, the same pixels show the bones' insides or the background.
// A second plane, across X, cuts away the bones on its side (those wholly there vanish), and its
// sections are filled too. Screenshots: build/test-artifacts/viewer/cut-*.png.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/cap_cut.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { describe, test } from 'node:test';

import {
  countDiffering, countForeground, missingPrerequisite, openViewer, phantomSite, settle, shootCanvas, waitLoaded, waitRefined, withPixels,
} from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# cap browser tests skipped: ${skip}`);
const kView = { viewport: { width: 900, height: 700 }, deviceScaleFactor: 1 };

/// The colours of `png` (a screenshot of a region at client `origin`) in the square of side
/// 2 * `half` + 1 pixels around each of `points` (client coordinates): per point { mean: [r, g, b],
/// spread (the largest channel's max - min) }, decoded by withPixels on `lab` (a blank page). Pixels
/// of the square outside the image count as transparent black, as a canvas reads them.
function patchColors(lab, png, origin, points, half = 2) {
  return withPixels(lab, [png], ([image], { origin, points, half }) => points.map((p) => {
    const x0 = Math.round(p.x - origin.x) - half;
    const y0 = Math.round(p.y - origin.y) - half;
    const lo = [255, 255, 255];
    const hi = [0, 0, 0];
    const sum = [0, 0, 0];
    for (let y = y0; y <= y0 + 2 * half; ++y) {
      for (let x = x0; x <= x0 + 2 * half; ++x) {
        const inside = x >= 0 && y >= 0 && x < image.width && y < image.height;
        const i = 4 * (y * image.width + x);
        for (let k = 0; k < 3; ++k) {
          const v = inside ? image.data[i + k] : 0;
          lo[k] = Math.min(lo[k], v);
          hi[k] = Math.max(hi[k], v);
          sum[k] += v;
        }
      }
    }
    return { mean: sum.map((s) => s / ((2 * half + 1) ** 2)), spread: Math.max(...hi.map((h, k) => h - lo[k])) };
  }), { origin, points, half });
}

/// Counts the pixels of `png` within `tolerance` of `rgb` in every channel; with rgb null, inside
/// `rect` (client coordinates; `origin`: the image's), the pixels not `background` and those of
/// them in the plain bone colour's hue (green and blue near red, as in 0xd9cdb5, however lit,
/// unlike the highlight's orange): { pixels, near } or { foreground, plain }. Decoded on `lab`.
function countNear(lab, png, rgb, tolerance, { rect = null, origin = null, background = null } = {}) {
  return withPixels(lab, [png], ([image], { rgb, tolerance, rect, origin, background }) => {
    const px = image.data;
    if (rgb) {
      let near = 0;
      for (let i = 0; i < px.length; i += 4) {
        if ([0, 1, 2].every((k) => Math.abs(px[i + k] - rgb[k]) <= tolerance)) ++near;
      }
      return { pixels: px.length / 4, near };
    }
    const x0 = Math.max(0, Math.floor(rect.left - origin.x));
    const y0 = Math.max(0, Math.floor(rect.top - origin.y));
    const x1 = Math.min(image.width, Math.ceil(rect.right - origin.x));
    const y1 = Math.min(image.height, Math.ceil(rect.bottom - origin.y));
    const bg = [1, 3, 5].map((i) => parseInt(background.slice(i, i + 2), 16));
    let foreground = 0;
    let plain = 0;
    for (let y = y0; y < y1; ++y) {
      for (let x = x0; x < x1; ++x) {
        const i = 4 * (y * image.width + x);
        if (![0, 1, 2].some((k) => Math.abs(px[i + k] - bg[k]) > 24)) continue;
        ++foreground;
        if (px[i + 1] >= 0.85 * px[i] && px[i + 2] >= 0.7 * px[i]) ++plain;
      }
    }
    return { foreground, plain };
  }, { rgb, tolerance, rect, origin, background });
}

describe('a capped cut', { skip: skip ?? false }, () => {
  // Full resolution only: every view is final once loaded (no refinement to wait for).
  const site = phantomSite('osteon-cap-', ['--no-lod']);

  test('the sections are filled with the bones\' colour; a second plane cuts and is capped too', async () => {
    const context = await site.browser.newContext(kView);
    const lab = await context.newPage();  // decodes the screenshots
    const { page, problems } = await openViewer(context, `${site.server.url}p/`);
    const full = await waitLoaded(page);
    assert.deepEqual(full.errors, []);
    const { min, max } = site.m.bounds;
    const center = min.map((v, i) => (v + max[i]) / 2);
    // Straight at the plane across Y, from the side it cuts away (-Y), Z up.
    const distance = 1.25 * (max[2] - min[2]) / 2 / Math.tan((20 * Math.PI) / 180);
    const front = [center[0], center[1] - distance, center[2]];
    await page.evaluate((cam) => window.osteon.setViewState(`v=1&cam=${cam.join(',')}`), [...front, ...center, 0, 0, 1, 40]);
    await waitRefined(page);
    const whole = await shootCanvas(page, 'cut-none');

    // The cut through the middle of Y, keeping the back half (+Y), capped.
    assert.equal(await page.locator('#clip-cap').isChecked(), true, 'capping is on by default');
    await page.locator('#clip-on').check();
    await page.locator('#clip-axis').selectOption('1');
    await page.locator('#clip-pos').fill('500');
    await settle(page);
    await waitRefined(page);
    const capped = await shootCanvas(page, 'cut-capped');
    await page.locator('#clip-cap').uncheck();
    await settle(page);
    await waitRefined(page);
    const uncapped = await shootCanvas(page, 'cut-uncapped');

    // Where the sections are seen, the cap draws a flat fill (one colour, the plane facing the
    // eye) that the bones' insides, curved and lit from all sides, mostly do not match.
    const bounds = await page.evaluate(() => window.osteon.screenBoundsOf());
    const drawn = await countForeground(context, capped.png, capped.box, bounds, full.background);
    const names = ['skull', 'pelvis', 'scapula_l', 'femur_r', 'humerus_r'];
    const at = (shot) => page.evaluate((n) => n.map((name) => window.osteon.screenPositionOf(name)), names)
      .then((points) => patchColors(lab, shot.png, shot.box, points));
    const [wholeAt, cappedAt, uncappedAt] = [await at(whole), await at(capped), await at(uncapped)];
    const fill = cappedAt[0].mean;
    const filled = await countNear(lab, capped.png, fill, 4);
    const open = await countNear(lab, uncapped.png, fill, 4);
    const changed = await countDiffering(context, capped.png, uncapped.png, 4);
    console.log(`# front: ${drawn.differing} bone pixels; ${filled.near} of the cap's colour capped, ${open.near} uncapped; ${changed.differing} change`);
    assert.ok(drawn.fraction > 0.08, 'the cut skeleton is drawn');
    assert.ok(changed.differing > 0.3 * drawn.differing, `capping changes ${changed.differing} of ${drawn.differing} pixels`);
    assert.ok(filled.near > 0.4 * drawn.differing && filled.near > 2 * open.near, `${filled.near} pixels of the cap's colour, ${open.near} without caps`);
    // The skull's and the pelvis's sections: flat, in the bone colour (0xd9cdb5, lit).
    const background = [1, 3, 5].map((i) => parseInt(full.background.slice(i, i + 2), 16));
    const isBackground = (c) => c.spread <= 2 && c.mean.every((v, k) => Math.abs(v - background[k]) <= 4);
    for (const k of [0, 1]) {
      const { mean: [r, g, b], spread } = cappedAt[k];
      assert.ok(spread <= 2 && r > g && g > b && Math.abs(b / r - 0xb5 / 0xd9) < 0.05 && r > 120, `${names[k]}'s section: ${JSON.stringify(cappedAt[k])}`);
    }
    assert.ok(uncappedAt[0].spread > 8, `the skull's inside, uncapped: ${JSON.stringify(uncappedAt[0])}`);
    // Beyond the plane: the scapula (wholly there) is gone.
    assert.ok(Math.abs(wholeAt[2].mean[0] - cappedAt[2].mean[0]) > 24, `the scapula: ${JSON.stringify([wholeAt[2], cappedAt[2]])}`);

    // Highlighted, femur_l (the mirrored instance of a batch) is capped in its instance's colour.
    await page.locator('#clip-cap').check();
    await page.evaluate(() => window.osteon.select('femur_l'));
    await settle(page);
    await waitRefined(page);
    const lit = await shootCanvas(page, 'cut-capped-highlight');
    // Below the pelvis: the lower two thirds of the femur's box.
    const femurBox = await page.evaluate(() => window.osteon.screenBoundsOf('femur_l'));
    femurBox.top += (femurBox.bottom - femurBox.top) / 3;
    const femur = await countNear(lab, lit.png, null, 0, { rect: femurBox, origin: lit.box, background: full.background });
    assert.ok(femur.foreground > 500 && femur.plain < 0.02 * femur.foreground, `femur_l: ${JSON.stringify(femur)}`);
    await page.evaluate(() => window.osteon.select(null));

    // From the front left, a second plane across X through the middle, keeping +X (the eye is
    // on the side it cuts away, so its sections face it too).
    const left = [center[0] - 0.5 * distance, center[1] - distance, center[2]];
    await page.evaluate((cam) => window.osteon.setViewState(`v=1&cam=${cam.join(',')}`), [...left, ...center, 0, 0, 1, 40]);
    await page.locator('#clip-on').check();  // a view without a plane turns the cut off
    await settle(page);
    await waitRefined(page);
    const one = await shootCanvas(page, 'cut-one-plane-oblique');
    await page.locator('#clip2-on').check();
    await settle(page);
    await waitRefined(page);
    const two = await shootCanvas(page, 'cut-two-planes');
    await page.locator('#clip-cap').uncheck();
    await settle(page);
    await waitRefined(page);
    const twoOpen = await shootCanvas(page, 'cut-two-planes-uncapped');
    const [oneAt, twoAt, twoOpenAt] = [await at(one), await at(two), await at(twoOpen)];
    const oneDrawn = await countForeground(context, one.png, one.box, await page.evaluate(() => window.osteon.screenBoundsOf()), full.background);
    const cutMore = await countDiffering(context, one.png, two.png);
    const capsTwo = await countDiffering(context, two.png, twoOpen.png, 4);
    console.log(`# two planes: ${oneDrawn.differing} bone pixels with one; ${cutMore.differing} change with the second; capping changes ${capsTwo.differing}`);
    assert.ok(cutMore.differing > 0.25 * oneDrawn.differing, `the second plane changes ${cutMore.differing} pixels`);
    // The right femur and humerus lie wholly beyond the second plane: gone.
    for (const k of [3, 4]) {
      assert.ok(!isBackground(oneAt[k]) && isBackground(twoAt[k]), `${names[k]}: ${JSON.stringify([oneAt[k], twoAt[k]])}`);
    }
    // The skull's centre shows the second plane's section: flat, unlike the first's or the inside.
    assert.ok(twoAt[0].spread <= 2 && Math.abs(twoAt[0].mean[0] - oneAt[0].mean[0]) > 24, `the skull: ${JSON.stringify([oneAt[0], twoAt[0]])}`);
    assert.ok(capsTwo.differing > 0.15 * oneDrawn.differing && twoOpenAt[0].spread > 8, `capping two planes changes ${capsTwo.differing} pixels; ${JSON.stringify(twoOpenAt[0])}`);
    assert.deepEqual(problems, []);
    await context.close();
  });
});
