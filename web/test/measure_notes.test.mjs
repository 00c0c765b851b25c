// SPDX-License-Identifier: Apache-2.0
// Measurements and notes pinned to the surface (measure.mjs, notes.mjs, overlay.mjs), in
// Chromium, on the standalone page of the phantom: window.osteon.measure between two vertices
// of the phantom's own files gives their distance and the sum of their parts' error bounds from
// the manifest; three points give the angle at the middle one; picks (measureAt, the Measure
// tool's taps) land on the bone's surface. A note travels in the share link and comes back, to
// the digit, in a new page; a hostile link's note text shows as text, never as markup, and a
// link's 1000 notes are cut to 64. Export downloads { unit, notes, measurements }. The share
// text's `notes` field itself is checked under Node first.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/measure_notes.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import path from 'node:path';
import { before, describe, test } from 'node:test';

import { angleOf, distanceOf } from '../viewer/measure.mjs';
import { wrapText } from '../viewer/overlay.mjs';
import { encodeViewState, parseViewState } from '../viewer/share.mjs';
import { artifacts, missingPrerequisite, openViewer, phantomSite, settle, waitLoaded } from './browser_helpers.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# measure and notes browser tests skipped: ${skip}`);
const kDesktop = { viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 };
const kHostile = '<img src=x onerror=alert(1)>';

describe('the share text\'s notes (share.mjs)', () => {
  test('notes round-trip with separators in their text and part; a hostile field is bounded', () => {
    const notes = [
      { p: [1.25, -3, 1600.01], part: 'skull', text: 'Foramen magnum; see "a,b" & 50% = <b>' },
      { p: [0, 0, 0], part: null, text: 'ä/β#' },
    ];
    const view = { camera: null, selected: null, hidden: null, only: null, groupsOff: [], clip: null, notes };
    const text = encodeViewState(view);
    assert.doesNotMatch(text, /[ #"<>]/, 'URL-safe');
    const { view: back, errors } = parseViewState(`#${text}`);
    assert.deepEqual(errors, []);
    assert.deepEqual(back, view);

    const many = Array.from({ length: 1000 }, (_, i) => `${i},0,0,,${encodeURIComponent(i ? 'n' : 'x'.repeat(900))}`).join(';');
    const hostile = parseViewState(`v=1&notes=${many};1,2`);
    assert.equal(hostile.view.notes.length, 64);
    assert.equal(hostile.view.notes[0].text.length, 500);
    assert.ok(hostile.errors.some((e) => e.includes('only the first 64')), hostile.errors.join('\n'));
    assert.ok(hostile.errors.some((e) => e.includes('cut to 500')), hostile.errors.join('\n'));
    const bad = parseViewState('v=1&notes=1,2,x,,a;1,2,3,%E0%A4%A,b;1,2,3,,ok');
    assert.deepEqual(bad.view.notes, [{ p: [1, 2, 3], part: null, text: 'ok' }]);
    assert.equal(bad.errors.length, 2, bad.errors.join('\n'));
  });

  test('a note\'s label wraps at spaces, in at most 4 lines of 32 characters', () => {
    assert.deepEqual(wrapText('short'), ['short']);
    assert.deepEqual(wrapText('A long note text to see how the label reads on a phone'), ['A long note text to see how the', 'label reads on a phone']);
    const lines = wrapText('x'.repeat(500));
    assert.equal(lines.length, 4);
    assert.ok(lines.every((l) => l.length <= 32));
    assert.ok(lines[3].endsWith('…'));
  });

  test('distances carry their bound; angles are exact near 0 and 180 degrees', () => {
    assert.deepEqual(distanceOf([0, 0, 0], [3, 4, 12], 0.25, 'mm'), { distance: 13, errorBound: 0.25, unit: 'mm', text: '13.0 mm ± 0.250 mm' });
    assert.equal(angleOf([1, 0, 0], [0, 0, 0], [0, 2, 0]).angleDeg, 90);
    assert.ok(Math.abs(angleOf([1, 0, 0], [0, 0, 0], [1, 1e-9, 0]).angleDeg - 180 / Math.PI * 1e-9) < 1e-15);
    assert.equal(angleOf([1, 0, 0], [1, 0, 0], [0, 1, 0]).angleDeg, null);
  });
});

/// The vertices of an OBJ file: { first: [x, y, z], box: { min, max } }.
function verticesOf(file) {
  const vertices = readFileSync(file, 'utf8').split('\n').filter((l) => l.startsWith('v ')).map((l) => l.split(/\s+/).slice(1, 4).map(Number));
  const box = { min: [0, 1, 2].map((i) => Math.min(...vertices.map((v) => v[i]))), max: [0, 1, 2].map((i) => Math.max(...vertices.map((v) => v[i]))) };
  return { first: vertices[0], box };
}

/// A part's error bound as the manifest gives it: the largest of its instances' (an instance
/// without its own takes its component's).
function partBound(m, name) {
  const id = m.parts.findIndex((p) => p.name === name);
  const bounds = m.instances.filter((inst) => inst.part === id)
    .map((inst) => inst.error_bound ?? m.components.find((c) => c.id === inst.component).error_bound);
  return Math.max(...bounds);
}

/// The normalized device coordinates of a client point over the canvas.
async function ndcOf(page, x, y) {
  const box = await page.locator('#canvas').boundingBox();
  return [((x - box.x) / box.width) * 2 - 1, -(((y - box.y) / box.height) * 2 - 1)];
}

/// The overlay's labels: a note's whole text (its tooltip; its lines are checked to be that text
/// wrapped), a measurement's text.
const overlayTexts = (page) => page.evaluate(() => [...document.querySelector('osteon-viewer').shadowRoot.querySelectorAll('#overlay text')].map((t) => {
  const title = t.querySelector('title');
  if (!title) return t.textContent;
  const lines = [...t.querySelectorAll('tspan')].map((s) => s.textContent).join(' ');
  return lines === title.textContent.replace(/\s+/g, ' ').trim() ? title.textContent : `lines "${lines}" of "${title.textContent}"`;
}));

describe('measurements and notes on the surface', { skip: skip ?? false }, () => {
  let skullVertex;
  let skullBox;  // the source mesh's box
  let femurVertex;
  let page;
  let problems;
  let context;
  let picksPoints = false;  // the renderer answers picks with the surface point

  const site = phantomSite('osteon-measure-', [], {
    phantomArgs: ['--format', 'obj'],
    beforePack: (work) => {
      const phantom = path.join(work, 'phantom');
      ({ first: skullVertex, box: skullBox } = verticesOf(path.join(phantom, 'skull.obj')));
      femurVertex = verticesOf(path.join(phantom, 'femur_l.obj')).first;
    },
  });

  before(async () => {
    context = await site.browser.newContext({ ...kDesktop, acceptDownloads: true });
    ({ page, problems } = await openViewer(context, `${site.server.url}p/`));
    page.on('dialog', (d) => {
      problems.push(`dialog: ${d.message()}`);
      d.dismiss();
    });
    const state = await waitLoaded(page);
    assert.deepEqual(state.errors, []);
  });


  test('the distance between two vertices, with the sum of their parts\' error bounds; a right angle', async () => {
    const d = await page.evaluate(([a, b]) => window.osteon.measure({ point: a, part: 'skull' }, { point: b, part: 'femur_l' }), [skullVertex, femurVertex]);
    const expected = Math.hypot(...skullVertex.map((v, i) => v - femurVertex[i]));
    assert.ok(Math.abs(d.distance - expected) <= 1e-9 * expected, `${d.distance} against ${expected}`);
    const bound = partBound(site.m, 'skull') + partBound(site.m, 'femur_l');
    assert.ok(bound > 0);
    assert.ok(Math.abs(d.errorBound - bound) <= 1e-12 * bound, `${d.errorBound} against ${bound}`);
    assert.equal(d.unit, site.m.unit);
    assert.match(d.text, new RegExp(`^[0-9.]+ ${site.m.unit} ± [0-9.e-]+ ${site.m.unit}$`));
    // Given without parts, each point takes the part whose box holds it.
    const plain = await page.evaluate(([a, b]) => window.osteon.measure(a, b), [skullVertex, femurVertex]);
    assert.ok(Math.abs(plain.distance - expected) <= 1e-9 * expected);

    const v = skullVertex;
    const right = await page.evaluate(([a, b, c]) => window.osteon.measure(a, b, c), [[v[0] + 10, v[1], v[2]], v, [v[0], v[1] + 3, v[2] + 4]]);
    assert.ok(Math.abs(right.angleDeg - 90) <= 1e-9, `${right.angleDeg}`);
    assert.equal(right.text, '90.0°');
    const straight = await page.evaluate(([a, b, c]) => window.osteon.measure(a, b, c), [[v[0] + 1, v[1], v[2]], v, [v[0] - 5, v[1], v[2]]]);
    assert.ok(Math.abs(straight.angleDeg - 180) <= 1e-9, `${straight.angleDeg}`);
    assert.equal(await page.evaluate(() => window.osteon.measure([0, 0, 'x'], [1, 1, 1])), null);
  });

  test('picks land on the surface: measureAt, and the Measure tool\'s taps', async (t) => {
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    const pelvis = await page.evaluate(() => window.osteon.screenPositionOf('pelvis'));
    const r = await page.evaluate(([a, b]) => window.osteon.measureAt(a, b), [await ndcOf(page, skull.x, skull.y), await ndcOf(page, skull.x + 12, skull.y + 8)]);
    if (r === null) {
      t.todo('the renderer\'s \'picked\' answer carries no point yet');
      return;
    }
    picksPoints = true;
    assert.deepEqual(r.parts, ['skull', 'skull']);
    // On the decoded skull: inside the source mesh's box, give or take its error bound.
    const slack = partBound(site.m, 'skull') + 1e-3;
    for (const p of r.points) {
      for (let i = 0; i < 3; ++i) assert.ok(p[i] >= skullBox.min[i] - slack && p[i] <= skullBox.max[i] + slack, `point ${p} outside the skull's box`);
    }
    const expected = Math.hypot(...r.points[0].map((x, i) => x - r.points[1][i]));
    assert.ok(Math.abs(r.distance - expected) <= 1e-9 * Math.max(1, expected));
    assert.ok(r.distance > 0);
    assert.equal(r.errorBound, 2 * partBound(site.m, 'skull'));

    // The tool: three taps, skull, pelvis, skull again; the selection does not change.
    const before = await page.evaluate(() => window.osteon.notes().measurements.length);
    await page.locator('#measure-tool').click();
    assert.equal(await page.locator('#measure-tool').getAttribute('aria-pressed'), 'true');
    for (const [x, y] of [[skull.x - 10, skull.y], [pelvis.x, pelvis.y], [skull.x + 10, skull.y - 10]]) {
      const count = await page.evaluate(() => window.osteon.notes().measurements.at(-1)?.points.length ?? 0);
      await page.mouse.click(x, y);
      await page.waitForFunction((n) => (window.osteon.notes().measurements.at(-1)?.points.length ?? 0) !== n, count);
    }
    const all = await page.evaluate(() => window.osteon.notes().measurements);
    assert.equal(all.length, before + 1);
    const angle = all.at(-1);
    assert.equal(angle.kind, 'angle');
    assert.deepEqual(angle.parts, ['skull', 'pelvis', 'skull']);
    assert.ok(angle.angleDeg > 0 && angle.angleDeg < 180);
    assert.equal(await page.evaluate(() => window.osteon.selected), null);
    await settle(page);
    const texts = await overlayTexts(page);
    assert.ok(texts.includes(angle.text), `${angle.text} in ${texts}`);
    assert.ok(texts.includes(r.text), `${r.text} in ${texts}`);
    mkdirSync(artifacts, { recursive: true });
    await page.screenshot({ path: path.join(artifacts, 'measure.png') });
    // Esc removes them; the tool stays on, a second Esc switches it off.
    await page.locator('#canvas').focus();
    await page.keyboard.press('Escape');
    assert.equal(await page.evaluate(() => window.osteon.notes().measurements.length), 0);
    assert.equal(await page.locator('#measure-tool').getAttribute('aria-pressed'), 'true');
    await page.keyboard.press('Escape');
    assert.equal(await page.locator('#measure-tool').getAttribute('aria-pressed'), 'false');
    assert.deepEqual(problems, []);
  });

  test('a note travels in the share link; a hostile link\'s notes show as text, bounded', async () => {
    const text = 'Foramen magnum; see "a,b" & 50%';
    const added = await page.evaluate(([p, text]) => window.osteon.addNote({ point: p, part: 'skull', text }), [skullVertex, text]);
    assert.equal(added.text, text);
    assert.equal(added.part, 'skull');
    for (let i = 0; i < 3; ++i) assert.ok(Math.abs(added.p[i] - skullVertex[i]) <= 0.01, `${added.p} against ${skullVertex}`);
    // Through the tool as well, where picks carry points: tap, type, Enter.
    if (picksPoints) {
      const pelvis = await page.evaluate(() => window.osteon.screenPositionOf('pelvis'));
      await page.locator('#note-tool').click();
      assert.equal(await page.locator('#note-tool').getAttribute('aria-pressed'), 'true');
      await page.mouse.click(pelvis.x, pelvis.y);
      await page.locator('#note-text').waitFor({ state: 'visible' });
      await page.locator('#note-text').fill('Acetabulum');
      await page.keyboard.press('Enter');
      await page.waitForFunction(() => window.osteon.notes().notes.length === 2);
      await page.locator('#note-tool').click();
    }
    const notes = (await page.evaluate(() => window.osteon.notes())).notes;
    await page.waitForFunction(() => /&notes=/.test(location.hash), null, { timeout: 5000 });
    await settle(page);
    const texts = await overlayTexts(page);
    for (const n of notes) assert.ok(texts.includes(n.text), `${n.text} in ${texts}`);
    await page.screenshot({ path: path.join(artifacts, 'notes.png') });

    // The link, in a new page: the same notes.
    const link = await page.evaluate(() => location.href);
    const opened = await openViewer(context, link);
    const state = await waitLoaded(opened.page);
    assert.deepEqual(state.errors, []);
    assert.deepEqual((await opened.page.evaluate(() => window.osteon.notes())).notes, notes);
    assert.deepEqual(await overlayTexts(opened.page), notes.map((n) => n.text));
    assert.deepEqual(opened.problems, []);
    await opened.page.close();

    // A hostile link: markup in a note, 1000 notes.
    const note = (i) => `${skullVertex.join(',')},skull,${encodeURIComponent(i ? `n${i}` : kHostile)}`;
    const hostile = await openViewer(context, `${site.server.url}p/#v=1&notes=${Array.from({ length: 1000 }, (_, i) => note(i)).join(';')}`);
    hostile.page.on('dialog', (d) => {
      hostile.problems.push(`dialog: ${d.message()}`);
      d.dismiss();
    });
    const hostileState = await waitLoaded(hostile.page);
    const listed = (await hostile.page.evaluate(() => window.osteon.notes())).notes;
    assert.equal(listed.length, 64);
    assert.equal(listed[0].text, kHostile);
    assert.ok(hostileState.errors.some((e) => e.includes('only the first 64')), hostileState.errors.join('\n'));
    const shown = await hostile.page.evaluate(() => {
      const root = document.querySelector('osteon-viewer').shadowRoot;
      return { images: root.querySelectorAll('img').length + document.querySelectorAll('img').length, texts: root.querySelectorAll('#overlay text').length };
    });
    assert.equal(shown.images, 0);
    assert.equal(shown.texts, 64);
    assert.ok((await overlayTexts(hostile.page)).includes(kHostile));
    assert.deepEqual(hostile.problems, []);
    await hostile.page.close();
    assert.deepEqual(problems, []);
  });

  test('the overlay follows the camera, keeps its labels\' size, and leaves out what is behind it', async () => {
    const marks = () => page.evaluate(() => {
      const overlay = document.querySelector('osteon-viewer').shadowRoot.getElementById('overlay');
      const point = overlay.querySelector('.note-point');
      const text = overlay.querySelector('.note-label');
      return {
        point: point && [Number(point.getAttribute('cx')), Number(point.getAttribute('cy'))],
        fontSize: text && getComputedStyle(text).fontSize,
        texts: overlay.querySelectorAll('text').length,
        lines: overlay.querySelectorAll('line').length,
      };
    });
    const start = await marks();
    assert.ok(start.point && start.texts >= 1);
    // Zoom in with the wheel: the pinned point moves on screen with the bone, the label keeps its size.
    const box = await page.locator('#canvas').boundingBox();
    await page.mouse.move(box.x + box.width * 0.3, box.y + box.height * 0.3);
    await page.mouse.wheel(0, -400);
    await settle(page);
    const zoomed = await marks();
    assert.ok(Math.hypot(zoomed.point[0] - start.point[0], zoomed.point[1] - start.point[1]) > 5, `${start.point} then ${zoomed.point}`);
    assert.equal(zoomed.fontSize, start.fontSize);
    const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    assert.ok(skull.inFront);
    // A camera in front of every note, looking away from them: nothing is drawn.
    const view = await page.evaluate(() => window.osteon.viewState());
    const { notes } = await page.evaluate(() => window.osteon.notes());
    const [x, z] = [skullVertex[0], skullVertex[2]];
    const y = Math.min(...notes.map((n) => n.p[1])) - 20;
    const cam = [x, y, z, x, y - 500, z, 0, 0, 1, 35].join(',');
    await page.evaluate((text) => window.osteon.setViewState(text), view.replace(/cam=[^&]*/, `cam=${cam}`));
    await settle(page);
    const behind = await marks();
    assert.equal(behind.point, null);
    assert.equal(behind.texts, 0);
    assert.equal(behind.lines, 0);
    await page.evaluate((text) => window.osteon.setViewState(text), view);
    await settle(page);
    assert.ok((await marks()).point);
    // A note on the skull's near side is drawn plainly; seen from the opposite side, the skull's
    // other wall hides it, and it is drawn faded.
    const canvasBox = await page.locator('#canvas').boundingBox();
    const skullAt = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
    const ndc = [((skullAt.x - canvasBox.x) / canvasBox.width) * 2 - 1, -((skullAt.y - canvasBox.y) / canvasBox.height) * 2 + 1];
    const front = await page.evaluate((n) => window.osteon.pickAt(n), ndc);
    assert.equal(site.m.parts[front.part].name.replace(/\.[a-z]+$/, ''), 'skull');
    await page.evaluate((p) => window.osteon.addNote({ point: p, part: 'skull', text: 'Near side' }), front.point);
    const faded = () => page.evaluate(() => {
      const overlay = document.querySelector('osteon-viewer').shadowRoot.getElementById('overlay');
      const label = [...overlay.querySelectorAll('.note-label')].find((t) => t.textContent.includes('Near side'));
      return label ? label.classList.contains('behind') : null;
    });
    await page.waitForTimeout(600);  // the depth check runs after the view has been still
    assert.equal(await faded(), false);
    const cam0 = await page.evaluate(() => window.osteon.cameraState());
    const opposite = cam0.position.map((v, i) => 2 * cam0.target[i] - v);
    const withNote = await page.evaluate(() => window.osteon.viewState());  // a view carries its notes
    await page.evaluate((text) => window.osteon.setViewState(text), withNote.replace(/cam=[^&]*/, `cam=${[...opposite, ...cam0.target, ...cam0.up, cam0.fov].join(',')}`));
    await settle(page);
    await page.waitForFunction(() => {
      const overlay = document.querySelector('osteon-viewer').shadowRoot.getElementById('overlay');
      return [...overlay.querySelectorAll('.note-label.behind')].some((t) => t.textContent.includes('Near side'));
    }, null, { timeout: 10000 });
    await page.screenshot({ path: path.join(artifacts, 'notes-behind.png') });
    await page.evaluate((text) => window.osteon.setViewState(text), view);
    await settle(page);
    // The tools are buttons in the tab order: Space toggles them.
    await page.locator('#measure-tool').focus();
    await page.keyboard.press('Space');
    assert.equal(await page.locator('#measure-tool').getAttribute('aria-pressed'), 'true');
    await page.keyboard.press('Tab');
    assert.equal(await page.evaluate(() => document.querySelector('osteon-viewer').shadowRoot.activeElement?.id), 'note-tool');
    await page.keyboard.press('Space');
    assert.equal(await page.locator('#measure-tool').getAttribute('aria-pressed'), 'false');
    assert.equal(await page.locator('#note-tool').getAttribute('aria-pressed'), 'true');
    await page.keyboard.press('Space');
    assert.equal(await page.locator('#note-tool').getAttribute('aria-pressed'), 'false');
    assert.deepEqual(problems, []);
  });

  test('Export downloads the unit, the notes and the measurements', async () => {
    if (picksPoints) {
      const skull = await page.evaluate(() => window.osteon.screenPositionOf('skull'));
      assert.ok(await page.evaluate(([a, b]) => window.osteon.measureAt(a, b), [await ndcOf(page, skull.x, skull.y), await ndcOf(page, skull.x, skull.y + 20)]));
    }
    const [download] = await Promise.all([page.waitForEvent('download'), page.locator('#notes-export').click()]);
    assert.equal(download.suggestedFilename(), 'osteon-notes.json');
    const json = JSON.parse(readFileSync(await download.path(), 'utf8'));
    assert.equal(json.unit, site.m.unit);
    assert.deepEqual(json, await page.evaluate(() => window.osteon.notes()));
    assert.ok(json.notes.length >= 1);
    assert.equal(json.notes[0].part, 'skull');
    assert.equal(json.measurements.length, picksPoints ? 1 : 0);
    if (picksPoints) assert.equal(json.measurements[0].kind, 'distance');
    assert.deepEqual(problems, []);
  });
});
