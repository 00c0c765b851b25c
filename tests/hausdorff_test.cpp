// SPDX-License-Identifier: Apache-2.0
#include "osteon/hausdorff.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "fixtures.hpp"
#include "osteon/codec.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace hausdorff_test {

// ---- helpers -------------------------------------------------------------------------------

double segment_distance(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  Vec3d ab = b - a;
  double l2 = dot(ab, ab);
  double t = l2 > 0 ? std::clamp(dot(p - a, ab) / l2, 0.0, 1.0) : 0.0;
  return length(p - Vec3d{a.x + t * ab.x, a.y + t * ab.y, a.z + t * ab.z});
}

// The brute-force answer: the nearest of the projection onto the plane (when it falls inside,
// judged by the signs of three cross products) and the three edges.
double brute_triangle_distance(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  double best =
      std::min({segment_distance(p, a, b), segment_distance(p, b, c), segment_distance(p, c, a)});
  Vec3d n = cross(b - a, c - a);
  double n2 = dot(n, n);
  if (n2 > 0) {
    double s = dot(p - a, n) / n2;
    Vec3d q{p.x - s * n.x, p.y - s * n.y, p.z - s * n.z};
    bool inside = dot(cross(b - a, q - a), n) >= 0 &&
                  dot(cross(c - b, q - b), n) >= 0 &&
                  dot(cross(a - c, q - c), n) >= 0;
    if (inside) best = std::min(best, std::fabs(s) * std::sqrt(n2));
  }
  return best;
}

double brute_mesh_distance(const Mesh& mesh, const Vec3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    best = std::min(best, brute_triangle_distance(p, to_double(mesh.positions[mesh.indices[3 * t]]),
                                                  to_double(mesh.positions[mesh.indices[3 * t + 1]]),
                                                  to_double(mesh.positions[mesh.indices[3 * t + 2]])));
  }
  return best;
}

// A unit square [0,1]^2 in the plane z = 0 of n x n quads, then mapped by `lift`.
template <class F>
Mesh make_grid(int n, F lift) {
  Mesh mesh;
  mesh.name = "grid";
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) mesh.positions.push_back(lift(float(i) / n, float(j) / n));
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      uint32_t v = uint32_t(j * (n + 1) + i);
      mesh.indices.insert(mesh.indices.end(), {v, v + 1, v + uint32_t(n) + 2});
      mesh.indices.insert(mesh.indices.end(), {v, v + uint32_t(n) + 2, v + uint32_t(n) + 1});
    }
  }
  return mesh;
}

Mesh translated(Mesh mesh, Vec3 by) {
  for (Vec3& p : mesh.positions) p = {p.x + by.x, p.y + by.y, p.z + by.z};
  return mesh;
}

HausdorffReport measure(const Mesh& a, const Mesh& b, const HausdorffOptions& options = {}) {
  Result<HausdorffReport> r = hausdorff(a, b, options);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? r.value() : HausdorffReport{};
}

/// A phantom bone (phantom seed `seed`, detail 3) and a copy with every coordinate moved by up to
/// 0.05 (noise seed `noise_seed`).
std::pair<Mesh, Mesh> phantom_and_noisy_copy(uint64_t seed, unsigned noise_seed) {
  Phantom phantom = make_phantom({.seed = seed, .detail = 3});
  Mesh a = phantom.scene.parts[0];
  Mesh b = a;
  std::mt19937 rng(noise_seed);
  std::uniform_real_distribution<float> noise(-0.05f, 0.05f);
  for (Vec3& p : b.positions) p = {p.x + noise(rng), p.y + noise(rng), p.z + noise(rng)};
  return {std::move(a), std::move(b)};
}

// ---- closest point on a triangle -------------------------------------------------------------

TEST(Hausdorff, PointTriangleDistanceMatchesBruteForce) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coord(-2, 2);
  auto random_point = [&] { return Vec3d{coord(rng), coord(rng), coord(rng)}; };
  for (int trial = 0; trial < 20000; ++trial) {
    Vec3d a = random_point(), b = random_point(), c = random_point();
    switch (trial % 6) {
      case 1:  // a sliver: c almost on ab
        c = {a.x + 0.3 * (b.x - a.x) + 1e-6, a.y + 0.3 * (b.y - a.y), a.z + 0.3 * (b.z - a.z)};
        break;
      case 2:  // collinear: zero area
        c = {a.x + 2 * (b.x - a.x), a.y + 2 * (b.y - a.y), a.z + 2 * (b.z - a.z)};
        break;
      case 3:  // two corners equal
        c = b;
        break;
      case 4:  // a point
        b = c = a;
        break;
      case 5:  // one very short edge: thin, though the angle at a is not small
        b = {a.x + 1e-9, a.y - 2e-9, a.z};
        break;
      default:
        break;
    }
    Vec3d p = random_point();
    ClosestPoint got = closest_point_on_triangle(p, a, b, c);
    double expected = brute_triangle_distance(p, a, b, c);
    ASSERT_NEAR(got.distance, expected, 1e-9) << "trial " << trial;
    // The point returned is at that distance and lies on the triangle.
    EXPECT_NEAR(length(p - got.point), got.distance, 1e-9);
    EXPECT_NEAR(brute_triangle_distance(got.point, a, b, c), 0.0, 1e-7) << "trial " << trial;
    EXPECT_EQ(got.triangle, ClosestPoint::kNoTriangle);
  }
}

TEST(Hausdorff, PointTriangleExactAtCornersAndFace) {
  Vec3d a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_EQ(closest_point_on_triangle(a, a, b, c).distance, 0.0);
  EXPECT_EQ(closest_point_on_triangle(c, a, b, c).distance, 0.0);
  ClosestPoint above = closest_point_on_triangle({0.25, 0.25, 2}, a, b, c);
  EXPECT_DOUBLE_EQ(above.distance, 2.0);
  EXPECT_EQ(above.point, (Vec3d{0.25, 0.25, 0}));
  ClosestPoint beyond = closest_point_on_triangle({2, 2, 0}, a, b, c);
  EXPECT_DOUBLE_EQ(beyond.distance, std::sqrt(4.5));  // to (0.5, 0.5, 0) on edge bc
}

// ---- the hierarchy ---------------------------------------------------------------------------

TEST(Hausdorff, DistanceQueryMatchesBruteForceOnEveryCategory) {
  std::mt19937_64 rng(11);
  std::vector<test::NamedMesh> meshes = test::mesh_categories();
  meshes.push_back({"phantom", make_phantom({.seed = 2, .detail = 2}).scene.parts[0]});
  for (const auto& [category, mesh] : meshes) {
    SCOPED_TRACE(category);
    Result<DistanceQuery> query = DistanceQuery::build(mesh);
    ASSERT_TRUE(query.ok()) << query.status().message();
    EXPECT_EQ(query->triangle_count(), mesh.triangle_count());
    Aabb box = query->bounds();
    double span = std::max({box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z});
    std::uniform_real_distribution<double> x(box.min.x - span, box.max.x + span);
    std::uniform_real_distribution<double> y(box.min.y - span, box.max.y + span);
    std::uniform_real_distribution<double> z(box.min.z - span, box.max.z + span);
    std::uniform_int_distribution<uint32_t> any(0, uint32_t(mesh.triangle_count() - 1));
    for (int i = 0; i < 300; ++i) {
      Vec3d p{x(rng), y(rng), z(rng)};
      if (i % 10 == 0) p = {p.x * 1000, p.y * 1000, p.z * 1000};  // far away
      double expected = brute_mesh_distance(mesh, p);
      ClosestPoint got = query->closest(p);
      ASSERT_NEAR(got.distance, expected, 1e-9 * std::max(1.0, expected));
      ASSERT_LT(got.triangle, mesh.triangle_count());
      ClosestPoint hinted = query->closest(p, any(rng));
      ASSERT_NEAR(hinted.distance, expected, 1e-9 * std::max(1.0, expected));
      EXPECT_NEAR(length(p - got.point), got.distance, 1e-9 * std::max(1.0, expected));
    }
  }
}

TEST(Hausdorff, DistanceQueryOnALargeMeshMatchesBruteForce) {
  Mesh sphere = make_icosphere(6, 50.0f);  // 81,920 triangles: a deep tree, built in parallel
  Result<DistanceQuery> query = DistanceQuery::build(sphere);
  ASSERT_TRUE(query.ok());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> coord(-80, 80);
  for (int i = 0; i < 40; ++i) {
    Vec3d p{coord(rng), coord(rng), coord(rng)};
    ASSERT_NEAR(query->closest(p).distance, brute_mesh_distance(sphere, p), 1e-9);
  }
}

TEST(Hausdorff, NearEnoughQueriesStopEarlyOrAreExact) {
  std::mt19937_64 rng(17);
  for (const auto& [category, mesh] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    Result<DistanceQuery> query = DistanceQuery::build(mesh);
    ASSERT_TRUE(query.ok()) << query.status().message();
    Aabb box = query->bounds();
    std::uniform_real_distribution<double> x(box.min.x - 1, box.max.x + 1);
    std::uniform_real_distribution<double> y(box.min.y - 1, box.max.y + 1);
    std::uniform_real_distribution<double> z(box.min.z - 1, box.max.z + 1);
    std::uniform_real_distribution<double> enough(0, 2);
    for (int i = 0; i < 300; ++i) {
      const Vec3d p{x(rng), y(rng), z(rng)};
      const double exact = brute_mesh_distance(mesh, p);
      const double e = enough(rng);
      const ClosestPoint got = query->closest(p, ClosestPoint::kNoTriangle, e);
      ASSERT_LT(got.triangle, mesh.triangle_count());
      EXPECT_NEAR(length(p - got.point), got.distance, 1e-9 * std::max(1.0, exact));
      if (exact > e) {
        ASSERT_NEAR(got.distance, exact, 1e-9 * std::max(1.0, exact));  // none near enough
      } else {
        ASSERT_LE(got.distance, e);  // stopped at a near-enough triangle
        ASSERT_GE(got.distance, exact - 1e-9 * std::max(1.0, exact));
      }
    }
  }
}

TEST(Hausdorff, MaxOnlyGivesTheSameMaxBitForBit) {
  const auto [a, b] = phantom_and_noisy_copy(3, 9);
  HausdorffOptions options;
  options.samples = 60000;
  const HausdorffReport full = measure(a, b, options);
  options.max_only = true;
  for (int threads : {1, 2}) {
    options.threads = threads;
    const HausdorffReport fast = measure(a, b, options);
    for (auto [x, y] : {std::pair{&fast.forward, &full.forward},
                        std::pair{&fast.backward, &full.backward}}) {
      EXPECT_EQ(x->max, y->max);
      EXPECT_EQ(x->max_at, y->max_at);
      EXPECT_EQ(x->samples, y->samples);
      EXPECT_EQ(x->mean, 0.0);
      EXPECT_EQ(x->rms, 0.0);
    }
    EXPECT_EQ(fast.symmetric.max, full.symmetric.max);
  }
}

TEST(Hausdorff, KnownMaxKeepsTheLargerExact) {
  const auto pair = phantom_and_noisy_copy(3, 9);
  const Mesh& a = pair.first;  // named, not bound: clang's lambdas cannot capture a binding
  const Mesh& b = pair.second;
  HausdorffOptions options;
  options.samples = 60000;
  options.max_only = true;
  Result<DistanceQuery> to_b = DistanceQuery::build(b);
  ASSERT_TRUE(to_b.ok()) << to_b.status().message();
  auto one_sided = [&] {
    Result<OneSidedDistance> r = one_sided_distance(a, to_b.value(), options);
    EXPECT_TRUE(r.ok()) << r.status().message();
    return r.ok() ? r.value() : OneSidedDistance{};
  };
  const OneSidedDistance exact = one_sided();
  ASSERT_GT(exact.max, 0.0);
  // Below the largest distance: the same largest, bit for bit.
  options.known_max = 0.5 * exact.max;
  const OneSidedDistance below = one_sided();
  EXPECT_EQ(below.max, exact.max);
  EXPECT_EQ(below.max_at, exact.max_at);
  // Above it: nothing is wanted, and nothing larger than it is reported.
  options.known_max = 2 * exact.max;
  const OneSidedDistance above = one_sided();
  EXPECT_LE(above.max, options.known_max);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double infinity = std::numeric_limits<double>::infinity();
  for (double bad : {-1.0, nan, infinity}) {
    options.known_max = bad;
    Result<OneSidedDistance> refused = one_sided_distance(a, to_b.value(), options);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.status().message().find("known_max"), std::string::npos);
  }
}

// ---- analytic cases --------------------------------------------------------------------------

TEST(Hausdorff, UnitSphereAgainstSphereOfRadius101) {
  // Both spheres are the same icosphere (20,480 triangles), scaled. Their exact answer is 0.01;
  // the tessellation bounds every distance: a point p of either lies within 1.01 of the origin
  // and its scaled copy on the other sphere is 0.01 |p| / (1 or 1.01) <= 0.01 away, and every
  // triangle's plane is at least r_in from the origin (the unit sphere's smallest triangle
  // inradius-from-centre), so every distance is at least 1.01 r_in - 1.
  Mesh unit = make_icosphere(5, 1.0f);
  Mesh larger = make_icosphere(5, 1.01f);
  double r_in = 1;
  for (size_t t = 0; t < unit.triangle_count(); ++t) {
    Vec3d a = to_double(unit.positions[unit.indices[3 * t]]);
    Vec3d n = cross(to_double(unit.positions[unit.indices[3 * t + 1]]) - a,
                    to_double(unit.positions[unit.indices[3 * t + 2]]) - a);
    r_in = std::min(r_in, std::fabs(dot(a, n)) / length(n));
  }
  double lower = 1.01 * r_in - 1 - 1e-6, upper = 0.01 + 1e-6;
  ASSERT_GT(lower, 0.0097);  // the tessellation error: at most 3% of the answer
  HausdorffReport r = measure(unit, larger);
  for (const OneSidedDistance* d : {&r.forward, &r.backward, &r.symmetric}) {
    EXPECT_GE(d->mean, lower);
    EXPECT_LE(d->max, upper);
    EXPECT_GE(d->max, d->rms);
    EXPECT_GE(d->rms, d->mean);
  }
  EXPECT_EQ(r.forward.samples, 10u * unit.triangle_count());
  EXPECT_NEAR(r.forward.diagonal, 2 * std::sqrt(3.0), 0.01);  // the icosphere's box
  EXPECT_EQ(r.symmetric.max, std::max(r.forward.max, r.backward.max));
  EXPECT_NEAR(*r.symmetric.max_relative(), r.symmetric.max / r.symmetric.diagonal, 1e-15);
}

TEST(Hausdorff, PlaneAgainstShiftedPlaneIsTheShift) {
  auto flat = [](float x, float y) { return Vec3{x, y, 0}; };
  Mesh a = make_grid(20, flat);
  Mesh b = translated(a, {0, 0, 0.05f});
  HausdorffReport r = measure(a, b);
  for (const OneSidedDistance* d : {&r.forward, &r.backward, &r.symmetric}) {
    EXPECT_NEAR(d->max, 0.05, 1e-7);
    EXPECT_NEAR(d->mean, 0.05, 1e-7);
    EXPECT_NEAR(d->rms, 0.05, 1e-7);
  }
}

TEST(Hausdorff, PlaneAgainstTiltedPlaneHasTheAnalyticMeanAndRms) {
  // b is z = 0.1 x over the same square. From a, the distance at (x, y, 0) is 0.1 x / sqrt(1.01)
  // (the perpendicular foot stays inside b); from b, (x, y, 0.1 x) is 0.1 x above a. x is
  // uniform over either surface, so max, mean and RMS are those of 0.1 x scaled.
  auto flat = [](float x, float y) { return Vec3{x, y, 0}; };
  auto tilted = [](float x, float y) { return Vec3{x, y, 0.1f * x}; };
  HausdorffReport r = measure(make_grid(20, flat), make_grid(20, tilted));
  double k = 1 / std::sqrt(1.01);
  EXPECT_NEAR(r.forward.max, 0.1 * k, 1e-7);
  EXPECT_NEAR(r.forward.mean, 0.05 * k, 0.01 * 0.05);
  EXPECT_NEAR(r.forward.rms, 0.1 * k / std::sqrt(3.0), 0.01 * 0.058);
  EXPECT_NEAR(r.backward.max, 0.1, 1e-7);
  EXPECT_NEAR(r.backward.mean, 0.05, 0.01 * 0.05);
  EXPECT_NEAR(r.backward.rms, 0.1 / std::sqrt(3.0), 0.01 * 0.058);
  EXPECT_EQ(r.symmetric.mean, r.backward.mean);
}

TEST(Hausdorff, DisjointMeshesFarApartMeasureTheGap) {
  // For p in the unit cube, the nearest point of the cube moved by 1000 along x is straight
  // across: 1000 - p.x. The corner samples at x = 0 give the max exactly; x is uniform over the
  // cube's surface, so the mean is 999.5.
  Mesh a = make_box({0, 0, 0}, {1, 1, 1});
  Mesh b = make_box({1000, 0, 0}, {1001, 1, 1});
  HausdorffReport r = measure(a, b, {.samples = 30000});
  EXPECT_NEAR(r.forward.max, 1000.0, 1e-9);
  EXPECT_NEAR(r.forward.mean, 999.5, 0.01);
  EXPECT_NEAR(r.backward.max, 1000.0, 1e-9);
  EXPECT_NEAR(r.symmetric.diagonal, std::sqrt(1001.0 * 1001.0 + 2), 1e-9);
  // And a million units away (the boxes' facing sides 1e6 - 1 apart).
  HausdorffReport far = measure(a, translated(a, {0, 0, 1e6f}));
  EXPECT_NEAR(far.symmetric.max, 1e6, 1e-6);
  EXPECT_NEAR(far.symmetric.mean, 1e6 - 0.5, 0.1);
}

TEST(Hausdorff, AMeshAgainstItselfIsExactlyZero) {
  std::vector<test::NamedMesh> meshes = test::mesh_categories();
  for (const Mesh& part : make_phantom({.seed = 5, .detail = 2}).scene.parts) {
    meshes.push_back({part.name, part});
  }
  for (const auto& [category, mesh] : meshes) {
    SCOPED_TRACE(category);
    HausdorffReport r = measure(mesh, mesh);
    EXPECT_EQ(r.symmetric.max, 0.0);
    EXPECT_EQ(r.symmetric.mean, 0.0);
    EXPECT_EQ(r.symmetric.rms, 0.0);
    EXPECT_GT(r.symmetric.samples, 0u);
  }
}

TEST(Hausdorff, ARealMeshAgainstItselfIsExactlyZero) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  Result<Scene> scene = read_path(data + "/MyoHub__myo_sim/meshes/ground_spine.stl");
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Mesh& mesh = scene->parts[0];
  HausdorffReport r = measure(mesh, mesh);
  EXPECT_EQ(r.symmetric.max, 0.0);
  EXPECT_EQ(r.symmetric.rms, 0.0);
}

TEST(Hausdorff, ZeroAreaTrianglesAreMeasuredAsSegments) {
  // Every triangle collinear: no area, so edges and vertices carry the samples.
  Mesh a;
  a.name = "segments";
  a.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  a.indices = {0, 1, 2};
  Mesh b = translated(a, {0, 1, 0});
  HausdorffReport r = measure(a, b, {.samples = 30});
  EXPECT_EQ(r.forward.face_samples, 0u);
  EXPECT_EQ(r.forward.vertex_samples, 3u);
  EXPECT_EQ(r.forward.edge_samples, 27u);
  EXPECT_DOUBLE_EQ(r.symmetric.max, 1.0);
  EXPECT_DOUBLE_EQ(r.symmetric.mean, 1.0);
}

// ---- sampling --------------------------------------------------------------------------------

TEST(Hausdorff, SampleBudgetIsSplitLikeMeshLab) {
  Mesh sphere = make_icosphere(3, 1.0f);  // 642 vertices, 1,280 triangles
  HausdorffReport by_default = measure(sphere, sphere);
  EXPECT_EQ(by_default.forward.samples, 12800u);
  EXPECT_EQ(by_default.forward.vertex_samples, 642u);
  EXPECT_EQ(by_default.forward.edge_samples, (12800u - 642u) / 2);
  EXPECT_EQ(by_default.forward.face_samples, 12800u - 642u - (12800u - 642u) / 2);
  HausdorffReport few = measure(sphere, sphere, {.samples = 300});
  EXPECT_EQ(few.forward.vertex_samples, 100u);
  EXPECT_EQ(few.forward.edge_samples, 100u);
  EXPECT_EQ(few.forward.face_samples, 100u);
  HausdorffReport faces_only =
      measure(sphere, sphere, {.samples = 500, .sample_vertices = false, .sample_edges = false});
  EXPECT_EQ(faces_only.forward.face_samples, 500u);
  EXPECT_EQ(faces_only.forward.samples, 500u);
}

TEST(Hausdorff, SameSeedSameFiguresWhateverTheThreads) {
  const auto [a, b] = phantom_and_noisy_copy(1, 5);
  HausdorffOptions options;
  options.samples = 100000;  // 25 blocks: several run on each thread
  options.seed = 42;
  std::vector<HausdorffReport> runs;
  for (int threads : {1, 2, 3}) {
    options.threads = threads;
    runs.push_back(measure(a, b, options));
  }
  for (const HausdorffReport& r : runs) {
    for (auto [x, y] :
         {std::pair{&r.forward, &runs[0].forward}, std::pair{&r.backward, &runs[0].backward}}) {
      EXPECT_EQ(x->max, y->max);
      EXPECT_EQ(x->mean, y->mean);
      EXPECT_EQ(x->rms, y->rms);
      EXPECT_EQ(x->max_at, y->max_at);
    }
  }
  options.seed = 43;
  HausdorffReport other = measure(a, b, options);
  EXPECT_NE(other.forward.mean, runs[0].forward.mean);
  EXPECT_NEAR(other.forward.mean, runs[0].forward.mean, 0.01 * runs[0].forward.mean);
}

TEST(Hausdorff, ProgressReachesTheTotalInOrder) {
  Mesh a = make_icosphere(5, 1.0f);
  Mesh b = make_icosphere(4, 1.0f);
  std::vector<std::pair<uint64_t, uint64_t>> calls;
  HausdorffOptions options;
  options.progress = [&](uint64_t done, uint64_t total) { calls.emplace_back(done, total); };
  HausdorffReport r = measure(a, b, options);
  ASSERT_FALSE(calls.empty());
  for (size_t i = 1; i < calls.size(); ++i) EXPECT_GT(calls[i].first, calls[i - 1].first);
  EXPECT_EQ(calls.back().first, r.symmetric.samples);
  EXPECT_EQ(calls.back().second, r.symmetric.samples);
}

TEST(Hausdorff, OneSidedAgainstAReusedQuery) {
  Mesh target = make_icosphere(4, 1.0f);
  Result<DistanceQuery> query = DistanceQuery::build(target);
  ASSERT_TRUE(query.ok());
  for (float radius : {0.9f, 1.1f}) {
    Result<OneSidedDistance> d = one_sided_distance(make_icosphere(4, radius), *query);
    ASSERT_TRUE(d.ok()) << d.status().message();
    EXPECT_NEAR(d->max, std::fabs(radius - 1), 0.01);
  }
}

// ---- bad input -------------------------------------------------------------------------------

TEST(Hausdorff, BadInputIsAClearError) {
  Mesh good = make_icosphere(1, 1.0f);
  Mesh empty;
  empty.source = "empty.stl";
  Result<HausdorffReport> r = hausdorff(good, empty);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::kInvalidArgument);
  EXPECT_EQ(r.status().message().rfind("empty.stl: has no triangles", 0), 0u)
      << r.status().message();
  EXPECT_FALSE(hausdorff(empty, good).ok());

  Mesh points = good;
  points.name = "points";
  points.indices.clear();
  EXPECT_FALSE(hausdorff(points, good).ok());

  Mesh nan = good;
  nan.source = "bad.ply";
  nan.positions[3].y = std::numeric_limits<float>::quiet_NaN();
  r = hausdorff(good, nan);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::kInvalidData);
  EXPECT_NE(r.status().message().find("bad.ply: non-finite coordinate"), std::string::npos)
      << r.status().message();
  EXPECT_NE(r.status().message().find("vertex 3"), std::string::npos);
  nan.positions[3].y = std::numeric_limits<float>::infinity();
  EXPECT_EQ(DistanceQuery::build(nan).status().code(), ErrorCode::kInvalidData);

  Mesh out_of_range = good;
  out_of_range.name = "broken";
  out_of_range.indices[4] = 999;
  r = hausdorff(out_of_range, good);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("broken: index 999 out of range"), std::string::npos);

  EXPECT_FALSE(hausdorff(good, good, {.samples_per_face = 0}).ok());
  EXPECT_FALSE(hausdorff(good, good, {.threads = -1}).ok());
  EXPECT_FALSE(hausdorff(good, good,
                         {.sample_vertices = false, .sample_edges = false, .sample_faces = false})
                   .ok());
}

TEST(Hausdorff, PaperRelativeErrorsOnlyWhereDefined) {
  Mesh a = make_icosphere(3, 1.0f);
  Mesh b = make_icosphere(3, 1.02f);
  HausdorffReport xy = measure(a, b);
  HausdorffReport xx = measure(a, a);
  // As printed, eq. (10)-(12) divide by d(X, X), which is 0: undefined.
  PaperRelativeErrors undefined = paper_relative_errors(xy.forward, xx.forward);
  EXPECT_FALSE(undefined.max.has_value());
  EXPECT_FALSE(undefined.mean.has_value());
  EXPECT_FALSE(undefined.rms.has_value());
  // Defined whenever the reference is not zero.
  OneSidedDistance reference = xy.forward;
  reference.max *= 2;
  PaperRelativeErrors defined = paper_relative_errors(xy.forward, reference);
  ASSERT_TRUE(defined.max.has_value());
  EXPECT_DOUBLE_EQ(*defined.max, 0.5);
  EXPECT_DOUBLE_EQ(*defined.mean, 0.0);
  // What osteon reports instead: relative to the bounding-box diagonal.
  EXPECT_NEAR(*xy.forward.max_relative(), xy.forward.max / xy.forward.diagonal, 1e-15);
  Mesh dot;
  dot.positions = {{1, 1, 1}};
  dot.indices = {0, 0, 0};
  EXPECT_FALSE(measure(dot, dot).forward.max_relative().has_value());
}

// ---- the codec's error bound ---------------------------------------------------------------

// Small meshes of several kinds (open, non-manifold, many components, metres and millimetres),
// or the phantom when ../shared/data is absent.
std::vector<Mesh> codec_meshes() {
  std::vector<Mesh> meshes;
  std::string data = test::shared_data_dir();
  if (!data.empty()) {
    for (const char* path :
         {"MyoHub__myo_sim/meshes/arm_r_pisiform.stl", "MyoHub__myo_sim/meshes/ground_spine.stl",
          "aHer-dev__3DAnatomy/models/bones/FJ119_BP63007_FMA52736_Sphenoid_bone.glb",
          "cearto__zen__MeshsegBenchmark/data/off/1.off"}) {
      Result<Scene> scene = read_path(data + "/" + path);
      EXPECT_TRUE(scene.ok()) << scene.status().message();
      if (scene.ok()) meshes.push_back(scene->parts[0]);
    }
  }
  if (meshes.empty()) {
    Phantom phantom = make_phantom({.seed = 9, .detail = 3});
    for (size_t i = 0; i < phantom.scene.parts.size(); i += 3) {
      meshes.push_back(phantom.scene.parts[i]);
    }
  }
  return meshes;
}

TEST(Hausdorff, CodecStaysWithinItsErrorBound) {
  // Every vertex moves by at most half a grid step per coordinate, so by at most sqrt(3)/2 steps;
  // a point of a triangle moves by a convex combination of its corners' moves, no more. So both
  // one-sided distances between the input (without the degenerate triangles the encoder drops)
  // and the decoded mesh are within sqrt(3)/2 steps, plus the float output's rounding.
  for (const Mesh& input : codec_meshes()) {
    SCOPED_TRACE(input.source.empty() ? input.name : input.source);
    Mesh mesh = input;
    remove_degenerate_triangles(mesh);
    Aabb box = bounding_box(mesh);
    double largest = std::max({std::fabs(box.min.x), std::fabs(box.min.y), std::fabs(box.min.z),
                               std::fabs(box.max.x), std::fabs(box.max.y), std::fabs(box.max.z)});
    for (int bits : {10, 14}) {
      SCOPED_TRACE(bits);
      EncodeReport report;
      Result<std::vector<uint8_t>> bytes = encode(mesh, {.bits = bits}, &report);
      ASSERT_TRUE(bytes.ok()) << bytes.status().message();
      Result<Mesh> decoded = decode(bytes->data(), bytes->size());
      ASSERT_TRUE(decoded.ok()) << decoded.status().message();
      HausdorffReport r = measure(mesh, *decoded, {.samples_per_face = 4});
      double bound = std::sqrt(3.0) * (0.5 * report.grid_step + largest * 0x1p-24 * 1.01);
      EXPECT_LE(r.symmetric.max, bound);
      // And the bound is not loose by orders of magnitude: quantization error is visible.
      EXPECT_GT(r.symmetric.max, 0.1 * bound);
      EXPECT_LT(r.symmetric.rms, r.symmetric.max);
    }
  }
}

// ---- MeshLab -------------------------------------------------------------------------------

bool on_path(const std::string& program) {
  return std::system(("command -v " + program + " >/dev/null 2>&1").c_str()) == 0;
}

TEST(Hausdorff, AgreesWithMeshLabOnASmallPair) {
  if (!on_path("meshlabserver") || !on_path("xvfb-run")) {
    GTEST_SKIP() << "meshlabserver or xvfb-run not installed (apt-get install meshlab xvfb "
                    "xauth): the MeshLab comparison runs in bench/hausdorff_bench";
  }
  // A copy of a sphere with seeded noise on every vertex, against the sphere. MeshLab's SampleNum
  // K takes all vertices (K >= vertices), K edge and K face points; osteon the same at V + 2K
  // samples. The largest distance is at a noisy vertex's tip, which both sample; mean and RMS
  // are averages over 100k random points, within a fraction of a percent of each other.
  std::string dir = test::scratch_dir();
  Mesh b = make_icosphere(4, 10.0f);  // 2,562 vertices, 5,120 triangles
  Mesh a = b;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.05f, 0.05f);
  for (Vec3& p : a.positions) p = {p.x + noise(rng), p.y + noise(rng), p.z + noise(rng)};
  ASSERT_TRUE(write_mesh(dir + "/a.ply", a).ok());
  ASSERT_TRUE(write_mesh(dir + "/b.ply", b).ok());
  const uint64_t k = 50000;
  std::string script = dir + "/hausdorff.mlx";
  test::write_bytes(
      script,
      "<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name=\"Hausdorff Distance\">\n"
      "  <Param type=\"RichMesh\" value=\"0\" name=\"SampledMesh\"/>\n"
      "  <Param type=\"RichMesh\" value=\"1\" name=\"TargetMesh\"/>\n"
      "  <Param type=\"RichBool\" value=\"false\" name=\"SaveSample\"/>\n"
      "  <Param type=\"RichBool\" value=\"true\" name=\"SampleVert\"/>\n"
      "  <Param type=\"RichBool\" value=\"true\" name=\"SampleEdge\"/>\n"
      "  <Param type=\"RichBool\" value=\"false\" name=\"SampleFauxEdge\"/>\n"
      "  <Param type=\"RichBool\" value=\"true\" name=\"SampleFace\"/>\n"
      "  <Param type=\"RichInt\" value=\"" +
          std::to_string(k) +
          "\" name=\"SampleNum\"/>\n"
          "  <Param type=\"RichAbsPerc\" value=\"100\" min=\"0\" max=\"100\" name=\"MaxDist\"/>\n"
          " </filter>\n</FilterScript>\n");
  std::string log = dir + "/log.txt";
  std::string command = "xvfb-run -a meshlabserver -i " + dir + "/a.ply -i " + dir + "/b.ply -s " +
                        script + " -l " + log + " >" + dir + "/out.txt 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::vector<uint8_t> bytes = test::read_bytes(log);
  std::string text(bytes.begin(), bytes.end());
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      text, m,
      std::regex(
          R"(min : ([0-9.eE+-]+)\s+max ([0-9.eE+-]+)\s+mean : ([0-9.eE+-]+)\s+RMS : ([0-9.eE+-]+))")))
      << text;
  double max = std::stod(m[2]), mean = std::stod(m[3]), rms = std::stod(m[4]);
  HausdorffReport r = measure(a, b, {.samples = a.vertex_count() + 2 * k});
  EXPECT_EQ(r.forward.vertex_samples, a.vertex_count());
  EXPECT_EQ(r.forward.face_samples, k);
  EXPECT_NEAR(r.forward.max, max, 0.02 * max);
  EXPECT_NEAR(r.forward.mean, mean, 0.02 * mean);
  EXPECT_NEAR(r.forward.rms, rms, 0.02 * rms);
}

// ---- the CLI -------------------------------------------------------------------------------

using test::CliRun;
using test::run_cli;

TEST(HausdorffCli, CompareJsonHasTheDocumentedFields) {
  std::string dir = test::scratch_dir();
  ASSERT_TRUE(write_mesh(dir + "/unit.ply", make_icosphere(4, 1.0f)).ok());
  ASSERT_TRUE(write_mesh(dir + "/larger.ply", make_icosphere(4, 1.01f)).ok());
  CliRun run = run_cli("compare " + dir + "/unit.ply " + dir + "/larger.ply --json");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;  // no progress bar when stderr is not a terminal
  nlohmann::json j = nlohmann::json::parse(run.out);
  for (const char* side : {"forward", "backward", "symmetric"}) {
    SCOPED_TRACE(side);
    ASSERT_TRUE(j.contains(side));
    for (const char* key : {"max", "mean", "rms", "diagonal", "max_relative", "samples"}) {
      EXPECT_TRUE(j[side].contains(key)) << key;
    }
    EXPECT_LE(j[side]["max"].get<double>(), 0.01 + 1e-6);
    EXPECT_GT(j[side]["mean"].get<double>(), 0.0095);
  }
  EXPECT_EQ(j["forward"]["samples"], 10 * 5120);
  EXPECT_EQ(j["matched_by"], "single");
  ASSERT_EQ(j["parts"].size(), 1u);
  EXPECT_EQ(j["parts"][0]["symmetric"]["max"], j["symmetric"]["max"]);

  CliRun fixed =
      run_cli("compare " + dir + "/unit.ply " + dir + "/larger.ply --json --samples 999");
  ASSERT_EQ(fixed.status, 0) << fixed.err;
  EXPECT_EQ(nlohmann::json::parse(fixed.out)["backward"]["samples"], 999);

  CliRun table = run_cli("compare " + dir + "/unit.ply " + dir + "/unit.ply");
  ASSERT_EQ(table.status, 0) << table.err;
  EXPECT_NE(table.out.find("symmetric"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("lower bound"), std::string::npos) << table.out;
}

TEST(HausdorffCli, ComparesFoldersPartByPart) {
  std::string dir = test::scratch_dir();
  std::filesystem::create_directories(dir + "/a");
  std::filesystem::create_directories(dir + "/b");
  Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  Mesh ball = make_icosphere(2, 1.0f);
  ASSERT_TRUE(write_mesh(dir + "/a/box.stl", box).ok());
  ASSERT_TRUE(write_mesh(dir + "/a/ball.stl", ball).ok());
  ASSERT_TRUE(write_mesh(dir + "/b/box.stl", translated(box, {0, 0, 0.25f})).ok());
  ASSERT_TRUE(write_mesh(dir + "/b/ball.stl", ball).ok());
  CliRun run = run_cli("compare --json " + dir + "/a " + dir + "/b");
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["matched_by"], "name");
  ASSERT_EQ(j["parts"].size(), 2u);
  for (const nlohmann::json& part : j["parts"]) {
    EXPECT_EQ(part["a"], part["b"]);
    double expected = part["a"] == "box" ? 0.25 : 0.0;
    EXPECT_NEAR(part["symmetric"]["max"].get<double>(), expected, 1e-6) << part["a"];
  }
  EXPECT_NEAR(j["symmetric"]["max"].get<double>(), 0.25, 1e-6);
  // Overall: every sample of both parts; the ball's zeros pull the mean below the box's 0.25.
  EXPECT_GT(j["forward"]["mean"].get<double>(), 0.0);
  EXPECT_LT(j["forward"]["mean"].get<double>(), 0.25);
  EXPECT_EQ(j["forward"]["samples"].get<uint64_t>(),
            j["parts"][0]["forward"]["samples"].get<uint64_t>() +
                j["parts"][1]["forward"]["samples"].get<uint64_t>());

  // A folder against one mesh: the folder's parts merged.
  Mesh both = box;
  for (const Vec3& p : ball.positions) both.positions.push_back(p);
  for (uint32_t i : ball.indices) both.indices.push_back(i + uint32_t(box.positions.size()));
  ASSERT_TRUE(write_mesh(dir + "/merged.ply", both).ok());
  CliRun merged = run_cli("compare --json " + dir + "/a " + dir + "/merged.ply");
  ASSERT_EQ(merged.status, 0) << merged.err;
  EXPECT_EQ(nlohmann::json::parse(merged.out)["symmetric"]["max"], 0.0);
}

TEST(HausdorffCli, PairsPartsByOrderOrRefuses) {
  std::string dir = test::scratch_dir();
  for (const char* sub : {"/a", "/b", "/c"}) std::filesystem::create_directories(dir + sub);
  Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  ASSERT_TRUE(write_mesh(dir + "/a/first.stl", box).ok());
  ASSERT_TRUE(write_mesh(dir + "/a/second.stl", translated(box, {5, 0, 0})).ok());
  ASSERT_TRUE(write_mesh(dir + "/b/one.stl", box).ok());
  ASSERT_TRUE(write_mesh(dir + "/b/two.stl", translated(box, {5, 0, 0.5f})).ok());
  CliRun by_order = run_cli("compare --json " + dir + "/a " + dir + "/b");
  ASSERT_EQ(by_order.status, 0) << by_order.err;
  nlohmann::json j = nlohmann::json::parse(by_order.out);
  EXPECT_EQ(j["matched_by"], "order");
  EXPECT_EQ(j["parts"][1]["a"], "second");
  EXPECT_EQ(j["parts"][1]["b"], "two");
  EXPECT_NEAR(j["symmetric"]["max"].get<double>(), 0.5, 1e-6);

  ASSERT_TRUE(write_mesh(dir + "/c/x.stl", box).ok());
  ASSERT_TRUE(write_mesh(dir + "/c/y.stl", box).ok());
  ASSERT_TRUE(write_mesh(dir + "/c/z.stl", box).ok());
  CliRun refused = run_cli("compare " + dir + "/a " + dir + "/c");
  EXPECT_EQ(refused.status, 2);
  EXPECT_NE(refused.err.find("cannot pair them"), std::string::npos) << refused.err;
}

TEST(HausdorffCli, CompareErrorsNameTheFile) {
  std::string dir = test::scratch_dir();
  ASSERT_TRUE(write_mesh(dir + "/ball.ply", make_icosphere(1, 1.0f)).ok());
  CliRun missing = run_cli("compare " + dir + "/ball.ply " + dir + "/none.ply");
  EXPECT_EQ(missing.status, 2);
  EXPECT_EQ(missing.err.rfind("osteon: error: " + dir + "/none.ply", 0), 0u) << missing.err;

  test::write_bytes(dir + "/nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  CliRun nan = run_cli("compare " + dir + "/ball.ply " + dir + "/nan.obj");
  EXPECT_EQ(nan.status, 2);
  EXPECT_EQ(nan.err.rfind("osteon: error: " + dir + "/nan.obj", 0), 0u) << nan.err;

  test::write_bytes(dir + "/points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  CliRun points = run_cli("compare " + dir + "/ball.ply " + dir + "/points.obj");
  EXPECT_EQ(points.status, 2);
  EXPECT_NE(points.err.find("points.obj"), std::string::npos) << points.err;

  CliRun bad_samples = run_cli("compare " + dir + "/ball.ply " + dir + "/ball.ply --samples 0");
  EXPECT_EQ(bad_samples.status, 2);
}

}  // namespace hausdorff_test
}  // namespace
}  // namespace osteon
