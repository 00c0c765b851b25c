// SPDX-License-Identifier: Apache-2.0
// Picking through bounding-volume hierarchies (three-mesh-bvh): every geometry drawn gets a BVH,
// built in the render worker's idle time once the skeleton is on screen, in slices of at most
// kSliceMs, so neither the first frame, the stream nor a frame waits for it. Mesh.prototype.raycast
// becomes three-mesh-bvh's, which falls back to three.js's own for a geometry without a tree yet:
// a pick is always answered, the same, only faster once the trees are there (bench/pick_bench.mjs
// measures both on skull_mc.ply). InstancedMesh's raycast casts through a Mesh per instance, so
// batches use the trees too.
//
// Based on: three-mesh-bvh's computeBoundsTree / acceleratedRaycast extension functions, with
// `indirect` trees, which leave the geometry's index as it is (the GPU's copy, shared with the
// see-through meshes and the caps, stays valid).

import { Mesh } from 'three';
import { acceleratedRaycast, computeBoundsTree } from 'three-mesh-bvh';

Mesh.prototype.raycast = acceleratedRaycast;

const kSliceMs = 8;  // the longest run of tree building before the worker takes messages again

/// A queue of geometries to index. `add(objects)` queues the geometries of draw objects not seen
/// before; building runs in timer slices and stops by itself when the queue is empty.
export function createPickIndex() {
  const seen = new WeakSet();
  const gone = new WeakSet();  // disposed before their turn
  const queue = [];
  let timer = null;
  let built = 0;

  function step() {
    timer = null;
    const start = performance.now();
    while (queue.length && performance.now() - start < kSliceMs) {
      const geometry = queue.shift();
      if (gone.has(geometry) || geometry.boundsTree || !geometry.index || !geometry.attributes.position) continue;
      computeBoundsTree.call(geometry, { indirect: true });
      ++built;
    }
    if (queue.length) timer = setTimeout(step, 0);
  }

  return {
    add(objects) {
      for (const object of objects) {
        const { geometry } = object;
        if (!geometry || seen.has(geometry)) continue;
        seen.add(geometry);
        geometry.addEventListener('dispose', () => gone.add(geometry));
        queue.push(geometry);
      }
      if (queue.length && timer === null) timer = setTimeout(step, 0);
    },
    /// How many trees are built, and how many geometries wait.
    stats: () => ({ built, waiting: queue.length }),
  };
}
