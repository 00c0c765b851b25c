// SPDX-License-Identifier: Apache-2.0
#include <cstdint>
#include <vector>

#include "osteon/volume.hpp"

// A label's voxel boundary as a mesh: the exact, stair-stepped surface that a smooth surface of
// the label is measured against ("every vertex within one voxel of the label's boundary").

namespace osteon {

Result<Mesh> voxel_faces(const LabelVolume& volume, uint32_t value) {
  uint32_t id = 0;
  for (size_t d = 1; d < volume.values.size(); ++d) {
    if (volume.values[d] == value) id = static_cast<uint32_t>(d);
  }
  if (id == 0) {
    return error(ErrorCode::kInvalidArgument, volume.source,
                 "label " + std::to_string(value) + " is not present in the volume");
  }
  const int64_t nx = volume.size[0], ny = volume.size[1], nz = volume.size[2];
  auto label_at = [&](int64_t i, int64_t j, int64_t k) -> uint32_t {
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0;
    return volume.id(static_cast<size_t>(i + nx * (j + ny * k)));
  };
  const bool mirrored = determinant3(volume.index_to_world) < 0;
  Mesh mesh;
  mesh.name = "label " + std::to_string(value) + " voxel faces";
  mesh.source = volume.source;
  mesh.unit = Unit::kMillimetre;
  for (int64_t k = 0; k < nz; ++k) {
    for (int64_t j = 0; j < ny; ++j) {
      for (int64_t i = 0; i < nx; ++i) {
        if (label_at(i, j, k) != id) continue;
        for (int axis = 0; axis < 3; ++axis) {
          for (int side = -1; side <= 1; side += 2) {
            const int64_t q[3] = {i + (axis == 0 ? side : 0), j + (axis == 1 ? side : 0),
                                  k + (axis == 2 ? side : 0)};
            if (label_at(q[0], q[1], q[2]) == id) continue;
            // The face's corners, counter-clockwise seen from outside (from the neighbour).
            const int a = (axis + 1) % 3, b = (axis + 2) % 3;
            const double du[4] = {-0.5, 0.5, 0.5, -0.5}, dv[4] = {-0.5, -0.5, 0.5, 0.5};
            const uint32_t first = static_cast<uint32_t>(mesh.positions.size());
            for (int n = 0; n < 4; ++n) {
              double p[3] = {double(i), double(j), double(k)};
              p[axis] += 0.5 * side;
              p[a] += du[n];
              p[b] += dv[n];
              mesh.positions.push_back(
                  to_float(transform_point(volume.index_to_world, Vec3d{p[0], p[1], p[2]})));
            }
            // (a, b, axis) is right-handed: the quad faces +axis; flip for the - side and for a
            // mirroring transform.
            const bool flip = (side < 0) != mirrored;
            const uint32_t order[6] = {0, 1, 2, 0, 2, 3};
            for (int t = 0; t < 6; t += 3) {
              mesh.indices.push_back(first + order[t]);
              mesh.indices.push_back(first + order[flip ? t + 2 : t + 1]);
              mesh.indices.push_back(first + order[flip ? t + 1 : t + 2]);
            }
          }
        }
      }
    }
  }
  mesh.stored_vertices = mesh.positions.size();
  return mesh;
}

}  // namespace osteon
