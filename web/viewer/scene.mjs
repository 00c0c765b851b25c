// SPDX-License-Identifier: Apache-2.0
// The three.js side of a package: turns each decoded component into draw calls for its instances,
// and keeps per-part visibility and highlight on them.
//
// Per component (docs/FORMAT.md: a part is drawn by one instance of each of its prototype's
// components):
//   - used by one instance: a THREE.Mesh with the instance's matrix (three.js flips the front
//     face itself when an object's world matrix has a negative determinant);
//   - used by several: a THREE.InstancedMesh for the instances that keep the winding, and a second
//     InstancedMesh for the mirrored ones (negative determinant), drawn from a copy of the index
//     buffer with two corners of every triangle swapped. three.js decides front faces per object,
//     not per instance, so a mirrored instance in the first batch would show its inside: culled
//     with FrontSide, or lit from the wrong side with DoubleSide (which flips normals on back faces).
// Positions and normals are shared by both batches (uploaded once); only the index buffer is copied.
//
// Levels of detail (docs/FORMAT.md): a component's batches are made with its first level; each
// finer level that arrives gets its own geometry (and flipped copy, where a mirrored batch needs
// one), and showLevel() swaps the geometry of every batch of the component at once, so picking,
// hiding, highlighting, instance colours and the mirrored batch's winding are the same at every
// level. A level removed is disposed (its GPU buffers freed) after its batches have moved to
// another; the first level is never removed.
//
// Hidden instances are packed out of an InstancedMesh (its count drops) rather than scaled to zero,
// so they cost nothing to draw or to raycast; `slots` maps an instanceId back to the instance.
//
// Per-part colours and opacity (setStyle): a colour replaces the manifest's (or the bone colour)
// in the instance colours and the part's own material. A part with opacity below 1 leaves its
// batches (packed out as if hidden) and draws each of its instances as Meshes of its own, with
// transparent materials of the part's (depthWrite off, so what lies behind still shows): three.js
// sorts transparent objects, not instances, back to front by their bounding spheres' centres, so
// objects per instance put the see-through bones in depth order, over the opaque ones, which stay
// batched as before. Each instance has two: its back faces, then its front faces (made in that
// order: three.js draws objects at the same depth in the order they were made), so a bone's far
// wall blends in under its near one. (Three.js would draw one double-sided transparent object in
// those two passes itself, but by changing its material twice a frame, which costs a program
// look-up per pass; one pass interleaves the walls triangle by triangle and shows bands.) Those
// meshes share the component's geometry (the level drawn) and are kept once made, so changing a
// part's opacity again costs a material change.
//
// Based on: three.js InstancedMesh and Mesh (matrixWorld.determinant() < 0 -> flipped front face).

import {
  Box3,
  BufferAttribute,
  BackSide,
  BufferGeometry,
  Color,
  DoubleSide,
  FrontSide,
  InstancedMesh,
  Matrix4,
  Mesh,
  MeshStandardMaterial,
  SRGBColorSpace,
  Sphere,
  Vector3,
} from 'three';

const kBoneColor = 0xd9cdb5;
const kHighlight = new Color(0xff7a2e);
const kWhite = new Color(1, 1, 1);

/// A colour from three 0..1 values in the manifest's colour space (sRGB), or null where they are
/// not all finite.
function srgbColor(values, at) {
  const [r, g, b] = [values[at], values[at + 1], values[at + 2]];
  return [r, g, b].every(Number.isFinite) ? new Color().setRGB(r, g, b, SRGBColorSpace) : null;
}

/// A copy of a triangle index buffer with every triangle's winding reversed (corners 1 and 2 swapped).
export function flipWinding(indices) {
  const flipped = indices.slice();
  for (let i = 0; i + 2 < flipped.length; i += 3) {
    flipped[i + 1] = indices[i + 2];
    flipped[i + 2] = indices[i + 1];
  }
  return flipped;
}

/// The geometry of one decoded mesh ({ positions, indices, normals } from the WebAssembly decoder).
/// The decoder's smooth normals are used when they match the positions, else recomputed. With
/// `component` (the manifest's), the bounding box and sphere come from its bounds grown by its
/// error bound, or by the level's error for a coarser level (every decoded vertex lies within
/// it), instead of a pass over the vertices.
function meshGeometry(mesh, component, level) {
  const geometry = new BufferGeometry();
  if (component) {
    const grow = Math.max(component.errorBound, level?.error ?? 0, 0);
    geometry.boundingBox = new Box3(new Vector3(...component.bounds.min), new Vector3(...component.bounds.max)).expandByScalar(grow);
    geometry.boundingSphere = geometry.boundingBox.getBoundingSphere(new Sphere());
  }
  geometry.setAttribute('position', new BufferAttribute(mesh.positions, 3));
  geometry.setIndex(new BufferAttribute(mesh.indices, 1));
  if (mesh.normals && mesh.normals.length === mesh.positions.length) {
    geometry.setAttribute('normal', new BufferAttribute(mesh.normals, 3));
  } else {
    geometry.computeVertexNormals();
  }
  return geometry;
}

/// Creates the scene side of a parsed manifest (manifest.mjs). `root` is the THREE.Group the
/// objects are added to. Returns functions; see each one's comment.
export function createPackageScene(manifest, root) {
  const material = new MeshStandardMaterial({ color: kBoneColor, roughness: 0.6, metalness: 0, side: DoubleSide });
  const highlightMaterial = material.clone();
  highlightMaterial.color.copy(material.color).multiply(kHighlight);
  // Every material in use, for the renderer's clipping planes. A part with its own colour (a
  // label volume's table) gets its own pair, made on first use; instanced batches use a white
  // material and carry each instance's colour, the bone colour for parts without one.
  const materials = [material, highlightMaterial];
  const instancedMaterial = material.clone();
  instancedMaterial.color.copy(kWhite);
  materials.push(instancedMaterial);
  const boneColor = new Color(kBoneColor);
  const manifestColors = manifest.parts.map((p) => (p.color ? srgbColor(p.color, 0) : null));
  let colorOverrides = null;           // Color (or null) per part, from setStyle's colours
  let opacities = null;                // opacity per part (Float32Array), or null: all opaque
  const partMaterials = new Map();     // part id -> [material, highlighted]
  const clearMaterials = new Map();    // part id -> its transparent materials [back faces, front faces]
  const clearOf = new Map();           // instance index -> its transparent Meshes [back, front], once made

  function partColor(partId) {
    return colorOverrides?.[partId] ?? manifestColors[partId] ?? boneColor;
  }

  /// A copy of the bone material that follows the clipping plane (setClip may have set one).
  function ownMaterial() {
    const own = material.clone();
    own.clippingPlanes = material.clippingPlanes;
    materials.push(own);
    return own;
  }

  function materialOf(partId, highlight) {
    const color = partColor(partId);
    if (color === boneColor) return highlight ? highlightMaterial : material;
    let pair = partMaterials.get(partId);
    if (!pair) {
      pair = [ownMaterial(), ownMaterial()];
      partMaterials.set(partId, pair);
    }
    pair[0].color.copy(color);
    pair[1].color.copy(color).multiply(kHighlight);
    return pair[highlight ? 1 : 0];
  }

  /// The opacity part `partId` is drawn with, 0..1 (1 without opacities).
  function partOpacity(partId) {
    const o = opacities?.[partId];
    return o === undefined || !(o < 1) ? 1 : Math.max(o, 0);
  }

  /// Whether part `partId` is drawn see-through (its own transparent meshes, not the batches).
  const isClear = (partId) => partOpacity(partId) < 1;

  /// The transparent materials of a part, [back faces, front faces], their colour (highlighted
  /// or not) and opacity set.
  function clearMaterialsOf(partId) {
    let pair = clearMaterials.get(partId);
    if (!pair) {
      pair = [BackSide, FrontSide].map((side) => Object.assign(ownMaterial(), { transparent: true, depthWrite: false, side }));
      clearMaterials.set(partId, pair);
    }
    for (const own of pair) {
      own.color.copy(partColor(partId));
      if (partId === highlighted) own.color.multiply(kHighlight);
      own.opacity = partOpacity(partId);
    }
    return pair;
  }

  const batches = [];                  // every draw object: { object, instances, instanced, mirror, component }
  const batchOf = new Map();           // instance index -> { batch, slot }
  const loaded = new Set();            // component ids drawn
  const drawnOf = new Map();           // component id -> { batches, levels: Map level -> { geometry, flipped }, drawn, first }
  const levelChanges = new Set();      // component ids whose drawn level changed since takeLevelChanges()
  let partVisible = () => true;
  let highlighted = -1;                // part id
  const matrix = new Matrix4();
  const instanceColor = new Color();   // a highlighted instance's colour, while packing

  /// Whether instance `i` is drawn in its batch: its part is visible and opaque.
  function instanceVisible(i) {
    const { part } = manifest.instances[i];
    return partVisible(part) && !isClear(part);
  }

  /// Writes an InstancedMesh's visible instances into its first slots and sets its count. Only
  /// what changed is uploaded again: the matrices when the slots moved, the colours when one
  /// changed (a style change elsewhere costs this batch a pass over its instances, no upload).
  function pack(batch) {
    const { object } = batch;
    const slots = batch.instances.filter(instanceVisible);
    const moved = !batch.slots || slots.length !== batch.slots.length || slots.some((i, k) => i !== batch.slots[k]);
    batch.slots = slots;
    const colors = object.instanceColor.array;
    let recoloured = false;
    slots.forEach((i, slot) => {
      if (moved) object.setMatrixAt(slot, matrix.fromArray(manifest.instances[i].matrix));
      const part = manifest.instances[i].part;
      const color = part === highlighted ? instanceColor.copy(partColor(part)).multiply(kHighlight) : partColor(part);
      if (colors[3 * slot] !== Math.fround(color.r) || colors[3 * slot + 1] !== Math.fround(color.g) || colors[3 * slot + 2] !== Math.fround(color.b)) {
        object.setColorAt(slot, color);
        recoloured = true;
      }
      batchOf.set(i, { batch, slot });
    });
    object.count = slots.length;
    object.visible = object.count > 0;
    if (recoloured) object.instanceColor.needsUpdate = true;
    if (!moved) return;
    object.instanceMatrix.needsUpdate = true;
    object.boundingSphere = null;      // recomputed from the visible instances on the next use
    object.boundingBox = null;
  }

  function refresh(batch) {
    if (batch.instanced) {
      pack(batch);
    } else {
      const i = batch.instances[0];
      batch.object.visible = instanceVisible(i);
      const part = manifest.instances[i].part;
      if (batch.object.visible) batch.object.material = materialOf(part, part === highlighted);
    }
  }

  /// The transparent Meshes of instance `i` (its component drawn), [back faces, front faces],
  /// made on first use with the geometry of the level drawn; a mirrored instance's matrix flips
  /// its front face (three.js does that per object), so they draw the component's own winding.
  function clearMeshes(i) {
    let pair = clearOf.get(i);
    if (pair) return pair;
    const instance = manifest.instances[i];
    const c = drawnOf.get(instance.component);
    const batch = { instances: [i], instanced: false, mirror: instance.mirror, component: instance.component, transparent: true };
    pair = clearMaterialsOf(instance.part).map((side, k) => {
      const object = new Mesh(c.levels.get(c.drawn).geometry, side);
      object.matrixAutoUpdate = false;
      object.matrix.fromArray(instance.matrix);
      object.matrixWorldNeedsUpdate = true;
      object.name = `${instance.component} (transparent, ${k ? 'front' : 'back'})`;
      object.userData.batch = batch;
      return object;
    });
    batch.object = pair[1];
    clearOf.set(i, pair);
    root.add(...pair);
    return pair;
  }

  /// Shows the transparent Meshes of every drawn instance of a visible part with opacity below 1,
  /// hides the others.
  function refreshClear() {
    if (!opacities && clearOf.size === 0) return;
    manifest.instances.forEach((instance, i) => {
      const show = loaded.has(instance.component) && partVisible(instance.part) && isClear(instance.part);
      if (!show && !clearOf.has(i)) return;
      const pair = clearMeshes(i);
      const sides = show ? clearMaterialsOf(instance.part) : null;
      pair.forEach((object, k) => {
        object.visible = show;
        if (show) object.material = sides[k];
      });
    });
  }

  function refreshAll() {
    for (const batch of batches) refresh(batch);
    refreshClear();
  }

  /// A level's geometry, and its winding-flipped twin (positions and normals shared) when
  /// `mirrored` (the component has a mirrored InstancedMesh). Throws when the mesh does not match
  /// the manifest's counts.
  function levelGeometry(component, level, mesh, mirrored) {
    const l = component.levels[level];
    const triangles = mesh.indices.length / 3;
    if (triangles !== l.triangles) {
      const what = component.levels.length > 1 ? `, level ${level + 1} of ${component.levels.length}` : '';
      throw new Error(`osteon: ${l.file} (component ${component.id}${what}): decoded ${triangles} triangles, the manifest says ${l.triangles}`);
    }
    const geometry = meshGeometry(mesh, component, l);
    let flipped = null;
    if (mirrored) {
      flipped = new BufferGeometry();
      flipped.boundingBox = geometry.boundingBox;
      flipped.boundingSphere = geometry.boundingSphere;
      flipped.setAttribute('position', geometry.getAttribute('position'));
      flipped.setAttribute('normal', geometry.getAttribute('normal'));
      flipped.setIndex(new BufferAttribute(flipWinding(geometry.index.array), 1));
    }
    return { geometry, flipped };
  }

  /// The geometry a batch draws of a level.
  const geometryFor = (batch, entry) => (batch.instanced && batch.mirror ? entry.flipped : entry.geometry);

  /// Adds a decoded component (its id and the decoder's mesh of level `level`, default 0: its
  /// first stream) for all its instances. Returns the draw objects made. Throws when the mesh
  /// does not match the manifest's counts.
  function addComponent(id, mesh, level = 0) {
    const component = manifest.componentById.get(id);
    if (!component) throw new Error(`osteon: no component ${id} in the manifest`);
    if (loaded.has(id)) throw new Error(`osteon: component ${id}: added twice`);
    const uses = manifest.instancesOf.get(id);
    const mirrored = uses.length > 1 && uses.some((i) => manifest.instances[i].mirror);
    const entry = levelGeometry(component, level, mesh, mirrored);
    const { geometry } = entry;
    const made = [];
    if (uses.length === 1) {
      const object = new Mesh(geometry, material);
      object.matrixAutoUpdate = false;
      object.matrix.fromArray(manifest.instances[uses[0]].matrix);
      object.matrixWorldNeedsUpdate = true;  // matrixAutoUpdate is off: nothing else sets it
      object.name = id;
      made.push({ object, instances: uses, instanced: false, mirror: manifest.instances[uses[0]].mirror });
    } else {
      for (const mirror of [false, true]) {
        const instances = uses.filter((i) => manifest.instances[i].mirror === mirror);
        if (!instances.length) continue;
        const object = new InstancedMesh(mirror ? entry.flipped : geometry, instancedMaterial, instances.length);
        object.name = `${id}${mirror ? ' (mirrored)' : ''}`;
        // Instance colours exist from the start, so the shader is compiled once with them.
        object.setColorAt(0, kWhite);
        made.push({ object, instances, instanced: true, mirror });
      }
    }
    for (const batch of made) {
      batch.component = id;
      batch.object.userData.batch = batch;
      batches.push(batch);
      // Every instance, also one hidden or see-through now (pack sets the slots of the drawn ones).
      for (const i of batch.instances) batchOf.set(i, { batch, slot: batch.instanced ? -1 : 0 });
      refresh(batch);
      root.add(batch.object);
    }
    loaded.add(id);
    drawnOf.set(id, { batches: made, levels: new Map([[level, entry]]), drawn: level, first: level, mirrored });
    if (opacities) refreshClear();
    return made.map((b) => b.object);
  }

  /// Adds level `level` of a component already drawn (its first level added), without showing
  /// it. Throws when the mesh does not match the manifest or the level is there already.
  function addLevel(id, level, mesh) {
    const c = drawnOf.get(id);
    if (!c) throw new Error(`osteon: component ${id}: a level arrived before its first one`);
    if (c.levels.has(level)) throw new Error(`osteon: component ${id}: level ${level + 1} added twice`);
    c.levels.set(level, levelGeometry(manifest.componentById.get(id), level, mesh, c.mirrored));
  }

  /// Draws component `id` at `level` (a level it holds) on all its batches. Returns whether
  /// anything changed.
  function showLevel(id, level) {
    const c = drawnOf.get(id);
    const entry = c?.levels.get(level);
    if (!entry || c.drawn === level) return false;
    for (const batch of c.batches) {
      batch.object.geometry = geometryFor(batch, entry);
      if (batch.instanced) {
        // Recomputed from the new geometry's sphere and the visible instances on the next use.
        batch.object.boundingSphere = null;
        batch.object.boundingBox = null;
      }
    }
    for (const i of manifest.instancesOf.get(id)) {
      for (const object of clearOf.get(i) ?? []) object.geometry = entry.geometry;
    }
    c.drawn = level;
    levelChanges.add(id);
    return true;
  }

  /// Disposes level `level` of component `id` (never its first); if it was drawn, the finest
  /// level it holds below it is drawn instead (else the coarsest above).
  function removeLevel(id, level) {
    const c = drawnOf.get(id);
    const entry = c?.levels.get(level);
    if (!entry || level === c.first) return false;
    if (c.drawn === level) {
      const others = [...c.levels.keys()].filter((l) => l !== level).sort((a, b) => a - b);
      showLevel(id, [...others].reverse().find((l) => l < level) ?? others[0]);
    }
    c.levels.delete(level);
    // Both geometries share the position and normal attributes: dispose them together.
    entry.geometry.dispose();
    entry.flipped?.dispose();
    return true;
  }

  /// The level component `id` is drawn at, or null when it is not drawn.
  function drawnLevel(id) {
    return drawnOf.get(id)?.drawn ?? null;
  }

  /// The levels held per component id (ascending), for tests.
  function levelsHeld(id) {
    const c = drawnOf.get(id);
    return c ? [...c.levels.keys()].sort((a, b) => a - b) : [];
  }

  /// [[id, level]] for the components whose drawn level changed since the last call.
  function takeLevelChanges() {
    const out = [...levelChanges].map((id) => [id, drawnOf.get(id).drawn]);
    levelChanges.clear();
    return out;
  }

  /// Bytes of the GPU buffers the held levels use: positions, normals and index buffers of the
  /// geometries a batch draws (refine.mjs gpuBytes estimates the same from the manifest).
  function gpuBytes() {
    let bytes = 0;
    for (const c of drawnOf.values()) {
      const plain = c.batches.some((b) => !(b.instanced && b.mirror));
      const flippedUsed = c.batches.some((b) => b.instanced && b.mirror);
      for (const { geometry, flipped } of c.levels.values()) {
        bytes += geometry.getAttribute('position').array.byteLength + geometry.getAttribute('normal').array.byteLength;
        if (plain) bytes += geometry.index.array.byteLength;
        if (flippedUsed) bytes += flipped.index.array.byteLength;
      }
    }
    return bytes;
  }

  /// Sets which parts are drawn: `visible(partId) -> boolean`.
  function setVisibility(visible) {
    partVisible = visible;
    refreshAll();
  }

  /// Highlights one part (an id; -1 for none).
  function setHighlight(partId) {
    highlighted = partId;
    refreshAll();
  }

  /// Sets how parts are drawn, in one pass over the draw objects: `visible(partId) -> boolean`,
  /// the highlighted part (-1 for none), `colors` (3 values 0..1 per part in the manifest's colour
  /// space, sRGB; null: the manifest's colours; a part whose values are not finite keeps its own)
  /// and `opacity` (one value 0..1 per part; null: all opaque). A field left undefined keeps
  /// what was set. O(instances + parts).
  function setStyle({ visible, highlight, colors, opacity }) {
    if (visible !== undefined) partVisible = visible;
    if (highlight !== undefined) highlighted = highlight;
    if (colors !== undefined) colorOverrides = colors ? manifest.parts.map((_, p) => (3 * p + 2 < colors.length ? srgbColor(colors, 3 * p) : null)) : null;
    if (opacity !== undefined) opacities = opacity ?? null;
    refreshAll();
  }

  /// The part under a three.js intersection ({ object, instanceId }), or -1.
  function partOf(hit) {
    const batch = hit.object.userData.batch;
    if (!batch) return -1;
    const instance = batch.instanced ? batch.slots[hit.instanceId] : batch.instances[0];
    return instance === undefined ? -1 : manifest.instances[instance].part;
  }

  /// The objects a raycast should test: the visible ones (batches and transparent meshes; those
  /// of a see-through instance hit its back faces and its front faces).
  function pickable() {
    const objects = batches.filter((b) => b.object.visible).map((b) => b.object);
    for (const pair of clearOf.values()) if (pair[0].visible) objects.push(...pair);
    return objects;
  }

  /// How a part is drawn: for each of its instances whether it is loaded, GPU-instanced (and the
  /// batch's size), mirrored, and the level drawn (null while not loaded).
  function drawInfo(partId) {
    return manifest.instancesOfPart[partId].map((i) => {
      const where = batchOf.get(i);
      return {
        instance: i,
        component: manifest.instances[i].component,
        loaded: !!where,
        instanced: where ? where.batch.instanced : manifest.instancesOf.get(manifest.instances[i].component).length > 1,
        batchSize: where ? where.batch.instances.length : 0,
        mirror: manifest.instances[i].mirror,
        level: where ? drawnLevel(manifest.instances[i].component) : null,
      };
    });
  }

  /// Counts over the loaded components: instances and triangles drawn (visible, at the level
  /// drawn), draw calls.
  function stats() {
    let instances = 0;
    let triangles = 0;
    let drawCalls = 0;
    for (const batch of batches) {
      if (!batch.object.visible) continue;
      const n = batch.instanced ? batch.object.count : 1;
      instances += n;
      triangles += n * manifest.componentById.get(batch.component).levels[drawnLevel(batch.component)].triangles;
      ++drawCalls;
    }
    for (const [back] of clearOf.values()) {
      if (!back.visible) continue;
      const { component } = back.userData.batch;
      ++instances;
      triangles += manifest.componentById.get(component).levels[drawnLevel(component)].triangles;
      drawCalls += 2;
    }
    return { instances, triangles, drawCalls, components: loaded.size };
  }

  return {
    addComponent, addLevel, showLevel, removeLevel, drawnLevel, levelsHeld, takeLevelChanges, gpuBytes,
    setVisibility, setHighlight, setStyle, partOpacity, partOf, pickable, drawInfo, stats, materials, batches,
  };
}
