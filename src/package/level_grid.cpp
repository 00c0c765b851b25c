// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/mesh.hpp"
#include "package/package_internal.hpp"

// How a coarser level of detail is stored: on a grid as coarse as its distance from the full level
// allows. A level 0.4 mm off need not keep 0.05 mm, and each doubling of the step saves about
// three bits a vertex. A vertex may move by up to twice the level's distance: pack measures the
// quantized level, whose error is then about 1.1 times the distance, and the coarsest levels of
// BodyParts3D and MyoSim take 12-14% fewer bytes than with a move of at most the distance. A part
// that is one component stores the level on a coarser grid; the pieces of a segmented part must
// meet exactly at every mix of levels, so there only the vertices off the piece's border move,
// onto a coarser lattice of the part's own grid, and the geometry coder's lattice coding
// (docs/FORMAT.md, "Geometry section") codes their coordinates in lattice periods.

namespace osteon::detail {

double level_step(double step, double distance) {
  double coarse = step;
  for (int doublings = 0; doublings < 16 && std::sqrt(3.0) * coarse <= 2 * distance; ++doublings) {
    coarse *= 2;
  }
  return coarse;
}

std::vector<uint8_t> border_vertices(const Mesh& mesh) {
  // Each edge as (smaller id, larger id); an edge used by other than two triangles is a border.
  std::vector<uint64_t> edges;
  edges.reserve(mesh.indices.size());
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = mesh.indices[3 * t + k], b = mesh.indices[3 * t + (k + 1) % 3];
      edges.push_back(uint64_t{std::min(a, b)} << 32 | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<uint8_t> border(mesh.positions.size(), 0);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2) border[edges[i] >> 32] = border[uint32_t(edges[i])] = 1;
    i = j;
  }
  return border;
}

Mesh snap_inside_border(const Mesh& mesh, const QuantizationGrid& grid, uint32_t period) {
  Mesh out = mesh;
  const std::vector<uint8_t> border = border_vertices(mesh);
  const double spacing = grid.step * period;
  // The nearest plane, as a whole number of grid steps, written as dequantize() writes a position,
  // so that the encoder's quantization finds that number of steps again, exactly.
  auto snap = [&](float& coordinate, float origin) {
    const double steps = double(std::llround((double(coordinate) - origin) / spacing)) * period;
    coordinate = static_cast<float>(origin + steps * grid.step);
  };
  for (size_t v = 0; v < out.positions.size(); ++v) {
    if (border[v]) continue;
    snap(out.positions[v].x, grid.origin.x);
    snap(out.positions[v].y, grid.origin.y);
    snap(out.positions[v].z, grid.origin.z);
  }
  // A triangle that snapping made degenerate (two corners on one lattice point, or all three on
  // one line) is one the encoder drops, which would open a hole that the other pieces' borders
  // no longer match: its snapped corners go back where they were (off the lattice, which the
  // lattice coding allows per coordinate), until no such triangle is left. Each pass puts back
  // at least one vertex, and with all of them back the mesh is the input.
  for (bool restored = true; restored;) {
    restored = false;
    for (size_t t = 0; t < out.triangle_count(); ++t) {
      if (!is_degenerate_triangle(out, t) || is_degenerate_triangle(mesh, t)) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = out.indices[3 * t + k];
        if (border[v] || out.positions[v] == mesh.positions[v]) continue;
        out.positions[v] = mesh.positions[v];
        restored = true;
      }
    }
  }
  return out;
}

}  // namespace osteon::detail
