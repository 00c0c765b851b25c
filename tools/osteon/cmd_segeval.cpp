// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli.hpp"
#include "osteon/io.hpp"
#include "support/segeval.hpp"

// osteon segeval MESH SEG REF... [--json]: SEG scored against each reference segmentation (a
// .seg file, or a folder of them) with the Princeton Segmentation Benchmark's measures, and the
// mean over the references, as the benchmark scores one mesh.
// osteon segeval MESH --human REF... [--json]: every unordered pair of the references (the
// human segmentations of one mesh) scored against each other: the benchmark's human row.

namespace osteon::cli {

namespace {

namespace fs = std::filesystem;

struct SegevalArgs {
  std::string mesh;
  std::vector<std::string> files;
  bool human = false;
  bool json = false;
};

struct LoadedSeg {
  std::string path;
  PreparedSegmentation prepared;
};

// The mesh's parts merged in order, so triangle t is the file's t-th triangle.
Mesh merge_parts(Scene& scene) {
  if (scene.parts.size() == 1) return std::move(scene.parts[0]);
  Mesh merged;
  merged.name = scene.parts.empty() ? std::string() : scene.parts[0].name;
  merged.source = scene.parts.empty() ? std::string() : scene.parts[0].source;
  for (Mesh& part : scene.parts) {
    uint32_t base = static_cast<uint32_t>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), part.positions.begin(), part.positions.end());
    for (uint32_t i : part.indices) merged.indices.push_back(base + i);
  }
  return merged;
}

// A path, or every .seg file in a folder (sorted by name).
Status expand_paths(const std::string& path, std::vector<std::string>* out) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    out->push_back(path);
    return {};
  }
  std::vector<std::string> found;
  for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
    if (entry.path().extension() == ".seg" && entry.is_regular_file(ec)) {
      found.push_back(entry.path().string());
    }
  }
  if (ec) return error(ErrorCode::kIoError, path, "cannot list the folder: " + ec.message());
  if (found.empty()) return error(ErrorCode::kIoError, path, "the folder holds no .seg file");
  std::sort(found.begin(), found.end());
  out->insert(out->end(), found.begin(), found.end());
  return {};
}

Result<LoadedSeg> load(const SegmentationEvaluator& evaluator, const std::string& path) {
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint32_t> labels, read_seg(path, evaluator.triangle_count()));
  OSTEON_ASSIGN_OR_RETURN(PreparedSegmentation prepared, evaluator.prepare(labels, path));
  return LoadedSeg{path, std::move(prepared)};
}

nlohmann::json scores_json(const SegmentationScores& s) {
  nlohmann::json j;
  j["cut_discrepancy"] = s.cut_discrepancy ? nlohmann::json(*s.cut_discrepancy) : nullptr;
  j["hamming"] = s.hamming;
  j["hamming_rm"] = s.hamming_rm;
  j["hamming_rf"] = s.hamming_rf;
  j["one_minus_rand_index"] = s.one_minus_rand_index;
  j["gce"] = s.gce;
  j["lce"] = s.lce;
  return j;
}

nlohmann::json seg_json(const LoadedSeg& seg) {
  return {{"path", seg.path},
          {"segments", seg.prepared.segments},
          {"cut_vertices", seg.prepared.cut_vertices.size()}};
}

std::string fixed(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.4f", value);
  return text;
}

void print_row(const std::string& label, const std::string& segments, const SegmentationScores& s) {
  std::printf("%-28s %8s %9s %7s %7s %7s %7s %7s %7s\n", label.c_str(), segments.c_str(),
              s.cut_discrepancy ? fixed(*s.cut_discrepancy).c_str() : "undef",
              fixed(s.hamming).c_str(), fixed(s.hamming_rm).c_str(), fixed(s.hamming_rf).c_str(),
              fixed(s.one_minus_rand_index).c_str(), fixed(s.gce).c_str(), fixed(s.lce).c_str());
}

void print_scores_header() {
  std::printf("%-28s %8s %9s %7s %7s %7s %7s %7s %7s\n", "", "segments", "CD", "HD", "Rm", "Rf",
              "1-RI", "GCE", "LCE");
}

std::string base_name(const std::string& path) {
  return fs::path(path).filename().string();
}

int run_segeval(const SegevalArgs& args) {
  if (args.human && args.files.empty()) return fail("--human needs the reference .seg files");
  if (!args.human && args.files.size() < 2) {
    return fail(
        "give the segmentation to score and at least one reference: osteon segeval "
        "MESH SEG REF.seg... (or MESH --human REF.seg...)");
  }
  Result<Scene> scene = read_path(args.mesh);
  if (!scene.ok()) return fail(scene.status());
  Mesh mesh = merge_parts(scene.value());
  Result<SegmentationEvaluator> evaluator = SegmentationEvaluator::create(mesh);
  if (!evaluator.ok()) return fail(evaluator.status());

  // The segmentation to score (not in --human mode), then the references.
  std::optional<LoadedSeg> seg;
  size_t first_reference = 0;
  if (!args.human) {
    Result<LoadedSeg> loaded = load(evaluator.value(), args.files[0]);
    if (!loaded.ok()) return fail(loaded.status());
    seg = std::move(loaded.value());
    first_reference = 1;
  }
  std::vector<std::string> reference_paths;
  for (size_t i = first_reference; i < args.files.size(); ++i) {
    Status expanded = expand_paths(args.files[i], &reference_paths);
    if (!expanded.ok()) return fail(expanded);
  }
  if (args.human && reference_paths.size() < 2) {
    return fail("--human compares pairs of references: give at least two .seg files");
  }
  std::vector<LoadedSeg> references;
  for (const std::string& path : reference_paths) {
    Result<LoadedSeg> loaded = load(evaluator.value(), path);
    if (!loaded.ok()) return fail(loaded.status());
    references.push_back(std::move(loaded.value()));
  }

  nlohmann::json j = {{"mesh", args.mesh},
                      {"triangles", evaluator->triangle_count()},
                      {"vertices", evaluator->vertex_count()},
                      {"area", evaluator->area()},
                      {"average_radius", evaluator->average_radius()},
                      {"mode", args.human ? "human_pairs" : "references"}};
  if (!args.json) {
    std::printf("%s: %zu triangles, average radius %.6g\n", args.mesh.c_str(),
                evaluator->triangle_count(), evaluator->average_radius());
    if (seg) {
      std::printf("%s: %u segments, scored against %zu references\n", seg->path.c_str(),
                  seg->prepared.segments, references.size());
    } else {
      std::printf("%zu references, %zu pairs\n", references.size(),
                  references.size() * (references.size() - 1) / 2);
    }
    print_scores_header();
  }
  ScoreAverage average;
  nlohmann::json rows = nlohmann::json::array();
  if (args.human) {
    for (size_t a = 0; a < references.size(); ++a) {
      for (size_t b = a + 1; b < references.size(); ++b) {
        SegmentationScores s = evaluator->compare(references[a].prepared, references[b].prepared);
        rows.push_back({{"a", a}, {"b", b}, {"scores", scores_json(s)}});
        average.add(s);
        std::swap(s.hamming_rm, s.hamming_rf);
        average.add(s);
      }
    }
  } else {
    for (const LoadedSeg& ref : references) {
      SegmentationScores s = evaluator->compare(seg->prepared, ref.prepared);
      average.add(s);
      nlohmann::json row = seg_json(ref);
      row["scores"] = scores_json(s);
      rows.push_back(row);
      if (!args.json) print_row(base_name(ref.path), std::to_string(ref.prepared.segments), s);
    }
  }
  SegmentationScores mean = average.mean();
  size_t comparisons = args.human ? average.count() / 2 : average.count();
  size_t cd_defined =
      args.human ? average.cut_discrepancy_count() / 2 : average.cut_discrepancy_count();
  if (args.json) {
    if (seg) j["segmentation"] = seg_json(*seg);
    nlohmann::json refs = nlohmann::json::array();
    for (const LoadedSeg& ref : references) refs.push_back(seg_json(ref));
    if (args.human) {
      j["references"] = refs;
      j["pairs"] = rows;
    } else {
      j["references"] = rows;
    }
    j["mean"] = scores_json(mean);
    j["comparisons"] = comparisons;
    j["cut_discrepancy_defined"] = cd_defined;
    std::cout << j.dump(2) << "\n";
  } else {
    std::string label = args.human ? "mean of " + std::to_string(comparisons) + " pairs"
                                   : "mean of " + std::to_string(comparisons) + " references";
    print_row(label, "", mean);
    if (cd_defined < comparisons) {
      std::printf(
          "CD is undefined for %zu of %zu comparisons (a segmentation without a cut); the "
          "mean is over the others.\n",
          comparisons - cd_defined, comparisons);
    }
  }
  return kExitOk;
}

}  // namespace

void register_segeval(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<SegevalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "segeval",
      "Score a segmentation (.seg) against reference segmentations with the Princeton "
      "Segmentation Benchmark's measures (CD, HD with Rm and Rf, 1 - RI, GCE, LCE)");
  cmd->add_option("MESH", args->mesh, "The mesh the .seg files label (one id per triangle)")
      ->required();
  cmd->add_option("SEG", args->files,
                  "The segmentation to score, then the references (.seg files or folders of "
                  "them); with --human, only references")
      ->required();
  cmd->add_flag("--human", args->human,
                "Score every unordered pair of the references against each other (human "
                "consistency)");
  cmd->add_flag("--json", args->json, "Print a JSON report");
  cmd->callback([args, run] { *run = [args] { return run_segeval(*args); }; });
}

}  // namespace osteon::cli
