// SPDX-License-Identifier: Apache-2.0
#include "support/segeval.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"

// The Princeton Segmentation Benchmark's measures: hand-worked answers on a square and a cube,
// the .seg reader's errors, the CLI, and the benchmark's Human, None and Every rows on the 38
// models in ../shared/data, which an independent implementation of segEval gives.

namespace osteon {
namespace {
namespace segeval_test {

namespace fs = std::filesystem;

std::vector<uint8_t> bytes_of(const std::string& text) {
  return std::vector<uint8_t>(text.begin(), text.end());
}

Result<std::vector<uint32_t>> parse(const std::string& text, size_t faces) {
  std::vector<uint8_t> b = bytes_of(text);
  return parse_seg(b.data(), b.size(), "x.seg", faces);
}

// A unit square in z = 0 as two triangles sharing the diagonal 0-2.
Mesh square() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

// The unit cube, two triangles per side, sides in the order z=0, z=1, x=0, x=1, y=0, y=1
// (triangles 2s and 2s + 1 are side s). Every triangle has area 1/2 and its centroid at distance
// sqrt(11)/6 from the cube's centre, so the average radius is sqrt(11)/6.
Mesh cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i) {
    m.positions.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  }
  // Each side's corners in order around it; split along the diagonal a-c.
  const uint32_t sides[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 4, 6, 2},
                                {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}};
  for (const auto& s : sides) {
    m.indices.insert(m.indices.end(), {s[0], s[1], s[2], s[0], s[2], s[3]});
  }
  return m;
}

// Per cube triangle, from a per-side label.
std::vector<uint32_t> by_side(const std::vector<uint32_t>& side_label) {
  std::vector<uint32_t> labels;
  for (uint32_t l : side_label) labels.insert(labels.end(), {l, l});
  return labels;
}

const std::vector<uint32_t> kAxes = by_side({0, 0, 1, 1, 2, 2});    // S1: z, x, y sides
const std::vector<uint32_t> kSides = by_side({0, 1, 2, 3, 4, 5});   // S2: one per side
const std::vector<uint32_t> kBottom = by_side({0, 1, 1, 1, 1, 1});  // S3: bottom and the rest

SegmentationScores scores_of(const Mesh& mesh, const std::vector<uint32_t>& seg,
                             const std::vector<uint32_t>& ref) {
  Result<SegmentationScores> s = evaluate_segmentation(mesh, seg, ref);
  EXPECT_TRUE(s.ok()) << s.status().message();
  return s.ok() ? s.value() : SegmentationScores{};
}

constexpr double kEps = 1e-12;

// ---------------------------------------------------------------------------------------------
// Hand-worked cases

TEST(SegEval, IdenticalPartitionsScoreZeroWhateverTheIds) {
  Mesh m = cube();
  std::vector<uint32_t> renamed = by_side({7, 7, 30, 30, 4, 4});
  SegmentationScores s = scores_of(m, kAxes, renamed);
  ASSERT_TRUE(s.cut_discrepancy.has_value());
  EXPECT_NEAR(*s.cut_discrepancy, 0, kEps);
  EXPECT_NEAR(s.hamming, 0, kEps);
  EXPECT_NEAR(s.hamming_rm, 0, kEps);
  EXPECT_NEAR(s.hamming_rf, 0, kEps);
  EXPECT_EQ(s.one_minus_rand_index, 0);
  EXPECT_NEAR(s.gce, 0, kEps);
  EXPECT_NEAR(s.lce, 0, kEps);
}

TEST(SegEval, SquareSplitAgainstWhole) {
  // seg: one segment per triangle; ref: one segment. The only pair is split in seg, joined in
  // ref: 1 - RI = 1. The ref's one segment (area 1) matches a half: Rm = 1/2; each of seg's
  // halves lies inside it: Rf = 0. GCE, LCE: 0 (segEval's trivial case). CD: the ref has no cut.
  SegmentationScores s = scores_of(square(), {0, 1}, {0, 0});
  EXPECT_FALSE(s.cut_discrepancy.has_value());
  EXPECT_NEAR(s.hamming_rm, 0.5, kEps);
  EXPECT_NEAR(s.hamming_rf, 0, kEps);
  EXPECT_NEAR(s.hamming, 0.25, kEps);
  EXPECT_EQ(s.one_minus_rand_index, 1.0);
  EXPECT_EQ(s.gce, 0);
  EXPECT_EQ(s.lce, 0);
  // Both cut along the diagonal: the cuts coincide.
  SegmentationScores same = scores_of(square(), {0, 1}, {1, 0});
  ASSERT_TRUE(same.cut_discrepancy.has_value());
  EXPECT_EQ(*same.cut_discrepancy, 0);
}

TEST(SegEval, CubeBottomAgainstAxes) {
  // seg S3 = {bottom (2 triangles, area 1), the rest (10, area 5)}; ref S1 = {z sides, x sides,
  // y sides} (4 triangles, area 2 each). Contingency cells (area): bottom/z 1, rest/z 1 (top),
  // rest/x 2, rest/y 2.
  Mesh m = cube();
  SegmentationScores s = scores_of(m, kBottom, kAxes);
  // Hamming: the ref's segments keep 1 + 2 + 2 of area 6 in their best matches, so Rm = 1/6;
  // seg's keep 1 (bottom) + 2 (rest: x or y), so Rf = 3/6.
  EXPECT_NEAR(s.hamming_rm, 1.0 / 6, kEps);
  EXPECT_NEAR(s.hamming_rf, 0.5, kEps);
  EXPECT_NEAR(s.hamming, 1.0 / 3, kEps);
  // Rand: pairs together in seg C(2,2) + C(10,2) = 46, in ref 3 C(4,2) = 18, in both
  // 1 + 1 + 6 + 6 = 14: disagreements 46 + 18 - 28 = 36 of C(12,2) = 66.
  EXPECT_NEAR(s.one_minus_rand_index, 36.0 / 66, kEps);
  // Refinement errors E(seg, ref, t) = 1 - |cell| / |seg region|: bottom 0, top 1 - 1/5, x and y
  // 1 - 2/5: sum 2(0) + 2(0.8) + 4(0.6) + 4(0.6) = 6.4. E(ref, seg, t) = 1 - |cell| / |ref
  // region|: bottom 1/2, top 1/2, x and y 0: sum 2. GCE = min(6.4, 2) / 12; LCE sums the
  // per-triangle minimum: 2(0) + 2(0.5) + 0 = 1, over 12.
  EXPECT_NEAR(s.gce, 2.0 / 12, kEps);
  EXPECT_NEAR(s.lce, 1.0 / 12, kEps);
  // Cuts: seg's are the bottom square's 4 corners; ref's all 8 corners. The bottom corners are
  // 0 from ref's cuts and from seg's; each top corner is 1 edge (length 1) from the nearest
  // bottom corner. Mean over 4 + 8 cut vertices: 4 / 12, over the average radius sqrt(11)/6.
  ASSERT_TRUE(s.cut_discrepancy.has_value());
  EXPECT_NEAR(*s.cut_discrepancy, (4.0 / 12) / (std::sqrt(11.0) / 6), 1e-6);

  // Swapped, only Rm and Rf change: they trade places.
  SegmentationScores r = scores_of(m, kAxes, kBottom);
  EXPECT_NEAR(r.hamming_rm, s.hamming_rf, kEps);
  EXPECT_NEAR(r.hamming_rf, s.hamming_rm, kEps);
  EXPECT_NEAR(r.hamming, s.hamming, kEps);
  EXPECT_NEAR(r.one_minus_rand_index, s.one_minus_rand_index, kEps);
  EXPECT_NEAR(r.gce, s.gce, kEps);
  EXPECT_NEAR(r.lce, s.lce, kEps);
  EXPECT_NEAR(*r.cut_discrepancy, *s.cut_discrepancy, kEps);
}

TEST(SegEval, CubeRefinementHasNoConsistencyError) {
  // S2 (one segment per side) refines S1: no refinement error either way round.
  Mesh m = cube();
  SegmentationScores s = scores_of(m, kSides, kAxes);
  EXPECT_NEAR(s.gce, 0, kEps);
  EXPECT_NEAR(s.lce, 0, kEps);
  // Each ref segment (area 2) keeps 1 in its best side: Rm = 3/6; each side lies in one axis
  // segment: Rf = 0.
  EXPECT_NEAR(s.hamming_rm, 0.5, kEps);
  EXPECT_NEAR(s.hamming_rf, 0, kEps);
  // Together in seg 6 C(2,2) = 6, in ref 18, in both 6: (6 + 18 - 12) / 66.
  EXPECT_NEAR(s.one_minus_rand_index, 12.0 / 66, kEps);
  // Every corner is on a cut of both.
  EXPECT_NEAR(*s.cut_discrepancy, 0, kEps);
}

TEST(SegEval, CubeTrivialSegmentations) {
  Mesh m = cube();
  std::vector<uint32_t> none(12, 0), every(12);
  for (uint32_t t = 0; t < 12; ++t) every[t] = t;
  // One segment: nothing missed, the false alarms are all but the largest ref segment (2 of 6);
  // 1 - RI = 1 - 18/66; no cut, so CD is undefined.
  SegmentationScores n = scores_of(m, none, kAxes);
  EXPECT_FALSE(n.cut_discrepancy.has_value());
  EXPECT_NEAR(n.hamming_rm, 0, kEps);
  EXPECT_NEAR(n.hamming_rf, 4.0 / 6, kEps);
  EXPECT_NEAR(n.one_minus_rand_index, 48.0 / 66, kEps);
  EXPECT_EQ(n.gce, 0);
  EXPECT_EQ(n.lce, 0);
  // One segment per triangle: each ref segment keeps one triangle (1/2) of its 2: Rm = 4.5 / 6;
  // 1 - RI = 18 / 66; every corner is a cut vertex of both.
  SegmentationScores e = scores_of(m, every, kAxes);
  EXPECT_NEAR(e.hamming_rm, 4.5 / 6, kEps);
  EXPECT_NEAR(e.hamming_rf, 0, kEps);
  EXPECT_NEAR(e.one_minus_rand_index, 18.0 / 66, kEps);
  EXPECT_EQ(e.gce, 0);
  EXPECT_NEAR(*e.cut_discrepancy, 0, kEps);
}

TEST(SegEval, EvaluatorReportsAreaAndAverageRadius) {
  Result<SegmentationEvaluator> ev = SegmentationEvaluator::create(cube());
  ASSERT_TRUE(ev.ok()) << ev.status().message();
  EXPECT_EQ(ev->triangle_count(), 12u);
  EXPECT_EQ(ev->vertex_count(), 8u);
  EXPECT_NEAR(ev->area(), 6, kEps);
  EXPECT_NEAR(ev->average_radius(), std::sqrt(11.0) / 6, 1e-9);
  Result<PreparedSegmentation> p = ev->prepare(kBottom);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->segments, 2u);
  EXPECT_EQ(p->cut_vertices, (std::vector<uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(p->cut_distance[7], 1);  // a top corner, one vertical edge away
}

TEST(SegEval, AverageOverReferencesAndHumanPairs) {
  Result<SegmentationEvaluator> ev = SegmentationEvaluator::create(cube());
  ASSERT_TRUE(ev.ok());
  std::vector<PreparedSegmentation> refs;
  for (const auto* labels : {&kAxes, &kSides, &kBottom})
    refs.push_back(ev->prepare(*labels).value());
  PreparedSegmentation none = ev->prepare(std::vector<uint32_t>(12, 0)).value();

  ScoreAverage a = score_against_references(ev.value(), refs[2], refs);
  EXPECT_EQ(a.count(), 3u);
  EXPECT_EQ(a.cut_discrepancy_count(), 3u);
  double rand_sum = 0;
  for (const auto& r : refs) rand_sum += ev->compare(refs[2], r).one_minus_rand_index;
  EXPECT_NEAR(a.mean().one_minus_rand_index, rand_sum / 3, kEps);

  // A segmentation without a cut: CD undefined for every reference, so for the mean.
  ScoreAverage n = score_against_references(ev.value(), none, refs);
  EXPECT_EQ(n.cut_discrepancy_count(), 0u);
  EXPECT_FALSE(n.mean().cut_discrepancy.has_value());
  // Averaging means (meshes): a mean without CD adds nothing to the CD mean.
  ScoreAverage meshes;
  meshes.add_mean(a);
  meshes.add_mean(n);
  EXPECT_EQ(meshes.count(), 2u);
  EXPECT_EQ(meshes.cut_discrepancy_count(), 1u);
  EXPECT_NEAR(*meshes.mean().cut_discrepancy, *a.mean().cut_discrepancy, kEps);

  // Human pairs: 3 unordered pairs, each both ways, so Rm and Rf average to HD.
  ScoreAverage h = score_reference_pairs(ev.value(), refs);
  EXPECT_EQ(h.count(), 6u);
  EXPECT_NEAR(h.mean().hamming_rm, h.mean().hamming_rf, kEps);
  EXPECT_NEAR(h.mean().hamming_rm, h.mean().hamming, kEps);
  EXPECT_EQ(score_reference_pairs(ev.value(), {refs[0]}).count(), 0u);
}

TEST(SegEval, CutDiscrepancyStaysWithinConnectedComponents) {
  // Two unit squares far apart: triangles 0, 1 (A) and 2, 3 (B).
  Mesh m = square();
  for (int i = 0; i < 4; ++i) m.positions.push_back({m.positions[i].x + 10, m.positions[i].y, 0});
  m.indices.insert(m.indices.end(), {4, 5, 6, 4, 6, 7});
  std::vector<uint32_t> cut_in_a = {0, 1, 2, 2}, cut_in_b = {0, 0, 1, 2},
                        cut_in_both = {0, 1, 2, 3};
  // No cut vertex of either reaches a cut of the other: undefined.
  EXPECT_FALSE(scores_of(m, cut_in_a, cut_in_b).cut_discrepancy.has_value());
  // B's cut has no counterpart to measure to and is left out; A's cuts coincide.
  SegmentationScores s = scores_of(m, cut_in_a, cut_in_both);
  ASSERT_TRUE(s.cut_discrepancy.has_value());
  EXPECT_EQ(*s.cut_discrepancy, 0);
}

TEST(SegEval, NonManifoldEdgeIsACutWhenItsTrianglesDiffer) {
  // Three triangles on the edge 0-1.
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  Result<SegmentationEvaluator> ev = SegmentationEvaluator::create(m);
  ASSERT_TRUE(ev.ok());
  EXPECT_EQ(ev->prepare({0, 0, 1}).value().cut_vertices, (std::vector<uint32_t>{0, 1}));
  EXPECT_TRUE(ev->prepare({0, 0, 0}).value().cut_vertices.empty());
}

TEST(SegEval, OneTriangleMeshHasClearResults) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2};
  SegmentationScores s = scores_of(m, {5}, {0});
  EXPECT_FALSE(s.cut_discrepancy.has_value());  // no edge between two triangles: no cut
  EXPECT_EQ(s.hamming, 0);
  EXPECT_EQ(s.one_minus_rand_index, 0);  // no pair of triangles to disagree on
  EXPECT_EQ(s.gce, 0);
  EXPECT_EQ(s.lce, 0);
}

TEST(SegEval, MeshesWithoutTrianglesOrAreaAreErrors) {
  Mesh empty;
  empty.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  Result<SegmentationEvaluator> e = SegmentationEvaluator::create(empty);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(e.status().message().find("no triangles"), std::string::npos);

  Mesh flat;
  flat.source = "flat.off";
  flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.indices = {0, 1, 2, 0, 0, 1};
  Result<SegmentationEvaluator> f = SegmentationEvaluator::create(flat);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.status().message().find("flat.off: "), std::string::npos) << f.status().message();
}

TEST(SegEval, ZeroAreaTrianglesAreCountedNotDividedBy) {
  // A square plus a zero-area triangle (0, 1, 1 repeated) in its own segment: the area-based
  // ratios of that segment are 0/0, taken as no error; 1 - RI still counts it.
  Mesh m = square();
  m.indices.insert(m.indices.end(), {0, 1, 1});
  SegmentationScores s = scores_of(m, {0, 0, 1}, {0, 0, 0});
  EXPECT_TRUE(std::isfinite(s.hamming) && std::isfinite(s.gce) && std::isfinite(s.lce));
  EXPECT_NEAR(s.one_minus_rand_index, 2.0 / 3, kEps);  // 2 of the 3 pairs split in seg only
}

TEST(SegEval, PrepareChecksTheLabelCount) {
  Result<SegmentationEvaluator> ev = SegmentationEvaluator::create(square());
  ASSERT_TRUE(ev.ok());
  Result<PreparedSegmentation> p = ev->prepare({0, 1, 2}, "mine.seg");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().message(), "mine.seg: 3 segment ids for a mesh of 2 triangles");
}

// ---------------------------------------------------------------------------------------------
// .seg files

TEST(SegFile, ReadsOneIdPerLine) {
  EXPECT_EQ(parse("0\n1\n1\n", 3).value(), (std::vector<uint32_t>{0, 1, 1}));
  EXPECT_EQ(parse("4\r\n2\r\n", 2).value(), (std::vector<uint32_t>{4, 2}));
  EXPECT_EQ(parse("3\n7", 2).value(), (std::vector<uint32_t>{3, 7}));          // no final newline
  EXPECT_EQ(parse("3\n\n7\n\n\n", 2).value(), (std::vector<uint32_t>{3, 7}));  // blank lines
  EXPECT_TRUE(parse("", 0).ok());
}

TEST(SegFile, BadFilesNameTheFileAndLine) {
  struct Case {
    const char* text;
    size_t faces;
    const char* message;
  };
  const Case cases[] = {
      {"0\n1\n", 3,
       "x.seg: 2 segment ids for the mesh's 3 faces (one per line, in face order) (line 3)"},
      {"0\n1\n2\n3\n", 3, "x.seg: more segment ids than the mesh's 3 faces (line 4)"},
      {"0\n-1\n2\n", 3, "x.seg: segment id -1 is negative (line 2)"},
      {"0\nabc\n2\n", 3, "x.seg: 'abc' is not a segment id (expected an integer >= 0) (line 2)"},
      {"0\n1.5\n2\n", 3, "x.seg: '1.5' is not a segment id (expected an integer >= 0) (line 2)"},
      {"0 1\n2\n", 2,
       "x.seg: more than one value on a line (expected one segment id per face) (line 1)"},
      {"4294967295\n", 1,
       "x.seg: segment id 4294967295 is too large (at most 4294967294) (line 1)"},
      {"", 2, "x.seg: 0 segment ids for the mesh's 2 faces (one per line, in face order) (line 1)"},
  };
  for (const Case& c : cases) {
    Result<std::vector<uint32_t>> r = parse(c.text, c.faces);
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.status().code(), ErrorCode::kInvalidData);
    EXPECT_EQ(r.status().message(), c.message);
  }
}

TEST(SegFile, MissingFileOrFolderIsAnIoError) {
  std::string dir = test::scratch_dir();
  Result<std::vector<uint32_t>> missing = read_seg(dir + "/absent.seg", 3);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), ErrorCode::kIoError);
  EXPECT_NE(missing.status().message().find("absent.seg: cannot open"), std::string::npos);
  Result<std::vector<uint32_t>> folder = read_seg(dir, 3);
  ASSERT_FALSE(folder.ok());
  EXPECT_EQ(folder.status().code(), ErrorCode::kIoError);
  test::write_bytes(dir + "/ok.seg", "1\n0\n");
  EXPECT_EQ(read_seg(dir + "/ok.seg", 2).value(), (std::vector<uint32_t>{1, 0}));
}

// ---------------------------------------------------------------------------------------------
// The CLI

using test::CliRun;
using test::run_cli;

// The cube as an OFF file and its segmentations as .seg files in `dir`.
void write_cube_files(const std::string& dir) {
  Mesh m = cube();
  std::string off = "OFF\n8 12 0\n";
  for (const Vec3& p : m.positions) {
    off += std::to_string(int(p.x)) + " " + std::to_string(int(p.y)) + " " +
           std::to_string(int(p.z)) + "\n";
  }
  for (size_t t = 0; t < 12; ++t) {
    off += "3 " + std::to_string(m.indices[3 * t]) + " " + std::to_string(m.indices[3 * t + 1]) +
           " " + std::to_string(m.indices[3 * t + 2]) + "\n";
  }
  test::write_bytes(dir + "/cube.off", off);
  auto seg_text = [](const std::vector<uint32_t>& labels) {
    std::string s;
    for (uint32_t l : labels) s += std::to_string(l) + "\n";
    return s;
  };
  fs::create_directories(dir + "/refs");
  test::write_bytes(dir + "/bottom.seg", seg_text(kBottom));
  test::write_bytes(dir + "/refs/axes.seg", seg_text(kAxes));
  test::write_bytes(dir + "/refs/sides.seg", seg_text(kSides));
}

TEST(SegEvalCli, ScoresAgainstReferencesAsJson) {
  std::string dir = test::scratch_dir();
  write_cube_files(dir);
  CliRun run = run_cli("segeval " + dir + "/cube.off " + dir + "/bottom.seg " + dir +
                       "/refs/axes.seg --json");
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["triangles"], 12);
  EXPECT_EQ(j["mode"], "references");
  EXPECT_EQ(j["segmentation"]["segments"], 2);
  ASSERT_EQ(j["references"].size(), 1u);
  const nlohmann::json& s = j["references"][0]["scores"];
  EXPECT_NEAR(s["hamming_rm"].get<double>(), 1.0 / 6, 1e-12);
  EXPECT_NEAR(s["one_minus_rand_index"].get<double>(), 36.0 / 66, 1e-12);
  EXPECT_NEAR(s["gce"].get<double>(), 2.0 / 12, 1e-12);
  EXPECT_NEAR(s["cut_discrepancy"].get<double>(), 2 / std::sqrt(11.0), 1e-6);
  EXPECT_EQ(j["mean"], s);
  EXPECT_EQ(j["comparisons"], 1);
}

TEST(SegEvalCli, ReferenceFolderAndHumanPairs) {
  std::string dir = test::scratch_dir();
  write_cube_files(dir);
  // A folder of references: both .seg files, averaged.
  CliRun run = run_cli("segeval " + dir + "/cube.off " + dir + "/bottom.seg " + dir + "/refs");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("mean of 2 references"), std::string::npos) << run.out;
  // --human: every unordered pair of the three.
  run = run_cli("segeval " + dir + "/cube.off --human " + dir + "/bottom.seg " + dir +
                "/refs --json");
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["mode"], "human_pairs");
  EXPECT_EQ(j["comparisons"], 3);
  EXPECT_EQ(j["pairs"].size(), 3u);
  EXPECT_NEAR(j["mean"]["hamming_rm"].get<double>(), j["mean"]["hamming_rf"].get<double>(), 1e-12);
  // A segmentation without a cut: CD is null, and said so in text.
  std::string none;
  for (int t = 0; t < 12; ++t) none += "0\n";
  test::write_bytes(dir + "/none.seg", none);
  run = run_cli("segeval " + dir + "/cube.off " + dir + "/none.seg " + dir + "/refs --json");
  ASSERT_EQ(run.status, 0) << run.err;
  j = nlohmann::json::parse(run.out);
  EXPECT_TRUE(j["mean"]["cut_discrepancy"].is_null());
  EXPECT_EQ(j["cut_discrepancy_defined"], 0);
}

TEST(SegEvalCli, BadInputIsAnErrorWithExitCode2) {
  std::string dir = test::scratch_dir();
  write_cube_files(dir);
  test::write_bytes(dir + "/short.seg", "0\n1\n");
  test::write_bytes(dir + "/negative.seg", "0\n0\n0\n0\n0\n-3\n0\n0\n0\n0\n0\n0\n");
  test::write_bytes(dir + "/empty.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
  struct Case {
    std::string args;
    std::string message;
  };
  const Case cases[] = {
      {dir + "/cube.off " + dir + "/short.seg " + dir + "/refs",
       "short.seg: 2 segment ids for the mesh's 12 faces"},
      {dir + "/cube.off " + dir + "/bottom.seg " + dir + "/negative.seg",
       "negative.seg: segment id -3 is negative (line 6)"},
      {dir + "/cube.off " + dir + "/absent.seg " + dir + "/refs", "absent.seg: cannot open"},
      {dir + "/absent.off " + dir + "/bottom.seg " + dir + "/refs", "absent.off: no such file"},
      {dir + "/empty.off " + dir + "/bottom.seg " + dir + "/refs", "empty.off: no triangles"},
      {dir + "/cube.off " + dir + "/bottom.seg", "at least one reference"},
      {dir + "/cube.off --human " + dir + "/bottom.seg", "at least two"},
  };
  for (const Case& c : cases) {
    CliRun run = run_cli("segeval " + c.args);
    EXPECT_EQ(run.status, 2) << c.args;
    EXPECT_EQ(run.err.rfind("osteon: error: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
  }
}

// ---------------------------------------------------------------------------------------------
// The benchmark's rows on ../shared/data

struct BenchmarkMesh {
  std::string id;
  Mesh mesh;
  std::vector<std::vector<uint32_t>> human;
};

// The Princeton models in ../shared/data with their human segmentations.
std::vector<BenchmarkMesh> load_benchmark(const std::string& data) {
  std::string root = data + "/cearto__zen__MeshsegBenchmark/data";
  std::vector<BenchmarkMesh> meshes;
  std::error_code ec;
  if (!fs::is_directory(root + "/off", ec)) return meshes;
  std::vector<fs::path> offs;
  for (const auto& entry : fs::directory_iterator(root + "/off")) offs.push_back(entry.path());
  std::sort(offs.begin(), offs.end());
  for (const fs::path& off : offs) {
    BenchmarkMesh b;
    b.id = off.stem().string();
    Result<Scene> scene = read_path(off.string());
    EXPECT_TRUE(scene.ok()) << scene.status().message();
    if (!scene.ok() || scene->parts.size() != 1) continue;
    b.mesh = std::move(scene->parts[0]);
    std::vector<fs::path> segs;
    for (const auto& entry : fs::directory_iterator(root + "/seg/Benchmark/" + b.id, ec)) {
      segs.push_back(entry.path());
    }
    std::sort(segs.begin(), segs.end());
    for (const fs::path& seg : segs) {
      Result<std::vector<uint32_t>> labels = read_seg(seg.string(), b.mesh.triangle_count());
      EXPECT_TRUE(labels.ok()) << labels.status().message();
      if (labels.ok()) b.human.push_back(std::move(labels.value()));
    }
    meshes.push_back(std::move(b));
  }
  return meshes;
}

void expect_row(const char* row, const SegmentationScores& got, std::optional<double> cd, double hd,
                double rm, double rf, double ri, double gce, double lce) {
  constexpr double kTolerance = 0.002;  // within 0.002 of the independent implementation
  SCOPED_TRACE(row);
  EXPECT_EQ(got.cut_discrepancy.has_value(), cd.has_value());
  if (got.cut_discrepancy && cd) {
    EXPECT_NEAR(*got.cut_discrepancy, *cd, kTolerance);
  }
  EXPECT_NEAR(got.hamming, hd, kTolerance);
  EXPECT_NEAR(got.hamming_rm, rm, kTolerance);
  EXPECT_NEAR(got.hamming_rf, rf, kTolerance);
  EXPECT_NEAR(got.one_minus_rand_index, ri, kTolerance);
  EXPECT_NEAR(got.gce, gce, kTolerance);
  EXPECT_NEAR(got.lce, lce, kTolerance);
}

TEST(SegEvalBenchmark, ReproducesTheHumanNoneAndEveryRows) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  std::vector<BenchmarkMesh> meshes = load_benchmark(data);
  if (meshes.empty()) GTEST_SKIP() << "no Princeton benchmark models in " << data;
  ASSERT_EQ(meshes.size(), 38u);
  size_t human = 0;
  ScoreAverage human_row, none_row, every_row;
  for (const BenchmarkMesh& b : meshes) {
    SCOPED_TRACE(b.id);
    Result<SegmentationEvaluator> ev = SegmentationEvaluator::create(b.mesh);
    ASSERT_TRUE(ev.ok()) << ev.status().message();
    std::vector<PreparedSegmentation> refs;
    for (const auto& labels : b.human) refs.push_back(ev->prepare(labels).value());
    human += refs.size();
    size_t triangles = b.mesh.triangle_count();
    std::vector<uint32_t> none(triangles, 0), every(triangles);
    for (size_t t = 0; t < triangles; ++t) every[t] = static_cast<uint32_t>(t);
    // Per mesh: the mean over its human segmentations (or their pairs); then over meshes.
    human_row.add_mean(score_reference_pairs(ev.value(), refs));
    none_row.add_mean(score_against_references(ev.value(), ev->prepare(none).value(), refs));
    every_row.add_mean(score_against_references(ev.value(), ev->prepare(every).value(), refs));
  }
  EXPECT_EQ(human, 443u);
  expect_row("Human", human_row.mean(), 0.1454, 0.0970, 0.0970, 0.0970, 0.0942, 0.0711, 0.0466);
  expect_row("None", none_row.mean(), std::nullopt, 0.2687, 0.0000, 0.5375, 0.6809, 0, 0);
  expect_row("Every", every_row.mean(), 0.5333, 0.4987, 0.9975, 0.0000, 0.3192, 0, 0);
}

}  // namespace segeval_test
}  // namespace
}  // namespace osteon
