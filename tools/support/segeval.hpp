// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Based on: X. Chen, A. Golovinskiy, T. Funkhouser, "A Benchmark for 3D Mesh Segmentation", ACM
// TOG 28(3) (SIGGRAPH 2009), and its evaluation program segEval (MeshsegBenchmark-1.0), whose
// definitions the five measures follow (the one deviation, segEval's integer division in 1 - RI,
// and the cases segEval leaves undefined are in docs/DESIGN.md, "Segmentation evaluation");
// D. Martin et al., "A Database of Human Segmented
// Natural Images", ICCV 2001 (GCE, LCE); Q. Huang, B. Dom, "Quantitative methods of evaluating
// image segmentation", ICIP 1995 (Hamming distance); W. Rand, JASA 1971 (Rand index).
//
// A segmentation is one segment id per triangle, in triangle order (the benchmark's .seg file: one
// id per line per face). Ids need not be contiguous: only the partition they make counts.

namespace osteon {

namespace detail {
struct EvaluationMesh;
}

/// Reads a .seg file: one integer segment id >= 0 per line, one line per face of the mesh, in
/// face order (blank lines and '\r' are ignored, as the benchmark's own reader ignores them).
/// `face_count` is the mesh's triangle count: a mesh read by read_path keeps the file's faces in
/// order (a triangle mesh's triangle t is its face t; polygons are fan-triangulated, so a .seg
/// for a polygonal mesh does not fit its triangles).
/// Errors (each names the file and, where there is one, the line): kIoError when the file cannot
/// be read; kInvalidData for a token that is not an integer, a negative id, an id above
/// 2^32 - 2, two values on one line, or a number of ids other than `face_count`.
Result<std::vector<uint32_t>> read_seg(const std::string& path, size_t face_count);

/// read_seg on bytes already in memory; `source` names them in messages.
Result<std::vector<uint32_t>> parse_seg(const uint8_t* data, size_t size, const std::string& source,
                                        size_t face_count);

/// The benchmark's five measures of one segmentation against one reference. Every value is an
/// error: 0 for identical segmentations, larger for worse ones.
struct SegmentationScores {
  /// Cut discrepancy: the mean distance from each cut vertex of one segmentation to the nearest
  /// cut vertex of the other, taken over the cut vertices of both, divided by the mesh's average
  /// radius. Empty (undefined) when either segmentation has no cut, as in segEval. Known
  /// approximation (segEval's): distances are shortest paths along mesh edges, not surface
  /// geodesics. A cut vertex whose connected component holds no cut of the other segmentation is
  /// left out (CD is undefined when that leaves none).
  std::optional<double> cut_discrepancy;
  double hamming = 0;     ///< Hamming distance HD = (Rm + Rf) / 2, area-weighted
  double hamming_rm = 0;  ///< missing rate: the reference's area its best-matching segment misses
  double hamming_rf = 0;  ///< false-alarm rate: the same with the two segmentations swapped
  double one_minus_rand_index = 0;  ///< 1 - RI over triangle pairs (counted, not area-weighted)
  double gce = 0;                   ///< global consistency error (area ratios, averaged over faces)
  double lce = 0;                   ///< local consistency error (area ratios, averaged over faces)
};

/// What the evaluator keeps of one segmentation: made once, compared with many others.
struct PreparedSegmentation {
  std::vector<uint32_t> labels;  ///< the ids renumbered 0..segments-1 in order of first use
  uint32_t segments = 0;
  /// Vertices on a cut: endpoints of an edge whose triangles lie in different segments.
  std::vector<uint32_t> cut_vertices;
  /// Per vertex, the shortest edge-path distance to the nearest cut vertex; +infinity where no
  /// cut vertex is reachable (no cut at all, or none in the vertex's connected component).
  std::vector<double> cut_distance;
};

/// The benchmark's evaluation on one mesh, with what every comparison needs computed once:
/// triangle areas, the edge graph, the average radius. Reusable: prepare each segmentation once,
/// then compare any two (human-vs-human scoring compares every pair).
class SegmentationEvaluator {
 public:
  /// Errors: kInvalidArgument for a mesh with no triangle or whose triangles all have zero area
  /// (every measure but 1 - RI divides by the area). Complexity O(T log T).
  static Result<SegmentationEvaluator> create(const Mesh& mesh);

  size_t triangle_count() const;
  size_t vertex_count() const;
  double area() const;
  /// The area-weighted mean distance from the surface to its area-weighted centroid (triangle
  /// centroids weighted by area, as segEval's R3Mesh::AverageRadius): CD's unit.
  double average_radius() const;

  /// Renumbers `labels` (one per triangle), finds its cut vertices and their distance field (a
  /// multi-source Dijkstra over the mesh edges). Errors: kInvalidArgument when labels.size() is
  /// not the triangle count (`name` names the segmentation). O(T + V log V).
  Result<PreparedSegmentation> prepare(const std::vector<uint32_t>& labels,
                                       const std::string& name = "segmentation") const;

  /// Scores `seg` against the reference `ref` (both from this evaluator's prepare). Rm and Rf are
  /// the only measures that change when the two are swapped (they trade places).
  /// O(T + V), plus O(T log T) when segments(seg) x segments(ref) exceeds 4 T (a sparse
  /// contingency table).
  SegmentationScores compare(const PreparedSegmentation& seg,
                             const PreparedSegmentation& ref) const;

 private:
  SegmentationEvaluator() = default;
  std::shared_ptr<const detail::EvaluationMesh> mesh_;
};

/// One-off: scores `seg` against `ref` on `mesh` (see SegmentationEvaluator for errors).
Result<SegmentationScores> evaluate_segmentation(const Mesh& mesh, const std::vector<uint32_t>& seg,
                                                 const std::vector<uint32_t>& ref);

/// The mean of many scores, as the benchmark averages them: every measure over every score added,
/// except the cut discrepancy, averaged over the scores that have one (undefined when none has).
class ScoreAverage {
 public:
  void add(const SegmentationScores& scores);
  /// Adds a mean as one score (averaging meshes: each mesh's mean counts once).
  void add_mean(const ScoreAverage& other) {
    if (other.count() > 0) add(other.mean());
  }
  SegmentationScores mean() const;
  size_t count() const { return count_; }
  size_t cut_discrepancy_count() const { return cd_count_; }

 private:
  size_t count_ = 0;
  size_t cd_count_ = 0;
  double cd_ = 0, hamming_ = 0, rm_ = 0, rf_ = 0, rand_ = 0, gce_ = 0, lce_ = 0;
};

/// The benchmark's score of one segmentation on one mesh: compared with every reference (the
/// human segmentations of the mesh), averaged over them.
ScoreAverage score_against_references(const SegmentationEvaluator& evaluator,
                                      const PreparedSegmentation& seg,
                                      const std::vector<PreparedSegmentation>& references);

/// Human consistency on one mesh: every unordered pair of `references`, taken in both directions
/// (as the benchmark's groupSegEval records Rm and Rf both ways; the other measures are
/// symmetric), averaged. Fewer than two references give an empty average.
ScoreAverage score_reference_pairs(const SegmentationEvaluator& evaluator,
                                   const std::vector<PreparedSegmentation>& references);

}  // namespace osteon
