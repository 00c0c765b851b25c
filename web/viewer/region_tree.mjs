// SPDX-License-Identifier: Apache-2.0
// The panel's region tree (#region-tree): the manifest's groups (docs/FORMAT.md, "Groups and
// languages": region, then side, ...) with the parts as leaves, each node with the count of parts
// under it and a check box that shows or hides them all (indeterminate while some are shown).
// It follows the WAI-ARIA tree pattern: one item in the tab order (roving tabindex), the arrow
// keys move and expand or collapse, Home and End jump, Enter and Space toggle the check box.
//
// A package may hold 65,536 groups, so the tree is built lazily: a node's children are made on
// its first expansion, kBatch at a time (a "more" item makes the next), and the model is a few
// flat arrays. The tree only shows what the panel's state says; what a check box or a selection
// does is the panel's (the handlers given to buildTree), so visibility stays in state.hiddenParts.
// Names are set as text, never as markup: they come from the package.

import { groupName, langAttribute, partName } from './language.mjs';

/// How many children a node makes at a time.
export const kBatch = 200;

/// Names in order as people read them ("Rib 2" before "Rib 10"); one collator for every
/// comparison (localeCompare with options makes one per call: seconds for 65,536 groups), made
/// when first needed (making it loads the locale's collation data: most of this module's start
/// on a slow phone).
let collator = null;
export function compareNames(a, b) {
  prepareNames();
  return collator.compare(a, b);
}

/// Makes compareNames' collator now (a task of its own before the lists are built: a twelfth of
/// a second on a slow phone).
export function prepareNames() {
  collator ??= new Intl.Collator('en', { numeric: true });
}

const isGroup = (key) => key[0] === 'g';
const indexOf = (key) => Number(key.slice(1));

/// The tree of `manifest` (null when it has no groups): { childGroups, childParts (per group),
/// rootGroups, rootParts, total (parts under each group), shown (of those, the visible ones),
/// sorted (the nodes whose children are sorted by name),
/// expanded (a Set of group indices), filter (a Set of the keys a search keeps, or null), query
/// (the search it keeps them for), made (node key -> how many children it has made), rows
/// (key -> the row's elements, for the rows made so far), focusKey, selectedKey }. Keys are
/// 'g<group index>' and 'p<part id>'.
export function createTreeModel(manifest) {
  const { groups, parts } = manifest;
  if (!groups.length) return null;
  const n = groups.length;
  const childGroups = Array.from({ length: n }, () => []);
  const childParts = Array.from({ length: n }, () => []);
  const rootGroups = [];
  const rootParts = [];
  groups.forEach((g, i) => (g.parent < 0 ? rootGroups : childGroups[g.parent]).push(i));
  for (const part of parts) (part.path < 0 ? rootParts : childParts[part.path]).push(part.id);
  const total = new Int32Array(n);
  for (const part of parts) if (part.path >= 0) ++total[part.path];
  for (let i = n - 1; i >= 0; --i) if (groups[i].parent >= 0) total[groups[i].parent] += total[i];
  const expanded = new Set();
  // One root (a skeleton) opens showing its regions.
  if (rootGroups.length === 1 && !rootParts.length) expanded.add(rootGroups[0]);
  return {
    childGroups, childParts, rootGroups, rootParts, total, shown: new Int32Array(total), expanded,
    sorted: new Set(), filter: null, query: '', made: new Map(), rows: new Map(), focusKey: null, selectedKey: null, container: null, handlers: null,
  };
}

/// The keys of the children of `key` (null: the roots), groups first, in the manifest's order
/// (pack lists derived regions head to toe, a names file's in the order its parts reach them),
/// then the parts by name (sorted on first use, so a tree of 65,536 groups sorts only what is
/// opened); those a search keeps only.
function childrenOf(state, key) {
  const { tree, manifest } = state;
  const groups = key === null ? tree.rootGroups : tree.childGroups[indexOf(key)];
  const parts = key === null ? tree.rootParts : tree.childParts[indexOf(key)];
  if (!tree.sorted.has(key)) {
    tree.sorted.add(key);
    parts.sort((a, b) => compareNames(manifest.parts[a].displayName, manifest.parts[b].displayName));
  }
  const keys = [...groups.map((g) => `g${g}`), ...parts.map((p) => `p${p}`)];
  return tree.filter ? keys.filter((k) => tree.filter.has(k)) : keys;
}

/// The key of the parent node of `key` (null for a root).
function parentOf(manifest, key) {
  const g = isGroup(key) ? manifest.groups[indexOf(key)].parent : manifest.parts[indexOf(key)].path;
  return g < 0 ? null : `g${g}`;
}

/// The part ids under node `key`.
export function partsUnder(state, key) {
  const { tree } = state;
  if (!isGroup(key)) return [indexOf(key)];
  const out = [];
  const stack = [indexOf(key)];
  while (stack.length) {
    const g = stack.pop();
    out.push(...tree.childParts[g]);
    stack.push(...tree.childGroups[g]);
  }
  return out;
}

/// Node `key`'s name in the panel's language.
export function nodeName(state, key) {
  const { manifest, language } = state;
  return isGroup(key) ? groupName(manifest, indexOf(key), language) : partName(manifest, manifest.parts[indexOf(key)], language);
}

const plural = (n) => `${n} bone${n === 1 ? '' : 's'}`;

function labelRow(state, key, row) {
  const name = nodeName(state, key);
  row.name.textContent = name;
  row.name.lang = langAttribute(state.language);
  row.li.setAttribute('aria-label', isGroup(key) ? `${name}, ${plural(state.tree.total[indexOf(key)])}` : name);
}

function checkRow(state, key, row) {
  const { tree } = state;
  let on;
  let some;
  if (isGroup(key)) {
    const g = indexOf(key);
    on = tree.shown[g] === tree.total[g];
    some = tree.shown[g] > 0 && !on;
  } else {
    on = tree.handlers.partVisible(indexOf(key));
    some = false;
  }
  row.box.checked = on;
  row.box.indeterminate = some;
  row.li.setAttribute('aria-checked', some ? 'mixed' : String(on));
  row.li.classList.toggle('hidden-part', !on && !some);
}

function makeItem(state, key, level, position, size) {
  const { tree } = state;
  const li = document.createElement('li');
  li.setAttribute('role', 'treeitem');
  li.setAttribute('aria-level', String(level));
  li.setAttribute('aria-posinset', String(position));
  li.setAttribute('aria-setsize', String(size));
  li.tabIndex = -1;
  li.dataset.key = key;
  const line = document.createElement('div');
  line.className = 'node';
  const twisty = document.createElement('span');
  twisty.className = 'twisty';
  twisty.setAttribute('aria-hidden', 'true');
  // The check box is the item's aria-checked for assistive technology; the mouse clicks it.
  const box = document.createElement('input');
  box.type = 'checkbox';
  box.tabIndex = -1;
  box.setAttribute('aria-hidden', 'true');
  const name = document.createElement('span');
  name.className = 'node-name';
  line.append(twisty, box, name);
  const row = { li, box, name, ul: null, level };
  if (isGroup(key)) {
    const count = document.createElement('span');
    count.className = 'node-count';
    count.textContent = String(tree.total[indexOf(key)]);
    li.dataset.count = count.textContent;
    line.append(count);
    li.setAttribute('aria-expanded', 'false');
  }
  li.append(line);
  tree.rows.set(key, row);
  labelRow(state, key, row);
  checkRow(state, key, row);
  if (key === tree.selectedKey) li.setAttribute('aria-selected', 'true');
  if (isGroup(key) && tree.expanded.has(indexOf(key))) expandRow(state, key);
  return li;
}

/// Makes children `from` .. `from + kBatch` of `key` (null: the roots) into `ul`, then a "more"
/// item if some are left.
function makeChildren(state, key, ul, level, from = 0) {
  const { tree } = state;
  const keys = childrenOf(state, key);
  const items = document.createDocumentFragment();
  // Made again (after a search), a node makes as many as it had.
  const had = from === 0 && !tree.filter ? tree.made.get(key) ?? 0 : 0;
  const end = Math.min(keys.length, Math.max(from + kBatch, had));
  if (!tree.filter) tree.made.set(key, end);
  for (let i = from; i < end; ++i) items.append(makeItem(state, keys[i], level, i + 1, keys.length));
  if (end < keys.length) {
    const more = document.createElement('li');
    more.setAttribute('role', 'treeitem');
    more.setAttribute('aria-level', String(level));
    more.tabIndex = -1;
    more.className = 'more';
    more.dataset.more = String(end);
    more.dataset.parent = key ?? '';
    more.textContent = `${keys.length - end} more…`;
    items.append(more);
  }
  ul.append(items);
}

/// Makes the next batch in place of "more" item `more`.
function makeMore(state, more) {
  const ul = more.parentElement;
  const key = more.dataset.parent || null;
  const level = Number(more.getAttribute('aria-level'));
  const from = Number(more.dataset.more);
  more.remove();
  makeChildren(state, key, ul, level, from);
  return ul.children[from] ?? null;
}

function expandRow(state, key) {
  const row = state.tree.rows.get(key);
  state.tree.expanded.add(indexOf(key));
  if (!row) return;
  row.li.setAttribute('aria-expanded', 'true');
  if (!row.ul) {
    row.ul = document.createElement('ul');
    row.ul.setAttribute('role', 'group');
    row.li.append(row.ul);
    makeChildren(state, key, row.ul, row.level + 1);
  }
  row.ul.hidden = false;
}

function collapseRow(state, key) {
  const row = state.tree.rows.get(key);
  state.tree.expanded.delete(indexOf(key));
  if (!row) return;
  row.li.setAttribute('aria-expanded', 'false');
  if (row.ul) row.ul.hidden = true;
}

/// (Re)makes the tree's rows from the model: the roots, and the children of every expanded node.
export function renderTree(state) {
  const { tree } = state;
  const container = tree.container;
  tree.rows.clear();
  container.replaceChildren();
  makeChildren(state, null, container, 1);
  const focus = tree.rows.get(tree.focusKey)?.li ?? container.querySelector('[role="treeitem"]');
  if (focus) focus.tabIndex = 0;
}

/// Recounts the visible parts under every group and sets every check box made so far.
export function updateTreeChecks(state) {
  const { tree, manifest } = state;
  if (!tree) return;
  const { groups, parts } = manifest;
  tree.shown.fill(0);
  for (const part of parts) if (part.path >= 0 && tree.handlers.partVisible(part.id)) ++tree.shown[part.path];
  for (let i = groups.length - 1; i >= 0; --i) if (groups[i].parent >= 0) tree.shown[groups[i].parent] += tree.shown[i];
  for (const [key, row] of tree.rows) checkRow(state, key, row);
}

/// Renames every row made so far (the panel's language changed).
export function renameTree(state) {
  const { tree } = state;
  if (!tree) return;
  for (const [key, row] of tree.rows) labelRow(state, key, row);
}

/// Keeps only the nodes on the way to `partIds` and `groupIds` (a search's matches; null: every
/// node), and expands the tree to them (their ancestors stay expanded after the search).
export function filterTree(state, partIds, groupIds = []) {
  const { tree, manifest } = state;
  if (!tree) return;
  if (partIds === null) {
    tree.filter = null;
  } else {
    tree.filter = new Set();
    // Each match and its ancestors are kept; the ancestors expand.
    const keep = (key) => {
      for (let k = key; k !== null && !tree.filter.has(k); k = parentOf(manifest, k)) {
        tree.filter.add(k);
        if (k !== key) tree.expanded.add(indexOf(k));
      }
    };
    for (const id of partIds) keep(`p${id}`);
    for (const g of groupIds) keep(`g${g}`);
  }
  renderTree(state);
}

/// Expands the tree to node `key`, makes its row if need be, and marks it the tree's selection
/// (aria-selected); `focus`: moves the keyboard focus there too.
export function revealNode(state, key, { focus = false, scroll = true } = {}) {
  const { tree, manifest } = state;
  if (!tree) return;
  const previous = tree.rows.get(tree.selectedKey);
  previous?.li.removeAttribute('aria-selected');
  tree.selectedKey = key;
  if (key === null) return;
  if (tree.filter && !tree.filter.has(key)) filterTree(state, null);
  const chain = [];
  for (let k = parentOf(manifest, key); k !== null; k = parentOf(manifest, k)) chain.unshift(k);
  for (const k of chain) expandRow(state, k);
  let row = tree.rows.get(key);
  // Beyond the batches made so far: make more until it is.
  for (let guard = 0; !row && guard < 1000; ++guard) {
    const parent = chain.length ? tree.rows.get(chain.at(-1)).ul : tree.container;
    const more = parent?.querySelector(':scope > li.more');
    if (!more) break;
    makeMore(state, more);
    row = tree.rows.get(key);
  }
  if (!row) return;
  row.li.setAttribute('aria-selected', 'true');
  if (focus) moveFocus(state, row.li);
  if (scroll && row.li.offsetParent) row.li.scrollIntoView({ block: 'nearest' });
}

function moveFocus(state, li) {
  const { tree } = state;
  for (const old of tree.container.querySelectorAll('[role="treeitem"][tabindex="0"]')) old.tabIndex = -1;
  li.tabIndex = 0;
  li.focus();
  if (li.dataset.key) tree.focusKey = li.dataset.key;
}

/// The items a person can see (not inside a collapsed node), in order.
function visibleItems(tree) {
  return [...tree.container.querySelectorAll('[role="treeitem"]')].filter((li) => {
    for (let ul = li.parentElement; ul && ul !== tree.container; ul = ul.parentElement) if (ul.hidden) return false;
    return true;
  });
}

function onKey(state, e) {
  const { tree } = state;
  const li = e.target.closest('[role="treeitem"]');
  if (!li || !tree.container.contains(li)) return;
  const key = li.dataset.key ?? null;
  const items = () => visibleItems(tree);
  const go = (to) => {
    if (!to) return;
    moveFocus(state, to);
    if (to.dataset.key) tree.handlers.select(to.dataset.key);
  };
  switch (e.key) {
    case 'ArrowDown': {
      const all = items();
      go(all[all.indexOf(li) + 1]);
      break;
    }
    case 'ArrowUp': {
      const all = items();
      go(all[all.indexOf(li) - 1]);
      break;
    }
    case 'Home':
      go(items()[0]);
      break;
    case 'End':
      go(items().at(-1));
      break;
    case 'ArrowRight':
      if (key && isGroup(key)) {
        if (!tree.expanded.has(indexOf(key))) expandRow(state, key);
        else go(tree.rows.get(key).ul?.querySelector('[role="treeitem"]'));
      }
      break;
    case 'ArrowLeft':
      if (key && isGroup(key) && tree.expanded.has(indexOf(key))) {
        collapseRow(state, key);
      } else {
        const parent = li.parentElement.closest('[role="treeitem"]');
        if (parent && tree.container.contains(parent)) go(parent);
      }
      break;
    case 'Enter':
    case ' ':
      if (!key) go(makeMore(state, li));
      else tree.handlers.toggle(key);
      break;
    default:
      return;
  }
  e.preventDefault();
  e.stopPropagation();
}

function onClick(state, e) {
  const { tree } = state;
  const li = e.target.closest('[role="treeitem"]');
  if (!li || !tree.container.contains(li)) return;
  const key = li.dataset.key ?? null;
  if (!key) {
    const first = makeMore(state, li);
    if (first) moveFocus(state, first);
    return;
  }
  if (e.target.matches('input[type="checkbox"]')) {
    tree.handlers.toggle(key);
    return;
  }
  moveFocus(state, li);
  if (e.target.closest('.twisty') && isGroup(key)) {
    if (tree.expanded.has(indexOf(key))) collapseRow(state, key);
    else expandRow(state, key);
    return;
  }
  tree.handlers.select(key);
}

function onDoubleClick(state, e) {
  const li = e.target.closest('[role="treeitem"]');
  const key = li?.dataset.key;
  if (!key || !isGroup(key) || e.target.matches('input')) return;
  if (state.tree.expanded.has(indexOf(key))) collapseRow(state, key);
  else expandRow(state, key);
}

/// Makes the tree of state.manifest into `container` (the #region-tree element) and returns the
/// model (null, leaving the container empty, when the package has no groups). `handlers`:
/// { partVisible(id), toggle(key) (a check box or Enter/Space), select(key) (a click, or the
/// focus moved by a key) }.
export function buildTree(state, container, handlers) {
  const tree = createTreeModel(state.manifest);
  state.tree = tree;
  if (!tree) return null;
  tree.container = container;
  tree.handlers = handlers;
  updateTreeChecks(state);
  renderTree(state);
  container.addEventListener('keydown', (e) => onKey(state, e));
  container.addEventListener('click', (e) => onClick(state, e));
  container.addEventListener('dblclick', (e) => onDoubleClick(state, e));
  // The roving tabindex follows a focus that arrives otherwise (a screen reader's cursor).
  container.addEventListener('focusin', (e) => {
    const li = e.target.closest?.('[role="treeitem"]');
    if (li && li.tabIndex !== 0) moveFocus(state, li);
  });
  return tree;
}
