// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "fixtures.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"
#include "osteon/volume.hpp"
#include "surface_internal.hpp"

// extract_surfaces (src/surface_nets.cpp, src/simplify_surfaces.cpp) on synthetic label volumes:
// closed, oriented, manifold surfaces of the right topology and volume, touching labels sharing
// their boundary exactly, every vertex within one voxel of its label's boundary.

namespace osteon {
namespace {
namespace surface_nets_test {

constexpr double kPi = 3.14159265358979323846;

using LabelOf = std::function<uint32_t(int, int, int)>;

/// A volume of dense ids label(i, j, k), each id d standing for label value 10 * d (so values
/// and ids differ), one byte a voxel (two with `wide`).
LabelVolume make_volume(int nx, int ny, int nz, const LabelOf& label, bool wide = false) {
  LabelVolume v;
  v.size = {uint32_t(nx), uint32_t(ny), uint32_t(nz)};
  v.bytes_per_voxel = wide ? 2 : 1;
  v.voxels.resize(v.voxel_count() * size_t(v.bytes_per_voxel));
  uint32_t top = 0;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const uint32_t d = label(i, j, k);
        const size_t index = size_t(i) + size_t(nx) * (size_t(j) + size_t(ny) * size_t(k));
        if (wide) {
          v.voxels[2 * index] = uint8_t(d & 0xFF);
          v.voxels[2 * index + 1] = uint8_t(d >> 8);
        } else {
          v.voxels[index] = uint8_t(d);
        }
        top = std::max(top, d);
      }
    }
  }
  for (uint32_t d = 1; d <= top; ++d) v.values.push_back(10 * d);
  return v;
}

std::vector<LabelSurface> extract_or_fail(const LabelVolume& volume,
                                          const SurfaceOptions& options = {},
                                          detail::SimplifyReport* report = nullptr) {
  auto result = detail::extract_surfaces(volume, options, report);
  EXPECT_TRUE(result.ok()) << result.status().message();
  return result.ok() ? std::move(result).value() : std::vector<LabelSurface>{};
}

/// Closed, consistently oriented, edge- and vertex-manifold, no degenerate triangle, facing
/// outwards (each component, or, where a label may enclose cavities, the whole).
void expect_closed_manifold(const Mesh& mesh, const std::string& what,
                            bool cavities_possible = false) {
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_GT(r.triangles, 0u) << what;
  EXPECT_EQ(r.boundary_edges, 0u) << what;
  EXPECT_EQ(r.nonmanifold_edges, 0u) << what;
  EXPECT_EQ(r.nonmanifold_vertices, 0u) << what;
  EXPECT_EQ(r.inconsistent_edges, 0u) << what;
  EXPECT_EQ(r.degenerate_triangles, 0u) << what;
  EXPECT_EQ(r.unreferenced_vertices, 0u) << what;
  EXPECT_TRUE(r.closed && r.oriented) << what;
  EXPECT_TRUE(detail::is_closed_manifold(mesh.indices, nullptr)) << what;
  EXPECT_GT(r.volume, 0) << what << ": faces inwards";
  if (cavities_possible) return;
  for (const ComponentReport& c : r.component_reports) {
    EXPECT_GT(c.volume, 0) << what << ": a component faces inwards";
  }
}

/// Distance from p to the unit voxel face centred at `centre`, perpendicular to `axis`.
double face_distance(const Vec3d& p, const Vec3d& centre, int axis) {
  const double d[3] = {p.x - centre.x, p.y - centre.y, p.z - centre.z};
  double sum = 0;
  for (int a = 0; a < 3; ++a) {
    const double out = a == axis ? d[a] : std::max(0.0, std::abs(d[a]) - 0.5);
    sum += out * out;
  }
  return std::sqrt(sum);
}

/// The largest distance from a vertex of `mesh` (in index coordinates: identity transform) to
/// the nearest voxel face between dense id `id` and another region.
double max_distance_to_label_boundary(const Mesh& mesh, const LabelOf& label, uint32_t id,
                                      const std::array<int, 3>& size) {
  auto at = [&](int i, int j, int k) {
    if (i < 0 || j < 0 || k < 0 || i >= size[0] || j >= size[1] || k >= size[2]) return 0u;
    return label(i, j, k);
  };
  double worst = 0;
  for (const Vec3& v : mesh.positions) {
    const Vec3d p = to_double(v);
    double best = std::numeric_limits<double>::infinity();
    const int ci = int(std::floor(p.x)), cj = int(std::floor(p.y)), ck = int(std::floor(p.z));
    for (int k = ck - 2; k <= ck + 3; ++k) {
      for (int j = cj - 2; j <= cj + 3; ++j) {
        for (int i = ci - 2; i <= ci + 3; ++i) {
          for (int axis = 0; axis < 3; ++axis) {
            const int di = axis == 0, dj = axis == 1, dk = axis == 2;
            const uint32_t a = at(i, j, k), b = at(i + di, j + dj, k + dk);
            if (a == b || (a != id && b != id)) continue;
            const Vec3d centre{i + 0.5 * di, j + 0.5 * dj, k + 0.5 * dk};
            best = std::min(best, face_distance(p, centre, axis));
          }
        }
      }
    }
    worst = std::max(worst, best);
  }
  return worst;
}

/// Oriented triangles as position triples, each rotated to start at its smallest corner.
using Triangle = std::array<float, 9>;
Triangle canonical(const Vec3& a, const Vec3& b, const Vec3& c) {
  std::array<Vec3, 3> v{a, b, c};
  auto less = [](const Vec3& x, const Vec3& y) {
    return std::tie(x.x, x.y, x.z) < std::tie(y.x, y.y, y.z);
  };
  int first = 0;
  for (int k = 1; k < 3; ++k) {
    if (less(v[k], v[first])) first = k;
  }
  Triangle t;
  for (int k = 0; k < 3; ++k) {
    const Vec3& p = v[(first + k) % 3];
    t[3 * k] = p.x, t[3 * k + 1] = p.y, t[3 * k + 2] = p.z;
  }
  return t;
}

struct PositionLess {
  bool operator()(const Vec3& a, const Vec3& b) const {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  }
};

/// Triangles of `a` whose three corners are all positions of `b`, reversed (as `b` holds them).
std::multiset<Triangle> shared_triangles(const Mesh& a, const Mesh& b, bool reverse) {
  std::set<Vec3, PositionLess> in_b(b.positions.begin(), b.positions.end());
  std::multiset<Triangle> out;
  for (size_t t = 0; t < a.triangle_count(); ++t) {
    const Vec3& p = a.positions[a.indices[3 * t]];
    const Vec3& q = a.positions[a.indices[3 * t + 1]];
    const Vec3& r = a.positions[a.indices[3 * t + 2]];
    if (!in_b.count(p) || !in_b.count(q) || !in_b.count(r)) continue;
    out.insert(reverse ? canonical(p, r, q) : canonical(p, q, r));
  }
  return out;
}

/// The triangles of surface `a` whose other side is label `b_value`, as oriented position
/// triples (reversed when `reverse`).
std::multiset<Triangle> facing(const Mesh& a, const std::vector<uint32_t>& sides, uint32_t b_value,
                               bool reverse) {
  std::multiset<Triangle> out;
  for (size_t t = 0; t < a.triangle_count(); ++t) {
    if (sides[t] != b_value) continue;
    const Vec3& p = a.positions[a.indices[3 * t]];
    const Vec3& q = a.positions[a.indices[3 * t + 1]];
    const Vec3& r = a.positions[a.indices[3 * t + 2]];
    out.insert(reverse ? canonical(p, r, q) : canonical(p, q, r));
  }
  return out;
}

/// Every pair of surfaces holds their shared boundary triangle for triangle, oppositely wound.
void expect_shared_boundaries(const LabelVolume& volume, const SurfaceOptions& options,
                              const std::string& what) {
  std::vector<std::vector<uint32_t>> sides;
  auto result = detail::extract_surfaces(volume, options, nullptr, &sides);
  ASSERT_TRUE(result.ok());
  const auto& surfaces = result.value();
  ASSERT_EQ(sides.size(), surfaces.size());
  for (size_t a = 0; a < surfaces.size(); ++a) {
    ASSERT_EQ(sides[a].size(), surfaces[a].mesh.triangle_count());
    for (size_t b = a + 1; b < surfaces.size(); ++b) {
      const auto from_a = facing(surfaces[a].mesh, sides[a], surfaces[b].value, true);
      const auto from_b = facing(surfaces[b].mesh, sides[b], surfaces[a].value, false);
      EXPECT_EQ(from_a, from_b) << what << ": labels " << surfaces[a].value << " and "
                                << surfaces[b].value;
    }
  }
}

// ---- the volumes ------------------------------------------------------------------------------

constexpr double kSphereRadius = 10;
constexpr int kSphereSize = 28;
constexpr double kSphereCentre = 13.5;

uint32_t sphere(int i, int j, int k) {
  const double x = i - kSphereCentre, y = j - kSphereCentre, z = k - kSphereCentre;
  return x * x + y * y + z * z <= kSphereRadius * kSphereRadius ? 1 : 0;
}

// Label 1 in x 2..6, label 2 in x 7..11 (touching at a face), both y 2..9, z 3..8.
uint32_t two_boxes(int i, int j, int k) {
  if (j < 2 || j > 9 || k < 3 || k > 8) return 0;
  if (i >= 2 && i <= 6) return 1;
  if (i >= 7 && i <= 11) return 2;
  return 0;
}

uint32_t torus(int i, int j, int k) {
  const double x = i - 12.5, y = j - 12.5, z = k - 5.5;
  const double ring = std::sqrt(x * x + y * y) - 8;
  return ring * ring + z * z <= 9 ? 1 : 0;
}

/// Dense ids from a seeded generator: each voxel background with probability 1 - fill, else
/// one of `labels` labels.
LabelOf random_labels(int size, int labels, double fill, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  auto ids = std::make_shared<std::vector<uint32_t>>(size_t(size) * size * size);
  for (uint32_t& d : *ids) d = u(rng) < fill ? 1 + uint32_t(u(rng) * labels) % labels : 0;
  return [ids, size](int i, int j, int k) {
    return (*ids)[size_t(i) + size_t(size) * (size_t(j) + size_t(size) * size_t(k))];
  };
}

// ---- tests --------------------------------------------------------------------------------------

TEST(SurfaceNets, SphereIsClosedGenusZeroOutwardWithTheRightVolume) {
  const LabelVolume volume = make_volume(kSphereSize, kSphereSize, kSphereSize, sphere);
  const auto surfaces = extract_or_fail(volume);
  ASSERT_EQ(surfaces.size(), 1u);
  const Mesh& mesh = surfaces[0].mesh;
  expect_closed_manifold(mesh, "sphere");
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus, 0);
  const double expected = 4.0 / 3.0 * kPi * std::pow(kSphereRadius, 3);
  EXPECT_NEAR(r.volume, expected, 0.03 * expected);
  double worst = 0;
  for (const Vec3& v : mesh.positions) {
    const Vec3d d = to_double(v) - Vec3d{kSphereCentre, kSphereCentre, kSphereCentre};
    worst = std::max(worst, std::abs(length(d) - kSphereRadius));
  }
  EXPECT_LE(worst, 1.0) << "a vertex is over a voxel from the analytic sphere";
  EXPECT_EQ(surfaces[0].triangles_extracted, mesh.triangle_count());
  EXPECT_EQ(surfaces[0].value, 10u);
  EXPECT_EQ(mesh.name, "label 10");
}

TEST(SurfaceNets, RawNetIsTheVoxelBoundary) {
  // Without smoothing every vertex is a cell centre, so the net encloses exactly the voxels.
  const LabelVolume volume = make_volume(kSphereSize, kSphereSize, kSphereSize, sphere);
  SurfaceOptions options;
  options.smoothing_iterations = 0;
  const auto surfaces = extract_or_fail(volume, options);
  ASSERT_EQ(surfaces.size(), 1u);
  expect_closed_manifold(surfaces[0].mesh, "raw sphere");
  uint64_t voxels = 0;
  for (uint8_t v : volume.voxels) voxels += v;
  EXPECT_NEAR(diagnose(surfaces[0].mesh).volume, double(voxels), 1e-6 * double(voxels));
}

TEST(SurfaceNets, EveryVertexIsWithinOneVoxelOfItsLabelBoundary) {
  struct Case {
    const char* name;
    int size;
    LabelOf label;
  };
  const Case cases[] = {
      {"sphere", kSphereSize, sphere},
      {"two boxes", 14, two_boxes},
      {"torus", 26, torus},
      {"random", 12, random_labels(12, 3, 0.5, 7)},
  };
  for (const Case& c : cases) {
    const LabelVolume volume = make_volume(c.size, c.size, c.size, c.label);
    const auto surfaces = extract_or_fail(volume);
    for (size_t o = 0; o < surfaces.size(); ++o) {
      const double worst = max_distance_to_label_boundary(
          surfaces[o].mesh, c.label, uint32_t(o + 1), {c.size, c.size, c.size});
      EXPECT_LE(worst, 1.0) << c.name << ", label " << o + 1;
    }
  }
}

TEST(SurfaceNets, TouchingBoxesShareTheirInterfaceExactly) {
  const LabelVolume volume = make_volume(14, 12, 12, two_boxes);
  const auto surfaces = extract_or_fail(volume);
  ASSERT_EQ(surfaces.size(), 2u);
  const Mesh& one = surfaces[0].mesh;
  const Mesh& two = surfaces[1].mesh;
  expect_closed_manifold(one, "box 1");
  expect_closed_manifold(two, "box 2");
  EXPECT_EQ(diagnose(one).genus, 0);
  EXPECT_EQ(diagnose(two).genus, 0);
  // Every vertex of box 1 in the cells between x = 6 and x = 7 is a vertex of box 2, bit for bit.
  std::set<Vec3, PositionLess> in_two(two.positions.begin(), two.positions.end());
  size_t interface = 0;
  for (const Vec3& p : one.positions) {
    if (p.x <= 6 || p.x >= 7) continue;
    ++interface;
    EXPECT_TRUE(in_two.count(p)) << p.x << " " << p.y << " " << p.z;
  }
  EXPECT_GE(interface, size_t(8 * 6));
  // The interface triangles are the same in both, oppositely wound: no gap, no overlap.
  const auto from_one = shared_triangles(one, two, true);
  const auto from_two = shared_triangles(two, one, false);
  EXPECT_EQ(from_one, from_two);
  EXPECT_GE(from_one.size(), size_t(2 * 8 * 6));
  expect_shared_boundaries(volume, {}, "boxes");
  // The interface stays flat: cells on it and on its rim (where it meets the background, a
  // junction line) are smoothed only within the interface's plane.
  for (const Mesh* mesh : {&one, &two}) {
    for (const Vec3& p : mesh->positions) {
      if (p.x > 6 && p.x < 7) {
        EXPECT_EQ(p.x, 6.5f);
      }
    }
  }
}

TEST(SurfaceNets, TorusHasGenusOne) {
  const LabelVolume volume = make_volume(26, 26, 12, torus);
  const auto surfaces = extract_or_fail(volume);
  ASSERT_EQ(surfaces.size(), 1u);
  expect_closed_manifold(surfaces[0].mesh, "torus");
  const DiagnosisReport r = diagnose(surfaces[0].mesh);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus, 1);
}

TEST(SurfaceNets, VoxelsTouchingByAnEdgeOrACornerAreSplit) {
  // Two voxels sharing only an edge, and two sharing only a corner: each voxel its own closed
  // cube, the shared cell's vertex split in two.
  const std::vector<std::array<int, 3>> second = {{3, 3, 2}, {3, 3, 3}};
  for (const auto& s : second) {
    const LabelVolume volume = make_volume(6, 6, 6, [&](int i, int j, int k) {
      return (i == 2 && j == 2 && k == 2) || (i == s[0] && j == s[1] && k == s[2]) ? 1u : 0u;
    });
    for (int iterations : {0, 16}) {
      SurfaceOptions options;
      options.smoothing_iterations = iterations;
      const auto surfaces = extract_or_fail(volume, options);
      ASSERT_EQ(surfaces.size(), 1u);
      const std::string what = s[2] == 2 ? "edge pair" : "corner pair";
      expect_closed_manifold(surfaces[0].mesh, what);
      const DiagnosisReport r = diagnose(surfaces[0].mesh);
      EXPECT_EQ(r.components, 2u) << what;
      EXPECT_EQ(r.genus, 0) << what;
      // The split vertices are distinct points: welding by position keeps the mesh manifold.
      Mesh welded = surfaces[0].mesh;
      EXPECT_EQ(weld(welded).vertices_after, welded.positions.size());
      EXPECT_EQ(welded.positions.size(), surfaces[0].mesh.positions.size()) << what;
    }
  }
}

TEST(SurfaceNets, HandleThroughASingleEdgeStaysManifold) {
  // Voxels (1,1,2) and (2,2,2) touch by an edge; the label loops round that edge through the
  // slices above and below, so separating the two voxels would leave a handle whose hole is the
  // edge itself: no room for a manifold mesh. That face joins them instead.
  const std::set<std::array<int, 3>> on = {{1, 1, 2}, {2, 2, 2}, {1, 1, 3}, {1, 2, 3},
                                           {2, 2, 3}, {1, 1, 1}, {1, 2, 1}, {2, 2, 1}};
  const LabelVolume volume = make_volume(5, 5, 5, [&](int i, int j, int k) {
    return on.count({i, j, k}) ? 1u : 0u;
  });
  const auto surfaces = extract_or_fail(volume);
  ASSERT_EQ(surfaces.size(), 1u);
  expect_closed_manifold(surfaces[0].mesh, "edge handle");
  EXPECT_EQ(diagnose(surfaces[0].mesh).components, 1u);
}

TEST(SurfaceNets, RandomLabelsGiveClosedManifolds) {
  // Noise is the hard case: every ambiguous face and cell configuration occurs.
  for (uint32_t seed = 1; seed <= 12; ++seed) {
    const int labels = 1 + int(seed % 4);
    const double fill = 0.3 + 0.05 * (seed % 8);
    const LabelVolume volume =
        make_volume(10, 10, 10, random_labels(10, labels, fill, seed), seed % 2 == 0);
    for (double precision : {0.0, 1.0}) {
      SurfaceOptions options;
      options.precision = precision;
      detail::SimplifyReport report;
      const auto surfaces = extract_or_fail(volume, options, &report);
      expect_shared_boundaries(volume, options, "seed " + std::to_string(seed));
      for (const LabelSurface& s : surfaces) {
        expect_closed_manifold(s.mesh,
                               "seed " + std::to_string(seed) + ", label " +
                                   std::to_string(s.value) + ", precision " +
                                   std::to_string(precision),
                               true);
      }
    }
  }
}

TEST(SurfaceNets, LabelAtTheVolumeEdgeIsClosed) {
  // A box touching three sides of the volume, and a volume that is all one label.
  const LabelVolume corner =
      make_volume(8, 8, 8, [](int i, int j, int k) { return i < 5 && j < 4 && k >= 3 ? 1u : 0u; });
  const LabelVolume full = make_volume(4, 5, 6, [](int, int, int) { return 1u; });
  for (const LabelVolume* volume : {&corner, &full}) {
    const auto surfaces = extract_or_fail(*volume);
    ASSERT_EQ(surfaces.size(), 1u);
    expect_closed_manifold(surfaces[0].mesh, "at the edge");
    EXPECT_EQ(diagnose(surfaces[0].mesh).genus, 0);
  }
}

TEST(SurfaceNets, MirroredTransformStillFacesOutward) {
  LabelVolume volume = make_volume(14, 12, 12, two_boxes);
  volume.index_to_world = {-0.8, 0, 0, 0, 0, 0.7, 0, 0, 0, 0, 1.5, 0, 100, -20, 5, 1};
  ASSERT_LT(determinant3(volume.index_to_world), 0);
  const auto surfaces = extract_or_fail(volume);
  ASSERT_EQ(surfaces.size(), 2u);
  for (const LabelSurface& s : surfaces) {
    expect_closed_manifold(s.mesh, "mirrored " + s.mesh.name);
    EXPECT_GT(diagnose(s.mesh).volume, 0);
  }
  // The same boxes, unmirrored, enclose the same volume up to the voxel size.
  LabelVolume plain = make_volume(14, 12, 12, two_boxes);
  plain.index_to_world = {0.8, 0, 0, 0, 0, 0.7, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, 1};
  const auto reference = extract_or_fail(plain);
  ASSERT_EQ(reference.size(), 2u);
  for (size_t o = 0; o < 2; ++o) {
    EXPECT_NEAR(diagnose(surfaces[o].mesh).volume, diagnose(reference[o].mesh).volume, 1e-3);
  }
}

TEST(SurfaceNets, ThreadCountDoesNotChangeTheMeshes) {
  const LabelVolume volume = make_volume(24, 24, 40, [](int i, int j, int k) {
    if (torus(i, j, k % 12) != 0) return 1u;
    return sphere(i + 2, j + 2, k - 10) != 0 ? 2u : 0u;
  });
  for (double precision : {0.0, 0.5}) {
    SurfaceOptions one, two;
    one.threads = 1, two.threads = 2;
    one.precision = two.precision = precision;
    const auto a = extract_or_fail(volume, one);
    const auto b = extract_or_fail(volume, two);
    ASSERT_EQ(a.size(), b.size());
    for (size_t o = 0; o < a.size(); ++o) {
      EXPECT_EQ(a[o].mesh.positions, b[o].mesh.positions);
      EXPECT_EQ(a[o].mesh.indices, b[o].mesh.indices);
    }
  }
}

TEST(SurfaceNets, SimplifiedSphereStaysClosedAndNear) {
  const LabelVolume volume = make_volume(kSphereSize, kSphereSize, kSphereSize, sphere);
  const auto full = extract_or_fail(volume);
  SurfaceOptions options;
  options.precision = 0.5;
  detail::SimplifyReport report;
  const auto simplified = extract_or_fail(volume, options, &report);
  ASSERT_EQ(simplified.size(), 1u);
  const Mesh& mesh = simplified[0].mesh;
  expect_closed_manifold(mesh, "simplified sphere");
  EXPECT_EQ(diagnose(mesh).genus, 0);
  EXPECT_EQ(simplified[0].triangles_extracted, full[0].mesh.triangle_count());
  EXPECT_LT(mesh.triangle_count() * 4, full[0].mesh.triangle_count());
  EXPECT_EQ(report.unsimplified, 0u);
  HausdorffOptions h;
  h.samples_per_face = 20;
  auto distance = hausdorff(mesh, full[0].mesh, h);
  ASSERT_TRUE(distance.ok()) << distance.status().message();
  EXPECT_LE(distance->symmetric.max, 1.1 * options.precision);
  std::printf("[ sphere   ] %zu triangles, %zu simplified at 0.5 voxel, Hausdorff %.3f\n",
              full[0].mesh.triangle_count(), mesh.triangle_count(), distance->symmetric.max);
}

TEST(SurfaceNets, SimplifiedBoxesKeepTheirInterfaceShared) {
  const LabelVolume volume = make_volume(14, 12, 12, two_boxes);
  SurfaceOptions options;
  options.precision = 0.5;
  detail::SimplifyReport report;
  const auto surfaces = extract_or_fail(volume, options, &report);
  ASSERT_EQ(surfaces.size(), 2u);
  const Mesh& one = surfaces[0].mesh;
  const Mesh& two = surfaces[1].mesh;
  expect_closed_manifold(one, "simplified box 1");
  expect_closed_manifold(two, "simplified box 2");
  EXPECT_LT(one.triangle_count(), surfaces[0].triangles_extracted);
  EXPECT_EQ(report.patches, 3u);  // 1 | background, 1 | 2, 2 | background
  const auto from_one = shared_triangles(one, two, true);
  const auto from_two = shared_triangles(two, one, false);
  EXPECT_EQ(from_one, from_two);
  EXPECT_FALSE(from_one.empty());
  expect_shared_boundaries(volume, options, "simplified boxes");
  // No vertex of the interface is lost by one side only.
  std::set<Vec3, PositionLess> in_two(two.positions.begin(), two.positions.end());
  for (const Vec3& p : one.positions) {
    if (p.x > 6 && p.x < 7) {
      EXPECT_TRUE(in_two.count(p)) << p.x << " " << p.y << " " << p.z;
    }
  }
}

TEST(SurfaceNets, TouchingSpheresSimplifyToOneSharedBoundary) {
  // Three overlapping balls split between three labels by nearest centre: curved interfaces
  // and junction lines, as where bones meet.
  const double centres[3][3] = {{9, 10, 10}, {17, 10, 10}, {13, 16, 11}};
  const LabelVolume volume = make_volume(26, 26, 22, [&](int i, int j, int k) {
    uint32_t best = 0;
    double nearest = 7.5 * 7.5;
    for (uint32_t c = 0; c < 3; ++c) {
      const double dx = i - centres[c][0], dy = j - centres[c][1], dz = k - centres[c][2];
      const double d = dx * dx + dy * dy + dz * dz;
      if (d <= nearest) nearest = d, best = c + 1;
    }
    return best;
  });
  const auto full = extract_or_fail(volume);
  SurfaceOptions options;
  options.precision = 1.0;
  const auto simplified = extract_or_fail(volume, options);
  ASSERT_EQ(simplified.size(), 3u);
  for (size_t o = 0; o < 3; ++o) {
    const Mesh& mesh = simplified[o].mesh;
    expect_closed_manifold(mesh, "ball " + std::to_string(o + 1));
    EXPECT_LT(mesh.triangle_count() * 3, full[o].mesh.triangle_count());
    auto distance = hausdorff(mesh, full[o].mesh);
    ASSERT_TRUE(distance.ok());
    EXPECT_LE(distance->symmetric.max, 1.25 * options.precision) << "ball " << o + 1;
  }
  expect_shared_boundaries(volume, options, "balls");
}

TEST(SurfaceNets, SelectionNamesAndWideVoxels) {
  LabelVolume volume = make_volume(14, 12, 12, two_boxes);
  volume.table = {{10, "femur", false, {}, 0}, {20, "", false, {}, 0}};
  SurfaceOptions options;
  options.labels = {20};
  const auto only_two = extract_or_fail(volume, options);
  ASSERT_EQ(only_two.size(), 1u);
  EXPECT_EQ(only_two[0].value, 20u);
  EXPECT_EQ(only_two[0].mesh.name, "label 20");
  expect_closed_manifold(only_two[0].mesh, "box 2 alone");
  const auto both = extract_or_fail(volume);
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(both[0].mesh.name, "femur");
  // Cells of label 2 smooth with no cell that lacks label 2 here, so the surface is the same.
  EXPECT_EQ(test::canonical_triangles(both[1].mesh), test::canonical_triangles(only_two[0].mesh));

  // The same volume stored two bytes a voxel gives the same meshes.
  LabelVolume wide = make_volume(14, 12, 12, two_boxes, true);
  const auto from_wide = extract_or_fail(wide);
  ASSERT_EQ(from_wide.size(), 2u);
  for (size_t o = 0; o < 2; ++o) {
    EXPECT_EQ(from_wide[o].mesh.positions, both[o].mesh.positions);
    EXPECT_EQ(from_wide[o].mesh.indices, both[o].mesh.indices);
  }
}

TEST(SurfaceNets, RejectsBadArguments) {
  const LabelVolume volume = make_volume(8, 8, 8, two_boxes);
  SurfaceOptions absent;
  absent.labels = {30};
  auto result = extract_surfaces(volume, absent);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("30"), std::string::npos);
  SurfaceOptions negative;
  negative.precision = -1;
  EXPECT_EQ(extract_surfaces(volume, negative).status().code(), ErrorCode::kInvalidArgument);
  LabelVolume truncated = volume;
  truncated.voxels.pop_back();
  EXPECT_EQ(extract_surfaces(truncated).status().code(), ErrorCode::kInvalidArgument);
  // An empty volume has empty surfaces.
  LabelVolume empty;
  auto none = extract_surfaces(empty);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(SurfaceNets, ClosedManifoldCheckFindsTheBadVertices) {
  // Two tetrahedra sharing one vertex: closed and oriented, but vertex 0 has two fans.
  std::vector<uint32_t> bow_tie = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,
                                   0, 5, 4, 0, 4, 6, 0, 6, 5, 4, 5, 6};
  std::vector<uint32_t> bad;
  EXPECT_FALSE(detail::is_closed_manifold(bow_tie, &bad));
  EXPECT_TRUE(std::find(bad.begin(), bad.end(), 0u) != bad.end());
  std::vector<uint32_t> tetrahedron(bow_tie.begin(), bow_tie.begin() + 12);
  EXPECT_TRUE(detail::is_closed_manifold(tetrahedron, nullptr));
  tetrahedron.resize(9);  // open
  EXPECT_FALSE(detail::is_closed_manifold(tetrahedron, nullptr));
}

}  // namespace surface_nets_test
}  // namespace
}  // namespace osteon
