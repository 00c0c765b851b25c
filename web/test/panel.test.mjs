// SPDX-License-Identifier: Apache-2.0
// The teaching panel in Chromium, on the phantom skeleton packed with a names file that places
// each bone in its region and side and names it in English, Latin and Japanese: the region tree
// (counts, check boxes, the WAI-ARIA tree keys), the search in every language, colour by region
// and its legend, the language menu, per-node opacity and the x-ray, the keys on the canvas, and
// a name full of markup shown as text.
//
//   cd web && npm run build:viewer && OSTEON_CLI=$PWD/../build/release/osteon node --test test/panel.test.mjs
//
// Environment: see browser_helpers.mjs.

import assert from 'node:assert/strict';
import { cpSync, mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { describe, test } from 'node:test';
import { gzipSync } from 'node:zlib';

import {
  artifacts, countDiffering, missingPrerequisite, observeLongTasks, openViewer, phantomSite, settle, shootCanvas, waitLoaded,
} from './browser_helpers.mjs';
import { languageLabel, partGroupText, partName } from '../viewer/language.mjs';
import { colorBy, kPalette } from '../viewer/palette.mjs';
import { createTreeModel } from '../viewer/region_tree.mjs';

const skip = missingPrerequisite();
if (skip) console.log(`# panel browser tests skipped: ${skip}`);
const kDesktop = { viewport: { width: 1280, height: 900 }, deviceScaleFactor: 1 };
const kEvil = '<img src=x onerror=alert(1)>';

// The phantom's parts (osteon phantom), placed and named: file, English, Latin, Japanese, path,
// system.
const kNames = [
  ['skull', 'Skull', 'Cranium', '頭蓋骨', 'Skeleton / Skull', 'Axial skeleton'],
  ['atlas_c1', 'Atlas', 'Atlas', '環椎', 'Skeleton / Vertebral column', 'Axial skeleton'],
  ['vertebra_l1', 'First lumbar vertebra', 'Vertebra lumbalis I', '第一腰椎', 'Skeleton / Vertebral column', 'Axial skeleton'],
  ['vertebra_l2', 'Second lumbar vertebra', 'Vertebra lumbalis II', '第二腰椎', 'Skeleton / Vertebral column', 'Axial skeleton'],
  ['vertebra_l3', 'Third lumbar vertebra', 'Vertebra lumbalis III', '第三腰椎', 'Skeleton / Vertebral column', 'Axial skeleton'],
  ['rib_l1', 'Left first rib', 'Costa prima sinistra', '左第一肋骨', 'Skeleton / Thorax / Left', 'Axial skeleton'],
  ['rib_l2', 'Left second rib', 'Costa secunda sinistra', '左第二肋骨', 'Skeleton / Thorax / Left', 'Axial skeleton'],
  ['scapula_l', 'Left scapula', 'Scapula sinistra', '左肩甲骨', 'Skeleton / Upper limb / Left', 'Appendicular skeleton'],
  ['humerus_l', 'Left humerus', 'Humerus sinister', '左上腕骨', 'Skeleton / Upper limb / Left', 'Appendicular skeleton'],
  ['humerus_r', 'Right humerus', 'Humerus dexter', '右上腕骨', 'Skeleton / Upper limb / Right', 'Appendicular skeleton'],
  ['pelvis', 'Pelvis', 'Pelvis', '骨盤', 'Skeleton / Pelvis', 'Appendicular skeleton'],
  ['femur_l', 'Left femur', 'Femur sinistrum', '左大腿骨', 'Skeleton / Lower limb / Left', 'Appendicular skeleton'],
  ['femur_r', 'Right femur', 'Femur dextrum', '右大腿骨', 'Skeleton / Lower limb / Right', 'Appendicular skeleton'],
  ['phalanx_2_l', 'Left index finger', 'Phalanx digiti II', '左示指', 'Skeleton / Upper limb / Left / Hand', 'Appendicular skeleton'],
  ['phalanx_3_l', 'Left middle finger', 'Phalanx digiti III', '左中指', 'Skeleton / Upper limb / Left / Hand', 'Appendicular skeleton'],
  ['phalanx_4_l', 'Left ring finger', 'Phalanx digiti IV', '左薬指', 'Skeleton / Upper limb / Left / Hand', 'Appendicular skeleton'],
  ['phalanx_5_l', `Left little finger ${kEvil}`, 'Phalanx digiti V', '左小指', 'Skeleton / Upper limb / Left / Hand', 'Appendicular skeleton'],
];
// The regions as the tree and the legend list them: by name.
const kRegions = ['Lower limb', 'Pelvis', 'Skull', 'Thorax', 'Upper limb', 'Vertebral column'];

/// The region tree's items as people see them: [{ key, name, level, count, expanded, checked }].
function treeItems(page) {
  return page.evaluate(() => {
    const root = document.querySelector('osteon-viewer').shadowRoot;
    return [...root.querySelectorAll('#region-tree [role="treeitem"]')].filter((li) => li.offsetParent !== null).map((li) => ({
      key: li.dataset.key,
      name: li.querySelector('.node-name')?.textContent ?? li.textContent,
      level: Number(li.getAttribute('aria-level')),
      count: li.dataset.count === undefined ? null : Number(li.dataset.count),
      expanded: li.getAttribute('aria-expanded'),
      checked: li.getAttribute('aria-checked'),
    }));
  });
}

/// The key and name of the element focused in the viewer's shadow root.
function focused(page) {
  return page.evaluate(() => {
    const active = document.querySelector('osteon-viewer').shadowRoot.activeElement;
    return { id: active?.id ?? null, role: active?.getAttribute('role') ?? null, key: active?.dataset?.key ?? null, name: active?.querySelector?.('.node-name')?.textContent ?? null };
  });
}

const readState = (page) => page.evaluate(() => JSON.parse(JSON.stringify(window.osteon)));
const item = (page, name) => page.locator('#region-tree [role="treeitem"]', { has: page.locator(':scope > .node > .node-name', { hasText: new RegExp(`^${name}$`) }) });

/// The number of groups of the package rewritten with a flat tree (kManyGroups regions).
const kManyGroups = 20000;

/// Rewrites the package in `dir` (manifest.json and its .gz) with kManyGroups regions under one
/// root, the parts spread over them.
function manyGroups(dir) {
  const file = path.join(dir, 'manifest.json');
  const json = JSON.parse(readFileSync(file, 'utf8'));
  json.groups = [{ name: 'Skeleton' }, ...Array.from({ length: kManyGroups }, (_, i) => ({ name: `Region ${String(i).padStart(5, '0')}`, parent: 0 }))];
  json.parts.forEach((p, i) => {
    p.path = 1 + Math.floor((i * kManyGroups) / json.parts.length);
    p.group = `Skeleton / ${json.groups[p.path].name}`;
  });
  const text = JSON.stringify(json);
  writeFileSync(file, text);
  writeFileSync(`${file}.gz`, gzipSync(text, { level: 9 }));
}

/// A manifest as parseManifest returns it, of `paths` (one part per path, ' / ' between groups)
/// and the parts' `systems`.
function manifestOf(paths, systems = []) {
  const groups = [];
  const index = new Map();
  const parts = paths.map((p, id) => {
    let parent = -1;
    for (const [k, name] of p.split(' / ').entries()) {
      const key = `${parent}/${name}`;
      if (!index.has(key)) {
        index.set(key, groups.length);
        groups.push({ name, parent, names: { la: `${name} (la)` }, depth: k + 1 });
      }
      parent = index.get(key);
    }
    return { id, name: `part${id}`, displayName: `Part ${id}`, group: p, path: parent, names: id === 0 ? { la: 'Pars prima' } : {}, system: systems[id] ?? '' };
  });
  return { parts, groups, languages: ['en', 'la'] };
}

describe('the panel\'s tables (no browser)', () => {
  test('colour by region takes the first level the paths differ at: BodyParts3D\'s six regions', () => {
    const regions = ['Skull', 'Vertebral column', 'Thorax', 'Upper limb', 'Pelvis', 'Lower limb'];
    const paths = regions.flatMap((r) => [`Skeleton / ${r} / Left`, `Skeleton / ${r} / Right`, `Skeleton / ${r}`]);
    const manifest = manifestOf(paths);
    const { colors, legend } = colorBy(manifest, 'region');
    const colorOf = (id) => [...colors.slice(3 * id, 3 * id + 3)].join(',');
    assert.deepEqual(legend.map((e) => e.label('en')), [...regions].sort());
    assert.deepEqual(legend.map((e) => e.label('la')), [...regions].sort().map((r) => `${r} (la)`));
    for (let r = 0; r < regions.length; ++r) {
      assert.equal(colorOf(3 * r), colorOf(3 * r + 1));
      assert.equal(colorOf(3 * r), colorOf(3 * r + 2));
    }
    assert.equal(new Set(paths.map((_, id) => colorOf(id))).size, 6);
    assert.equal(new Set(kPalette.map((c) => c.join())).size, kPalette.length);
    // Paths that differ at their roots: the roots; parts without a path: a neutral class.
    const two = manifestOf(['Head / Skull', 'Trunk / Spine', 'Trunk / Ribs']);
    two.parts.push({ id: 3, name: 'loose', displayName: 'Loose', group: '', path: -1, names: {}, system: '' });
    assert.deepEqual(colorBy(two, 'region').legend.map((e) => e.label('en')), ['Head', 'Trunk', '(no region)']);
    assert.deepEqual(colorBy(manifestOf(['A', 'B'], ['Skeletal', '']), 'system').legend.map((e) => e.label('en')), ['Skeletal', '(no system)']);
    assert.equal(colorBy(manifest, 'part'), null);
  });

  test('names in a language, with the display name where none is given; the tree model counts', () => {
    const manifest = manifestOf(['Skeleton / Upper limb / Left', 'Skeleton / Upper limb / Right', 'Skeleton / Skull']);
    assert.equal(partName(manifest, manifest.parts[0], 'la'), 'Pars prima');
    assert.equal(partName(manifest, manifest.parts[1], 'la'), 'Part 1');
    assert.equal(partName(manifest, manifest.parts[0], 'en'), 'Part 0');
    assert.equal(partGroupText(manifest, manifest.parts[0], 'la'), 'Skeleton (la) / Upper limb (la) / Left (la)');
    assert.equal(languageLabel('und'), 'Default');
    const tree = createTreeModel(manifest);
    assert.deepEqual([...tree.total], [3, 2, 1, 1, 1]);
    assert.deepEqual([...tree.expanded], [0], 'one root opens');
    assert.equal(createTreeModel({ ...manifest, groups: [] }), null);
  });
});

describe('the teaching panel', { skip: skip ?? false }, () => {
  const site = phantomSite('osteon-panel-', (work) => ['--no-lod', '--names', path.join(work, 'names.csv')], {
    beforePack: (work) => {
      const csv = ['file,display_name:en,name:la,name:ja,path,system', ...kNames.map((row) => row.map((f) => (/[",]/.test(f) ? `"${f.replace(/"/g, '""')}"` : f)).join(','))];
      writeFileSync(path.join(work, 'names.csv'), `${csv.join('\n')}\n`);
    },
    afterPack: (work) => {
      cpSync(path.join(work, 'site', 'p'), path.join(work, 'site', 'many'), { recursive: true });
      manyGroups(path.join(work, 'site', 'many'));
    },
  });

  test('tree, search, colour by region, languages, opacity, keys and markup', async () => {
    assert.deepEqual(site.m.languages, ['en', 'la', 'ja']);
    const n = site.m.parts.length;
    assert.equal(n, kNames.length);
    const context = await site.browser.newContext(kDesktop);
    const dialogs = [];
    const { page, problems } = await openViewer(context, `${site.server.url}p/`, async (p) => p.on('dialog', (d) => {
      dialogs.push(d.message());
      d.dismiss();
    }));
    const full = await waitLoaded(page);
    assert.deepEqual(full.errors, []);
    await page.locator('#region-tree [role="treeitem"]').first().waitFor();
    assert.equal(await page.locator('#part-list li').count(), n);
    assert.equal(await page.locator('#region-tree').getAttribute('role'), 'tree');

    // The tree: Skeleton, open, over the six regions; the counts add up.
    let items = await treeItems(page);
    assert.deepEqual(items[0], { key: 'g0', name: 'Skeleton', level: 1, count: n, expanded: 'true', checked: 'true' });
    const regions = items.filter((i) => i.level === 2);
    // In the manifest's order of the groups (pack's: the names file's order of its rows).
    const order = site.m.groups.filter((g) => g.parent === 0).map((g) => g.name);
    assert.deepEqual([...order].sort(), kRegions);
    assert.deepEqual(regions.map((i) => i.name), order);
    assert.equal(regions.reduce((sum, i) => sum + i.count, 0), n);
    const counts = new Map([['Lower limb', 2], ['Pelvis', 1], ['Skull', 1], ['Thorax', 2], ['Upper limb', 7], ['Vertebral column', 4]]);
    assert.deepEqual(regions.map((i) => i.count), order.map((r) => counts.get(r)));
    assert.ok(regions.every((i) => i.expanded === 'false'), 'the regions start collapsed (their rows are made on first expansion)');
    assert.equal(await page.locator('#region-tree [aria-level="3"]').count(), 0, 'nothing below the regions is made yet');
    assert.deepEqual(await page.locator('#region-tree [role="treeitem"][aria-level="2"]').first().getAttribute('aria-setsize'), '6');

    // Unchecking a region hides its parts; the root shows the mixed state; checking shows them.
    await item(page, 'Lower limb').locator(':scope > .node input').click();
    let s = await readState(page);
    assert.equal(s.instancesDrawn, full.instancesDrawn - 2);
    items = await treeItems(page);
    assert.equal(items.find((i) => i.name === 'Lower limb').checked, 'false');
    assert.equal(items[0].checked, 'mixed');
    assert.equal(await page.locator('#region-tree [data-key="g0"] > .node input').evaluate((b) => b.indeterminate), true);
    assert.equal(await page.locator('#part-list li.hidden-part').count(), 2);
    await item(page, 'Lower limb').locator(':scope > .node input').click();
    assert.equal((await readState(page)).instancesDrawn, full.instancesDrawn);
    assert.equal((await treeItems(page))[0].checked, 'true');

    // Expand the upper limb with a click on its arrow, for the screenshot.
    await item(page, 'Upper limb').locator(':scope > .node .twisty').click();
    await item(page, 'Left').first().locator(':scope > .node .twisty').click();
    mkdirSync(artifacts, { recursive: true });
    await settle(page);
    await page.screenshot({ path: path.join(artifacts, 'panel-tree.png') });

    // A Japanese name finds the left femur: the tree expands to it, the rest is filtered out.
    await page.locator('#search').fill('左大腿骨');
    items = await treeItems(page);
    assert.deepEqual(items.map((i) => i.name), ['Skeleton', 'Lower limb', 'Left', 'Left femur']);
    assert.deepEqual(items.slice(0, 3).map((i) => i.expanded), ['true', 'true', 'true']);
    assert.equal(await page.locator('#part-count').textContent(), `1 of ${n} match`);
    // A Latin name and a region's name match too.
    await page.locator('#search').fill('dext');
    assert.deepEqual((await treeItems(page)).filter((i) => i.count === null).map((i) => i.name), ['Right humerus', 'Right femur'], 'in the tree\'s order: upper limb before lower');
    await page.locator('#search').fill('thorax');
    assert.deepEqual((await treeItems(page)).filter((i) => i.count === null).map((i) => i.name), ['Left first rib', 'Left second rib']);
    await page.locator('#search').fill('');
    items = await treeItems(page);
    assert.ok(items.some((i) => i.name === 'Left femur'), 'the femur stays expanded to after the search');
    assert.ok(items.some((i) => i.name === 'Skull' && i.level === 2));

    // Colour by region: six legend entries; every part takes its region's colour, each region its own.
    await settle(page);
    const before = await shootCanvas(page, 'panel-colour-before');
    await page.locator('#color-by').selectOption('region');
    s = await readState(page);
    assert.equal(s.colorBy, 'region');
    assert.equal(s.partColors.length, 3 * n);
    const colorOf = (id) => s.partColors.slice(3 * id, 3 * id + 3).map((v) => Math.round(v * 255)).join(',');
    const regionOf = (part) => kNames.find((row) => row[0] === part.source.replace(/\.[a-z]+$/, ''))[4].split(' / ')[1];
    const byRegion = new Map();
    for (const part of site.m.parts) {
      const c = colorOf(part.id);
      const r = regionOf(part);
      if (byRegion.has(r)) assert.equal(byRegion.get(r), c, `${part.display_name} has ${r}'s colour`);
      byRegion.set(r, c);
    }
    assert.equal(new Set(byRegion.values()).size, 6, JSON.stringify([...byRegion]));
    const legend = page.locator('#legend li');
    assert.deepEqual(await legend.allTextContents(), kRegions);
    const swatches = await page.locator('#legend .swatch').evaluateAll((els) => els.map((e) => getComputedStyle(e).backgroundColor));
    assert.equal(new Set(swatches).size, 6);
    await settle(page);
    const after = await shootCanvas(page, 'panel-colour-after');
    const changed = await countDiffering(context, before.png, after.png, 12);
    await page.screenshot({ path: path.join(artifacts, 'panel-colour-by-region.png') });
    assert.ok(changed.differing > 2000, `colour by region changed ${changed.differing} pixels`);
    // By system: two classes; back to the parts' own colours.
    await page.locator('#color-by').selectOption('system');
    assert.deepEqual(await legend.allTextContents(), ['Appendicular skeleton', 'Axial skeleton']);
    await page.locator('#color-by').selectOption('part');
    assert.equal((await readState(page)).partColors, null);
    assert.equal(await page.locator('#legend').isHidden(), true);

    // The language menu: Japanese renames the tree, the list and the info box; the Latin name
    // shows under the name.
    const languages = await page.locator('#language option').evaluateAll((os) => os.map((o) => o.value));
    assert.deepEqual(languages, ['en', 'la', 'ja']);
    assert.equal(await page.evaluate(() => window.osteon.select('Left femur')), true);
    assert.equal(await page.locator('#info-name').textContent(), 'Left femur');
    assert.equal(await page.locator('#info-latin').textContent(), 'Femur sinistrum');
    assert.equal(await page.locator('#info-latin').isVisible(), true);
    await page.locator('#language').selectOption('ja');
    assert.equal((await readState(page)).language, 'ja');
    assert.ok((await treeItems(page)).some((i) => i.name === '左大腿骨'), 'the tree names the femur in Japanese');
    assert.equal(await page.locator('#part-list button[data-part]').filter({ hasText: '左大腿骨' }).count(), 1);
    assert.equal(await page.locator('#info-name').textContent(), '左大腿骨');
    assert.equal(await page.locator('#info-latin').textContent(), 'Femur sinistrum');
    await page.locator('#language').selectOption('la');
    assert.equal(await page.locator('#info-name').textContent(), 'Femur sinistrum');
    assert.equal(await page.locator('#info-latin').isHidden(), true);
    await page.locator('#language').selectOption('en');
    assert.equal(await page.locator('#announce').getAttribute('aria-live'), 'polite');
    assert.equal(await page.locator('#announce').textContent(), 'Left femur');

    // Opacity of a node: the upper limb at 40%; the x-ray: all but the selected bone see-through.
    await item(page, 'Upper limb').locator(':scope > .node .node-name').click();
    assert.equal((await readState(page)).selected, null, 'selecting a region leaves no bone selected');
    assert.equal(await page.locator('#node-opacity-name').textContent(), 'Upper limb');
    await page.locator('#node-opacity').fill('40');
    s = await readState(page);
    const upper = new Set(site.m.parts.filter((p) => regionOf(p) === 'Upper limb').map((p) => p.id));
    for (const part of site.m.parts) assert.ok(Math.abs(s.partOpacity[part.id] - (upper.has(part.id) ? 0.4 : 1)) < 1e-6, `${part.display_name}: ${s.partOpacity[part.id]}`);
    await page.locator('#node-opacity').fill('100');
    assert.equal((await readState(page)).partOpacity, null);
    await page.evaluate(() => window.osteon.select('Pelvis'));
    await settle(page);
    const opaque = await shootCanvas(page, 'panel-xray-before');
    await page.locator('#xray').check();
    await settle(page);
    const xray = await shootCanvas(page, 'panel-xray');
    const seeThrough = await countDiffering(context, opaque.png, xray.png, 12);
    assert.ok(seeThrough.differing > 2000, `the x-ray changed ${seeThrough.differing} pixels`);
    s = await readState(page);
    const pelvis = site.m.parts.find((p) => p.display_name === 'Pelvis').id;
    assert.equal(s.xray, true);
    for (const part of site.m.parts) assert.ok(Math.abs(s.partOpacity[part.id] - (part.id === pelvis ? 1 : 0.3)) < 1e-6);
    await page.locator('#xray').uncheck();
    assert.equal((await readState(page)).partOpacity, null);

    // The keyboard: Tab from the search reaches the tree; the arrows move and expand; H hides
    // the selected bone; Esc clears the selection.
    await page.evaluate(() => window.osteon.select(null));
    await page.locator('#search').focus();
    await page.keyboard.press('Tab');
    let f = await focused(page);
    assert.equal(f.role, 'treeitem', JSON.stringify(f));
    await page.keyboard.press('Home');
    assert.equal((await focused(page)).key, 'g0');
    // Down the tree to the pelvis (the regions in the names file's order).
    for (let k = 0; k < 40 && (await focused(page)).name !== 'Pelvis'; ++k) await page.keyboard.press('ArrowDown');
    assert.equal((await focused(page)).name, 'Pelvis');
    const pelvisGroup = (await focused(page)).key;
    const pelvisExpanded = () => page.locator(`#region-tree [data-key="${pelvisGroup}"]`).getAttribute('aria-expanded');
    assert.equal(await pelvisExpanded(), 'true', 'expanded when the pelvis was selected');
    await page.keyboard.press('ArrowLeft');
    assert.equal(await pelvisExpanded(), 'false');
    await page.keyboard.press('ArrowRight');
    assert.equal(await page.locator(`#region-tree [data-key="${pelvisGroup}"]`).getAttribute('aria-expanded'), 'true');
    await page.keyboard.press('ArrowRight');
    f = await focused(page);
    assert.equal(f.key[0], 'p');
    assert.equal((await readState(page)).selected, 'Pelvis', 'the bone reached is selected');
    await page.keyboard.press('h');
    s = await readState(page);
    assert.equal(s.instancesDrawn, full.instancesDrawn - 1);
    assert.equal(await page.locator(`#region-tree [data-key="${f.key}"]`).getAttribute('aria-checked'), 'false');
    await page.keyboard.press('Space');
    assert.equal((await readState(page)).instancesDrawn, full.instancesDrawn, 'Space shows it again');
    await page.keyboard.press('ArrowLeft');
    assert.equal((await focused(page)).key, pelvisGroup);
    await page.keyboard.press('ArrowLeft');
    assert.equal(await page.locator(`#region-tree [data-key="${pelvisGroup}"]`).getAttribute('aria-expanded'), 'false');
    await page.keyboard.press('Escape');
    assert.equal((await readState(page)).selected, null);
    // The next region, Lower limb, expanded by the search: ArrowLeft collapses it; a region
    // reached with the arrows: H hides it all, Space shows it again.
    await page.keyboard.press('ArrowDown');
    f = await focused(page);
    assert.equal(f.name, 'Lower limb');
    assert.equal(await page.locator(`#region-tree [data-key="${f.key}"]`).getAttribute('aria-expanded'), 'true');
    await page.keyboard.press('ArrowLeft');
    assert.equal(await page.locator(`#region-tree [data-key="${f.key}"]`).getAttribute('aria-expanded'), 'false');
    await page.keyboard.press('h');
    assert.equal((await readState(page)).instancesDrawn, full.instancesDrawn - 2);
    await page.keyboard.press('Space');
    assert.equal((await readState(page)).instancesDrawn, full.instancesDrawn);

    // On the canvas: the arrows orbit, + zooms in, F fits, I isolates the selection.
    await page.locator('#canvas').focus();
    const cam0 = await page.evaluate(() => window.osteon.cameraState());
    await page.keyboard.press('ArrowLeft');
    await settle(page);
    const cam1 = await page.evaluate(() => window.osteon.cameraState());
    const distance = (c) => Math.hypot(...c.position.map((v, i) => v - c.target[i]));
    assert.ok(Math.hypot(...cam1.position.map((v, i) => v - cam0.position[i])) > 0.1 * distance(cam0), 'ArrowLeft orbits');
    assert.ok(Math.abs(distance(cam1) - distance(cam0)) < 1e-3 * distance(cam0), 'an orbit keeps the distance');
    await page.keyboard.press('+');
    await settle(page);
    assert.ok(distance(await page.evaluate(() => window.osteon.cameraState())) < 0.95 * distance(cam1), '+ zooms in');
    await page.evaluate(() => window.osteon.select('Left femur'));
    await page.locator('#canvas').focus();
    await page.keyboard.press('i');
    assert.equal((await readState(page)).instancesDrawn, 1);
    await page.keyboard.press('Escape');
    assert.equal((await readState(page)).selected, null);
    await page.locator('#show-all').click();

    // Markup in a name is text.
    const seen = await page.evaluate(() => {
      const root = document.querySelector('osteon-viewer').shadowRoot;
      return { images: root.querySelectorAll('img').length + document.querySelectorAll('img').length, text: root.textContent };
    });
    assert.equal(seen.images, 0);
    assert.ok(seen.text.includes(`Left little finger ${kEvil}`));
    assert.deepEqual(dialogs, []);

    // Every control has a name.
    const unnamed = await page.evaluate(() => {
      const root = document.querySelector('osteon-viewer').shadowRoot;
      const controls = '#search, #region-tree [role="treeitem"], #node-opacity, #language, #color-by, #xray, #canvas, #part-list input, #part-list button';
      return [...root.querySelectorAll(controls)].filter((el) => {
        if (el.getAttribute('aria-hidden') === 'true' || el.closest('[hidden]')) return false;
        const labelled = el.getAttribute('aria-label') || el.getAttribute('aria-labelledby') || el.labels?.length || el.closest('label') || el.textContent.trim() || el.title;
        return !labelled;
      }).map((el) => el.id || el.outerHTML.slice(0, 80));
    });
    assert.deepEqual(unnamed, []);
    assert.deepEqual(problems, []);
    await context.close();
  });

  test(`${kManyGroups} groups: the tree makes its rows a batch at a time, and a search finds the last`, async () => {
    const context = await site.browser.newContext(kDesktop);
    await observeLongTasks(context);
    const { page, problems } = await openViewer(context, `${site.server.url}many/`);
    const full = await waitLoaded(page);
    assert.deepEqual(full.errors, []);
    await page.locator('#region-tree [role="treeitem"]').first().waitFor();
    const rows = () => page.locator('#region-tree [role="treeitem"]').count();
    // The root, its first batch of 200 regions, and a "more" item.
    assert.equal(await rows(), 1 + 200 + 1);
    assert.equal(await page.locator('#region-tree [aria-level="2"]').first().getAttribute('aria-setsize'), String(kManyGroups));
    const more = page.locator('#region-tree li.more');
    assert.equal(await more.textContent(), `${kManyGroups - 200} more…`);
    await more.click();
    assert.equal(await rows(), 1 + 400 + 1);
    const last = `Region ${String(kManyGroups - 1).padStart(5, '0')}`;
    await page.locator('#search').fill(last);
    assert.deepEqual((await treeItems(page)).map((i) => i.name), ['Skeleton', last]);
    await page.locator('#search').fill('');
    assert.equal(await rows(), 1 + 400 + 1);
    const longest = await page.evaluate(() => Math.max(0, ...window.__longTasks.map(([, d]) => d)));
    console.log(`${kManyGroups} groups: the longest task took ${longest.toFixed(0)} ms`);
    assert.deepEqual(problems, []);
    await context.close();
  });
});
