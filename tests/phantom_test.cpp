// SPDX-License-Identifier: Apache-2.0
#include "support/phantom.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "osteon/diagnose.hpp"
#include "osteon/mesh.hpp"

namespace osteon {
namespace {
namespace phantom_test {

std::array<double, 3> apply(const std::array<double, 16>& m, const Vec3& p) {
  return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12],
          m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
          m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

double determinant3(const std::array<double, 16>& m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
         m[8] * (m[1] * m[6] - m[5] * m[2]);
}

/// The largest distance between `transform` applied to `from`'s vertices and `to`'s vertices.
double largest_deviation(const Mesh& from, const Mesh& to, const std::array<double, 16>& m) {
  double worst = 0;
  for (size_t v = 0; v < from.positions.size(); ++v) {
    const auto q = apply(m, from.positions[v]);
    const Vec3& p = to.positions[v];
    const double dx = q[0] - p.x, dy = q[1] - p.y, dz = q[2] - p.z;
    worst = std::max(worst, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return worst;
}

/// How many triangles face away from `centre` (from the Z axis through it when `radial`).
size_t triangles_facing_out(const Mesh& mesh, std::array<double, 3> centre, bool radial = false) {
  size_t outward = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3& a = mesh.positions[mesh.indices[3 * t]];
    const Vec3& b = mesh.positions[mesh.indices[3 * t + 1]];
    const Vec3& c = mesh.positions[mesh.indices[3 * t + 2]];
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
    const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const double mx = (a.x + b.x + c.x) / 3 - centre[0], my = (a.y + b.y + c.y) / 3 - centre[1];
    const double mz = radial ? 0.0 : (a.z + b.z + c.z) / 3 - centre[2];
    if (nx * mx + ny * my + nz * mz > 0) ++outward;
  }
  return outward;
}

/// FNV-1a over the bytes of every part's positions and indices.
uint64_t fingerprint(const Scene& scene) {
  uint64_t h = 0xcbf29ce484222325ull;
  auto mix = [&h](const void* data, size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * 0x100000001b3ull;
  };
  for (const Mesh& m : scene.parts) {
    mix(m.name.data(), m.name.size());
    mix(m.positions.data(), m.positions.size() * sizeof(Vec3));
    mix(m.indices.data(), m.indices.size() * sizeof(uint32_t));
  }
  return h;
}

// ---- primitives ----------------------------------------------------------------------------

TEST(Phantom, IcosphereCounts) {
  for (int s = 0; s <= 4; ++s) {
    SCOPED_TRACE(s);
    const Mesh mesh = make_icosphere(s, 3.0f);
    const size_t power = size_t{1} << (2 * s);
    EXPECT_EQ(mesh.triangle_count(), 20 * power);
    EXPECT_EQ(mesh.vertex_count(), 10 * power + 2);
    EXPECT_EQ(mesh.stored_vertices, mesh.vertex_count());
    for (const Vec3& p : mesh.positions) {
      EXPECT_NEAR(std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z), 3.0, 1e-5);
    }
    const DiagnosisReport r = diagnose(mesh);
    EXPECT_EQ(r.euler, 2);
    EXPECT_EQ(r.genus, 0);
    EXPECT_TRUE(r.oriented);
    EXPECT_EQ(r.degenerate_triangles, 0u);
    EXPECT_EQ(triangles_facing_out(mesh, {0, 0, 0}), mesh.triangle_count());
  }
}

TEST(Phantom, TorusCounts) {
  const Mesh mesh = make_torus(5.0f, 1.0f, 20, 8);
  EXPECT_EQ(mesh.triangle_count(), 2u * 20 * 8);
  EXPECT_EQ(mesh.vertex_count(), 20u * 8);
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_EQ(r.euler, 0);
  EXPECT_EQ(r.genus, 1);
  EXPECT_TRUE(r.oriented);
  EXPECT_GT(r.volume, 0);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_NEAR(r.bbox.max.x, 6.0, 1e-5);
  EXPECT_NEAR(r.bbox.max.z, 1.0, 0.05);
  // Every triangle faces away from the nearest point of the tube's centre circle.
  size_t outward = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    Mesh one;
    one.positions = mesh.positions;
    one.indices.assign(mesh.indices.begin() + 3 * t, mesh.indices.begin() + 3 * t + 3);
    const Vec3& a = mesh.positions[one.indices[0]];
    const double mx = a.x, my = a.y, len = std::sqrt(mx * mx + my * my);
    outward += triangles_facing_out(one, {5 * mx / len, 5 * my / len, 0});
  }
  EXPECT_EQ(outward, mesh.triangle_count());
}

TEST(Phantom, OpenCylinderCounts) {
  const Mesh mesh = make_open_cylinder(2.0f, 6.0f, 12, 5);
  EXPECT_EQ(mesh.vertex_count(), 12u * 6);
  EXPECT_EQ(mesh.triangle_count(), 2u * 12 * 5);
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.boundary_edges, 24u);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_FLOAT_EQ(r.bbox.min.z, -3.0f);
  EXPECT_FLOAT_EQ(r.bbox.max.z, 3.0f);
  EXPECT_EQ(triangles_facing_out(mesh, {0, 0, 0}, true), mesh.triangle_count());
}

TEST(Phantom, BoxVertexOrder) {
  const Mesh mesh = make_box({-1, -2, -3}, {4, 5, 6});
  ASSERT_EQ(mesh.vertex_count(), 8u);
  EXPECT_EQ(mesh.triangle_count(), 12u);
  EXPECT_EQ(mesh.positions[0], (Vec3{-1, -2, -3}));  // tests/fixtures.cpp relies on these two
  EXPECT_EQ(mesh.positions[1], (Vec3{4, -2, -3}));
  EXPECT_EQ(mesh.positions[7], (Vec3{4, 5, 6}));
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_TRUE(r.oriented);
  EXPECT_DOUBLE_EQ(r.volume, 5.0 * 7.0 * 9.0);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_EQ(triangles_facing_out(mesh, {1.5, 1.5, 1.5}), 12u);
}

TEST(Phantom, BookAndBowTie) {
  const Mesh book = make_nonmanifold_book();
  EXPECT_EQ(book.triangle_count(), 6u);
  EXPECT_EQ(book.vertex_count(), 8u);
  const DiagnosisReport b = diagnose(book);
  EXPECT_EQ(b.nonmanifold_edges, 1u);
  EXPECT_EQ(b.degenerate_triangles, 0u);

  const Mesh bowtie = make_bowtie_tetrahedra();
  EXPECT_EQ(bowtie.triangle_count(), 8u);
  EXPECT_EQ(bowtie.vertex_count(), 7u);
  const DiagnosisReport t = diagnose(bowtie);
  EXPECT_EQ(t.nonmanifold_vertices, 1u);
  EXPECT_EQ(t.nonmanifold_edges, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.degenerate_triangles, 0u);
  ASSERT_EQ(t.component_reports.size(), 1u);
  EXPECT_NEAR(t.volume, 1.0 / 3.0, 1e-12);  // both tetrahedra face outwards
}

// ---- the phantom skeleton ------------------------------------------------------------------

TEST(Phantom, SameOptionsSameBytes) {
  const Phantom a = make_phantom();
  const Phantom b = make_phantom();
  ASSERT_EQ(a.scene.parts.size(), b.scene.parts.size());
  ASSERT_EQ(a.truth.size(), a.scene.parts.size());
  for (size_t i = 0; i < a.scene.parts.size(); ++i) {
    const Mesh &p = a.scene.parts[i], &q = b.scene.parts[i];
    EXPECT_EQ(p.name, q.name);
    EXPECT_TRUE(p.positions == q.positions) << p.name;
    EXPECT_TRUE(p.indices == q.indices) << p.name;
    EXPECT_EQ(a.truth[i].transform, b.truth[i].transform);
  }
  // Another seed changes the noise, nothing else.
  PhantomOptions other;
  other.seed = 99;
  const Phantom c = make_phantom(other);
  ASSERT_EQ(c.scene.parts.size(), a.scene.parts.size());
  for (size_t i = 0; i < a.scene.parts.size(); ++i) {
    const bool noisy = a.truth[i].kind == PhantomKind::kNoisyCopy;
    EXPECT_EQ(a.scene.parts[i].positions == c.scene.parts[i].positions, !noisy)
        << a.scene.parts[i].name;
    EXPECT_TRUE(a.scene.parts[i].indices == c.scene.parts[i].indices);
  }
}

TEST(Phantom, PinnedBytes) {
  // "Same options, same bytes", across builds too: the fingerprint of what this code produced.
  // Everything is + - * / sqrt in double (no libm), so only a compiler that fuses a * b + c into
  // one rounding (FMA contraction) may change it; then regenerate it and say so in the commit.
  PhantomOptions options;
  options.detail = 2;
  const Phantom p = make_phantom(options);
  size_t total = 0;
  for (const Mesh& m : p.scene.parts) total += m.triangle_count();
  EXPECT_EQ(total, 17288u);
  EXPECT_EQ(fingerprint(p.scene), 17734268525883123027ull);
}

TEST(Phantom, NamesUnitsAndKinds) {
  const Phantom p = make_phantom();
  std::set<std::string> names;
  std::set<PhantomKind> kinds;
  for (size_t i = 0; i < p.scene.parts.size(); ++i) {
    const Mesh& m = p.scene.parts[i];
    EXPECT_FALSE(m.name.empty());
    EXPECT_TRUE(names.insert(m.name).second) << "duplicate " << m.name;
    EXPECT_EQ(p.truth[i].name, m.name);
    EXPECT_EQ(m.unit, Unit::kMillimetre);
    EXPECT_EQ(m.stored_vertices, m.vertex_count());
    kinds.insert(p.truth[i].kind);
  }
  for (PhantomKind kind :
       {PhantomKind::kOriginal, PhantomKind::kExactCopy, PhantomKind::kRotatedCopy,
        PhantomKind::kMirroredCopy, PhantomKind::kNoisyCopy, PhantomKind::kWithHoles,
        PhantomKind::kGenusOne, PhantomKind::kNonManifold}) {
    EXPECT_TRUE(kinds.count(kind)) << "no part of kind " << int(kind);
  }
  for (const char* name : {"skull", "femur_l", "femur_r", "humerus_l", "humerus_r", "vertebra_l1",
                           "vertebra_l2", "vertebra_l3", "rib_l1", "rib_l2", "pelvis"}) {
    EXPECT_TRUE(names.count(name)) << name;
  }
  EXPECT_EQ(guess_unit(p.scene), Unit::kMillimetre);
  // A standing skeleton: about 1.7 m tall, everything within 2048 mm of the origin (where float
  // spacing is still below 1.3e-4 mm).
  float top = -1e9f, bottom = 1e9f;
  for (const Mesh& m : p.scene.parts) {
    const Aabb box = bounding_box(m);
    top = std::max(top, box.max.z);
    bottom = std::min(bottom, box.min.z);
    for (float v : {box.min.x, box.min.y, box.min.z, box.max.x, box.max.y, box.max.z}) {
      EXPECT_LT(std::fabs(v), 2048.0f) << m.name;
    }
  }
  EXPECT_GT(top - bottom, 1000.0f);
}

TEST(Phantom, TruthAgreesWithDiagnosis) {
  for (int detail : {1, 2, 3}) {
    PhantomOptions options;
    options.detail = detail;
    const Phantom p = make_phantom(options);
    for (size_t i = 0; i < p.scene.parts.size(); ++i) {
      const Mesh& m = p.scene.parts[i];
      const PhantomPart& truth = p.truth[i];
      SCOPED_TRACE(m.name + " detail " + std::to_string(detail));
      const DiagnosisReport r = diagnose(m);
      EXPECT_EQ(r.components, 1u);
      EXPECT_EQ(r.degenerate_triangles, 0u);
      EXPECT_EQ(r.unreferenced_vertices, 0u);
      EXPECT_EQ(r.inconsistent_edges, 0u);
      EXPECT_EQ(r.genus, truth.genus);
      EXPECT_EQ(r.boundary_loops, size_t(truth.boundary_loops));
      EXPECT_EQ(r.nonmanifold_edges, size_t(truth.nonmanifold_edges));
      const bool closed =
          truth.kind != PhantomKind::kWithHoles && truth.kind != PhantomKind::kNonManifold;
      EXPECT_EQ(r.closed, closed);
      if (closed) {
        EXPECT_TRUE(r.oriented);
        EXPECT_GT(r.volume, 0) << "inside out";
      }
      if (truth.kind == PhantomKind::kGenusOne) {
        EXPECT_EQ(truth.genus, 1);
      }
      if (truth.kind == PhantomKind::kWithHoles) {
        EXPECT_GT(truth.boundary_loops, 0);
      }
      if (truth.kind == PhantomKind::kNonManifold) {
        EXPECT_GT(truth.nonmanifold_edges, 0);
      }
    }
  }
}

TEST(Phantom, CopiesFollowTheirTransforms) {
  const Phantom p = make_phantom();
  size_t copies = 0;
  for (size_t i = 0; i < p.scene.parts.size(); ++i) {
    const PhantomPart& truth = p.truth[i];
    const Mesh& copy = p.scene.parts[i];
    SCOPED_TRACE(copy.name);
    const bool is_copy =
        truth.kind == PhantomKind::kExactCopy || truth.kind == PhantomKind::kRotatedCopy ||
        truth.kind == PhantomKind::kMirroredCopy || truth.kind == PhantomKind::kNoisyCopy;
    if (!is_copy) {
      EXPECT_TRUE(truth.copy_of.empty());
      EXPECT_EQ(truth.transform,
                (std::array<double, 16>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}));
      EXPECT_EQ(truth.noise, 0.0f);
      continue;
    }
    ++copies;
    size_t o = 0;
    while (o < p.truth.size() && p.truth[o].name != truth.copy_of) ++o;
    ASSERT_LT(o, p.truth.size()) << "copy of a missing part " << truth.copy_of;
    const Mesh& original = p.scene.parts[o];
    ASSERT_EQ(copy.vertex_count(), original.vertex_count());
    ASSERT_EQ(copy.triangle_count(), original.triangle_count());
    const auto& m = truth.transform;
    EXPECT_EQ(m[3], 0.0);
    EXPECT_EQ(m[7], 0.0);
    EXPECT_EQ(m[11], 0.0);
    EXPECT_EQ(m[15], 1.0);
    const double det = determinant3(m);
    const double deviation = largest_deviation(original, copy, m);
    const DiagnosisReport ro = diagnose(original), rc = diagnose(copy);
    switch (truth.kind) {
      case PhantomKind::kExactCopy:
        EXPECT_EQ(det, 1.0);
        EXPECT_TRUE(m[0] == 1 && m[5] == 1 && m[10] == 1 && m[1] == 0 && m[2] == 0 && m[4] == 0 &&
                    m[6] == 0 && m[8] == 0 && m[9] == 0)
            << "an exact copy is a translation";
        EXPECT_LT(deviation, 1e-4);
        EXPECT_EQ(copy.indices, original.indices);
        break;
      case PhantomKind::kRotatedCopy:
        EXPECT_NEAR(det, 1.0, 1e-12);
        EXPECT_LT(deviation, 1e-4);
        EXPECT_EQ(copy.indices, original.indices);
        break;
      case PhantomKind::kMirroredCopy: {
        EXPECT_NEAR(det, -1.0, 1e-12);
        EXPECT_LT(deviation, 1e-4);
        // The same triangles, wound the other way, so the surface still faces out.
        for (size_t k = 0; k < copy.indices.size(); k += 3) {
          EXPECT_EQ(copy.indices[k], original.indices[k]);
          EXPECT_EQ(copy.indices[k + 1], original.indices[k + 2]);
          EXPECT_EQ(copy.indices[k + 2], original.indices[k + 1]);
        }
        EXPECT_GT(rc.volume, 0);
        EXPECT_NEAR(rc.volume, ro.volume, 1e-4 * ro.volume);
        break;
      }
      case PhantomKind::kNoisyCopy:
        EXPECT_GT(truth.noise, 0.0f);
        EXPECT_NEAR(det, 1.0, 1e-12);
        EXPECT_LT(deviation, truth.noise + 1e-4);
        EXPECT_GT(deviation, 0.5 * truth.noise);  // the noise is really there
        EXPECT_EQ(copy.indices, original.indices);
        break;
      default:
        break;
    }
    if (truth.kind != PhantomKind::kNoisyCopy) {
      EXPECT_EQ(truth.noise, 0.0f);
    }
    // Rigid motions keep the area; copies keep the truth of their original.
    EXPECT_NEAR(rc.area, ro.area, 2e-3 * ro.area);
    EXPECT_EQ(truth.genus, p.truth[o].genus);
    EXPECT_EQ(truth.boundary_loops, p.truth[o].boundary_loops);
  }
  EXPECT_GE(copies, 8u);
}

TEST(Phantom, DetailScalesTheTriangles) {
  auto femur_triangles = [](int detail) {
    PhantomOptions options;
    options.detail = detail;
    const Phantom p = make_phantom(options);
    for (const Mesh& m : p.scene.parts) {
      if (m.name == "femur_l") return m.triangle_count();
    }
    return size_t{0};
  };
  const size_t d2 = femur_triangles(2), d3 = femur_triangles(3), d4 = femur_triangles(4);
  EXPECT_GE(d2, 800u);  // "about 1k triangles a bone"
  EXPECT_LE(d2, 1500u);
  EXPECT_GE(d3, 3000u);  // the default: a few thousand
  EXPECT_LE(d3, 6000u);
  EXPECT_GE(d4, 12000u);  // about 16k
  EXPECT_LE(d4, 24000u);
  EXPECT_EQ(femur_triangles(0), femur_triangles(1));  // clamped to 1
}

}  // namespace phantom_test
}  // namespace
}  // namespace osteon
