// SPDX-License-Identifier: Apache-2.0
// The viewer's panel (index.html's markup, in the element's shadow root): the error box, the
// progress bar and status line, the statistics, the selected bone's info, the list of bones with
// its search and checkboxes, the region tree (region_tree.mjs) and the opacity of its nodes, the
// language menu, "Colour by" and its legend, the x-ray, the groups, the clipping plane, "Copy
// link", and the buttons. Every function takes the viewer's state (state.mjs); wirePanel
// attaches the listeners once. Every name from the package is set as text, never as markup.

import { baseLanguage, groupPath, langAttribute, languageLabel, partGroupText, partName } from './language.mjs';
import { drawInfo, drawStats, findPart, formatLength } from './manifest.mjs';
import { colorBy } from './palette.mjs';
import { buildTree, compareNames, filterTree, nodeName, partsUnder, prepareNames, renameTree, revealNode, updateTreeChecks } from './region_tree.mjs';
import { emit, partVisible, viewChanged } from './state.mjs';
import { whenIdle } from './stream.mjs';
import { fitAll, framePart, requestRender, send, sendParts } from './view.mjs';

/// The element `id` of this viewer's markup (its shadow root: several viewers share a page).
export const $ = (state, id) => state.root.getElementById(id);

// ---------------------------------------------------------------------------------------------
// Status, errors, statistics

/// Lists an 'osteon: ...' message in the error box and in window.osteon.errors.
/// The box lists the first kErrorsListed and counts the rest: a package whose every component
/// fails (tens of thousands, say) would otherwise cost a list row each, all at once.
const kErrorsListed = 100;

export function reportError(state, message) {
  const { errors } = state.report;
  errors.push(message);
  const list = $(state, 'error-list');
  if (errors.length <= kErrorsListed) {
    const li = document.createElement('li');
    li.textContent = message;  // text, never markup: messages quote names from the package
    list.append(li);
  } else {
    if (errors.length === kErrorsListed + 1) list.append(document.createElement('li'));
    list.lastElementChild.textContent = `and ${errors.length - kErrorsListed} more (the report lists them all)`;
  }
  $(state, 'errors').hidden = false;
}

function megabytes(bytes) {
  return `${(bytes / 1e6).toFixed(bytes < 1e7 ? 2 : 1)} MB`;
}

// The status line and the statistics are rewritten at most every kStatusMs while loading, however
// many components arrive: every change on the page is a new frame for the browser's compositor,
// which (with a software GPU, headless) reads the whole window back each time, on the same GPU
// thread that creates the renderer's context and compiles its shaders. Changing the text at every
// animation frame kept that thread busy and delayed the first bones by hundreds of milliseconds.
const kStatusMs = 500;

export function scheduleStatus(state) {
  if (state.statusTimer !== null) return;
  state.statusTimer = setTimeout(() => {
    state.statusTimer = null;
    state.statusAt = performance.now();
    updateStatus(state);
  }, Math.max(0, state.statusAt + kStatusMs - performance.now()));
}

/// Rewrites the progress bar, the status line and the statistics now.
export function updateStatus(state) {
  const r = state.report;
  const settledCount = r.componentsLoaded + r.componentsFailed;
  $(state, 'progress').max = Math.max(1, r.componentsTotal);
  $(state, 'progress').value = settledCount;
  const failed = r.componentsFailed ? `, ${r.componentsFailed} failed` : '';
  if (r.done) {
    const seconds = ((r.allLoadedMs ?? performance.now()) / 1000).toFixed(2);
    const levels = state.levels?.hasLevels ? ` · ${r.levelsLoaded} of ${r.levelsTotal} levels` : '';
    $(state, 'progress-text').textContent =
      `${r.componentsLoaded} of ${r.componentsTotal} components${failed}${levels} · ${megabytes(r.bytesLoaded)} · ${seconds} s`;
    $(state, 'status').classList.add('done');
  } else {
    $(state, 'progress-text').textContent =
      `${settledCount} / ${r.componentsTotal} components${failed} · ${megabytes(r.bytesLoaded)} / ${megabytes(r.bytesTotal)}`;
  }
  $(state, 'stats').textContent =
    `${formatCount(r.instancesDrawn)} of ${formatCount(r.instancesTotal)} instances · ` +
    `${formatCount(r.trianglesDrawn)} triangles · ${r.drawCalls} draw calls` +
    (state.levels?.hasLevels ? ` · ${megabytes(r.gpuBytes)} of ${megabytes(r.budget.bytes)} GPU memory` : '');
}

/// A count with its thousands grouped as English writes them ("16,650,000"), without Intl: the
/// first toLocaleString() of a page loads the locale's number data, tens of milliseconds of the
/// first status line on a slow phone.
export function formatCount(n) {
  return String(n).replace(/\B(?=(\d{3})+(?!\d))/g, ',');
}

/// The level the renderer shows of component `id` (0, the first, until it says otherwise).
const levelOf = (state) => (id) => state.report.levelDrawn?.[id] ?? 0;

/// The counts in window.osteon, from the manifest and what is on screen (synchronous: a test
/// reads them right after a click).
export function updateStats(state) {
  if (!state.manifest) return;
  const s = drawStats(state.manifest, state.loaded, (id) => partVisible(state, id), levelOf(state));
  state.report.instancesDrawn = s.instances;
  state.report.trianglesDrawn = s.triangles;
  state.report.drawCalls = s.drawCalls;
  scheduleStatus(state);
}

// ---------------------------------------------------------------------------------------------
// Selection, visibility, lists

/// Shows what hiddenParts and groupOn say: the list's checkboxes, the renderer's parts, the counts.
export function applyVisibility(state) {
  for (const row of state.partRows) {
    const visible = partVisible(state, row.part.id);
    row.checkbox.checked = visible;
    row.li.classList.toggle('hidden-part', !visible);
  }
  for (const [group, on] of state.groupOn) {
    const box = state.groupBoxes.get(group);
    if (box) box.checked = on;
  }
  updateTreeChecks(state);
  sendParts(state);
  updateStats(state);
  viewChanged(state);
}

/// Hides part `id`.
export function hidePart(state, id) {
  state.hiddenParts.add(id);
  applyVisibility(state);
}

/// Shows part `id` (and its group, if that was switched off).
export function showPart(state, id) {
  state.hiddenParts.delete(id);
  state.groupOn.set(state.manifest.parts[id].group, true);
  applyVisibility(state);
}

/// Shows part `id` alone.
export function isolatePart(state, id) {
  const { manifest, hiddenParts } = state;
  for (const part of manifest.parts) if (part.id !== id) hiddenParts.add(part.id);
  hiddenParts.delete(id);
  state.groupOn.set(manifest.parts[id].group, true);
  applyVisibility(state);
}

/// Shows every part and every group.
export function showAllParts(state) {
  state.hiddenParts.clear();
  for (const group of state.groupOn.keys()) state.groupOn.set(group, true);
  applyVisibility(state);
}

function drawnAs(state, part) {
  const { manifest } = state;
  const info = drawInfo(manifest, part.id, state.loaded, levelOf(state));
  const words = [];
  if (part.prototype !== part.id) {
    const mirrored = info.some((i) => i.mirror);
    words.push(`an instance of ${manifest.parts[part.prototype].displayName}${mirrored ? ', mirrored' : ''}`);
  } else {
    const copies = manifest.parts.filter((p) => p.prototype === part.id && p.id !== part.id).length;
    words.push(copies ? `its own mesh, repeated by ${copies} other part${copies > 1 ? 's' : ''}` : 'its own mesh');
  }
  const instanced = info.filter((i) => i.instanced);
  if (instanced.length) {
    const batch = Math.max(...instanced.map((i) => i.batchSize));
    words.push(`GPU-instanced${batch ? ` (${batch} in one draw call)` : ''}`);
  }
  words.push(`${info.length} component${info.length > 1 ? 's' : ''}${info.every((i) => i.loaded) ? '' : `, ${info.filter((i) => !i.loaded).length} not loaded`}`);
  return { text: words.join(' · '), instance: part.prototype !== part.id, gpuInstanced: instanced.length > 0, info };
}

/// The level a part is drawn at, for people: "level 2 of 4, error 0.31 mm" (levels counted from
/// the coarsest; the error is the drawn level's measured distance from full resolution), a range
/// when its components differ, "not loaded" before its first level is drawn.
function levelText(state, info) {
  const { manifest } = state;
  const drawn = info.filter((i) => i.loaded);
  if (!drawn.length) return { text: 'not loaded', level: null };
  const levels = drawn.map((i) => manifest.componentById.get(i.component).levels);
  const numbers = drawn.map((i) => i.level + 1);
  const counts = levels.map((l) => l.length);
  const error = Math.max(...drawn.map((i, k) => levels[k][i.level].error));
  const lo = Math.min(...numbers);
  const hi = Math.max(...numbers);
  const of = Math.max(...counts);
  const full = drawn.every((i, k) => i.level === counts[k] - 1);
  const which = lo === hi && counts.every((n) => n === of) ? `level ${lo} of ${of}` : `levels ${lo}–${hi} of up to ${of}`;
  const missing = drawn.length < info.length ? `, ${info.length - drawn.length} not loaded` : '';
  return {
    text: `${which}${full ? ' (full resolution)' : ''}, error ${drawn.length > 1 ? 'up to ' : ''}${formatLength(error, manifest.unit)}${missing}`,
    level: hi,
  };
}

/// Fills the info section for the selected part (or says none is).
export function showInfo(state) {
  const { manifest, selectedPart } = state;
  const part = selectedPart >= 0 ? manifest.parts[selectedPart] : null;
  state.report.selected = part ? part.displayName : null;
  const name = part ? partName(manifest, part, state.language) : 'No bone selected';
  $(state, 'info-name').textContent = name;
  $(state, 'info-name').lang = part ? langAttribute(state.language) : 'en';
  // The Latin name, in smaller type under the name, when the panel shows another language.
  const latin = !part ? '' : baseLanguage(manifest) === 'la' ? part.displayName : part.names.la ?? '';
  $(state, 'info-latin').textContent = latin;
  $(state, 'info-latin').hidden = !latin || state.language === 'la' || latin === name;
  $(state, 'info-hint').hidden = !!part;
  $(state, 'info-fields').hidden = !part;
  for (const id of ['frame', 'hide', 'isolate']) $(state, id).disabled = !part;
  for (const row of state.partRows) row.button.setAttribute('aria-current', String(row.part.id === selectedPart));
  if (!part) return;
  const bound = Math.max(...manifest.instancesOfPart[part.id].map((i) => manifest.instances[i].errorBound));
  const drawn = drawnAs(state, part);
  $(state, 'info-group').textContent = partGroupText(manifest, part, state.language) || '(none)';
  $(state, 'info-triangles').textContent = formatCount(part.triangles);
  $(state, 'info-error').textContent = Number.isFinite(bound) ? formatLength(bound, manifest.unit) : '–';
  $(state, 'info-drawn').textContent = drawn.text;
  const level = levelText(state, drawn.info);
  $(state, 'info-level').textContent = level.text;
  $(state, 'info').dataset.level = level.level === null ? '' : String(level.level);
  $(state, 'info').dataset.instance = String(drawn.instance);
  $(state, 'info').dataset.gpuInstanced = String(drawn.gpuInstanced);
  $(state, 'info-source').textContent = part.source || part.name;
}

/// Selects part `partId` (-1: none): highlighted, its info shown, framed if `frame`, its row
/// scrolled into view if `scroll`.
export function select(state, partId, { frame = false, scroll = true, reveal = true } = {}) {
  const changed = state.selectedPart !== partId;
  state.selectedPart = partId;
  if (state.xray) updateOpacity(state);
  sendParts(state);
  showInfo(state);
  if (reveal && state.tree) {
    revealNode(state, partId >= 0 ? `p${partId}` : null, { scroll });
    showNodeOpacity(state);
  }
  if (changed) {
    const part = partId >= 0 ? state.manifest.parts[partId] : null;
    $(state, 'announce').textContent = part ? partName(state.manifest, part, state.language) : 'No bone selected';
    emit(state, 'select', part
      ? { name: part.displayName, partName: part.name, part: part.id, group: part.group, source: part.source || null, triangles: part.triangles }
      : { name: null, partName: null, part: -1, group: null, source: null, triangles: 0 });
    viewChanged(state);
  }
  if (partId >= 0) {
    if (frame) framePart(state, partId);
    const row = state.partRows.find((r) => r.part.id === partId);
    if (scroll && row && row.li.offsetParent) row.li.scrollIntoView({ block: 'nearest' });
  }
}

/// select() by display name, name or source file; false for an unknown name.
export function selectByName(state, name, options) {
  const part = state.manifest && findPart(state.manifest, name);
  if (!part) return false;
  select(state, part.id, options);
  return true;
}

function buildLists(state) {
  const { manifest, partRows } = state;
  const list = $(state, 'part-list');
  // One collator for the whole sort: localeCompare with options makes one per comparison.
  const sorted = [...manifest.parts].sort((a, b) => compareNames(a.displayName, b.displayName));
  const tree = buildTree(state, $(state, 'region-tree'), {
    partVisible: (id) => partVisible(state, id),
    toggle: (key) => toggleNode(state, key),
    select: (key) => selectNode(state, key),
  });
  if (tree) {
    $(state, 'tree-box').hidden = false;
    $(state, 'part-list-box').open = false;  // the tree lists them all; the flat list stays a click away
  }
  // One listener each for the whole list instead of two per bone.
  list.addEventListener('change', (e) => {
    const id = Number(e.target.dataset.part);
    if (!(id >= 0)) return;
    if (e.target.checked) {
      state.hiddenParts.delete(id);
      state.groupOn.set(manifest.parts[id].group, true);
    } else {
      state.hiddenParts.add(id);
    }
    applyVisibility(state);
  });
  list.addEventListener('click', (e) => {
    const button = e.target.closest('button[data-part]');
    if (button) select(state, Number(button.dataset.part), { frame: true, scroll: false });
  });
  // The rows go in a few at a time, a task each: on a slow phone, laying out a few hundred rows
  // at once was the load's longest task. Each row takes the state (shown, selected, language)
  // of when it is made; what changes later reaches the rows made so far.
  let next = 0;
  const addRows = () => {
    const rows = document.createDocumentFragment();
    for (const end = Math.min(sorted.length, next + kRowsPerTask); next < end; ++next) {
      const part = sorted[next];
      const li = document.createElement('li');
      const checkbox = document.createElement('input');
      checkbox.type = 'checkbox';
      checkbox.checked = partVisible(state, part.id);
      checkbox.dataset.part = String(part.id);
      const button = document.createElement('button');
      button.type = 'button';
      button.title = part.name;
      button.dataset.part = String(part.id);
      if (state.selectedPart >= 0) button.setAttribute('aria-current', String(part.id === state.selectedPart));
      li.append(checkbox, button);
      li.classList.toggle('hidden-part', !partVisible(state, part.id));
      rows.append(li);
      const row = { part, li, checkbox, button };
      nameRow(state, row);
      partRows.push(row);
    }
    list.append(rows);
    // A search typed meanwhile reaches the new rows; the count waits for the whole list.
    if (next < sorted.length) {
      if ($(state, 'search').value.trim()) filterList(state);
      idle(addRows);
      return;
    }
    filterList(state);
    state.report.listsBuilt = true;
  };
  addRows();
  showInfo(state);
  if (tree && state.selectedPart >= 0) revealNode(state, `p${state.selectedPart}`);
  showNodeOpacity(state);
}

/// Names part row `row` (in the part list) in the panel's language.
function nameRow(state, row) {
  const name = partName(state.manifest, row.part, state.language);
  row.button.textContent = name;
  row.button.lang = langAttribute(state.language);
  row.checkbox.setAttribute('aria-label', `Show ${name}`);
}

// The list of bones (235 rows for BodyParts3D) is built once loading has ended, or kListsAfterMs
// after the manifest, when the browser is idle: painting it takes the GPU process (which, with a
// software GPU, rasterizes the page's text too) from the renderer's frames, and held them off the
// screen by a third of a second when it was built at the first frame.
export const kListsAfterMs = 3000;

/// Rows of the bone list added a task.
const kRowsPerTask = 40;

export function buildListsSoon(state) {
  if (state.listsStarted || !state.manifest) return;
  state.listsStarted = true;
  // The names' collator first, in a task of its own: with the lists' rows, one task on a slow
  // phone would be a long one.
  idle(() => {
    prepareNames();
    idle(() => buildLists(state));
  });
}

/// Runs `f` when the browser is idle, or within half a second.
const idle = (f) => whenIdle(f, 500);

/// The group checkboxes, all on, once the manifest is read.
export function buildGroups(state) {
  const { manifest, groupOn } = state;
  buildLanguages(state);
  // The region tree (built with the lists) has these groups' check boxes, nested.
  $(state, 'groups-section').hidden = manifest.groups.length > 0;
  const groups = $(state, 'group-list');
  const counts = new Map();
  for (const part of manifest.parts) counts.set(part.group, (counts.get(part.group) ?? 0) + 1);
  for (const group of [...manifest.groupLabels].sort()) {
    groupOn.set(group, true);
    // With a region tree, its check boxes stand for these.
    if (manifest.groups.length) continue;
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = true;
    box.dataset.group = group;
    box.addEventListener('change', () => {
      groupOn.set(group, box.checked);
      applyVisibility(state);
    });
    label.append(box, ` ${group || '(no group)'} (${counts.get(group)})`);
    groups.append(label);
    state.groupBoxes.set(group, box);
  }
}

/// The most matches of a search the region tree expands to (the count says how many there are).
const kTreeMatches = 500;

/// What a search looks in, lower case: per part its names in every language, its name and its
/// groups' names in every language; per group its names.
function searchIndex(state) {
  if (!state.searchIndex) {
    const { manifest } = state;
    const groups = manifest.groups.map((g) => [g.name, ...Object.values(g.names)].join('\n').toLowerCase());
    const parts = manifest.parts.map((p) => {
      const words = [p.displayName, p.name, ...Object.values(p.names), p.group];
      if (p.path >= 0) for (const g of groupPath(manifest, p.path)) words.push(groups[g]);
      return words.join('\n').toLowerCase();
    });
    state.searchIndex = { parts, groups };
  }
  return state.searchIndex;
}

function filterList(state) {
  const { partRows } = state;
  const q = $(state, 'search').value.trim().toLowerCase();
  const index = searchIndex(state);
  let shown = 0;
  for (const row of partRows) {
    const match = !q || index.parts[row.part.id].includes(q);
    row.li.hidden = !match;
    shown += match;
  }
  $(state, 'part-count').textContent = q ? `${shown} of ${partRows.length} match` : `${partRows.length} bones`;
  if (state.tree && q !== state.tree.query) {
    state.tree.query = q;
    if (!q) {
      filterTree(state, null);
    } else {
      const parts = partRows.filter((r) => !r.li.hidden).slice(0, kTreeMatches).map((r) => r.part.id);
      const groups = [];
      for (let g = 0; g < index.groups.length && groups.length < kTreeMatches; ++g) if (index.groups[g].includes(q)) groups.push(g);
      filterTree(state, parts, groups);
    }
  }
  return partRows.filter((r) => !r.li.hidden);
}

// ---------------------------------------------------------------------------------------------
// The region tree's nodes, the language, colours and opacity

/// A tree node's check box (or Enter, Space): hides every part under it when all are shown,
/// else shows them all (and their groups).
export function toggleNode(state, key) {
  const ids = partsUnder(state, key);
  if (ids.every((id) => partVisible(state, id))) {
    for (const id of ids) state.hiddenParts.add(id);
  } else {
    for (const id of ids) {
      state.hiddenParts.delete(id);
      state.groupOn.set(state.manifest.parts[id].group, true);
    }
  }
  applyVisibility(state);
}

/// Hides every part under tree node `key`.
export function hideNode(state, key) {
  for (const id of partsUnder(state, key)) state.hiddenParts.add(id);
  applyVisibility(state);
}

/// Shows the parts under tree node `key` alone.
export function isolateNode(state, key) {
  const { manifest, hiddenParts } = state;
  const keep = new Set(partsUnder(state, key));
  for (const part of manifest.parts) {
    if (keep.has(part.id)) {
      hiddenParts.delete(part.id);
      state.groupOn.set(part.group, true);
    } else {
      hiddenParts.add(part.id);
    }
  }
  applyVisibility(state);
}

/// A tree node clicked, or reached with the arrow keys: a bone is selected; a group becomes the
/// tree's selection (what the opacity slider sets), and no bone is.
export function selectNode(state, key) {
  if (key[0] === 'p') {
    select(state, Number(key.slice(1)), { scroll: false });
  } else {
    select(state, -1, { reveal: false });
    revealNode(state, key, { scroll: false });
    showNodeOpacity(state);
  }
}

/// The language menu: the manifest's languages (hidden when it has fewer than two).
function buildLanguages(state) {
  const { manifest } = state;
  state.language = baseLanguage(manifest);
  state.report.language = state.language;
  const menu = $(state, 'language');
  menu.replaceChildren(...manifest.languages.map((tag) => {
    const option = document.createElement('option');
    option.value = tag;
    option.textContent = languageLabel(tag);
    return option;
  }));
  menu.value = state.language;
  $(state, 'language-label').hidden = manifest.languages.length < 2;
}

/// Names the bones and regions in language `tag` (one of manifest.languages) everywhere in the
/// panel: the tree, the list, the info box, the legend.
export function setLanguage(state, tag) {
  const { manifest } = state;
  if (!manifest || !(manifest.languages.includes(tag) || tag === baseLanguage(manifest))) return false;
  state.language = tag;
  state.report.language = tag;
  $(state, 'language').value = tag;
  for (const row of state.partRows) nameRow(state, row);
  renameTree(state);
  showInfo(state);
  drawLegend(state);
  showNodeOpacity(state);
  return true;
}

/// Colours the parts by `mode`: 'part' (each its own colour, the manifest's), 'region' or
/// 'system' (palette.mjs), and shows the legend.
export function setColorBy(state, mode) {
  const { manifest } = state;
  if (!manifest) return;
  const by = colorBy(manifest, mode);
  state.colorBy = by ? mode : 'part';
  $(state, 'color-by').value = state.colorBy;
  state.partColors = by?.colors ?? null;
  state.legend = by?.legend ?? null;
  state.report.colorBy = state.colorBy;
  state.report.partColors = state.partColors && [...state.partColors];
  drawLegend(state);
  sendParts(state);
}

function drawLegend(state) {
  const legend = $(state, 'legend');
  const entries = state.legend ?? [];
  legend.replaceChildren(...entries.map((entry) => {
    const li = document.createElement('li');
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = `rgb(${entry.color.join(' ')})`;
    swatch.setAttribute('aria-hidden', 'true');
    const label = document.createElement('span');
    label.textContent = entry.label(state.language);
    label.lang = langAttribute(state.language);
    li.append(swatch, label);
    return li;
  }));
  legend.hidden = !entries.length;
}

/// How see-through the x-ray draws every bone but the selected one.
export const kXrayOpacity = 0.3;

/// state.partOpacity from the opacities chosen per node, with the x-ray's on top.
function updateOpacity(state) {
  const n = state.manifest.parts.length;
  const chosen = state.chosenOpacity;
  let opacity = chosen ? chosen.slice() : null;
  if (state.xray) {
    opacity ??= new Float32Array(n).fill(1);
    for (let i = 0; i < n; ++i) if (i !== state.selectedPart) opacity[i] = Math.min(opacity[i], kXrayOpacity);
  }
  state.partOpacity = opacity;
  state.report.partOpacity = opacity && [...opacity];
}

/// The parts the opacity slider sets: those under the tree's selected node, else every part.
function opacityParts(state) {
  const key = state.tree?.selectedKey;
  return key ? partsUnder(state, key) : state.manifest.parts.map((p) => p.id);
}

/// Sets the opacity (0..1) of the parts under the tree's selected node (every part when none is).
export function setNodeOpacity(state, value) {
  const { manifest } = state;
  if (!manifest) return;
  const opacity = state.chosenOpacity ?? new Float32Array(manifest.parts.length).fill(1);
  for (const id of opacityParts(state)) opacity[id] = Math.min(1, Math.max(0, value));
  state.chosenOpacity = opacity.every((v) => v === 1) ? null : opacity;
  updateOpacity(state);
  showNodeOpacity(state);
  sendParts(state);
}

/// The opacity slider shows the selected node's name and its parts' (mean) opacity.
function showNodeOpacity(state) {
  if (!state.manifest) return;
  const key = state.tree?.selectedKey;
  const ids = opacityParts(state);
  const chosen = state.chosenOpacity;
  const mean = chosen && ids.length ? ids.reduce((sum, id) => sum + chosen[id], 0) / ids.length : 1;
  $(state, 'node-opacity-name').textContent = key ? nodeName(state, key) : 'every bone';
  $(state, 'node-opacity-name').lang = key ? langAttribute(state.language) : 'en';
  $(state, 'node-opacity').value = String(Math.round(mean * 100));
  $(state, 'node-opacity-value').textContent = `${Math.round(mean * 100)}%`;
}

/// The x-ray: every bone but the selected one drawn at kXrayOpacity, picks through them.
export function setXray(state, on) {
  state.xray = on;
  state.xrayPick = on;
  state.report.xray = on;
  $(state, 'xray').checked = on;
  if (!state.manifest) return;
  updateOpacity(state);
  sendParts(state);
}

// ---------------------------------------------------------------------------------------------
// Clipping plane

/// The plane of one axis, position and flip control set (`prefix` 'clip' or 'clip2'): across the
/// package's box at the slider's fraction of it, keeping the side above (below, flipped). Shows
/// its position beside the slider.
function axisPlane(state, prefix, positionId) {
  const { manifest } = state;
  const axis = Number($(state, `${prefix}-axis`).value);
  const t = Number($(state, positionId).value) / 1000;
  const lo = manifest.bounds.min[axis];
  const hi = manifest.bounds.max[axis];
  const at = lo + t * (hi - lo);
  const sign = $(state, `${prefix}-flip`).checked ? -1 : 1;
  // Three.js draws the side where normal . p + constant >= 0: keep p[axis] >= at, or <= at.
  const normal = [0, 0, 0];
  normal[axis] = sign;
  $(state, `${prefix}-value`).textContent = `${'XYZ'[axis]} = ${formatLength(at, manifest.unit)}`;
  return { normal, constant: -sign * at };
}

/// Sends the cut the controls describe to the renderer: the clipping plane, the second plane
/// where it is on (what either cuts away is removed), and whether the sections are filled.
export function updateClip(state) {
  if (!state.manifest) return;
  const on = $(state, 'clip-on').checked;
  const first = axisPlane(state, 'clip', 'clip-pos');
  const planes = [first];
  if ($(state, 'clip2-on').checked) planes.push(axisPlane(state, 'clip2', 'clip2-at'));
  const cap = $(state, 'clip-cap').checked;
  state.clip = { on, normal: first.normal, constant: first.constant, cap, planes };
  send(state, { type: 'clip', ...state.clip });
  requestRender(state);
  viewChanged(state);
}

/// The clipping plane's controls as a value: { on, axis (0..2), position (the slider's 0..1000
/// along the package's box), flip, cap (the sections filled), second: the second plane's { on,
/// axis, position, flip } }.
export function clipControls(state) {
  return {
    on: $(state, 'clip-on').checked,
    axis: Number($(state, 'clip-axis').value),
    position: Number($(state, 'clip-pos').value),
    flip: $(state, 'clip-flip').checked,
    cap: $(state, 'clip-cap').checked,
    second: {
      on: $(state, 'clip2-on').checked,
      axis: Number($(state, 'clip2-axis').value),
      position: Number($(state, 'clip2-at').value),
      flip: $(state, 'clip2-flip').checked,
    },
  };
}

/// Sets the clipping plane's controls (clipControls' value; cap and second optional, kept when
/// absent) and sends the planes.
export function setClipControls(state, { on, axis, position, flip, cap, second }) {
  $(state, 'clip-on').checked = on;
  $(state, 'clip-axis').value = String(axis);
  $(state, 'clip-pos').value = String(position);
  $(state, 'clip-flip').checked = flip;
  if (cap !== undefined) $(state, 'clip-cap').checked = cap;
  if (second) {
    $(state, 'clip2-on').checked = second.on;
    $(state, 'clip2-axis').value = String(second.axis);
    $(state, 'clip2-at').value = String(second.position);
    $(state, 'clip2-flip').checked = second.flip;
  }
  updateClip(state);
}

/// Puts the view's link in the share field and on the clipboard; where the clipboard refuses
/// (no permission, not a secure page), the field's text is selected for the person to copy.
export async function copyLink(state) {
  const field = $(state, 'share-link');
  const link = state.shareLink();
  field.value = link;
  field.hidden = false;
  try {
    await navigator.clipboard.writeText(link);
    $(state, 'share-note').textContent = 'Link copied';
  } catch (e) {
    field.focus();
    field.select();
    $(state, 'share-note').textContent = 'Press Ctrl+C (⌘C) to copy the link';
  }
}

// ---------------------------------------------------------------------------------------------
// The buttons and fields

/// Attaches the panel's listeners (once, before the manifest is read: each waits for it).
export function wirePanel(state) {
  $(state, 'fit').addEventListener('click', () => fitAll(state));
  $(state, 'panel-toggle').addEventListener('click', () => {
    const collapsed = $(state, 'panel').classList.toggle('collapsed');
    $(state, 'panel-toggle').setAttribute('aria-expanded', String(!collapsed));
  });
  $(state, 'frame').addEventListener('click', () => state.selectedPart >= 0 && framePart(state, state.selectedPart));
  $(state, 'hide').addEventListener('click', () => state.selectedPart >= 0 && hidePart(state, state.selectedPart));
  $(state, 'isolate').addEventListener('click', () => state.selectedPart >= 0 && isolatePart(state, state.selectedPart));
  $(state, 'show-all').addEventListener('click', () => state.manifest && showAllParts(state));
  $(state, 'copy-link').addEventListener('click', () => state.manifest && copyLink(state));
  $(state, 'search').addEventListener('input', () => state.manifest && filterList(state));
  $(state, 'language').addEventListener('change', (e) => setLanguage(state, e.target.value));
  $(state, 'color-by').addEventListener('change', (e) => setColorBy(state, e.target.value));
  $(state, 'node-opacity').addEventListener('input', (e) => setNodeOpacity(state, Number(e.target.value) / 100));
  $(state, 'xray').addEventListener('change', (e) => setXray(state, e.target.checked));
  $(state, 'search').addEventListener('keydown', (e) => {
    if (e.key !== 'Enter' || !state.manifest) return;
    const first = filterList(state)[0];
    if (first) select(state, first.part.id, { frame: true });
  });
  for (const id of ['clip-on', 'clip-axis', 'clip-flip', 'clip-cap', 'clip2-on', 'clip2-axis', 'clip2-flip']) {
    $(state, id).addEventListener('change', () => updateClip(state));
  }
  for (const id of ['clip-pos', 'clip2-at']) $(state, id).addEventListener('input', () => updateClip(state));
}
