// SPDX-License-Identifier: Apache-2.0
// Reads a package's manifest.json (docs/FORMAT.md, "Package (osteon pack), version 3"; version 2,
// without levels of detail, too) into the
// plain tables the viewer draws from: parts, chunk files, components by id (each a byte range of a
// chunk), instances with their world matrices, the fetch order, and each part's world bounding box
// (known before any mesh arrives, so the camera can be fitted and a bone framed or clicked before
// its component has loaded). It also counts what is drawn from which components are loaded
// (drawStats, drawInfo), so the page knows without asking the renderer, which may live in a worker.
//
// The manifest comes from the network: every field is checked, and a bad one throws
// Error('osteon: manifest.json: parts[3].prototype: ...') naming the field, instead of failing
// later inside three.js. No DOM and no three.js here, so Node tests run it as is.

const kUnits = new Set(['mm', 'cm', 'm', 'in', 'unknown']);

/// The newest .ostm stream version the decoder built beside this viewer (web/decoder) reads: the
/// C++ kStreamVersion (include/osteon/codec.hpp). A package's manifest records its streams'
/// version, so a viewer too old for them says so before fetching anything.
export const kStreamVersion = 8;

/// The most languages, groups and group levels a manifest may hold (docs/FORMAT.md, "Groups and
/// languages"); the C++ parser's kMaxLanguages, kMaxGroups, kMaxGroupDepth.
export const kMaxLanguages = 64;
export const kMaxGroups = 65536;
export const kMaxGroupDepth = 32;

/// A language tag as BCP 47 spells the common ones: "en", "la", "pt-BR", "zh-Hant-TW".
const kLanguageTag = /^[A-Za-z]{2,3}(-[A-Za-z0-9]{1,8})*$/;

/// The most entries a manifest may list in each of chunks, parts, components, instances and
/// stream_order (docs/FORMAT.md, "manifest.json", limits): 276 times BodyParts3D's 237
/// components. Each costs the page a fetch-log entry, a list row or a draw batch, so a manifest
/// listing a million would hold the page for seconds; it is refused before any entry is read.
export const kMaxEntries = 65536;

class ManifestError extends Error {}

function fail(where, what) {
  throw new ManifestError(`osteon: manifest.json: ${where}: ${what}`);
}

function isObject(v) {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/// Whether `v` is a number the manifest may hold: finite, also as a float (every number of the
/// manifest is drawn in float and written as the nearest float: one that rounds to a float's
/// infinity would be drawn, and written back, as infinity).
function isNumber(v) {
  return typeof v === 'number' && Number.isFinite(v) && Number.isFinite(Math.fround(v));
}

function number(v, where) {
  if (isNumber(v)) return v;
  if (typeof v !== 'number' || !Number.isFinite(v)) fail(where, `expected a finite number, got ${JSON.stringify(v)}`);
  fail(where, `${JSON.stringify(v)} is beyond a float's range`);
}

/// `n` numbers `v` (an array), checked; a field's name is made only for the message of a bad one,
/// since a dense skeleton's manifest holds tens of thousands of them.
function numbers(v, n, where, expected) {
  if (!Array.isArray(v) || v.length !== n) fail(where, expected);
  for (let i = 0; i < n; ++i) if (!isNumber(v[i])) number(v[i], `${where}[${i}]`);
  return v.slice();
}

function count(v, where) {
  if (!Number.isSafeInteger(v) || v < 0) fail(where, `expected a count, got ${JSON.stringify(v)}`);
  return v;
}

function string(v, where) {
  if (typeof v !== 'string') fail(where, `expected a string, got ${JSON.stringify(v)}`);
  return v;
}

function vec3(v, where) {
  return numbers(v, 3, where, 'expected [x, y, z]');
}

/// An sRGB colour [r, g, b], each 0..1.
function color(v, where) {
  const rgb = vec3(v, where);
  rgb.forEach((c, i) => {
    if (!(Math.fround(c) >= 0 && Math.fround(c) <= 1)) fail(`${where}[${i}]`, `expected 0..1, got ${c}`);
  });
  return rgb;
}

/// The package's "view": { up, eye }, two non-zero, non-parallel directions.
function viewOf(v) {
  if (!isObject(v)) fail('view', 'expected {"up": [x, y, z], "eye": [x, y, z]}');
  const up = vec3(v.up, 'view.up');
  const eye = vec3(v.eye, 'view.eye');
  const cross = [up[1] * eye[2] - up[2] * eye[1], up[2] * eye[0] - up[0] * eye[2], up[0] * eye[1] - up[1] * eye[0]];
  if (!(Math.hypot(...cross) > 1e-6 * Math.hypot(...up) * Math.hypot(...eye))) fail('view', 'up and eye must be non-zero and not parallel');
  return { up, eye };
}

function box(v, where) {
  if (!isObject(v)) fail(where, 'expected {"min": [x, y, z], "max": [x, y, z]}');
  const min = vec3(v.min, `${where}.min`);
  const max = vec3(v.max, `${where}.max`);
  // Compared as drawn, in float (1.00000001 > 1 in double, equal in float).
  for (let i = 0; i < 3; ++i) if (Math.fround(min[i]) > Math.fround(max[i])) fail(where, `min[${i}] > max[${i}]`);
  return { min, max };
}

/// The optional root "languages": unique language tags, the first the display names' language.
/// A part's optional "path": the index of its deepest group; -1 when absent.
function pathOf(v, where, groups) {
  if (v === undefined) return -1;
  const g = count(v, where);
  if (g >= groups.length) fail(where, `no group ${g} (the package has ${groups.length})`);
  return g;
}

function languagesOf(v) {
  if (v === undefined) return [];
  if (!Array.isArray(v)) fail('languages', 'expected an array of language tags');
  if (v.length > kMaxLanguages) fail('languages', `${v.length} languages, at most ${kMaxLanguages}`);
  const tags = [];
  v.forEach((tag, k) => {
    string(tag, `languages[${k}]`);
    if (!kLanguageTag.test(tag)) fail(`languages[${k}]`, `expected a language tag ("en", "pt-BR"), got ${JSON.stringify(tag)}`);
    if (tags.includes(tag)) fail(`languages[${k}]`, `${JSON.stringify(tag)} appears twice`);
    tags.push(tag);
  });
  return tags;
}

/// An optional "names" object {tag: name} of a group or part, its tags in `languages`.
function namesOf(v, where, languages) {
  if (v === undefined) return {};
  if (!isObject(v)) fail(`${where}.names`, 'expected an object {tag: name}');
  // Sorted as the C++ parser's map holds them, so both name the same first bad tag.
  const names = {};
  for (const tag of Object.keys(v).sort()) {
    if (!languages.includes(tag)) fail(`${where}.names.${tag}`, `${JSON.stringify(tag)} is not in languages`);
    names[tag] = string(v[tag], `${where}.names.${tag}`);
  }
  return names;
}

/// The optional root "groups": the region tree, each { name, parent (-1 for a root), names,
/// depth (1 for a root) }, every parent an earlier group.
function groupsOf(v, languages) {
  if (v === undefined) return [];
  if (!Array.isArray(v)) fail('groups', 'expected an array');
  if (v.length > kMaxGroups) fail('groups', `${v.length} groups, at most ${kMaxGroups}`);
  const groups = [];
  v.forEach((g, i) => {
    const where = `groups[${i}]`;
    if (!isObject(g)) fail(where, 'expected an object');
    const name = string(g.name, `${where}.name`);
    if (name === '') fail(`${where}.name`, 'expected a non-empty name');
    let parent = -1;
    if (g.parent !== undefined) {
      parent = count(g.parent, `${where}.parent`);
      if (parent >= i) fail(`${where}.parent`, `expected an earlier group's index (below ${i}), got ${parent}`);
    }
    const depth = parent < 0 ? 1 : groups[parent].depth + 1;
    if (depth > kMaxGroupDepth) fail(`${where}.parent`, `groups nested deeper than ${kMaxGroupDepth}`);
    groups.push({ name, parent, names: namesOf(g.names, where, languages), depth });
  });
  return groups;
}

/// A chunk file is named by its content hash, inside the package's c/ folder: nothing else is
/// accepted, so a manifest cannot make the viewer fetch from another host or folder.
const kChunkFile = /^c\/[0-9a-f]{24}\.ostc$/;

function chunkFile(v, where) {
  const file = string(v, where);
  if (!kChunkFile.test(file)) fail(where, `expected "c/<24 lower-case hex digits>.ostc", got ${JSON.stringify(file)}`);
  return file;
}

/// The determinant of the upper-left 3x3 of a column-major 4x4.
export function determinant3(m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
    m[8] * (m[1] * m[6] - m[5] * m[2]);
}

/// The world box of `local` (a {min, max} box) under the column-major 4x4 `m`: the box of its eight
/// transformed corners.
export function transformBox(local, m) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let corner = 0; corner < 8; ++corner) {
    const x = corner & 1 ? local.max[0] : local.min[0];
    const y = corner & 2 ? local.max[1] : local.min[1];
    const z = corner & 4 ? local.max[2] : local.min[2];
    for (let r = 0; r < 3; ++r) {
      const w = m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r];
      if (w < min[r]) min[r] = w;
      if (w > max[r]) max[r] = w;
    }
  }
  return { min, max };
}

/// `a` grown to hold `b` (in place; a copy of `b` when `a` is null).
function unionBox(a, b) {
  if (!a) return { min: [...b.min], max: [...b.max] };
  for (let i = 0; i < 3; ++i) {
    if (b.min[i] < a.min[i]) a.min[i] = b.min[i];
    if (b.max[i] > a.max[i]) a.max[i] = b.max[i];
  }
  return a;
}

/// The stream `v` names ({chunk, offset, bytes}), checked against the chunks.
function byteRange(v, where, chunks) {
  const k = count(v.chunk, `${where}.chunk`);
  if (k >= chunks.length) fail(`${where}.chunk`, `no chunk ${k} (the package has ${chunks.length})`);
  const offset = count(v.offset, `${where}.offset`);
  const bytes = count(v.bytes, `${where}.bytes`);
  if (offset > chunks[k].bytes) fail(`${where}.offset`, `byte ${offset} lies beyond the ${chunks[k].bytes} bytes of chunks[${k}]`);
  if (bytes === 0) fail(`${where}.bytes`, 'expected at least one byte');
  if (offset + bytes > chunks[k].bytes) {
    fail(`${where}.bytes`, `bytes ${offset}-${offset + bytes} lie beyond the ${chunks[k].bytes} bytes of chunks[${k}]`);
  }
  return { chunk: k, offset, bytes };
}

/// A component's coarser levels (docs/FORMAT.md "Levels of detail"), coarsest first: each
/// { chunk, offset, bytes, file, triangles, vertices, error }, fewer triangles than the next.
function levelsOf(c, where, chunks, component) {
  if (c.levels === undefined) return [];
  if (!Array.isArray(c.levels)) fail(`${where}.levels`, 'expected an array');
  const levels = c.levels.map((v, k) => {
    const at = `${where}.levels[${k}]`;
    if (!isObject(v)) fail(at, 'expected an object');
    const range = byteRange(v, at, chunks);
    const level = {
      ...range,
      file: chunks[range.chunk].file,
      triangles: count(v.triangles, `${at}.triangles`),
      vertices: count(v.vertices, `${at}.vertices`),
      error: number(v.error, `${at}.error`),
    };
    if (level.error < component.errorBound) fail(`${at}.error`, `${level.error} is below the component's error_bound ${component.errorBound}`);
    return level;
  });
  levels.forEach((level, k) => {
    const finer = k + 1 < levels.length ? levels[k + 1].triangles : component.triangles;
    if (level.triangles >= finer) fail(`${where}.levels[${k}].triangles`, `expected fewer than the next finer level's ${finer}`);
  });
  return levels;
}

/// Checks a parsed manifest.json and returns:
///   { unit, bounds, parts, chunks ({ index, file, bytes }), components (each with chunk,
///     offset, bytes and file, its chunk's file, of its full level; `levels`, every level
///     coarsest first with the full one last, each { level, chunk, offset, bytes, file,
///     triangles, vertices, error }; `first`, levels[0]), componentById: Map, instances, streamOrder
///     (component objects in fetch order), instancesOf: Map component id -> instance indices,
///     instancesOfPart: instance indices per part, partBounds: world box per part, languages
///     (tags, [] when absent), groups (the region tree: { name, parent (-1 for a root), names,
///     depth }, [] when absent), groupLabels (the parts' distinct group strings), bytesTotal (the chunks' bytes), refused (a message per instance not drawn: a matrix with
///     Infinity) }
/// Each instance gains `mirror` recomputed from its matrix's determinant (what decides the
/// winding on screen), `index` (in the instances drawn) and `source` (in the manifest's list). Throws Error('osteon: manifest.json: <field>: <what>').
export function parseManifest(json) {
  const steps = manifestSteps(json);
  for (;;) {
    const step = steps.next();
    if (step.done) return step.value;
  }
}

/// parseManifest in slices: `pause()` is awaited between slices of about `sliceMs` (default 20)
/// ms, so a page can read a dense skeleton's manifest (thousands of components and instances,
/// a few hundred milliseconds on a slow phone) without one long task. Same result, same errors.
export async function parseManifestSliced(json, pause, { sliceMs = 20, now = () => performance.now() } = {}) {
  const steps = manifestSteps(json);
  let start = now();
  for (;;) {
    const step = steps.next();
    if (step.done) return step.value;
    if (now() - start >= sliceMs) {
      await pause();
      start = now();
    }
  }
}

/// The entries checked between two chances to pause (manifestSteps yields after each group).
const kEntriesPerStep = 64;

/// parseManifest's work, yielding (nothing) every kEntriesPerStep components or instances.
function* manifestSteps(json) {
  if (!isObject(json)) fail('top level', 'expected a JSON object');
  if (json.format !== 'osteon-package') fail('format', `expected "osteon-package", got ${JSON.stringify(json.format)}`);
  if (json.version !== 2 && json.version !== 3) fail('version', `this viewer reads versions 2 and 3, the package is version ${JSON.stringify(json.version)}`);
  // The .ostm version of every stream (absent in packages written before it was recorded).
  if (json.stream_version !== undefined && !(Number.isInteger(json.stream_version) && json.stream_version >= 1 && json.stream_version <= kStreamVersion)) {
    fail('stream_version', `this viewer decodes stream versions 1 to ${kStreamVersion}, the package's are version ${JSON.stringify(json.stream_version)}`);
  }
  const unit = string(json.unit, 'unit');
  if (!kUnits.has(unit)) fail('unit', `expected one of ${[...kUnits].join(', ')}, got ${JSON.stringify(unit)}`);
  const bounds = box(json.bounds, 'bounds');
  const view = json.view === undefined ? null : viewOf(json.view);
  for (const key of ['chunks', 'parts', 'components', 'instances', 'stream_order']) {
    if (!Array.isArray(json[key])) fail(key, 'expected an array');
    if (json[key].length > kMaxEntries) fail(key, `${json[key].length} entries, this viewer reads at most ${kMaxEntries}`);
  }

  const languages = languagesOf(json.languages);
  const groupTree = groupsOf(json.groups, languages);

  const chunkFiles = new Set();
  const chunks = json.chunks.map((c, k) => {
    const where = `chunks[${k}]`;
    if (!isObject(c)) fail(where, 'expected an object');
    const file = chunkFile(c.file, `${where}.file`);
    if (chunkFiles.has(file)) fail(`${where}.file`, `${JSON.stringify(file)} appears twice`);
    chunkFiles.add(file);
    return { index: k, file, bytes: count(c.bytes, `${where}.bytes`) };
  });

  const parts = json.parts.map((p, i) => {
    const where = `parts[${i}]`;
    if (!isObject(p)) fail(where, 'expected an object');
    if (p.id !== i) fail(`${where}.id`, `expected ${i} (the index), got ${JSON.stringify(p.id)}`);
    const name = string(p.name, `${where}.name`);
    return {
      id: i,
      name,
      displayName: p.display_name === undefined ? name : string(p.display_name, `${where}.display_name`),
      group: p.group === undefined ? '' : string(p.group, `${where}.group`),
      source: p.source === undefined ? '' : string(p.source, `${where}.source`),
      triangles: count(p.triangles, `${where}.triangles`),
      prototype: count(p.prototype, `${where}.prototype`),
      color: p.color === undefined ? null : color(p.color, `${where}.color`),
      path: pathOf(p.path, `${where}.path`, groupTree),
      names: namesOf(p.names, where, languages),
      system: p.system === undefined ? '' : string(p.system, `${where}.system`),
    };
  });
  for (const p of parts) {
    if (p.prototype >= parts.length) fail(`parts[${p.id}].prototype`, `no part ${p.prototype}`);
  }

  const componentById = new Map();
  const components = [];
  for (let i = 0; i < json.components.length; ++i) {
    if (i % kEntriesPerStep === kEntriesPerStep - 1) yield;
    const c = json.components[i];
    const where = `components[${i}]`;
    if (!isObject(c)) fail(where, 'expected an object');
    const id = string(c.id, `${where}.id`);
    if (componentById.has(id)) fail(`${where}.id`, `${JSON.stringify(id)} appears twice`);
    const { chunk: k, offset, bytes } = byteRange(c, where, chunks);
    const component = {
      id,
      index: i,
      chunk: k,
      offset,
      bytes,
      file: chunks[k].file,
      triangles: count(c.triangles, `${where}.triangles`),
      vertices: count(c.vertices, `${where}.vertices`),
      bounds: box(c.bounds, `${where}.bounds`),
      errorBound: number(c.error_bound, `${where}.error_bound`),
    };
    // Every level, coarsest first, the full one last; `first` is the stream fetched first.
    component.levels = [...levelsOf(c, where, chunks, component), {
      level: 0, chunk: k, offset, bytes, file: chunks[k].file,
      triangles: component.triangles, vertices: component.vertices, error: component.errorBound,
    }];
    component.levels.forEach((level, n) => { level.level = n; });
    component.first = component.levels[0];
    componentById.set(id, component);
    components.push(component);
  }

  const instancesOf = new Map(components.map((c) => [c.id, []]));
  const instancesOfPart = parts.map(() => []);
  const partBounds = parts.map(() => null);
  const refused = [];
  const asFloat = new Float32Array(16);  // a matrix as drawn
  const instances = [];
  for (let i = 0; i < json.instances.length; ++i) {
    if (i % kEntriesPerStep === kEntriesPerStep - 1) yield;
    const inst = json.instances[i];
    const where = `instances[${i}]`;
    if (!isObject(inst)) fail(where, 'expected an object');
    const part = count(inst.part, `${where}.part`);
    if (part >= parts.length) fail(`${where}.part`, `no part ${part}`);
    const componentId = string(inst.component, `${where}.component`);
    const component = componentById.get(componentId);
    if (!component) fail(`${where}.component`, `no component ${JSON.stringify(componentId)}`);
    if (!Array.isArray(inst.matrix) || inst.matrix.length !== 16) fail(`${where}.matrix`, 'expected 16 numbers');
    // JSON has no NaN, but 1e999 reads as Infinity: such an instance alone is refused (reported
    // in `refused`), so one bad matrix neither hides the rest nor spoils the camera's box.
    const infinite = inst.matrix.findIndex((v) => typeof v === 'number' && !Number.isFinite(v));
    if (infinite >= 0) {
      refused.push(`osteon: manifest.json: ${where}.matrix[${infinite}]: ${inst.matrix[infinite]}, not a finite number: the instance is not drawn`);
      continue;
    }
    const matrix = numbers(inst.matrix, 16, `${where}.matrix`, 'expected 16 numbers');
    const det = determinant3(matrix);
    // Singular in float is singular as drawn (and as written back: entries below a float's
    // smallest step are written as 0).
    asFloat.set(matrix);
    if (!(Math.abs(det) > 0) || !(Math.abs(determinant3(asFloat)) > 0)) fail(`${where}.matrix`, 'singular (determinant 0)');
    const instance = {
      index: i,
      source: i,
      part,
      component: componentId,
      matrix,
      mirror: det < 0,
      errorBound: inst.error_bound === undefined ? component.errorBound : number(inst.error_bound, `${where}.error_bound`),
    };
    instances.push(instance);
  }
  // The refused instances leave no gap: indices count the drawn ones; `source` is the index in
  // the manifest's own list (what messages name).
  for (let i = 0; i < instances.length; ++i) {
    if (i % kEntriesPerStep === kEntriesPerStep - 1) yield;
    const instance = instances[i];
    instance.index = i;
    instancesOf.get(instance.component).push(i);
    instancesOfPart[instance.part].push(i);
    partBounds[instance.part] = unionBox(partBounds[instance.part], transformBox(componentById.get(instance.component).bounds, instance.matrix));
  }

  const seen = new Set();
  const streamOrder = json.stream_order.map((id, i) => {
    const component = componentById.get(id);
    if (!component) fail(`stream_order[${i}]`, `no component ${JSON.stringify(id)}`);
    if (seen.has(id)) fail(`stream_order[${i}]`, `${JSON.stringify(id)} appears twice`);
    seen.add(id);
    return component;
  });
  const missing = components.filter((c) => !seen.has(c.id)).map((c) => c.id);
  if (missing.length) fail('stream_order', `misses ${missing.slice(0, 5).join(', ')}${missing.length > 5 ? ', ...' : ''}`);

  // A part without instances (none should exist) still gets a box, so framing it does not fail.
  for (let i = 0; i < parts.length; ++i) partBounds[i] ??= bounds;
  // The distinct group strings of the parts (what viewers before the region tree toggled).
  const groupLabels = [...new Set(parts.map((p) => p.group))];
  const used = new Set(components.flatMap((c) => c.levels.map((level) => level.chunk)));
  return {
    unit,
    bounds,
    view,
    parts,
    chunks,
    components,
    componentById,
    instances,
    streamOrder,
    instancesOf,
    instancesOfPart,
    partBounds,
    languages,
    groups: groupTree,
    groupLabels,
    refused,
    bytesTotal: chunks.reduce((sum, c) => sum + (used.has(c.index) ? c.bytes : 0), 0),
  };
}

/// Finds a part by display name, then name, then source file, case-insensitively; null if none.
export function findPart(manifest, query) {
  const q = String(query).trim().toLowerCase();
  for (const key of ['displayName', 'name', 'source']) {
    const part = manifest.parts.find((p) => p[key].toLowerCase() === q);
    if (part) return part;
  }
  return null;
}

/// A length in the manifest's unit, for people: 3 significant digits and the unit.
export function formatLength(value, unit) {
  const text = value === 0 ? '0' : Math.abs(value) >= 1000 ? value.toFixed(0) : value.toPrecision(3);
  return unit === 'unknown' ? `${text} units` : `${text} ${unit}`;
}

/// What is drawn once the components in `loaded` (a Set of ids) are on screen, each at level
/// `levelOf(id)` (default 0: its first level), and the parts for which `partVisible(partId)`
/// holds are shown: { instances, triangles, drawCalls, components }. It counts the way scene.mjs
/// draws (one Mesh for a component one instance uses; otherwise one InstancedMesh for the
/// instances that keep the winding and one for the mirrored ones, each a draw call while any of
/// its instances shows), so the page knows it without the renderer.
export function drawStats(manifest, loaded, partVisible, levelOf = () => 0) {
  let instances = 0;
  let triangles = 0;
  let drawCalls = 0;
  for (const id of loaded) {
    const component = manifest.componentById.get(id);
    const uses = manifest.instancesOf.get(id);
    const batches = uses.length === 1 ? [uses] : [false, true].map((m) => uses.filter((i) => manifest.instances[i].mirror === m));
    for (const batch of batches) {
      const shown = batch.filter((i) => partVisible(manifest.instances[i].part)).length;
      instances += shown;
      triangles += shown * component.levels[levelOf(id)].triangles;
      drawCalls += shown > 0 ? 1 : 0;
    }
  }
  return { instances, triangles, drawCalls, components: loaded.size };
}

/// How a part is drawn, per instance: { instance, component, loaded, instanced, batchSize,
/// mirror, level } (batchSize: the instances in its draw call's batch, 0 while not loaded; level:
/// `levelOf(component)`, null while not loaded), as scene.mjs draws it.
export function drawInfo(manifest, partId, loaded, levelOf = () => 0) {
  return manifest.instancesOfPart[partId].map((i) => {
    const { component, mirror } = manifest.instances[i];
    const uses = manifest.instancesOf.get(component);
    const instanced = uses.length > 1;
    const isLoaded = loaded.has(component);
    const batchSize = !isLoaded ? 0 : instanced ? uses.filter((j) => manifest.instances[j].mirror === mirror).length : 1;
    return { instance: i, component, loaded: isLoaded, instanced, batchSize, mirror, level: isLoaded ? levelOf(component) : null };
  });
}
