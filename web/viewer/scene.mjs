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
// Based on: three.js InstancedMesh and Mesh (matrixWorld.determinant() < 0 -> flipped front face).

import {
  Box3,
  BufferAttribute,
  BufferGeometry,
  Color,
  DoubleSide,
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
  const partMaterials = new Map();     // part id -> [material, highlighted]

  function partColor(partId) {
    const rgb = manifest.parts[partId].color;
    return rgb ? new Color().setRGB(rgb[0], rgb[1], rgb[2], SRGBColorSpace) : boneColor;
  }

  function materialOf(partId, highlight) {
    if (!manifest.parts[partId].color) return highlight ? highlightMaterial : material;
    let pair = partMaterials.get(partId);
    if (!pair) {
      const own = material.clone();
      own.color.copy(partColor(partId));
      const lit = own.clone();
      lit.color.multiply(kHighlight);
      pair = [own, lit];
      partMaterials.set(partId, pair);
      materials.push(own, lit);
    }
    return pair[highlight ? 1 : 0];
  }

  const batches = [];                  // every draw object: { object, instances, instanced, mirror, component }
  const batchOf = new Map();           // instance index -> { batch, slot }
  const loaded = new Set();            // component ids drawn
  const drawnOf = new Map();           // component id -> { batches, levels: Map level -> { geometry, flipped }, drawn, first }
  const levelChanges = new Set();      // component ids whose drawn level changed since takeLevelChanges()
  let partVisible = () => true;
  let highlighted = -1;                // part id
  const matrix = new Matrix4();

  function instanceVisible(i) {
    return partVisible(manifest.instances[i].part);
  }

  /// Writes an InstancedMesh's visible instances into its first slots and sets its count.
  function pack(batch) {
    const { object } = batch;
    batch.slots = batch.instances.filter(instanceVisible);
    batch.slots.forEach((i, slot) => {
      object.setMatrixAt(slot, matrix.fromArray(manifest.instances[i].matrix));
      const part = manifest.instances[i].part;
      const color = partColor(part);
      object.setColorAt(slot, part === highlighted ? color.clone().multiply(kHighlight) : color);
      batchOf.set(i, { batch, slot });
    });
    object.count = batch.slots.length;
    object.visible = object.count > 0;
    object.instanceMatrix.needsUpdate = true;
    if (object.instanceColor) object.instanceColor.needsUpdate = true;
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
      batch.object.material = materialOf(part, part === highlighted);
    }
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
      if (!batch.instanced) batchOf.set(batch.instances[0], { batch, slot: 0 });
      refresh(batch);
      root.add(batch.object);
    }
    loaded.add(id);
    drawnOf.set(id, { batches: made, levels: new Map([[level, entry]]), drawn: level, first: level, mirrored });
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
    for (const batch of batches) refresh(batch);
  }

  /// Highlights one part (an id; -1 for none).
  function setHighlight(partId) {
    highlighted = partId;
    for (const batch of batches) refresh(batch);
  }

  /// The part under a three.js intersection ({ object, instanceId }), or -1.
  function partOf(hit) {
    const batch = hit.object.userData.batch;
    if (!batch) return -1;
    const instance = batch.instanced ? batch.slots[hit.instanceId] : batch.instances[0];
    return instance === undefined ? -1 : manifest.instances[instance].part;
  }

  /// The objects a raycast should test: the visible ones.
  function pickable() {
    return batches.filter((b) => b.object.visible).map((b) => b.object);
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
    return { instances, triangles, drawCalls, components: loaded.size };
  }

  return {
    addComponent, addLevel, showLevel, removeLevel, drawnLevel, levelsHeld, takeLevelChanges, gpuBytes,
    setVisibility, setHighlight, partOf, pickable, drawInfo, stats, materials, batches,
  };
}
