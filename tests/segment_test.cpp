// SPDX-License-Identifier: Apache-2.0
#include "osteon/segment.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <vector>

#include "dual_graph.hpp"
#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

// Segmentation: connected parts, Dijkstra region diffusion on the GD-weighted dual graph, merging
// and the streaming size limit.

namespace osteon {
namespace {
namespace segment_test {

/// Appends a grid of nx x ny quads spanning origin + [0,1]u x [0,1]v (two triangles each), facing
/// u x v. Vertices on the grid's edges are shared with earlier grids where positions are equal
/// (the caller welds).
void add_grid(Mesh& mesh, Vec3 origin, Vec3 u, Vec3 v, int nx, int ny) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const float a = float(i) / nx, b = float(j) / ny;
      mesh.positions.push_back({origin.x + a * u.x + b * v.x, origin.y + a * u.y + b * v.y,
                                origin.z + a * u.z + b * v.z});
    }
  }
  auto at = [&](int i, int j) { return base + static_cast<uint32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
}

/// A floor (z = 0, x in [0, 2], facing up) and a wall rising from its edge x = 2 (facing the
/// floor): one concave 90-degree crease. Returns the mesh; the floor's triangles come first.
Mesh floor_and_wall(size_t* floor_triangles) {
  Mesh mesh;
  add_grid(mesh, {0, 0, 0}, {2, 0, 0}, {0, 1, 0}, 24, 12);
  *floor_triangles = mesh.triangle_count();
  add_grid(mesh, {2, 0, 0}, {0, 1, 0}, {0, 0, 0.6f}, 12, 8);
  weld(mesh);
  return mesh;
}

/// True when every component's triangles are edge-connected.
bool components_connected(const Mesh& mesh, const Segmentation& seg) {
  const detail::DualGraph g = detail::build_dual_graph(mesh, {});
  std::vector<int> seen(seg.labels.size(), 0);
  std::set<uint32_t> started;
  for (uint32_t s = 0; s < seg.labels.size(); ++s) {
    if (seen[s]) continue;
    if (!started.insert(seg.labels[s]).second) return false;  // a second piece of a label
    std::vector<uint32_t> stack{s};
    seen[s] = 1;
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      for (uint32_t k = g.first[t]; k < g.first[t + 1]; ++k) {
        const uint32_t u = g.target[k];
        if (!seen[u] && seg.labels[u] == seg.labels[t]) {
          seen[u] = 1;
          stack.push_back(u);
        }
      }
    }
  }
  return true;
}

/// Labels are 0 .. count - 1, numbered in order of first appearance.
void expect_numbered(const Segmentation& seg) {
  uint32_t next = 0;
  for (uint32_t label : seg.labels) {
    ASSERT_LE(label, next);
    if (label == next) ++next;
  }
  EXPECT_EQ(next, seg.count);
}

TEST(DualGraph, WeightsFollowThePaper) {
  size_t floor = 0;
  const Mesh mesh = floor_and_wall(&floor);
  const detail::DualGraph g = detail::build_dual_graph(mesh, {300, 0.1});
  ASSERT_EQ(g.triangles(), mesh.triangle_count());
  // Interior floor arcs are flat (AD 0), crease arcs concave at 90 degrees (AD 1), each stored
  // in both directions with the same weight GD = (CD + phi * AD * mean CD) / diagonal.
  size_t crease = 0;
  for (uint32_t t = 0; t < g.triangles(); ++t) {
    for (uint32_t k = g.first[t]; k < g.first[t + 1]; ++k) {
      const uint32_t u = g.target[k];
      const bool across = (t < floor) != (u < floor);
      EXPECT_NEAR(g.concavity[k], across ? 1.0 : 0.0, 1e-5);
      if (across) ++crease;
      const double cd = g.weight[k] * g.diagonal - 300 * g.concavity[k] * g.mean_cd;
      EXPECT_GT(cd, 0);
      EXPECT_LT(cd, 0.2);  // centroids of neighbouring cells 1/12 apart at most
    }
  }
  EXPECT_EQ(crease, 2u * 12);  // 12 quads along the crease, one triangle each side, both ways
  EXPECT_NEAR(g.diagonal, std::sqrt(4 + 1 + 0.36), 1e-5);
}

TEST(DualGraph, ConvexEdgesUseEta) {
  const Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  const detail::DualGraph g = detail::build_dual_graph(box, {300, 0.25});
  float largest = 0;
  for (float ad : g.concavity) largest = std::max(largest, ad);
  EXPECT_NEAR(largest, 0.25, 1e-6);  // a box has only convex 90-degree edges: eta * (1 - 0)
}

TEST(Segment, CutsAlongTheConcaveCrease) {
  size_t floor = 0;
  const Mesh mesh = floor_and_wall(&floor);
  SegmentOptions options;
  options.segments = 2;
  Result<Segmentation> seg = segment(mesh, options);
  ASSERT_TRUE(seg.ok()) << seg.status().message();
  ASSERT_EQ(seg->count, 2u);
  EXPECT_EQ(seg->parts, 1u);
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    EXPECT_EQ(seg->labels[t], t < floor ? 0u : 1u) << "triangle " << t;
  }
}

TEST(Segment, WithoutAnglesTheCreaseIsNoBarrier) {
  // phi = 0 cuts by centroid distance only: the cut lands inside the larger floor.
  size_t floor = 0;
  const Mesh mesh = floor_and_wall(&floor);
  SegmentOptions options;
  options.segments = 2;
  options.phi = 0;
  Result<Segmentation> seg = segment(mesh, options);
  ASSERT_TRUE(seg.ok());
  ASSERT_EQ(seg->count, 2u);
  std::set<uint32_t> on_floor(seg->labels.begin(), seg->labels.begin() + floor);
  EXPECT_EQ(on_floor.size(), 2u);
}

TEST(Segment, ConnectedPartsAreNeverJoined) {
  Mesh mesh = make_box({0, 0, 0}, {1, 1, 1});
  const Mesh other = make_box({3, 0, 0}, {4, 1, 1});
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), other.positions.begin(), other.positions.end());
  for (uint32_t i : other.indices) mesh.indices.push_back(base + i);
  for (uint32_t wanted : {0u, 1u, 2u}) {
    SegmentOptions options;
    options.segments = wanted;
    Result<Segmentation> seg = segment(mesh, options);
    ASSERT_TRUE(seg.ok());
    EXPECT_EQ(seg->parts, 2u);
    EXPECT_EQ(seg->count, 2u) << "segments " << wanted;
    for (size_t t = 0; t < 12; ++t) EXPECT_EQ(seg->labels[t], 0u);
    for (size_t t = 12; t < 24; ++t) EXPECT_EQ(seg->labels[t], 1u);
  }
}

TEST(Segment, TargetCountOnEveryCategory) {
  for (const test::NamedMesh& m : test::mesh_categories()) {
    SCOPED_TRACE(m.category + " " + m.mesh.name);
    for (uint32_t wanted : {1u, 4u}) {
      SegmentOptions options;
      options.segments = wanted;
      Result<Segmentation> seg = segment(m.mesh, options);
      ASSERT_TRUE(seg.ok()) << seg.status().message();
      ASSERT_EQ(seg->labels.size(), m.mesh.triangle_count());
      expect_numbered(seg.value());
      // As many as wanted, or one per connected part when there are more parts; fewer only when
      // the mesh has fewer triangles.
      const uint32_t expected =
          std::min<uint32_t>(std::max(wanted, seg->parts), uint32_t(m.mesh.triangle_count()));
      EXPECT_EQ(seg->count, expected);
    }
  }
}

TEST(Segment, NoComponentLargerThanTheLimit) {
  const Mesh sphere = make_icosphere(4);  // 5120 triangles, no crease at all
  for (uint32_t limit : {300u, 1000u, 5000u}) {
    SegmentOptions options;
    options.max_triangles = limit;
    Result<Segmentation> seg = segment(sphere, options);
    ASSERT_TRUE(seg.ok());
    std::vector<uint32_t> sizes(seg->count, 0);
    for (uint32_t label : seg->labels) ++sizes[label];
    EXPECT_LE(*std::max_element(sizes.begin(), sizes.end()), limit);
    EXPECT_GE(seg->count, (5120 + limit - 1) / limit);
    expect_numbered(seg.value());
    EXPECT_TRUE(components_connected(sphere, seg.value())) << "limit " << limit;
  }
}

TEST(Segment, LimitWinsOverTheTargetCount) {
  const Mesh sphere = make_icosphere(3);  // 1280 triangles
  SegmentOptions options;
  options.segments = 2;
  options.max_triangles = 200;
  Result<Segmentation> seg = segment(sphere, options);
  ASSERT_TRUE(seg.ok());
  std::vector<uint32_t> sizes(seg->count, 0);
  for (uint32_t label : seg->labels) ++sizes[label];
  EXPECT_LE(*std::max_element(sizes.begin(), sizes.end()), 200u);
  EXPECT_TRUE(components_connected(sphere, seg.value()));
}

TEST(Segment, Deterministic) {
  const Phantom phantom = make_phantom();
  const Mesh& bone = phantom.scene.parts[0];
  SegmentOptions options;
  options.segments = 5;
  Result<Segmentation> a = segment(bone, options);
  Result<Segmentation> b = segment(bone, options);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->labels, b->labels);
  EXPECT_TRUE(components_connected(bone, a.value()));
}

TEST(Segment, SmallAndEmptyMeshes) {
  Mesh empty;
  Result<Segmentation> none = segment(empty);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->count, 0u);
  EXPECT_TRUE(none->labels.empty());

  Mesh one;
  one.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  one.indices = {0, 1, 2};
  SegmentOptions options;
  options.segments = 3;
  Result<Segmentation> single = segment(one, options);
  ASSERT_TRUE(single.ok());
  EXPECT_EQ(single->count, 1u);
  EXPECT_EQ(single->labels, std::vector<uint32_t>{0});

  // Degenerate triangles (a repeated index, zero area) are labelled like any other.
  Mesh degenerate = one;
  degenerate.positions.push_back({2, 0, 0});
  degenerate.indices.insert(degenerate.indices.end(), {1, 1, 2, 0, 1, 3});
  Result<Segmentation> seg = segment(degenerate, options);
  ASSERT_TRUE(seg.ok());
  EXPECT_EQ(seg->labels.size(), 3u);
}

TEST(Segment, BadInput) {
  Mesh mesh = make_box({0, 0, 0}, {1, 1, 1});
  mesh.source = "box.stl";
  mesh.positions[3].y = std::numeric_limits<float>::quiet_NaN();
  Result<Segmentation> nan = segment(mesh);
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.status().message(), "box.stl: segmentation: a position is not finite (vertex 3)");

  SegmentOptions options;
  options.phi = -1;
  Result<Segmentation> negative = segment(make_box({0, 0, 0}, {1, 1, 1}), options);
  ASSERT_FALSE(negative.ok());
  EXPECT_EQ(negative.status().code(), ErrorCode::kInvalidArgument);
}

TEST(Segment, RealMeshesFitTheStreamingLimit) {
  // A sample of every reader's real files, segmented for streaming as `osteon pack` will.
  OSTEON_REQUIRE_SHARED_DATA(data);
  for (const char* path :
       {"MyoHub__myo_sim/meshes/ground_spine.stl", "MyoHub__myo_sim/meshes/arm_r_radius.stl",
        "cearto__zen__MeshsegBenchmark/data/off/1.off"}) {
    SCOPED_TRACE(path);
    Result<Scene> scene = read_path(data + "/" + path);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    const Mesh mesh = merge_parts(std::move(scene.value()));
    SegmentOptions options;
    options.max_triangles = 2000;
    Result<Segmentation> seg = segment(mesh, options);
    ASSERT_TRUE(seg.ok()) << seg.status().message();
    std::vector<uint32_t> sizes(seg->count, 0);
    for (uint32_t label : seg->labels) ++sizes[label];
    EXPECT_LE(*std::max_element(sizes.begin(), sizes.end()), 2000u);
    EXPECT_TRUE(components_connected(mesh, seg.value()));
  }
}

TEST(SegmentCli, WritesOneLinePerTriangleAndAColouredPly) {
  const std::string dir = test::scratch_dir();
  size_t floor = 0;
  const Mesh mesh = floor_and_wall(&floor);
  ASSERT_TRUE(write_mesh(dir + "/corner.ply", mesh).ok());
  test::CliRun run = test::run_cli("segment " + dir + "/corner.ply -o " + dir + "/corner.seg " +
                                   "--segments 2 --colored " + dir + "/coloured.ply --json");
  ASSERT_EQ(run.status, 0) << run.err;
  const auto seg = test::read_bytes(dir + "/corner.seg");
  const std::string text(seg.begin(), seg.end());
  EXPECT_EQ(size_t(std::count(text.begin(), text.end(), '\n')), mesh.triangle_count());
  EXPECT_EQ(text.substr(0, 2), "0\n");
  EXPECT_EQ(text.substr(text.size() - 2), "1\n");
  EXPECT_NE(run.out.find("\"components\": 2"), std::string::npos) << run.out;
  Result<Scene> coloured = read_path(dir + "/coloured.ply");
  ASSERT_TRUE(coloured.ok()) << coloured.status().message();
  EXPECT_EQ(coloured->parts[0].triangle_count(), mesh.triangle_count());
}

TEST(SegmentCli, ErrorsNameTheFile) {
  const std::string dir = test::scratch_dir();
  test::CliRun run = test::run_cli("segment " + dir + "/missing.off -o " + dir + "/out.seg");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("osteon: error: " + dir + "/missing.off"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.seg"));
  run = test::run_cli("segment " + dir + "/missing.off -o " + dir + "/out.seg --phi -3");
  EXPECT_EQ(run.status, 2);
}

}  // namespace segment_test
}  // namespace
}  // namespace osteon
