// SPDX-License-Identifier: Apache-2.0
// Caps on a cut: where a clipping plane cuts a bone, the section is filled in the bone's colour,
// so a cut shows solid bone rather than the inside of its surface (render_three.mjs calls it).
//
// Stencil capping, one draw object (a single mesh, or one instance of an instanced batch) and one
// plane at a time, after the bones are drawn (higher renderOrder: three.js draws opaque objects in
// that order):
//   1. the object's triangles, clipped by that plane alone, with colour and depth writes off and
//      no depth test, invert the stencil: along a ray through a closed surface that is cut open,
//      an odd number of triangles is crossed exactly where the ray passes through the section;
//   2. a quad on the plane, covering the object's world bounds there and clipped by the other
//      plane, draws in the object's colour (lit as the bones are) where the stencil is not 0, with
//      the depth test on (the section is hidden by what lies in front of it);
//   3. the stencil is cleared for the next object.
// Only objects whose world bounds straddle the plane are capped (nothing is drawn for the rest,
// nor when the cut or its caps are off): the extra draw calls are two per object cut. A surface
// that is not closed may leave stray cap pixels; they stay inside its own bounds on the plane.
// Objects that are not opaque (transparent, or opacity below 1) are not capped.
//
// Based on: three.js's webgl_clipping_stencil example (stencil groups and a plane per clipping
// plane); stencil capping of cut solids as in niivue.

import {
  AlwaysStencilFunc,
  Box3,
  BufferAttribute,
  BufferGeometry,
  Color,
  DoubleSide,
  FrontSide,
  Group,
  InvertStencilOp,
  Matrix4,
  Mesh,
  MeshBasicMaterial,
  MeshStandardMaterial,
  NotEqualStencilFunc,
  Vector3,
} from 'three';

// A quad a little larger than the object's bounds on the plane: its section lies inside them.
const kQuadMargin = 1e-3;
// The caps' render order starts here: after every bone, whatever order the bones have.
const kFirstOrder = 1 << 20;

/// Creates the caps of `scene`'s cut objects, in a group of its own. Returns { setPlanes(planes,
/// on), update(batches) }: setPlanes takes the clipping planes (THREE.Plane, 1 or 2, the same
/// objects the bones' materials clip with) and whether caps are drawn; update, before each frame,
/// places the caps for scene.mjs's batches (each { object: Mesh or InstancedMesh }), testing each
/// drawn instance's world bounds (its geometry's bounding box) against each plane: O(instances
/// drawn x planes). The quad spans the bounds' shadow on the plane (their section, for a plane
/// across an axis; more, for an oblique one).
export function createCapping(scene) {
  const group = new Group();
  group.name = 'caps';
  scene.add(group);
  let planes = [];
  let capped = false;

  // Per plane: the stencil material (clipped by that plane) and the caps' (clipped by the others).
  const stencilMaterials = [];
  const capMaterials = [];
  function materialsFor(i) {
    if (!stencilMaterials[i]) {
      stencilMaterials[i] = new MeshBasicMaterial({
        side: DoubleSide,
        colorWrite: false,
        depthWrite: false,
        depthTest: false,
        stencilWrite: true,
        stencilFunc: AlwaysStencilFunc,
        stencilFail: InvertStencilOp,
        stencilZFail: InvertStencilOp,
        stencilZPass: InvertStencilOp,
      });
      // The bone material's (scene.mjs), coloured per vertex: one material serves every colour.
      capMaterials[i] = new MeshStandardMaterial({
        color: 0xffffff,
        vertexColors: true,
        roughness: 0.6,
        metalness: 0,
        side: FrontSide,
        stencilWrite: true,
        stencilRef: 0,
        stencilFunc: NotEqualStencilFunc,
      });
    }
    return [stencilMaterials[i], capMaterials[i]];
  }

  const clearStencil = (renderer) => renderer.clearStencil();
  const pool = [];  // { stencil: Mesh, cap: Mesh }, reused from frame to frame
  const none = new BufferGeometry();  // an unused stencil mesh's: it keeps no level alive
  function entry(k) {
    if (!pool[k]) {
      const stencil = new Mesh(none);
      stencil.matrixAutoUpdate = false;
      stencil.matrixWorldAutoUpdate = false;  // set directly: the instance's world matrix
      const quad = new BufferGeometry();
      for (const name of ['position', 'normal', 'color']) quad.setAttribute(name, new BufferAttribute(new Float32Array(12), 3));
      quad.setIndex([0, 1, 2, 0, 2, 3]);
      const cap = new Mesh(quad);
      cap.frustumCulled = false;
      cap.onAfterRender = clearStencil;
      pool[k] = { stencil, cap };
      group.add(stencil, cap);
    }
    return pool[k];
  }

  const box = new Box3();
  const world = new Matrix4();
  const local = new Matrix4();
  const color = new Color();
  const instanceColor = new Color();
  const u = new Vector3();
  const v = new Vector3();
  const origin = new Vector3();
  const corner = new Vector3();
  const point = new Vector3();

  /// Whether all of `box` lies on the side `plane` cuts away.
  function removedBy(plane, b) {
    const n = plane.normal;
    corner.set(n.x > 0 ? b.max.x : b.min.x, n.y > 0 ? b.max.y : b.min.y, n.z > 0 ? b.max.z : b.min.z);
    return plane.distanceToPoint(corner) < 0;
  }

  /// Writes the quad of `plane` over `b` (world bounds) into `geometry`, facing the side cut away,
  /// in `rgb`.
  function placeQuad(geometry, plane, b, rgb) {
    const n = plane.normal;
    // Two directions in the plane, and its point nearest the origin.
    const ax = Math.abs(n.x);
    const ay = Math.abs(n.y);
    const az = Math.abs(n.z);
    u.set(ax <= ay && ax <= az ? 1 : 0, ay < ax && ay <= az ? 1 : 0, az < ax && az < ay ? 1 : 0).cross(n).normalize();
    v.crossVectors(n, u);
    origin.copy(n).multiplyScalar(-plane.constant);
    // The box's extent along them.
    let a0 = Infinity;
    let a1 = -Infinity;
    let b0 = Infinity;
    let b1 = -Infinity;
    for (let i = 0; i < 8; ++i) {
      corner.set(i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y, i & 4 ? b.max.z : b.min.z);
      const a = corner.dot(u);
      const c = corner.dot(v);
      a0 = Math.min(a0, a);
      a1 = Math.max(a1, a);
      b0 = Math.min(b0, c);
      b1 = Math.max(b1, c);
    }
    const grow = kQuadMargin * Math.max(a1 - a0, b1 - b0, 1e-6);
    a0 -= grow;
    a1 += grow;
    b0 -= grow;
    b1 += grow;
    // Wound clockwise around n: its front faces the side cut away, where the section is seen from.
    const positions = geometry.getAttribute('position');
    const normals = geometry.getAttribute('normal');
    const colors = geometry.getAttribute('color');
    [[a0, b0], [a0, b1], [a1, b1], [a1, b0]].forEach(([a, c], k) => {
      point.copy(origin).addScaledVector(u, a).addScaledVector(v, c);
      positions.setXYZ(k, point.x, point.y, point.z);
      normals.setXYZ(k, -n.x, -n.y, -n.z);
      colors.setXYZ(k, rgb.r, rgb.g, rgb.b);
    });
    positions.needsUpdate = true;
    normals.needsUpdate = true;
    colors.needsUpdate = true;
  }

  return {
    setPlanes(next, on) {
      planes = next;
      capped = on && next.length > 0;
      planes.forEach((plane, i) => {
        const [stencil, cap] = materialsFor(i);
        const others = planes.filter((p) => p !== plane);
        if ((cap.clippingPlanes?.length ?? 0) !== others.length) cap.needsUpdate = true;
        if ((stencil.clippingPlanes?.length ?? 0) !== 1) stencil.needsUpdate = true;
        stencil.clippingPlanes = [plane];
        cap.clippingPlanes = others;
      });
    },

    update(batches) {
      let used = 0;
      if (capped) {
        planes.forEach((plane, i) => {
          const [stencilMaterial, capMaterial] = materialsFor(i);
          const others = planes.filter((p) => p !== plane);
          for (const { object } of batches) {
            const { material, geometry } = object;
            if (!object.visible || material.transparent || material.opacity < 1) continue;
            if (!geometry.boundingBox) geometry.computeBoundingBox();
            object.updateWorldMatrix(true, false);
            const count = object.isInstancedMesh ? object.count : 1;
            for (let slot = 0; slot < count; ++slot) {
              world.copy(object.matrixWorld);
              if (object.isInstancedMesh) world.multiply(object.getMatrixAt(slot, local));
              box.copy(geometry.boundingBox).applyMatrix4(world);
              if (!plane.intersectsBox(box) || others.some((p) => removedBy(p, box))) continue;
              color.copy(material.color);
              if (object.isInstancedMesh && object.instanceColor) color.multiply(object.getColorAt(slot, instanceColor));
              const { stencil, cap } = entry(used);
              stencil.geometry = geometry;
              stencil.material = stencilMaterial;
              stencil.matrixWorld.copy(world);
              cap.material = capMaterial;
              placeQuad(cap.geometry, plane, box, color);
              // After every bone, and each object's stencil right before its cap.
              stencil.renderOrder = kFirstOrder + 2 * used;
              cap.renderOrder = kFirstOrder + 2 * used + 1;
              stencil.visible = true;
              cap.visible = true;
              ++used;
            }
          }
        });
      }
      for (let k = used; k < pool.length; ++k) {
        pool[k].stencil.visible = false;
        pool[k].stencil.geometry = none;
        pool[k].cap.visible = false;
      }
    },
  };
}
