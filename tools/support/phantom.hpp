// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"

// Generated meshes with known truth: the primitives every test suite loops over (closed, open,
// genus > 0, non-manifold, multi-component, degenerate; geometry-central's MeshAssetSuite) and a
// synthetic "phantom" skeleton that stands in for ../shared/data when it is absent.

namespace osteon {

/// A closed genus-0 sphere: an icosahedron subdivided `subdivisions` times (20 * 4^s triangles),
/// projected to `radius`, centred at the origin, outward-facing.
Mesh make_icosphere(int subdivisions, float radius = 1.0f);
/// A closed genus-1 torus in the XY plane: `major` x `minor` quads split into triangles.
Mesh make_torus(float major_radius, float minor_radius, int major_segments, int minor_segments);
/// An open tube along Z (two boundary loops, genus 0): `segments` around, `rings` along.
Mesh make_open_cylinder(float radius, float height, int segments, int rings);
/// A closed axis-aligned box split into 12 triangles.
Mesh make_box(Vec3 min, Vec3 max);
/// Three quads sharing one edge (a "book" of three pages): one non-manifold edge, 6 triangles.
Mesh make_nonmanifold_book();
/// Two closed tetrahedra that share exactly one vertex (a non-manifold vertex, one component).
Mesh make_bowtie_tetrahedra();

/// What a phantom part is, so tests know the truth without re-deriving it.
enum class PhantomKind {
  kOriginal,      ///< a unique shape
  kExactCopy,     ///< the original's vertices moved (translated) by `transform`
  kRotatedCopy,   ///< rotated and translated
  kMirroredCopy,  ///< reflected (determinant -1), winding flipped so it still faces outward
  kNoisyCopy,     ///< rotated and translated, plus seeded noise of at most `noise` per vertex
  kWithHoles,     ///< an open surface (boundary loops)
  kGenusOne,      ///< a torus-like part (one handle)
  kNonManifold,   ///< a part with non-manifold edges
};

struct PhantomPart {
  std::string name;
  PhantomKind kind = PhantomKind::kOriginal;
  /// For copies: the part it copies, and the column-major 4x4 matrix that maps the original's
  /// vertices onto the copy's (before noise). Identity and empty for the others.
  std::string copy_of;
  std::array<double, 16> transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  float noise = 0.0f;
  int boundary_loops = 0;
  int genus = 0;  ///< -1 for non-manifold parts, where diagnose() reports none
  int nonmanifold_edges = 0;
};

struct PhantomOptions {
  /// Seeds the noise of the noisy copies; shapes and truth do not depend on it.
  uint64_t seed = 1;
  /// Subdivision level of the bone shapes, clamped to [1, 6]: 2 gives about 1k triangles a
  /// bone, 3 about 4k.
  int detail = 3;
};

struct Phantom {
  Scene scene;  ///< parts in millimetres, named like bones ("femur_l", "femur_r", ...)
  std::vector<PhantomPart> truth;  ///< one entry per scene part, same order
};

/// A deterministic synthetic skeleton (same options, same bytes) of named parts with known truth:
/// unique bone-like shapes, exact, rotated, mirrored and noisy copies, parts with holes, a genus-1
/// part and a non-manifold part.
Phantom make_phantom(const PhantomOptions& options = {});

}  // namespace osteon
