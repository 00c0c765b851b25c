// SPDX-License-Identifier: Apache-2.0
#include "support/segeval.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/byte_io.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"
#include "segeval_internal.hpp"

// Based on: the evaluation program of the Princeton Segmentation Benchmark (segEval, Chen,
// Golovinskiy, Funkhouser 2009), measure by measure:
// - Hamming distance (Huang & Dom 1995): each segment of one segmentation is matched with the
//   segment of the other that shares the most area with it; the missing rate Rm is the area of
//   the reference's segments outside their matches, the false-alarm rate Rf the same with the
//   roles swapped, both over the total area; HD = (Rm + Rf) / 2;
// - Rand index (Rand 1971): over all pairs of triangles (counted, not area-weighted), the fraction
//   on which the two segmentations disagree (same segment in one, different in the other), from
//   the contingency table: (sum C(n_i, 2) + sum C(m_j, 2) - 2 sum C(n_ij, 2)) / C(T, 2);
// - GCE and LCE (Martin et al. 2001): the local refinement error of triangle t is
//   E(S1, S2, t) = 1 - |R(S1, t) & R(S2, t)| / |R(S1, t)| with |.| an area, as segEval's reported
//   GCEa/LCEa; GCE = min(sum_t E(S1, S2, t), sum_t E(S2, S1, t)) / T and LCE = sum_t min(E(S1, S2,
//   t), E(S2, S1, t)) / T, averaged over triangles (not weighted by area), and 0 when either
//   segmentation is one segment or one segment per triangle, as in segEval.
// The contingency table has one cell per pair of segments that share a triangle; it is dense when
// small, else built by sorting, so a one-segment-per-triangle segmentation costs O(T log T).
// The cut discrepancy lives in tools/support/cut_discrepancy.cpp.

namespace osteon {

namespace {

std::string mesh_name(const Mesh& mesh) {
  if (!mesh.source.empty()) return mesh.source;
  return mesh.name.empty() ? std::string("mesh") : mesh.name;
}

/// One cell of the contingency table: the triangles in segment a of the first segmentation and
/// segment b of the second.
struct Cell {
  uint32_t a = 0;
  uint32_t b = 0;
  uint64_t count = 0;
  double area = 0;
};

std::vector<Cell> contingency(const PreparedSegmentation& s1, const PreparedSegmentation& s2,
                              const std::vector<double>& face_area) {
  size_t triangles = face_area.size();
  uint64_t table = uint64_t{s1.segments} * s2.segments;
  std::vector<Cell> cells;
  if (table <= std::max<uint64_t>(4 * triangles, 4096)) {
    std::vector<Cell> dense(table);
    for (size_t t = 0; t < triangles; ++t) {
      Cell& c = dense[size_t{s1.labels[t]} * s2.segments + s2.labels[t]];
      ++c.count;
      c.area += face_area[t];
    }
    for (size_t i = 0; i < dense.size(); ++i) {
      if (dense[i].count == 0) continue;
      dense[i].a = static_cast<uint32_t>(i / s2.segments);
      dense[i].b = static_cast<uint32_t>(i % s2.segments);
      cells.push_back(dense[i]);
    }
    return cells;
  }
  std::vector<std::pair<uint64_t, uint32_t>> keyed(triangles);
  for (size_t t = 0; t < triangles; ++t) {
    keyed[t] = {uint64_t{s1.labels[t]} * s2.segments + s2.labels[t], static_cast<uint32_t>(t)};
  }
  std::sort(keyed.begin(), keyed.end());
  for (size_t i = 0; i < keyed.size(); ++i) {
    if (i == 0 || keyed[i].first != keyed[i - 1].first) {
      cells.push_back({static_cast<uint32_t>(keyed[i].first / s2.segments),
                       static_cast<uint32_t>(keyed[i].first % s2.segments), 0, 0.0});
    }
    ++cells.back().count;
    cells.back().area += face_area[keyed[i].second];
  }
  return cells;
}

uint64_t pairs(uint64_t n) {
  return n * (n - 1) / 2;
}

/// 1 - intersection / region, the local refinement error; 0 for a region of zero area (only
/// zero-area triangles), where segEval divides 0 by 0.
double refinement_error(double intersection, double region) {
  return region > 0 ? 1.0 - intersection / region : 0.0;
}

/// Hamming distance, Rand index, GCE and LCE from the contingency table.
void region_measures(const PreparedSegmentation& seg, const PreparedSegmentation& ref,
                     const std::vector<double>& face_area, double total_area,
                     SegmentationScores* scores) {
  std::vector<Cell> cells = contingency(seg, ref, face_area);
  std::vector<uint64_t> seg_count(seg.segments, 0), ref_count(ref.segments, 0);
  std::vector<double> seg_area(seg.segments, 0.0), ref_area(ref.segments, 0.0);
  std::vector<double> seg_best(seg.segments, 0.0), ref_best(ref.segments, 0.0);
  uint64_t same_in_both = 0;
  for (const Cell& c : cells) {
    seg_count[c.a] += c.count;
    ref_count[c.b] += c.count;
    seg_area[c.a] += c.area;
    ref_area[c.b] += c.area;
    seg_best[c.a] = std::max(seg_best[c.a], c.area);
    ref_best[c.b] = std::max(ref_best[c.b], c.area);
    same_in_both += pairs(c.count);
  }

  // Hamming distance: Rm misses the reference's segments, Rf the evaluated ones.
  double ref_matched = 0, seg_matched = 0;
  for (double best : ref_best) ref_matched += best;
  for (double best : seg_best) seg_matched += best;
  scores->hamming_rm = std::max(0.0, (total_area - ref_matched) / total_area);
  scores->hamming_rf = std::max(0.0, (total_area - seg_matched) / total_area);
  scores->hamming = (scores->hamming_rm + scores->hamming_rf) / 2;

  // Rand index over triangle pairs, exact in integers.
  uint64_t triangles = face_area.size();
  if (triangles >= 2) {
    uint64_t same_in_seg = 0, same_in_ref = 0;
    for (uint64_t n : seg_count) same_in_seg += pairs(n);
    for (uint64_t n : ref_count) same_in_ref += pairs(n);
    uint64_t disagree = same_in_seg + same_in_ref - 2 * same_in_both;
    scores->one_minus_rand_index =
        static_cast<double>(disagree) / static_cast<double>(pairs(triangles));
  } else {
    scores->one_minus_rand_index = 0;  // no pair to disagree on
  }

  // Consistency errors; segEval's shortcut for the trivial segmentations, where they are 0.
  auto trivial = [triangles](uint32_t segments) { return segments == 1 || segments == triangles; };
  scores->gce = scores->lce = 0;
  if (trivial(seg.segments) || trivial(ref.segments)) return;
  double seg_in_ref = 0, ref_in_seg = 0, local = 0;
  for (const Cell& c : cells) {
    double e1 = refinement_error(c.area, seg_area[c.a]);
    double e2 = refinement_error(c.area, ref_area[c.b]);
    double n = static_cast<double>(c.count);
    seg_in_ref += n * e1;
    ref_in_seg += n * e2;
    local += n * std::min(e1, e2);
  }
  scores->gce = std::min(seg_in_ref, ref_in_seg) / static_cast<double>(triangles);
  scores->lce = local / static_cast<double>(triangles);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// .seg files

Result<std::vector<uint32_t>> parse_seg(const uint8_t* data, size_t size, const std::string& source,
                                        size_t face_count) {
  TextReader text(data, size);
  std::vector<uint32_t> labels;
  // An id takes at least two bytes ("0\n") but the last: reserve no more than the file can hold.
  labels.reserve(std::min<size_t>(face_count, size / 2 + 1));
  for (;;) {
    std::string_view token = text.next_token();
    if (token.empty()) break;
    std::string where = text.where();
    int64_t id = 0;
    if (!detail::parse_int(token, &id)) {
      return error(ErrorCode::kInvalidData, source,
                   quote_token(token) + " is not a segment id (expected an integer >= 0)", where);
    }
    if (id < 0) {
      return error(ErrorCode::kInvalidData, source,
                   "segment id " + std::to_string(id) + " is negative", where);
    }
    if (id >= int64_t{UINT32_MAX}) {
      return error(ErrorCode::kInvalidData, source,
                   "segment id " + std::to_string(id) + " is too large (at most 4294967294)",
                   where);
    }
    if (!text.next_token_on_line().empty()) {
      return error(ErrorCode::kInvalidData, source,
                   "more than one value on a line (expected one segment id per face)", where);
    }
    if (labels.size() == face_count) {
      return error(ErrorCode::kInvalidData, source,
                   "more segment ids than the mesh's " + std::to_string(face_count) + " faces",
                   where);
    }
    labels.push_back(static_cast<uint32_t>(id));
  }
  if (labels.size() != face_count) {
    return error(ErrorCode::kInvalidData, source,
                 std::to_string(labels.size()) + " segment ids for the mesh's " +
                     std::to_string(face_count) + " faces (one per line, in face order)",
                 text.where());
  }
  return labels;
}

Result<std::vector<uint32_t>> read_seg(const std::string& path, size_t face_count) {
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(path));
  return parse_seg(bytes.data(), bytes.size(), path, face_count);
}

// ---------------------------------------------------------------------------------------------
// The evaluator

Result<SegmentationEvaluator> SegmentationEvaluator::create(const Mesh& mesh) {
  size_t triangles = mesh.triangle_count();
  if (triangles == 0) {
    return error(ErrorCode::kInvalidArgument, mesh_name(mesh),
                 "the mesh has no triangles: there is nothing to segment");
  }
  if (triangles >= UINT32_MAX || mesh.positions.size() >= UINT32_MAX) {
    return error(ErrorCode::kInvalidArgument, mesh_name(mesh), "too large to evaluate");
  }
  for (uint32_t i : mesh.indices) {
    if (i >= mesh.positions.size()) {
      return error(ErrorCode::kInvalidArgument, mesh_name(mesh),
                   "vertex index " + std::to_string(i) + " out of range");
    }
  }
  auto data = std::make_shared<detail::EvaluationMesh>();
  data->vertex_count = mesh.positions.size();
  data->face_area.resize(triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const Vec3& p0 = mesh.positions[mesh.indices[3 * t]];
    const Vec3& p1 = mesh.positions[mesh.indices[3 * t + 1]];
    const Vec3& p2 = mesh.positions[mesh.indices[3 * t + 2]];
    data->face_area[t] = 0.5 * length(triangle_cross(p0, p1, p2));
    data->area += data->face_area[t];
  }
  if (!(data->area > 0) || !std::isfinite(data->area)) {
    return error(ErrorCode::kInvalidArgument, mesh_name(mesh),
                 "the triangles have no area (all degenerate), so area-weighted measures are "
                 "undefined");
  }
  data->average_radius = detail::average_radius(mesh, data->face_area);
  detail::build_edge_graph(mesh, data.get());
  SegmentationEvaluator evaluator;
  evaluator.mesh_ = std::move(data);
  return evaluator;
}

size_t SegmentationEvaluator::triangle_count() const {
  return mesh_->face_area.size();
}
size_t SegmentationEvaluator::vertex_count() const {
  return mesh_->vertex_count;
}
double SegmentationEvaluator::area() const {
  return mesh_->area;
}
double SegmentationEvaluator::average_radius() const {
  return mesh_->average_radius;
}

Result<PreparedSegmentation> SegmentationEvaluator::prepare(const std::vector<uint32_t>& labels,
                                                            const std::string& name) const {
  if (labels.size() != triangle_count()) {
    return error(ErrorCode::kInvalidArgument, name,
                 std::to_string(labels.size()) + " segment ids for a mesh of " +
                     std::to_string(triangle_count()) + " triangles");
  }
  PreparedSegmentation prepared;
  prepared.labels.resize(labels.size());
  std::unordered_map<uint32_t, uint32_t> renumber;
  for (size_t t = 0; t < labels.size(); ++t) {
    auto [it, added] = renumber.try_emplace(labels[t], prepared.segments);
    if (added) ++prepared.segments;
    prepared.labels[t] = it->second;
  }
  prepared.cut_vertices = detail::find_cut_vertices(*mesh_, prepared.labels);
  prepared.cut_distance = detail::distances_from(*mesh_, prepared.cut_vertices);
  return prepared;
}

SegmentationScores SegmentationEvaluator::compare(const PreparedSegmentation& seg,
                                                  const PreparedSegmentation& ref) const {
  assert(seg.labels.size() == triangle_count() && ref.labels.size() == triangle_count());
  SegmentationScores scores;
  region_measures(seg, ref, mesh_->face_area, mesh_->area, &scores);
  scores.cut_discrepancy = detail::cut_discrepancy(*mesh_, seg, ref);
  return scores;
}

Result<SegmentationScores> evaluate_segmentation(const Mesh& mesh, const std::vector<uint32_t>& seg,
                                                 const std::vector<uint32_t>& ref) {
  OSTEON_ASSIGN_OR_RETURN(SegmentationEvaluator evaluator, SegmentationEvaluator::create(mesh));
  OSTEON_ASSIGN_OR_RETURN(PreparedSegmentation a, evaluator.prepare(seg, "segmentation"));
  OSTEON_ASSIGN_OR_RETURN(PreparedSegmentation b, evaluator.prepare(ref, "reference"));
  return evaluator.compare(a, b);
}

// ---------------------------------------------------------------------------------------------
// Averages

void ScoreAverage::add(const SegmentationScores& s) {
  ++count_;
  if (s.cut_discrepancy) {
    ++cd_count_;
    cd_ += *s.cut_discrepancy;
  }
  hamming_ += s.hamming;
  rm_ += s.hamming_rm;
  rf_ += s.hamming_rf;
  rand_ += s.one_minus_rand_index;
  gce_ += s.gce;
  lce_ += s.lce;
}

SegmentationScores ScoreAverage::mean() const {
  SegmentationScores m;
  if (count_ == 0) return m;
  double n = static_cast<double>(count_);
  if (cd_count_ > 0) m.cut_discrepancy = cd_ / static_cast<double>(cd_count_);
  m.hamming = hamming_ / n;
  m.hamming_rm = rm_ / n;
  m.hamming_rf = rf_ / n;
  m.one_minus_rand_index = rand_ / n;
  m.gce = gce_ / n;
  m.lce = lce_ / n;
  return m;
}

ScoreAverage score_against_references(const SegmentationEvaluator& evaluator,
                                      const PreparedSegmentation& seg,
                                      const std::vector<PreparedSegmentation>& references) {
  ScoreAverage average;
  for (const PreparedSegmentation& ref : references) average.add(evaluator.compare(seg, ref));
  return average;
}

ScoreAverage score_reference_pairs(const SegmentationEvaluator& evaluator,
                                   const std::vector<PreparedSegmentation>& references) {
  ScoreAverage average;
  for (size_t i = 0; i < references.size(); ++i) {
    for (size_t j = i + 1; j < references.size(); ++j) {
      SegmentationScores s = evaluator.compare(references[i], references[j]);
      average.add(s);
      std::swap(s.hamming_rm, s.hamming_rf);
      average.add(s);
    }
  }
  return average;
}

}  // namespace osteon
