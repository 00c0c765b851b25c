// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"
#include "support/segeval.hpp"

// What fuzz/seg_fuzzer.cpp checks of one input, shared with tests/fuzz_corpus_test.cpp so the
// corpus replay asks exactly what the fuzzer asks. The bytes go to parse_seg (the Princeton
// benchmark's .seg reader) as the segmentation of a mesh with one face per non-blank line of the
// input (one fewer for inputs of odd size, so the "more ids than faces" path runs too). What
// parses is then scored, as osteon segeval scores it, on a strip of that many triangles against
// itself (all zero), one segment, and its ids read backwards. An error must name `source`; the
// labels must be as many as the faces; every score must be finite and in its range.

namespace osteon::fuzz {

/// What one input gave: whether it parsed, and the first broken promise ("" when none).
struct SegFuzzOutcome {
  bool parsed = false;
  std::string broken;
};

namespace seg_check {

/// The faces the fuzzer gives the mesh for these bytes.
inline size_t face_count(const uint8_t* data, size_t size) {
  size_t lines = 0;
  bool blank = true;
  for (size_t i = 0; i <= size; ++i) {
    if (i == size || data[i] == '\n') {
      if (!blank) ++lines;
      blank = true;
    } else if (data[i] != ' ' && data[i] != '\t' && data[i] != '\r') {
      blank = false;
    }
  }
  return size % 2 == 1 && lines > 0 ? lines - 1 : lines;
}

/// A strip of `triangles` triangles, each of area 1/2: triangle t joins vertices t, t+1, t+2.
inline Mesh strip(size_t triangles) {
  Mesh mesh;
  mesh.name = "strip";
  for (size_t v = 0; v < triangles + 2; ++v) {
    mesh.positions.push_back({static_cast<float>(v / 2), static_cast<float>(v % 2), 0.0f});
  }
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t a = static_cast<uint32_t>(t);
    if (t % 2 == 0) {
      mesh.indices.insert(mesh.indices.end(), {a, a + 1, a + 2});
    } else {
      mesh.indices.insert(mesh.indices.end(), {a + 1, a, a + 2});
    }
  }
  return mesh;
}

inline std::string out_of_unit(double value, const char* what) {
  constexpr double kSlack = 1e-9;
  if (value >= -kSlack && value <= 1 + kSlack) return "";
  return std::string(what) + " outside 0..1: " + std::to_string(value);
}

/// The first score out of its range ("" when none).
inline std::string broken(const SegmentationScores& s) {
  for (const std::string& b :
       {out_of_unit(s.hamming, "hamming"), out_of_unit(s.hamming_rm, "hamming_rm"),
        out_of_unit(s.hamming_rf, "hamming_rf"), out_of_unit(s.one_minus_rand_index, "1 - RI"),
        out_of_unit(s.gce, "gce"), out_of_unit(s.lce, "lce")}) {
    if (!b.empty()) return b;
  }
  if (s.cut_discrepancy && !(std::isfinite(*s.cut_discrepancy) && *s.cut_discrepancy >= 0))
    return "cut discrepancy not finite and >= 0: " + std::to_string(*s.cut_discrepancy);
  return "";
}

}  // namespace seg_check

/// Runs one input as the fuzzer does; `source` names it in parse_seg's messages.
inline SegFuzzOutcome seg_fuzz_one(const uint8_t* data, size_t size, const std::string& source) {
  SegFuzzOutcome out;
  const size_t faces = seg_check::face_count(data, size);
  Result<std::vector<uint32_t>> labels = parse_seg(data, size, source, faces);
  if (!labels.ok()) {
    const std::string& message = labels.status().message();
    if (message.rfind(source + ": ", 0) != 0 || message.size() <= source.size() + 2)
      out.broken = "message without source: " + message;
    return out;
  }
  out.parsed = true;
  if (labels->size() != faces) {
    out.broken = "wrong number of labels";
    return out;
  }
  for (uint32_t id : *labels) {
    if (id == UINT32_MAX) {
      out.broken = "label above 2^32 - 2";
      return out;
    }
  }
  if (faces == 0) return out;

  Result<SegmentationEvaluator> evaluator = SegmentationEvaluator::create(seg_check::strip(faces));
  if (!evaluator.ok()) {
    out.broken = "the strip is refused: " + evaluator.status().message();
    return out;
  }
  const std::vector<uint32_t> backwards(labels->rbegin(), labels->rend());
  Result<PreparedSegmentation> seg = evaluator->prepare(*labels, source);
  Result<PreparedSegmentation> one = evaluator->prepare(std::vector<uint32_t>(faces, 0), "one");
  Result<PreparedSegmentation> reversed = evaluator->prepare(backwards, "backwards");
  if (!seg.ok() || !one.ok() || !reversed.ok()) {
    out.broken = "prepare failed";
    return out;
  }
  for (uint32_t label : seg->labels) {
    if (label >= seg->segments) {
      out.broken = "renumbered label out of range";
      return out;
    }
  }
  const SegmentationScores self = evaluator->compare(*seg, *seg);
  out.broken = seg_check::broken(self);
  if (out.broken.empty() &&
      (self.hamming > 1e-9 || self.one_minus_rand_index != 0 || self.gce > 1e-9 ||
       self.lce > 1e-9 || (self.cut_discrepancy && *self.cut_discrepancy > 1e-9))) {
    out.broken = "a segmentation differs from itself";
  }
  if (out.broken.empty()) out.broken = seg_check::broken(evaluator->compare(*seg, *one));
  if (out.broken.empty()) out.broken = seg_check::broken(evaluator->compare(*one, *seg));
  if (out.broken.empty()) out.broken = seg_check::broken(evaluator->compare(*seg, *reversed));
  return out;
}

}  // namespace osteon::fuzz
