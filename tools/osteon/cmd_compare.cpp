// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "cli.hpp"
#include "progress.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

// osteon compare A B [--samples N] [--json]: Metro's measurement (samples on the vertices, edges
// and faces of each mesh, measured exactly to the other), one-sided both ways and symmetric, part
// by part and overall.

namespace osteon::cli {

namespace {

using Clock = std::chrono::steady_clock;

struct CompareArgs {
  std::string a;
  std::string b;
  uint64_t samples = 0;
  double samples_per_face = 10;
  uint64_t seed = 1;
  int threads = 0;
  bool json = false;
  bool whole = false;  ///< compare every part of each input merged into one mesh
  ReadOptions read;  ///< label volumes' options, for both inputs
};

// One pair of parts to measure.
struct Pair {
  const Mesh* a = nullptr;
  const Mesh* b = nullptr;
  HausdorffReport report;
};

// Every part of a scene as one mesh, named after the input.
Mesh merged(const Scene& scene, const std::string& path) {
  Mesh out;
  out.name = path;
  out.source = path;
  for (const Mesh& part : scene.parts) {
    uint32_t base = static_cast<uint32_t>(out.positions.size());
    out.positions.insert(out.positions.end(), part.positions.begin(), part.positions.end());
    for (uint32_t i : part.indices) out.indices.push_back(base + i);
  }
  return out;
}

// "stem/sub" -> "sub": a multi-part file's parts are named after the file, which differs between
// an original and its processed copy.
std::string without_first_component(const std::string& name) {
  size_t slash = name.find('/');
  return slash == std::string::npos ? name : name.substr(slash + 1);
}

// Pairs a's parts with b's: by name, else by name without the file stem, else by order (when
// the counts agree); `how` says which. Empty when none works.
std::vector<std::pair<size_t, size_t>> match_parts(const Scene& a, const Scene& b,
                                                   std::string* how) {
  std::vector<std::pair<size_t, size_t>> pairs;
  for (auto key : {+[](const std::string& s) { return s; }, &without_first_component}) {
    std::map<std::string, size_t> in_b;
    for (size_t j = 0; j < b.parts.size(); ++j) in_b.emplace(key(b.parts[j].name), j);
    if (in_b.size() != b.parts.size() || a.parts.size() != b.parts.size()) continue;
    pairs.clear();
    std::vector<bool> used(b.parts.size(), false);
    for (size_t i = 0; i < a.parts.size(); ++i) {
      auto found = in_b.find(key(a.parts[i].name));
      if (found == in_b.end() || used[found->second]) break;
      used[found->second] = true;
      pairs.emplace_back(i, found->second);
    }
    if (pairs.size() == a.parts.size()) {
      *how = "name";
      return pairs;
    }
  }
  pairs.clear();
  if (a.parts.size() == b.parts.size()) {
    for (size_t i = 0; i < a.parts.size(); ++i) pairs.emplace_back(i, i);
    *how = "order";
  }
  return pairs;
}

double diagonal_of(const Aabb& box) {
  if (box.empty) return 0;
  double dx = double(box.max.x) - box.min.x, dy = double(box.max.y) - box.min.y,
         dz = double(box.max.z) - box.min.z;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

Aabb box_of(const std::vector<const Mesh*>& meshes) {
  Aabb box;
  for (const Mesh* m : meshes) expand(box, bounding_box(*m));
  return box;
}

// The overall figure of several parts: the largest max, mean and RMS over every sample of every
// part (each measured against its own partner).
OneSidedDistance pooled(const std::vector<const OneSidedDistance*>& parts, double diagonal) {
  OneSidedDistance out;
  double sum = 0, sum2 = 0;
  out.max = -1;
  for (const OneSidedDistance* p : parts) {
    double n = double(p->samples);
    sum += n * p->mean;
    sum2 += n * p->rms * p->rms;
    out.samples += p->samples;
    out.vertex_samples += p->vertex_samples;
    out.edge_samples += p->edge_samples;
    out.face_samples += p->face_samples;
    if (p->max > out.max) {
      out.max = p->max;
      out.max_at = p->max_at;
      out.max_closest = p->max_closest;
    }
  }
  out.max = std::max(out.max, 0.0);
  out.mean = out.samples > 0 ? sum / double(out.samples) : 0;
  out.rms = out.samples > 0 ? std::sqrt(sum2 / double(out.samples)) : 0;
  out.diagonal = diagonal;
  return out;
}

nlohmann::json point_json(const Vec3d& p) {
  return {p.x, p.y, p.z};
}

nlohmann::json optional_json(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

nlohmann::json distance_json(const OneSidedDistance& d) {
  return {{"max", d.max},
          {"mean", d.mean},
          {"rms", d.rms},
          {"diagonal", d.diagonal},
          {"max_relative", optional_json(d.max_relative())},
          {"mean_relative", optional_json(d.mean_relative())},
          {"rms_relative", optional_json(d.rms_relative())},
          {"samples", d.samples},
          {"vertex_samples", d.vertex_samples},
          {"edge_samples", d.edge_samples},
          {"face_samples", d.face_samples},
          {"max_at", point_json(d.max_at)},
          {"max_closest", point_json(d.max_closest)}};
}

nlohmann::json report_json(const HausdorffReport& r) {
  return {{"forward", distance_json(r.forward)},
          {"backward", distance_json(r.backward)},
          {"symmetric", distance_json(r.symmetric)}};
}

std::string relative_text(const std::optional<double>& v) {
  if (!v) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.3e", *v);
  return text;
}

void print_rows(const HausdorffReport& r) {
  struct Row {
    const char* label;
    const OneSidedDistance* d;
  };
  for (Row row :
       {Row{"A -> B", &r.forward}, Row{"B -> A", &r.backward}, Row{"symmetric", &r.symmetric}}) {
    const OneSidedDistance& d = *row.d;
    std::printf("  %-10s %12.6g %12.6g %12.6g   %10s %10s %10s %12.6g %12llu\n", row.label, d.max,
                d.mean, d.rms, relative_text(d.max_relative()).c_str(),
                relative_text(d.mean_relative()).c_str(), relative_text(d.rms_relative()).c_str(),
                d.diagonal, static_cast<unsigned long long>(d.samples));
  }
}

void print_distance_header() {
  std::printf("  %-10s %12s %12s %12s   %10s %10s %10s %12s %12s\n", "", "max", "mean", "rms",
              "max/diag", "mean/diag", "rms/diag", "diagonal", "samples");
}

// The samples hausdorff() will take on both meshes of a pair (for the progress bar's total).
uint64_t expected_samples(const Mesh& a, const Mesh& b, const CompareArgs& args) {
  if (args.samples > 0) return 2 * args.samples;
  return uint64_t(std::llround(args.samples_per_face * double(a.triangle_count()))) +
         uint64_t(std::llround(args.samples_per_face * double(b.triangle_count())));
}

int run_compare(const CompareArgs& args) {
  Result<Scene> read_a = read_path(args.a, args.read);
  if (!read_a.ok()) return fail(read_a.status());
  Result<Scene> read_b = read_path(args.b, args.read);
  if (!read_b.ok()) return fail(read_b.status());
  Scene& scene_a = read_a.value();
  Scene& scene_b = read_b.value();

  // One part against several: the several merged (a codec stream holds one mesh).
  std::string matched_by = "single";
  std::vector<std::pair<size_t, size_t>> indices;
  if (args.whole || scene_a.parts.size() == 1 || scene_b.parts.size() == 1) {
    if (scene_a.parts.size() > 1) scene_a.parts = {merged(scene_a, args.a)};
    if (scene_b.parts.size() > 1) scene_b.parts = {merged(scene_b, args.b)};
    if (scene_a.parts.size() == 1 && scene_b.parts.size() == 1) indices.emplace_back(0, 0);
  } else {
    indices = match_parts(scene_a, scene_b, &matched_by);
    if (indices.empty()) {
      return fail(args.a + " has " + std::to_string(scene_a.parts.size()) + " parts and " + args.b +
                  " has " + std::to_string(scene_b.parts.size()) +
                  ", with different names: cannot pair them (compare one part or a merged mesh "
                  "instead)");
    }
  }
  std::vector<Pair> pairs;
  uint64_t total = 0;
  for (auto [i, j] : indices) {
    Pair pair;
    pair.a = &scene_a.parts[i];
    pair.b = &scene_b.parts[j];
    total += expected_samples(*pair.a, *pair.b, args);
    pairs.push_back(pair);
  }

  HausdorffOptions options;
  options.samples = args.samples;
  options.samples_per_face = args.samples_per_face;
  options.seed = args.seed;
  options.threads = args.threads;
  auto start = Clock::now();
  {
    ProgressBar bar("comparing", "samples", total);
    uint64_t before = 0;
    for (Pair& pair : pairs) {
      options.progress = [&](uint64_t done, uint64_t) { bar.update(before + done); };
      Result<HausdorffReport> report = hausdorff(*pair.a, *pair.b, options);
      if (!report.ok()) return fail(report.status());
      pair.report = report.value();
      before += pair.report.symmetric.samples;
    }
  }
  double seconds = std::chrono::duration<double>(Clock::now() - start).count();

  HausdorffReport overall;
  if (pairs.size() == 1) {
    overall = pairs[0].report;
  } else {
    std::vector<const Mesh*> parts_a, parts_b, both;
    std::vector<const OneSidedDistance*> forward, backward;
    for (const Pair& pair : pairs) {
      parts_a.push_back(pair.a);
      parts_b.push_back(pair.b);
      forward.push_back(&pair.report.forward);
      backward.push_back(&pair.report.backward);
    }
    both = parts_a;
    both.insert(both.end(), parts_b.begin(), parts_b.end());
    overall.forward = pooled(forward, diagonal_of(box_of(parts_a)));
    overall.backward = pooled(backward, diagonal_of(box_of(parts_b)));
    const OneSidedDistance& larger =
        overall.backward.max > overall.forward.max ? overall.backward : overall.forward;
    OneSidedDistance& s = overall.symmetric;
    s = larger;
    s.mean = std::max(overall.forward.mean, overall.backward.mean);
    s.rms = std::max(overall.forward.rms, overall.backward.rms);
    s.samples = overall.forward.samples + overall.backward.samples;
    s.vertex_samples = overall.forward.vertex_samples + overall.backward.vertex_samples;
    s.edge_samples = overall.forward.edge_samples + overall.backward.edge_samples;
    s.face_samples = overall.forward.face_samples + overall.backward.face_samples;
    s.diagonal = diagonal_of(box_of(both));
  }

  if (args.json) {
    nlohmann::json j = report_json(overall);
    j["a"] = args.a;
    j["b"] = args.b;
    j["seed"] = args.seed;
    j["samples_per_face"] =
        args.samples > 0 ? nlohmann::json(nullptr) : nlohmann::json(args.samples_per_face);
    j["matched_by"] = matched_by;
    j["seconds"] = seconds;
    nlohmann::json parts = nlohmann::json::array();
    for (const Pair& pair : pairs) {
      nlohmann::json p = report_json(pair.report);
      p["a"] = pair.a->name;
      p["b"] = pair.b->name;
      parts.push_back(std::move(p));
    }
    j["parts"] = std::move(parts);
    std::cout << j.dump(2) << "\n";
    return kExitOk;
  }

  std::printf("A: %s\nB: %s\n", args.a.c_str(), args.b.c_str());
  if (pairs.size() > 1) {
    std::printf("%zu parts paired by %s\n", pairs.size(), matched_by.c_str());
    for (const Pair& pair : pairs) {
      std::printf("\n%s  <->  %s\n", pair.a->name.c_str(), pair.b->name.c_str());
      print_distance_header();
      print_rows(pair.report);
    }
    std::printf("\noverall (every sample of every part, against its partner)\n");
  } else {
    std::printf("\n");
  }
  print_distance_header();
  print_rows(overall);
  const OneSidedDistance& s = overall.symmetric;
  std::printf(
      "\nlargest distance %.6g from (%.6g, %.6g, %.6g) to (%.6g, %.6g, %.6g)\n"
      "max is a sampled lower bound of the Hausdorff distance; mean and rms average the samples "
      "(%.1f s)\n",
      s.max, s.max_at.x, s.max_at.y, s.max_at.z, s.max_closest.x, s.max_closest.y, s.max_closest.z,
      seconds);
  return kExitOk;
}

}  // namespace

void register_compare(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Hausdorff distance between two meshes (Metro sampling): max, mean, RMS");
  cmd->add_option("A", args->a, "The original mesh (file or folder)")->required();
  cmd->add_option("B", args->b, "The processed mesh (file or folder)")->required();
  auto* samples = cmd->add_option("--samples", args->samples,
                                  "Samples on each mesh (each direction); default 10 per triangle")
                      ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40));
  cmd->add_option("--samples-per-face", args->samples_per_face,
                  "Samples per triangle when --samples is not given (default 10)")
      ->check(CLI::Range(1e-6, 1e6))
      ->excludes(samples);
  cmd->add_option("--seed", args->seed, "Seed of the sample positions (default 1)");
  cmd->add_flag("--whole", args->whole,
                "merge each input's parts into one mesh (files whose parts are named or split "
                "differently, e.g. after gltfpack)");
  cmd->add_option("--level", args->read.package_level,
                  "read packages at this level of detail, 0 the coarsest (default: full)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--threads", args->threads, "Worker threads (default: every core)")
      ->check(CLI::Range(0, 4096));
  cmd->add_flag("--json", args->json, "Print a JSON report");
  add_volume_options(cmd, &args->read);
  cmd->callback([args, run] { *run = [args] { return run_compare(*args); }; });
}

}  // namespace osteon::cli
