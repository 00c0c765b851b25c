// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"
#include "osteon/volume.hpp"

// What the surfaces of a label volume share (src/surface_nets.cpp extracts and smooths them,
// src/simplify_surfaces.cpp simplifies them patch by patch): the nets as extraction leaves them,
// the simplifier's entry point and the closed-manifold check both use.

namespace osteon::detail {

/// Marks a dense label id that is not extracted (SurfaceOptions::labels leaves it out).
inline constexpr uint32_t kNotSelected = UINT32_MAX;

/// One selected label's surface net, before simplification.
struct LabelNet {
  uint32_t id = 0;  ///< the label's dense id in the volume
  Mesh mesh;        ///< closed, oriented outwards, manifold
  /// Per triangle: the dense id of the region on its other side (0: background, which includes
  /// outside the volume). For two selected labels L and M, the triangles of L whose other side is
  /// M and those of M whose other side is L are the same triangles, listed in the same order:
  /// corners (0, 1, 2) of L's are corners (0, 2, 1) of M's, at bit-identical positions.
  std::vector<uint32_t> other;
};

/// What simplify_nets did.
struct SimplifyReport {
  size_t patches = 0;  ///< surface pieces between two regions, each simplified once
  /// Patches whose simplified form broke a mesh's closed manifold somewhere, and that were
  /// simplified again with the extracted triangles round those places kept.
  size_t frozen_patches = 0;
  /// Patches given up: kept whole as extracted (freezing did not help, or they would vanish).
  size_t unsimplified = 0;
};

/// Simplifies every net in place, patch by patch: a patch is the part of a label's surface that
/// faces one other region. Each patch is simplified once (meshopt_simplify, borders locked, error
/// bound `precision` in mesh units) and used by both labels it separates, so touching labels
/// keep one shared boundary. `output_of_id[id]` is the index in `nets` of dense id `id`, or
/// kNotSelected. Where a simplified patch breaks a mesh's closed manifold, the extracted
/// triangles round the place are kept and the rest simplified again (SimplifyReport). Drops the
/// vertices no triangle uses any more (the survivors keep their order) and sets `other` for the
/// simplified triangles (the rule above holds for them too).
/// Runs on the calling thread's task arena.
SimplifyReport simplify_nets(std::vector<LabelNet>& nets, const std::vector<uint32_t>& output_of_id,
                             double precision);

/// True when the triangles form closed, consistently oriented, edge- and vertex-manifold
/// surfaces: every half-edge (a, b) occurs once and its twin (b, a) once, no triangle repeats a
/// vertex, and the triangles around each vertex form one fan. Appends to `bad` (when not null)
/// the vertices where that fails, each at most a few times. O(n log n) for n indices.
bool is_closed_manifold(const std::vector<uint32_t>& indices, std::vector<uint32_t>* bad);

/// extract_surfaces, also reporting what simplification did and, per surface and triangle, the
/// label value on the triangle's other side (0: background); either may be null.
Result<std::vector<LabelSurface>> extract_surfaces(
    const LabelVolume& volume, const SurfaceOptions& options, SimplifyReport* report,
    std::vector<std::vector<uint32_t>>* sides = nullptr);

}  // namespace osteon::detail
