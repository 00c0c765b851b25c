// SPDX-License-Identifier: Apache-2.0
#include "osteon/repeats.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"
#include "repeats_internal.hpp"

// Repeated components: pose normalisation, voxel similarity, ICP, verification and grouping, on
// generated shapes with known answers (exact and noisy copies under every kind of transform,
// look-alikes that must not match, symmetric shapes, tiny components), the phantom's truth, and
// the real MyoSim meshes when ../shared/data is there.

namespace osteon {
namespace {
namespace repeats_test {

using Matrix = std::array<double, 16>;  // column-major, as RepeatMember::matrix

constexpr Matrix kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

Matrix compose(const Matrix& a, const Matrix& b) {  // a * b
  return osteon::multiply(a, b);
}

Matrix translation(double x, double y, double z) {
  Matrix m = kIdentity;
  m[12] = x;
  m[13] = y;
  m[14] = z;
  return m;
}

Matrix scaling(double s) {
  Matrix m = kIdentity;
  m[0] = m[5] = m[10] = s;
  return m;
}

Matrix mirror_x() {
  Matrix m = kIdentity;
  m[0] = -1;
  return m;
}

/// Rotation by `degrees` about the axis (x, y, z) (Rodrigues).
Matrix rotation(double degrees, double x, double y, double z) {
  const double n = std::sqrt(x * x + y * y + z * z);
  x /= n;
  y /= n;
  z /= n;
  const double a = degrees * 3.14159265358979323846 / 180, c = std::cos(a), s = std::sin(a);
  const double t = 1 - c;
  const double r[3][3] = {{t * x * x + c, t * x * y - s * z, t * x * z + s * y},
                          {t * x * y + s * z, t * y * y + c, t * y * z - s * x},
                          {t * x * z - s * y, t * y * z + s * x, t * z * z + c}};
  Matrix m = kIdentity;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) m[size_t(4 * col + row)] = r[row][col];
  }
  return m;
}

double determinant3(const Matrix& m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
         m[8] * (m[1] * m[6] - m[5] * m[2]);
}

double largest_side(const Mesh& mesh) {
  const Aabb b = bounding_box(mesh);
  return std::max({b.max.x - b.min.x, b.max.y - b.min.y, b.max.z - b.min.z});
}

/// An asymmetric blob: a subdivided icosahedron bent and stretched so that its three principal
/// moments differ and it is skewed along each axis.
Mesh blob(int subdivisions = 2) {
  Mesh mesh = make_icosphere(subdivisions, 1.0f);
  for (Vec3& p : mesh.positions) {
    const float x = p.x, y = p.y, z = p.z;
    const float taper = 1.0f + 0.4f * x;  // pear-shaped: skewed along its length
    p = {2.0f * x + 0.35f * y * y, (1.2f * y + 0.5f * z * z + 0.2f * x) * taper,
         (0.7f * z + 0.25f * x * x + 0.2f * y * y) * taper};
  }
  mesh.name = "blob";
  return mesh;
}

/// The same surface with its vertices listed in another order and each triangle starting at
/// another corner: a copy no vertex-to-vertex fit can see.
Mesh shuffled(const Mesh& mesh, uint32_t seed) {
  std::vector<uint32_t> order(mesh.positions.size());
  std::iota(order.begin(), order.end(), 0u);
  std::mt19937 rng(seed);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<uint32_t> where(order.size());
  Mesh out = mesh;
  for (size_t k = 0; k < order.size(); ++k) {
    out.positions[k] = mesh.positions[order[k]];
    where[order[k]] = uint32_t(k);
  }
  for (size_t f = 0; f < mesh.triangle_count(); ++f) {
    const uint32_t a = where[mesh.indices[3 * f]], b = where[mesh.indices[3 * f + 1]],
                   c = where[mesh.indices[3 * f + 2]];
    const int turn = int(f % 3);
    const uint32_t t[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) out.indices[3 * f + k] = t[(k + turn) % 3];
  }
  return out;
}

/// Moves every vertex by a seeded random offset of length at most `amplitude`.
Mesh with_noise(const Mesh& mesh, double amplitude, uint32_t seed) {
  Mesh out = mesh;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Vec3& p : out.positions) {
    double d[3];
    do {
      for (double& x : d) x = u(rng);
    } while (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1);
    p = {float(p.x + amplitude * d[0]), float(p.y + amplitude * d[1]),
         float(p.z + amplitude * d[2])};
  }
  return out;
}

Mesh named(Mesh mesh, const std::string& name) {
  mesh.name = name;
  return mesh;
}

RepeatReport find_or_fail(const std::vector<Mesh>& components, const RepeatOptions& options = {}) {
  Result<RepeatReport> report = find_repeats(components, options);
  EXPECT_TRUE(report.ok()) << report.status().message();
  return report.ok() ? report.value() : RepeatReport{};
}

/// Checks that every member's matrix, applied to its prototype, reproduces the member within the
/// reported error: every vertex of the moved prototype is within it of the member's surface and
/// every vertex of the member within it of the moved prototype's (vertices are among the
/// reported distance's samples), up to float rounding.
void expect_matrices_reproduce_members(const std::vector<Mesh>& components,
                                       const RepeatReport& report) {
  for (const RepeatGroup& g : report.groups) {
    for (const RepeatMember& m : g.members) {
      const Mesh& member = components[m.part];
      const Mesh moved = transform_mesh(components[g.prototype], m.matrix);
      EXPECT_EQ(m.mirror, determinant3(m.matrix) < 0);
      EXPECT_LE(m.hausdorff, m.tolerance);
      const double slack = 1e-6 * largest_side(member);
      Result<DistanceQuery> to_member = DistanceQuery::build(member);
      Result<DistanceQuery> to_moved = DistanceQuery::build(moved);
      ASSERT_TRUE(to_member.ok() && to_moved.ok());
      double forward = 0, backward = 0;
      for (const Vec3& p : moved.positions) {
        forward = std::max(forward, to_member->closest({p.x, p.y, p.z}).distance);
      }
      for (const Vec3& p : member.positions) {
        backward = std::max(backward, to_moved->closest({p.x, p.y, p.z}).distance);
      }
      EXPECT_LE(forward, m.hausdorff + slack) << member.name;
      EXPECT_LE(backward, m.hausdorff + slack) << member.name;
    }
  }
}

/// The largest difference between two matrices' entries, the translation relative to `size`.
double matrix_difference(const Matrix& a, const Matrix& b, double size) {
  double d = 0;
  for (int k = 0; k < 12; ++k) d = std::max(d, std::fabs(a[size_t(k)] - b[size_t(k)]));
  for (int k = 12; k < 15; ++k) d = std::max(d, std::fabs(a[size_t(k)] - b[size_t(k)]) / size);
  return d;
}

// ---- pose normalisation and voxels -----------------------------------------------------------

TEST(Pose, IsInvariantUnderMotionMirrorScaleAndTessellation) {
  const Mesh a = blob();
  detail::Pose pa;
  ASSERT_TRUE(detail::compute_pose(a, {}, &pa));
  EXPECT_EQ(pa.ambiguity, detail::AxisAmbiguity::kNone);
  for (int k = 0; k < 3; ++k) EXPECT_FALSE(pa.sign_free[size_t(k)]) << "axis " << k;
  EXPECT_GT(pa.moments[0], pa.moments[1]);
  EXPECT_GT(pa.moments[1], pa.moments[2]);
  EXPECT_NEAR(pa.moments[0] + pa.moments[1] + pa.moments[2], 1.0, 1e-12);

  const Matrix m = compose(translation(5, -3, 8),
                           compose(rotation(70, 1, 2, 3), compose(mirror_x(), scaling(2.5))));
  const Mesh b = shuffled(transform_mesh(a, m), 7);
  detail::Pose pb;
  ASSERT_TRUE(detail::compute_pose(b, {}, &pb));
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(pa.moments[size_t(k)], pb.moments[size_t(k)], 1e-6);
    EXPECT_NEAR(pa.skew[size_t(k)], pb.skew[size_t(k)], 1e-5);
    EXPECT_NEAR(pa.box_max[size_t(k)] - pa.box_min[size_t(k)],
                pb.box_max[size_t(k)] - pb.box_min[size_t(k)], 1e-5);
  }
  EXPECT_NEAR(pb.scale / pa.scale, 2.5, 1e-6);
  EXPECT_NEAR(pb.area / pa.area, 2.5 * 2.5, 1e-5);
  // The canonical frames agree: one is a mirror of the other, the same voxels.
  EXPECT_LT(detail::determinant(pa.axes) * detail::determinant(pb.axes), 0);
  const detail::VoxelSimilarity s = detail::voxel_similarity(
      detail::voxelize(a, pa, detail::kIdentity3), detail::voxelize(b, pb, detail::kIdentity3));
  EXPECT_GT(s.phi, 0.995);
  EXPECT_GT(s.jaccard, 0.97);

  // Splitting every triangle in four moves neither the centroid nor the moments (they are
  // integrals over the surface, not sums over vertices).
  Mesh finer;
  finer.positions = a.positions;
  for (size_t f = 0; f < a.triangle_count(); ++f) {
    const uint32_t v[3] = {a.indices[3 * f], a.indices[3 * f + 1], a.indices[3 * f + 2]};
    uint32_t mid[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = a.positions[v[k]], q = a.positions[v[(k + 1) % 3]];
      mid[k] = uint32_t(finer.positions.size());
      finer.positions.push_back({(p.x + q.x) / 2, (p.y + q.y) / 2, (p.z + q.z) / 2});
    }
    finer.indices.insert(finer.indices.end(), {v[0], mid[0], mid[2], v[1], mid[1], mid[0], v[2],
                                               mid[2], mid[1], mid[0], mid[1], mid[2]});
  }
  detail::Pose pf;
  ASSERT_TRUE(detail::compute_pose(finer, {}, &pf));
  EXPECT_NEAR(pf.centroid.x, pa.centroid.x, 1e-6);
  EXPECT_NEAR(pf.centroid.y, pa.centroid.y, 1e-6);
  EXPECT_NEAR(pf.scale, pa.scale, 1e-6);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(pf.moments[size_t(k)], pa.moments[size_t(k)], 1e-6);
}

TEST(Pose, FlagsSymmetricShapes) {
  detail::Pose p;
  ASSERT_TRUE(detail::compute_pose(make_icosphere(2), {}, &p));
  EXPECT_EQ(p.ambiguity, detail::AxisAmbiguity::kFull);
  ASSERT_TRUE(detail::compute_pose(make_box({0, 0, 0}, {1, 1, 1}), {}, &p));
  EXPECT_EQ(p.ambiguity, detail::AxisAmbiguity::kFull);
  ASSERT_TRUE(detail::compute_pose(make_open_cylinder(1, 6, 24, 12), {}, &p));
  EXPECT_EQ(p.ambiguity, detail::AxisAmbiguity::kPlane);
  EXPECT_EQ(p.distinct_axis, 0);  // the long axis: the two small moments are equal
  EXPECT_TRUE(p.sign_free[0]);    // and the tube is symmetric along it
  ASSERT_TRUE(detail::compute_pose(make_open_cylinder(3, 0.5f, 48, 2), {}, &p));
  EXPECT_EQ(p.ambiguity, detail::AxisAmbiguity::kPlane);
  EXPECT_EQ(p.distinct_axis, 2);  // a flat ring: the two large moments are equal

  Mesh flat;  // zero area: no pose
  flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.indices = {0, 1, 2};
  EXPECT_FALSE(detail::compute_pose(flat, {}, &p));
}

TEST(Pose, ThirdMomentsFixAxesTheSecondMomentsLeaveFree) {
  // A tube with a bump on one side: its two small moments are equal within 10% (a free turn
  // about its axis by the second moments), but the bump skews it in one direction of that plane,
  // which fixes the turn; a copy is then compared under sign flips only.
  Mesh bumped = make_open_cylinder(1, 6, 32, 24);
  for (Vec3& q : bumped.positions) {
    if (q.x > 0.3f && std::fabs(q.z - 1.0f) < 1.5f) {
      q.x += 0.8f * q.x * (1.5f - std::fabs(q.z - 1.0f));
    }
  }
  // Stretch y until its moment matches x's again (the bump made x's larger).
  detail::Pose p;
  ASSERT_TRUE(detail::compute_pose(bumped, {}, &p));
  const float stretch = float(std::sqrt(p.moments[1] / p.moments[2]));
  for (Vec3& q : bumped.positions) q.y *= stretch;
  ASSERT_TRUE(detail::compute_pose(bumped, {}, &p));
  EXPECT_EQ(p.ambiguity, detail::AxisAmbiguity::kNone);
  EXPECT_LT(p.moments[1] - p.moments[2], 0.1 * p.moments[1]);  // the moments alone: a tie
  const Matrix motion = compose(translation(3, 1, 4), compose(rotation(111, 1, 1, 5), mirror_x()));
  const std::vector<Mesh> components = {bumped, shuffled(transform_mesh(bumped, motion), 8)};
  const RepeatReport report = find_or_fail(components);
  ASSERT_EQ(report.members, 1u);
  EXPECT_LE(report.counters.pose_alternatives, 8u);
  EXPECT_TRUE(report.groups[0].members[0].mirror);
  expect_matrices_reproduce_members(components, report);
}

TEST(VoxelSimilarity, PhiCountsAgreeingVoxelsJaccardOccupiedOnes) {
  detail::VoxelGrid a, b;
  a.bits[0] = 0b1111;  // 4 occupied voxels
  b.bits[0] = 0b0011;  // 2 of them
  const detail::VoxelSimilarity s = detail::voxel_similarity(a, b);
  EXPECT_DOUBLE_EQ(s.phi, (4096.0 - 2) / 4096);
  EXPECT_DOUBLE_EQ(s.jaccard, 0.5);
  EXPECT_DOUBLE_EQ(detail::voxel_similarity(detail::VoxelGrid{}, detail::VoxelGrid{}).jaccard, 1);
  // Flipping axes twice is the identity; flipping x moves voxel 0 to voxel 15.
  const detail::VoxelGrid flipped = detail::flip_axes(a, 1);
  EXPECT_EQ(flipped.occupied(), 4);
  EXPECT_TRUE((flipped.bits[0] >> 15) & 1);
  EXPECT_EQ(detail::flip_axes(detail::flip_axes(a, 5), 5).bits, a.bits);
}

TEST(Icp, FitKeepsTheAskedDeterminantAndFindsScale) {
  const Mesh a = blob(1);
  const Matrix m = compose(translation(1, 2, 3), compose(rotation(40, 0, 1, 1), scaling(1.7)));
  const Matrix mm = compose(m, mirror_x());
  std::vector<Vec3d> from, to, to_mirror;
  const Mesh b = transform_mesh(a, m), c = transform_mesh(a, mm);
  for (size_t v = 0; v < a.vertex_count(); ++v) {
    from.push_back({a.positions[v].x, a.positions[v].y, a.positions[v].z});
    to.push_back({b.positions[v].x, b.positions[v].y, b.positions[v].z});
    to_mirror.push_back({c.positions[v].x, c.positions[v].y, c.positions[v].z});
  }
  detail::Similarity s;
  ASSERT_TRUE(detail::fit_similarity(from, to, 0, true, &s));
  EXPECT_NEAR(detail::similarity_scale(s), 1.7, 1e-6);
  EXPECT_GT(detail::determinant(s.linear), 0);
  ASSERT_TRUE(detail::fit_similarity(from, to_mirror, 0, true, &s));
  EXPECT_LT(detail::determinant(s.linear), 0);
  ASSERT_TRUE(detail::fit_similarity(from, to_mirror, -1, false, &s));
  EXPECT_NEAR(detail::similarity_scale(s), 1.0, 1e-12);
  EXPECT_FALSE(detail::fit_similarity({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, from, 0, true, &s));
}

// ---- exact and near copies -------------------------------------------------------------------

struct Case {
  const char* what;
  Matrix matrix;
};

std::vector<Case> transforms() {
  return {{"translation", translation(12, -4, 7)},
          {"rotation", compose(translation(1, 1, 1), rotation(123, 1, -2, 0.5))},
          {"reflection", compose(translation(-6, 0, 2), mirror_x())},
          {"reflection through a plane", compose(rotation(30, 0, 0, 1), mirror_x())},
          {"uniform scale", scaling(0.4)},
          {"everything", compose(translation(3, 9, -2), compose(rotation(200, 2, 1, -1),
                                                                compose(mirror_x(), scaling(3))))}};
}

TEST(FindRepeats, ExactCopiesUnderEveryTransform) {
  const Mesh a = blob();
  for (bool shuffle : {false, true}) {
    for (const Case& c : transforms()) {
      SCOPED_TRACE(std::string(c.what) + (shuffle ? ", vertices shuffled" : ""));
      Mesh b = named(transform_mesh(a, c.matrix), "copy");
      if (shuffle) b = shuffled(b, 3);
      const std::vector<Mesh> components = {a, b};
      const RepeatReport report = find_or_fail(components);
      ASSERT_EQ(report.groups.size(), 1u);
      ASSERT_EQ(report.groups[0].members.size(), 1u);
      const RepeatGroup& g = report.groups[0];
      const RepeatMember& m = g.members[0];
      // The larger copy is the prototype (equal areas, up to rounding: either).
      const double s = std::cbrt(std::fabs(determinant3(c.matrix)));
      if (s != 1) {
        EXPECT_EQ(g.prototype, s > 1 ? 1u : 0u);
      }
      EXPECT_EQ(m.mirror, determinant3(c.matrix) < 0);
      EXPECT_NEAR(m.scale, g.prototype == 1 ? 1 / s : s, 1e-6);
      if (g.prototype == 0) {
        EXPECT_LT(matrix_difference(m.matrix, c.matrix, largest_side(b)), 1e-5);
      }
      EXPECT_LT(m.hausdorff, 1e-5 * largest_side(b));
      EXPECT_EQ(report.triangles_saved, a.triangle_count());
      expect_matrices_reproduce_members(components, report);
    }
  }
}

TEST(FindRepeats, RigidOnlyRejectsScaledCopiesAndMirrorsWhenAsked) {
  const Mesh a = blob();
  RepeatOptions rigid;
  rigid.allow_scale = false;
  EXPECT_TRUE(find_or_fail({a, transform_mesh(a, scaling(1.5))}, rigid).groups.empty());
  EXPECT_EQ(find_or_fail({a, transform_mesh(a, rotation(50, 1, 0, 0))}, rigid).members, 1u);
  RepeatOptions no_mirror;
  no_mirror.allow_mirror = false;
  EXPECT_TRUE(
      find_or_fail({a, shuffled(transform_mesh(a, mirror_x()), 1)}, no_mirror).groups.empty());
}

TEST(FindRepeats, NoiseBelowTheToleranceIsAcceptedAboveItRejected) {
  const Mesh a = blob();
  const Mesh moved = transform_mesh(a, compose(translation(4, 0, 1), rotation(33, 1, 1, 0)));
  const double tolerance = repeat_tolerance(moved, {});
  ASSERT_GT(tolerance, 0);
  // Default tolerance (the codec's bound at 14 bits): a third of it passes, ten times fails.
  const std::vector<Mesh> quiet = {a, shuffled(with_noise(moved, tolerance / 3, 1), 2)};
  RepeatReport report = find_or_fail(quiet);
  ASSERT_EQ(report.members, 1u);
  EXPECT_LE(report.largest_error, tolerance);
  EXPECT_GT(report.largest_error, 0);
  expect_matrices_reproduce_members(quiet, report);

  const std::vector<Mesh> loud = {a, shuffled(with_noise(moved, 10 * tolerance, 1), 2)};
  report = find_or_fail(loud);
  EXPECT_EQ(report.members, 0u);
  EXPECT_EQ(report.counters.rejected_hausdorff, 1u);  // a candidate, refused on measurement
  // An explicit tolerance lets it through, and reports what it measured.
  RepeatOptions lenient;
  lenient.tolerance = 30 * tolerance;
  report = find_or_fail(loud, lenient);
  ASSERT_EQ(report.members, 1u);
  EXPECT_GT(report.largest_error, tolerance);
  EXPECT_LE(report.largest_error, lenient.tolerance);
  expect_matrices_reproduce_members(loud, report);
}

TEST(FindRepeats, ToleranceFollowsTheCodec) {
  const Mesh box = make_box({0, 0, 0}, {16383, 2, 3});
  RepeatOptions o;
  EXPECT_NEAR(repeat_tolerance(box, o), 0.5 * std::sqrt(3.0), 1e-9);  // step 1 at 14 bits
  o.bits = 12;
  EXPECT_NEAR(repeat_tolerance(box, o), 0.5 * 16383.0 / 4095 * std::sqrt(3.0), 1e-9);
  o.precision = 0.25;
  EXPECT_NEAR(repeat_tolerance(box, o), 0.25 * std::sqrt(3.0), 1e-12);
  o.tolerance = 2;
  EXPECT_EQ(repeat_tolerance(box, o), 2);
}

// ---- look-alikes that must not match ---------------------------------------------------------

TEST(FindRepeats, LookAlikesWithTheSameBoxAndVoxelsAreNotSubstituted) {
  // A blob and the same blob with a shallow dent in its side: same bounding box, nearly the
  // same voxels, but not the same shape.
  const Mesh a = blob(3);
  Mesh dented = a;
  const Aabb box = bounding_box(a);
  const float side = box.max.x - box.min.x;
  for (Vec3& p : dented.positions) {
    const float dy = p.y - box.max.y;
    if (std::fabs(p.x) < 0.15f * side && p.y > 0 && dy > -0.5f) p.y -= 0.04f * (0.5f + dy);
  }
  ASSERT_EQ(bounding_box(dented).max.x, box.max.x);
  const std::vector<Mesh> components = {
      a, named(transform_mesh(dented, rotation(90, 0, 0, 1)), "dented")};
  const RepeatReport report = find_or_fail(components);
  EXPECT_TRUE(report.groups.empty());
  EXPECT_EQ(report.counters.pairs_phi, 1u);           // the voxels could not tell them apart ...
  EXPECT_EQ(report.counters.rejected_hausdorff, 1u);  // ... the measurement could

  // A torus against an open ring of the same outer size: not repeats either.
  const Mesh torus = make_torus(3, 1, 32, 16);
  const Mesh ring = make_open_cylinder(3.5f, 2, 32, 4);
  EXPECT_TRUE(find_or_fail({torus, ring}).groups.empty());
}

// ---- symmetric shapes ------------------------------------------------------------------------

TEST(FindRepeats, SymmetricShapesAreFoundWithoutWrongMatches) {
  const Matrix motion = compose(translation(10, 20, 30), rotation(37, 1, 3, -2));
  struct Shape {
    const char* what;
    Mesh mesh;
  };
  const std::vector<Shape> shapes = {
      {"cylinder", make_open_cylinder(1, 6, 24, 12)},
      {"ring", make_open_cylinder(3, 0.5f, 48, 2)},
      {"sphere", make_icosphere(2, 2)},
      {"box", make_box({0, 0, 0}, {1, 1, 1})},
      {"long box", make_box({0, 0, 0}, {4, 1, 1})},
  };
  for (const Shape& s : shapes) {
    SCOPED_TRACE(s.what);
    for (bool shuffle : {false, true}) {
      Mesh copy = transform_mesh(s.mesh, motion);
      if (shuffle) copy = shuffled(copy, 5);
      const std::vector<Mesh> components = {s.mesh, copy};
      const RepeatReport report = find_or_fail(components);
      ASSERT_EQ(report.members, 1u) << (shuffle ? "shuffled" : "");
      expect_matrices_reproduce_members(components, report);
    }
  }
  // A cylinder is not a longer cylinder nor a sphere a slightly flattened one.
  Mesh flat_sphere = make_icosphere(2, 2);
  for (Vec3& p : flat_sphere.positions) p.z *= 0.97f;
  EXPECT_TRUE(find_or_fail({make_open_cylinder(1, 6, 24, 12), make_open_cylinder(1, 6.3f, 24, 12)})
                  .groups.empty());
  EXPECT_TRUE(find_or_fail({make_icosphere(2, 2), flat_sphere}).groups.empty());
}

// ---- tiny components -------------------------------------------------------------------------

TEST(FindRepeats, ComponentsOfOneToTenTriangles) {
  const Matrix motion = compose(translation(1, 2, 3), compose(rotation(71, 1, 0, 2), mirror_x()));
  std::vector<Mesh> components;
  for (int n = 1; n <= 10; ++n) {
    // A fan of n triangles around a vertex, its rim wobbling so that no two fans are alike.
    Mesh fan;
    fan.name = "fan" + std::to_string(n);
    fan.positions.push_back({0, 0, 0.3f * n});
    for (int k = 0; k <= n; ++k) {
      const double a = 2.0 * k / (n + 1);
      fan.positions.push_back(
          {float(std::cos(a) * (1 + 0.1 * k)), float(std::sin(a)), float(0.05 * k * k)});
    }
    for (int k = 0; k < n; ++k)
      fan.indices.insert(fan.indices.end(), {0, uint32_t(k + 1), uint32_t(k + 2)});
    components.push_back(fan);
    components.push_back(named(shuffled(transform_mesh(fan, motion), uint32_t(n)), fan.name + "'"));
  }
  const RepeatReport report = find_or_fail(components);
  // Every fan finds its own copy and nothing else.
  std::map<size_t, size_t> member_of;
  for (const RepeatGroup& g : report.groups) {
    for (const RepeatMember& m : g.members) member_of[m.part] = g.prototype;
  }
  for (size_t i = 0; i < components.size(); i += 2) {
    SCOPED_TRACE(components[i].name);
    const bool paired = (member_of.count(i + 1) && member_of[i + 1] == i) ||
                        (member_of.count(i) && member_of[i] == i + 1);
    EXPECT_TRUE(paired);
  }
  EXPECT_EQ(report.members, 10u);
  expect_matrices_reproduce_members(components, report);
}

// ---- the phantom's truth ---------------------------------------------------------------------

/// The inverse of a column-major affine 4x4 matrix.
Matrix inverse_affine(const Matrix& m) {
  const double det = determinant3(m);
  Matrix out = kIdentity;
  // The inverse of the 3x3 part by cofactors, then -inverse * translation.
  auto at = [&](int r, int c) { return m[size_t(4 * c + r)]; };
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      out[size_t(4 * c + r)] = (at(r1, c1) * at(r2, c2) - at(r1, c2) * at(r2, c1)) / det;
    }
  }
  for (int r = 0; r < 3; ++r) {
    out[size_t(12 + r)] =
        -(out[size_t(r)] * m[12] + out[size_t(4 + r)] * m[13] + out[size_t(8 + r)] * m[14]);
  }
  return out;
}

TEST(FindRepeats, PhantomTruthIsFoundAndNothingElse) {
  PhantomOptions po;
  po.detail = 1;
  const Phantom phantom = make_phantom(po);
  const std::vector<Mesh>& parts = phantom.scene.parts;
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < parts.size(); ++i) index[parts[i].name] = i;
  // Each part's original (itself for an original) and its truth matrix from it.
  auto root = [&](size_t i) {
    const PhantomPart& t = phantom.truth[i];
    return t.copy_of.empty() ? i : index.at(t.copy_of);
  };

  for (double tolerance : {0.0, 0.2}) {
    SCOPED_TRACE("tolerance " + std::to_string(tolerance));
    RepeatOptions options;
    options.tolerance = tolerance;
    const RepeatReport report = find_or_fail(parts, options);
    std::map<size_t, size_t> group_of;  // part -> its group's prototype
    for (const RepeatGroup& g : report.groups) {
      group_of[g.prototype] = g.prototype;
      for (const RepeatMember& m : g.members) {
        // No wrong group: member and prototype are copies of one original.
        const PhantomPart& truth = phantom.truth[m.part];
        EXPECT_EQ(root(m.part), root(g.prototype))
            << truth.name << " drawn from " << parts[g.prototype].name;
        group_of[m.part] = g.prototype;
        // The right matrix: prototype -> original -> member, by the truth.
        const Matrix expected = compose(phantom.truth[m.part].transform,
                                        inverse_affine(phantom.truth[g.prototype].transform));
        const bool noisy = truth.noise > 0 || phantom.truth[g.prototype].noise > 0;
        EXPECT_LT(matrix_difference(m.matrix, expected, largest_side(parts[m.part])),
                  noisy ? 2e-2 : 1e-4)
            << truth.name;
      }
    }
    // Every copy is in its original's group: the noisy one (0.05 mm) only at 0.2 mm.
    for (size_t i = 0; i < parts.size(); ++i) {
      const PhantomPart& truth = phantom.truth[i];
      if (truth.copy_of.empty()) continue;
      const bool expected = truth.noise == 0 || tolerance >= 0.2;
      const bool together =
          group_of.count(i) && group_of.count(root(i)) && group_of[i] == group_of[root(i)];
      EXPECT_EQ(together, expected) << truth.name;
    }
    expect_matrices_reproduce_members(parts, report);
  }
}

// ---- determinism, scale, errors --------------------------------------------------------------

TEST(FindRepeats, SameInputSameOutputWhateverTheThreads) {
  PhantomOptions po;
  po.detail = 1;
  const Phantom phantom = make_phantom(po);
  std::vector<Mesh> parts = phantom.scene.parts;
  parts.push_back(shuffled(transform_mesh(parts[0], rotation(20, 0, 1, 0)), 9));
  RepeatOptions one;
  one.threads = 1;
  const RepeatReport a = find_or_fail(parts, one);
  const RepeatReport b = find_or_fail(parts);
  ASSERT_EQ(a.groups.size(), b.groups.size());
  for (size_t g = 0; g < a.groups.size(); ++g) {
    EXPECT_EQ(a.groups[g].prototype, b.groups[g].prototype);
    ASSERT_EQ(a.groups[g].members.size(), b.groups[g].members.size());
    for (size_t k = 0; k < a.groups[g].members.size(); ++k) {
      EXPECT_EQ(a.groups[g].members[k].part, b.groups[g].members[k].part);
      EXPECT_EQ(a.groups[g].members[k].matrix, b.groups[g].members[k].matrix);
      EXPECT_EQ(a.groups[g].members[k].hausdorff, b.groups[g].members[k].hausdorff);
    }
  }
  EXPECT_EQ(a.counters.pairs_considered, b.counters.pairs_considered);
  EXPECT_EQ(a.counters.pairs_verified, b.counters.pairs_verified);
}

TEST(FindRepeats, ManyComponentsStayNearLinear) {
  // 60 distinct small shapes (blobs stretched differently along two axes) and 940 moved,
  // mirrored or scaled copies of them: every copy found, and far fewer pairs compared than
  // n^2 / 2.
  std::vector<Mesh> originals;
  for (int k = 0; k < 60; ++k) {
    Mesh m = blob(1);
    const float sx = 1.0f + 0.3f * float(k % 6), sz = 0.3f + 0.15f * float(k / 6);
    for (Vec3& p : m.positions) p = {p.x * sx, p.y, p.z * sz};
    m.name = "shape" + std::to_string(k);
    originals.push_back(m);
  }
  std::vector<Mesh> components = originals;
  std::vector<size_t> copy_of(originals.size(), SIZE_MAX);
  std::mt19937 rng(4);
  for (int k = 0; k < 940; ++k) {
    const size_t o = rng() % originals.size();
    Matrix m = compose(translation(double(rng() % 100), double(rng() % 100), double(rng() % 100)),
                       rotation(double(rng() % 360), 1 + double(rng() % 3), 1, double(rng() % 2)));
    if (k % 3 == 0) m = compose(m, mirror_x());
    if (k % 5 == 0) m = compose(m, scaling(0.5));
    components.push_back(named(transform_mesh(originals[o], m), "copy" + std::to_string(k)));
    copy_of.push_back(o);
  }
  const auto start = std::chrono::steady_clock::now();
  const RepeatReport report = find_or_fail(components);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(report.members, 940u);
  for (const RepeatGroup& g : report.groups) {
    const size_t shape = copy_of[g.prototype] == SIZE_MAX ? g.prototype : copy_of[g.prototype];
    for (const RepeatMember& m : g.members) {
      const size_t member_shape = copy_of[m.part] == SIZE_MAX ? m.part : copy_of[m.part];
      EXPECT_EQ(member_shape, shape) << components[m.part].name;
    }
  }
  EXPECT_LT(report.counters.pairs_considered, report.counters.pairs_total / 4);
  RecordProperty("seconds", std::to_string(seconds));
}

TEST(FindRepeats, BadInputGivesClearErrors) {
  const Mesh a = blob(1);
  Mesh empty;
  empty.name = "empty_bone";
  Result<RepeatReport> r = find_repeats({a, empty});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("empty_bone"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("component 1"), std::string::npos) << r.status().message();

  Mesh nan = a;
  nan.positions[5].y = std::numeric_limits<float>::quiet_NaN();
  r = find_repeats({nan, a});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::kInvalidData);
  EXPECT_NE(r.status().message().find("vertex 5"), std::string::npos) << r.status().message();

  Mesh out_of_range = a;
  out_of_range.indices[7] = 100000;
  r = find_repeats({out_of_range});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::kInvalidArgument);

  RepeatOptions bad;
  bad.bits = 30;
  EXPECT_EQ(find_repeats({a}, bad).status().code(), ErrorCode::kInvalidArgument);
  bad = {};
  bad.tolerance = -1;
  EXPECT_EQ(find_repeats({a}, bad).status().code(), ErrorCode::kInvalidArgument);

  // Nothing, one component, zero-area components: no groups, no error.
  EXPECT_TRUE(find_or_fail({}).groups.empty());
  EXPECT_TRUE(find_or_fail({a}).groups.empty());
  Mesh flat;
  flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.indices = {0, 1, 2};
  const RepeatReport report = find_or_fail({flat, flat, a});
  EXPECT_TRUE(report.groups.empty());
  EXPECT_EQ(report.counters.skipped, 2u);
}

TEST(SplitConnected, GivesOnePieceAVertexConnectedComponent) {
  Mesh two = make_box({0, 0, 0}, {1, 2, 3});
  const Mesh other = transform_mesh(two, compose(translation(5, 0, 0), rotation(90, 1, 0, 0)));
  const uint32_t base = uint32_t(two.positions.size());
  two.positions.insert(two.positions.end(), other.positions.begin(), other.positions.end());
  for (uint32_t i : other.indices) two.indices.push_back(base + i);
  two.positions.push_back({9, 9, 9});  // unreferenced: dropped
  two.name = "pair";
  const std::vector<Mesh> pieces = split_connected(two);
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_EQ(pieces[0].name, "pair#0");
  EXPECT_EQ(pieces[1].name, "pair#1");
  for (const Mesh& p : pieces) {
    EXPECT_EQ(p.vertex_count(), 8u);
    EXPECT_EQ(p.triangle_count(), 12u);
  }
  EXPECT_EQ(test::canonical_triangles(pieces[1]), test::canonical_triangles(other));
  const RepeatReport report = find_or_fail(pieces);
  EXPECT_EQ(report.members, 1u);
  EXPECT_EQ(split_connected(make_box({0, 0, 0}, {1, 1, 1})).size(), 1u);
}

// ---- the CLI ---------------------------------------------------------------------------------

std::string run_cli(const std::string& args, int* status) {
  const std::string command = std::string(OSTEON_CLI_PATH) + " " + args + " 2>&1";
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) out.append(buffer, n);
  const int raw = pclose(pipe);
  *status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return out;
}

TEST(Cli, RepeatsJsonListsGroupsMatricesAndCounters) {
  const std::string dir = test::scratch_dir();
  const Mesh a = blob(1);
  const Matrix mirror = compose(translation(3, 0, 0), mirror_x());
  ASSERT_TRUE(write_mesh(dir + "/left.ply", a).ok());
  ASSERT_TRUE(write_mesh(dir + "/right.ply", transform_mesh(a, mirror)).ok());
  ASSERT_TRUE(write_mesh(dir + "/other.ply", make_icosphere(1)).ok());
  int status = -1;
  const std::string out = run_cli("repeats --json " + dir, &status);
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out);
  ASSERT_EQ(j["groups"].size(), 1u);
  EXPECT_EQ(j["groups"][0]["prototype"], "left");
  ASSERT_EQ(j["groups"][0]["members"].size(), 1u);
  const nlohmann::json& m = j["groups"][0]["members"][0];
  EXPECT_EQ(m["part"], "right");
  EXPECT_EQ(m["mirror"], true);
  ASSERT_EQ(m["matrix"].size(), 16u);
  for (int k = 0; k < 16; ++k) EXPECT_NEAR(m["matrix"][k].get<double>(), mirror[size_t(k)], 1e-5);
  EXPECT_GE(m["hausdorff"].get<double>(), 0);
  EXPECT_GT(j["bytes_saved"].get<double>(), 0);
  EXPECT_EQ(j["counters"]["pairs_accepted"], 1);

  const std::string text = run_cli("repeats --repeat-tolerance 0.01 " + dir, &status);
  EXPECT_EQ(status, 0);
  EXPECT_NE(text.find("right"), std::string::npos) << text;
  EXPECT_NE(text.find("mirror"), std::string::npos) << text;

  EXPECT_EQ((run_cli("repeats --bits 4 " + dir, &status), status), 2);
  const std::string missing = run_cli("repeats /nonexistent/bones", &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(missing.find("osteon: error:"), std::string::npos) << missing;
}

// ---- real meshes -----------------------------------------------------------------------------

TEST(FindRepeats, MyoSimLeftAndRightBonesPairUp) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string dir = data + "/MyoHub__myo_sim/meshes/";
  if (!std::filesystem::exists(dir + "l_femur.stl")) GTEST_SKIP() << "MyoSim meshes absent";
  std::vector<Mesh> parts;
  for (const char* name : {"l_femur", "r_femur", "l_patella", "r_patella", "radius_lv", "radius_rv",
                           "ulna_lv", "lunate_lvs", "lunate_rvs"}) {
    Result<Scene> scene = read_path(dir + name + ".stl");
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    parts.push_back(std::move(scene->parts[0]));
  }
  const RepeatReport report = find_or_fail(parts);
  auto key = [&](size_t i) {  // the name without its side
    std::string n = parts[i].name;
    for (const char* side : {"l_", "r_"}) {
      if (n.rfind(side, 0) == 0) n = n.substr(2);
    }
    for (const char* side : {"_lvs", "_rvs", "_lv", "_rv"}) {
      const size_t at = n.rfind(side);
      if (at != std::string::npos && at + std::string(side).size() == n.size()) n = n.substr(0, at);
    }
    return n;
  };
  for (const RepeatGroup& g : report.groups) {
    for (const RepeatMember& m : g.members) {
      EXPECT_EQ(key(m.part), key(g.prototype))
          << parts[m.part].name << " drawn from " << parts[g.prototype].name;
    }
  }
  EXPECT_EQ(report.members, 4u);  // femur, patella, radius, lunate; the ulna has no partner here
  expect_matrices_reproduce_members(parts, report);
}

}  // namespace repeats_test
}  // namespace
}  // namespace osteon
