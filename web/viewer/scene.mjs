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
/// error bound (every decoded vertex lies within it), instead of a pass over the vertices.
function meshGeometry(mesh, component) {
  const geometry = new BufferGeometry();
  if (component) {
    const grow = Math.max(component.errorBound, 0);
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

  const batches = [];                  // every draw object: { object, instances, instanced, mirror }
  const batchOf = new Map();           // instance index -> { batch, slot }
  const loaded = new Set();            // component ids drawn
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

  /// Adds a decoded component (its id and the decoder's mesh) for all its instances. Returns the
  /// draw objects made. Throws when the mesh does not match the manifest's counts.
  function addComponent(id, mesh) {
    const component = manifest.componentById.get(id);
    if (!component) throw new Error(`osteon: no component ${id} in the manifest`);
    if (loaded.has(id)) throw new Error(`osteon: component ${id}: added twice`);
    const triangles = mesh.indices.length / 3;
    if (triangles !== component.triangles) {
      throw new Error(`osteon: ${component.file} (component ${id}): decoded ${triangles} triangles, the manifest says ${component.triangles}`);
    }
    const geometry = meshGeometry(mesh, component);
    const uses = manifest.instancesOf.get(id);
    const made = [];
    if (uses.length === 1) {
      const object = new Mesh(geometry, material);
      object.matrixAutoUpdate = false;
      object.matrix.fromArray(manifest.instances[uses[0]].matrix);
      object.matrixWorldNeedsUpdate = true;  // matrixAutoUpdate is off: nothing else sets it
      object.name = id;
      made.push({ object, instances: uses, instanced: false, mirror: manifest.instances[uses[0]].mirror });
    } else {
      let flipped = null;
      for (const mirror of [false, true]) {
        const instances = uses.filter((i) => manifest.instances[i].mirror === mirror);
        if (!instances.length) continue;
        let g = geometry;
        if (mirror) {
          flipped ??= new BufferGeometry();
          flipped.boundingBox = geometry.boundingBox;
          flipped.boundingSphere = geometry.boundingSphere;
          flipped.setAttribute('position', geometry.getAttribute('position'));
          flipped.setAttribute('normal', geometry.getAttribute('normal'));
          flipped.setIndex(new BufferAttribute(flipWinding(geometry.index.array), 1));
          g = flipped;
        }
        const object = new InstancedMesh(g, instancedMaterial, instances.length);
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
    return made.map((b) => b.object);
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
  /// batch's size), mirrored.
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
      };
    });
  }

  /// Counts over the loaded components: instances and triangles drawn (visible), draw calls.
  function stats() {
    let instances = 0;
    let triangles = 0;
    let drawCalls = 0;
    for (const batch of batches) {
      if (!batch.object.visible) continue;
      const n = batch.instanced ? batch.object.count : 1;
      instances += n;
      triangles += n * manifest.componentById.get(batch.component).triangles;
      ++drawCalls;
    }
    return { instances, triangles, drawCalls, components: loaded.size };
  }

  return { addComponent, setVisibility, setHighlight, partOf, pickable, drawInfo, stats, materials, batches };
}
