// SPDX-License-Identifier: Apache-2.0
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#if OSTEON_HAVE_CGAL
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/mesh_segmentation.h>
#include <CGAL/version.h>
#endif

#include "bench_markdown.hpp"
#include "osteon/io.hpp"
#include "support/segeval.hpp"
#include "osteon/segment.hpp"

// Segmentation quality on the Princeton Segmentation Benchmark, scored the benchmark's
// way (osteon's evaluator, tools/support/segeval.hpp): every segmentation of a model against
// each of its human segmentations, averaged over them, then over the models of a category and
// over all models. Rows:
// - Human: every unordered pair of a model's human segmentations (both ways for Rm and Rf);
// - None (one segment) and Every (one segment per triangle), the benchmark's trivial bounds;
// - CGAL's shape diameter function segmentation (sdf_values, then segmentation_from_sdf_values)
//   at its defaults and with K clusters, when CGAL was found at configure time;
// - any segmentation method added to `methods` in main(): a callback (mesh, K) -> one label
//   per triangle, where K is the benchmark's target: the most common human segment count of the
//   model (ties: the one nearest the median; the benchmark's util/parameters/nSeg-ByModel.txt).
// Published values for other methods are read off the bar charts of Chen et al. 2009 and shown as
// such (approximate); they are over the full benchmark (380 models), this run over the models
// that ../shared/data holds.

#ifndef OSTEON_SHARED_DATA_DIR
#define OSTEON_SHARED_DATA_DIR "../shared/data"
#endif

namespace osteon_bench {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using osteon::Mesh;
using osteon::PreparedSegmentation;
using osteon::ScoreAverage;
using osteon::SegmentationEvaluator;
using osteon::SegmentationScores;

/// The benchmark's categories, model ids 20 c + 1 .. 20 c + 20 (Spring, 261-280, is excluded).
const char* const kCategories[20] = {"Human", "Cup",     "Glasses", "Airplane", "Ant",
                                     "Chair", "Octopus", "Table",   "Teddy",    "Hand",
                                     "Plier", "Fish",    "Bird",    "Spring",   "Armadillo",
                                     "Bust",  "Mech",    "Bearing", "Vase",     "Fourleg"};

/// Published 1 - RI values, read off the bar chart of Chen et al. 2009 (Figure 6), full benchmark.
struct Published {
  const char* method;
  double one_minus_rand_index;
};
const Published kPublished[] = {
    {"Randomized Cuts", 0.15}, {"Shape Diameter", 0.17}, {"Normalized Cuts", 0.17},
    {"Core Extraction", 0.21}, {"Random Walks", 0.21},   {"K-Means", 0.25},
};

struct Model {
  int id = 0;
  int category = 0;
  Mesh mesh;
  int target = 0;  ///< K
  std::optional<SegmentationEvaluator> evaluator;
  std::vector<PreparedSegmentation> human;
  std::vector<int> human_segments;
};

/// A segmentation method under test: one label per triangle of `mesh`, aiming at
/// `target_segments` segments (methods that choose their own count may ignore it). An empty
/// result counts as a failure on that model.
using SegmentFn = std::function<std::vector<uint32_t>(const Mesh& mesh, int target_segments)>;

struct Method {
  std::string name;
  std::string note;
  SegmentFn run;
};

struct Row {
  std::string name;
  std::string note;
  std::map<int, ScoreAverage> by_category;
  ScoreAverage overall;
  double seconds = 0;
  size_t triangles = 0;  ///< over the models the method ran on (for the time per triangle)
  size_t failed = 0;
  double segments = 0;  ///< sum over models of the segment count produced
  size_t models = 0;
  bool timed = false;
  json per_model = json::array();
};

/// K, the benchmark's protocol: the most common segment count among the human segmentations;
/// several equally common ones: the one nearest the median count; still tied: the smaller.
int target_segments(std::vector<int> counts) {
  if (counts.empty()) return 0;
  std::sort(counts.begin(), counts.end());
  size_t n = counts.size();
  double median = n % 2 ? counts[n / 2] : (counts[n / 2 - 1] + counts[n / 2]) / 2.0;
  std::map<int, int> frequency;
  for (int c : counts) ++frequency[c];
  int best = 0, best_frequency = 0;
  for (auto [count, f] : frequency) {  // ascending count: ties keep the smaller
    bool more = f > best_frequency;
    bool nearer = f == best_frequency && std::abs(count - median) < std::abs(best - median);
    if (more || nearer) {
      best = count;
      best_frequency = f;
    }
  }
  return best;
}

// The models of the benchmark folder, sorted by id, with their human segmentations prepared.
std::vector<Model> load_models(const fs::path& root, const std::string& only) {
  std::vector<Model> models;
  std::error_code ec;
  if (!fs::is_directory(root / "off", ec)) return models;
  for (const auto& entry : fs::directory_iterator(root / "off")) {
    if (entry.path().extension() != ".off") continue;
    Model m;
    m.id = std::atoi(entry.path().stem().string().c_str());
    if (m.id <= 0) continue;
    m.category = (m.id - 1) / 20;
    if (m.category >= 20 || m.category == 13) continue;
    if (!only.empty() && only != kCategories[m.category] && only != std::to_string(m.id)) continue;
    osteon::Result<osteon::Scene> scene = osteon::read_path(entry.path().string());
    if (!scene.ok()) {
      std::fprintf(stderr, "segmentation_bench: %s\n", scene.status().message().c_str());
      continue;
    }
    m.mesh = std::move(scene->parts[0]);
    osteon::Result<SegmentationEvaluator> evaluator = SegmentationEvaluator::create(m.mesh);
    if (!evaluator.ok()) {
      std::fprintf(stderr, "segmentation_bench: %s\n", evaluator.status().message().c_str());
      continue;
    }
    m.evaluator = std::move(evaluator.value());
    std::vector<fs::path> segs;
    for (const auto& seg :
         fs::directory_iterator(root / "seg/Benchmark" / std::to_string(m.id), ec)) {
      if (seg.path().extension() == ".seg") segs.push_back(seg.path());
    }
    std::sort(segs.begin(), segs.end());
    for (const fs::path& seg : segs) {
      auto labels = osteon::read_seg(seg.string(), m.mesh.triangle_count());
      if (!labels.ok()) {
        std::fprintf(stderr, "segmentation_bench: %s\n", labels.status().message().c_str());
        continue;
      }
      m.human.push_back(m.evaluator->prepare(labels.value()).value());
      m.human_segments.push_back(static_cast<int>(m.human.back().segments));
    }
    if (m.human.empty()) continue;
    m.target = target_segments(m.human_segments);
    models.push_back(std::move(m));
  }
  std::sort(models.begin(), models.end(),
            [](const Model& a, const Model& b) { return a.id < b.id; });
  return models;
}

/// The benchmark's own K per model (util/parameters/nSeg-ByModel.txt, line i for model i).
std::map<int, int> published_targets(const fs::path& benchmark) {
  std::map<int, int> targets;
  std::ifstream in(benchmark / "util/parameters/nSeg-ByModel.txt");
  int k, id = 0;
  while (in >> k) targets[++id] = k;
  return targets;
}

json scores_json(const SegmentationScores& s) {
  return {{"cd", s.cut_discrepancy ? json(*s.cut_discrepancy) : json(nullptr)},
          {"hd", s.hamming},
          {"rm", s.hamming_rm},
          {"rf", s.hamming_rf},
          {"one_minus_ri", s.one_minus_rand_index},
          {"gce", s.gce},
          {"lce", s.lce}};
}


Row human_row(const std::vector<Model>& models) {
  Row row;
  row.name = "Human";
  row.note = "every unordered pair of a model's human segmentations";
  for (const Model& m : models) {
    ScoreAverage mean = osteon::score_reference_pairs(*m.evaluator, m.human);
    if (mean.count() == 0) continue;
    row.by_category[m.category].add_mean(mean);
    row.overall.add_mean(mean);
    double segments = 0;
    for (int s : m.human_segments) segments += s;
    row.segments += segments / static_cast<double>(m.human_segments.size());
    ++row.models;
    row.per_model.push_back({{"id", m.id}, {"scores", scores_json(mean.mean())}});
  }
  return row;
}

Row run_method(const std::vector<Model>& models, const Method& method, bool timed) {
  Row row;
  row.name = method.name;
  row.note = method.note;
  row.timed = timed;
  for (const Model& m : models) {
    std::fprintf(stderr, "segmentation_bench: %s on %d (%zu triangles) ...\n", method.name.c_str(),
                 m.id, m.mesh.triangle_count());
    double start = thread_seconds();
    std::vector<uint32_t> labels = method.run(m.mesh, m.target);
    double seconds = thread_seconds() - start;
    osteon::Result<PreparedSegmentation> prepared = m.evaluator->prepare(labels, method.name);
    if (labels.empty() || !prepared.ok()) {
      ++row.failed;
      row.per_model.push_back({{"id", m.id}, {"failed", true}});
      continue;
    }
    ScoreAverage mean = osteon::score_against_references(*m.evaluator, prepared.value(), m.human);
    row.by_category[m.category].add_mean(mean);
    row.overall.add_mean(mean);
    row.seconds += seconds;
    row.triangles += m.mesh.triangle_count();
    row.segments += prepared->segments;
    ++row.models;
    row.per_model.push_back({{"id", m.id},
                             {"target", m.target},
                             {"segments", prepared->segments},
                             {"seconds", seconds},
                             {"scores", scores_json(mean.mean())}});
  }
  return row;
}

#if OSTEON_HAVE_CGAL
// CGAL's shape diameter function segmentation (Shapira, Shamir, Cohen-Or 2008, the benchmark's
// "Shape Diameter" row) on a Surface_mesh built from the mesh in triangle order. The SDF values
// of each mesh are computed once and kept (8 bytes a triangle), so the second row (K clusters)
// times the segmentation step alone.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
using FaceIndex = SurfaceMesh::Face_index;

class CgalSdf {
 public:
  /// One label per triangle, or empty when CGAL cannot take the mesh (a face Surface_mesh
  /// refuses: non-manifold or inconsistently oriented). `clusters` empty: CGAL's default (5).
  std::vector<uint32_t> segment(const Mesh& m, std::optional<int> clusters) {
    SurfaceMesh surface;
    std::vector<SurfaceMesh::Vertex_index> vertices;
    vertices.reserve(m.positions.size());
    for (const osteon::Vec3& p : m.positions) {
      vertices.push_back(surface.add_vertex(Kernel::Point_3(p.x, p.y, p.z)));
    }
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      FaceIndex f = surface.add_face(vertices[m.indices[3 * t]], vertices[m.indices[3 * t + 1]],
                                     vertices[m.indices[3 * t + 2]]);
      if (f == SurfaceMesh::null_face() || f.idx() != t) return {};  // faces in triangle order
    }
    auto sdf = surface.add_property_map<FaceIndex, double>("f:sdf").first;
    auto cached = sdf_.find(&m);
    if (cached == sdf_.end()) {
      CGAL::sdf_values(surface, sdf);
      std::vector<double>& values = sdf_[&m];
      for (FaceIndex f : surface.faces()) values.push_back(sdf[f]);
    } else {
      for (FaceIndex f : surface.faces()) sdf[f] = cached->second[f.idx()];
    }
    auto ids = surface.add_property_map<FaceIndex, std::size_t>("f:sid").first;
    if (clusters) {
      CGAL::segmentation_from_sdf_values(surface, sdf, ids, static_cast<std::size_t>(*clusters));
    } else {
      CGAL::segmentation_from_sdf_values(surface, sdf, ids);
    }
    std::vector<uint32_t> labels(surface.number_of_faces());
    for (FaceIndex f : surface.faces()) labels[f.idx()] = static_cast<uint32_t>(ids[f]);
    return labels;
  }

 private:
  std::map<const Mesh*, std::vector<double>> sdf_;
};
#endif


std::string scores_cells(const SegmentationScores& s) {
  return (s.cut_discrepancy ? fixed(*s.cut_discrepancy, 4) : std::string("undefined")) + " | " +
         fixed(s.hamming, 4) + " | " + fixed(s.hamming_rm, 4) + " | " + fixed(s.hamming_rf, 4) + " | " +
         fixed(s.one_minus_rand_index, 4) + " | " + fixed(s.gce, 4) + " | " + fixed(s.lce, 4);
}

std::string markdown(const std::vector<Row>& rows, const std::vector<Model>& models) {
  std::ostringstream md;
  double k_sum = 0;
  for (const Model& m : models) k_sum += m.target;
  md << "### All models\n\n"
     << "| row | models | segments (mean) | CD | HD | Rm | Rf | 1 - RI | GCE | LCE | ms / "
        "triangle | what |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& row : rows) {
    md << "| " << row.name << " | " << row.models;
    if (row.failed > 0) md << " (" << row.failed << " failed)";
    md << " | " << (row.models ? fixed(row.segments / row.models, 1) : "-") << " | "
       << scores_cells(row.overall.mean()) << " | "
       << (row.timed && row.triangles ? fixed(1e3 * row.seconds / row.triangles, 4) : "-") << " | "
       << row.note << " |\n";
  }
  md << "\nK (the target segment count given to methods that take one) averages "
     << fixed(models.empty() ? 0 : k_sum / models.size(), 1) << " over these models.\n\n";

  md << "### Published (approximate)\n\n"
     << "Read off the bar charts of Chen, Golovinskiy, Funkhouser 2009 (the paper prints no "
        "table), over the full benchmark (380 models), segment counts as the benchmark chooses "
        "them: **approximate values, not measured here**.\n\n"
     << "| method | 1 - RI (approx.) |\n|---|---|\n";
  for (const Published& p : kPublished) {
    md << "| " << p.method << " | ~" << fixed(p.one_minus_rand_index, 2) << " |\n";
  }
  md << "| Human, full benchmark | 0.103 (CD 0.172, HD 0.099, GCE 0.067, LCE 0.044) "
        "|\n\n";

  md << "### By category\n\n"
     << "Each category's models averaged (CD over the models where it is defined).\n\n"
     << "| category | models | row | CD | HD | Rm | Rf | 1 - RI | GCE | LCE |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  std::map<int, int> per_category;
  for (const Model& m : models) ++per_category[m.category];
  for (auto [category, count] : per_category) {
    for (const Row& row : rows) {
      auto it = row.by_category.find(category);
      if (it == row.by_category.end()) continue;
      md << "| " << kCategories[category] << " | " << count << " | " << row.name << " | "
         << scores_cells(it->second.mean()) << " |\n";
    }
  }
  return md.str();
}

/// One segmentation in a child process, so that its peak memory is its own: reads `path`,
/// segments it with `options`, and reports triangles, components, the largest component, CPU
/// seconds and peak resident MB (or an error).
struct SpeedRun {
  bool ok = false;
  std::string error;
  double triangles = 0, components = 0, largest = 0, seconds = 0, read_mb = 0, peak_mb = 0;
};

SpeedRun segment_in_child(const std::string& path, const osteon::SegmentOptions& options) {
  SpeedRun run;
  int fds[2];
  if (pipe(fds) != 0) return run;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    std::string out;
    osteon::Result<osteon::Scene> scene = osteon::read_path(path);
    if (!scene.ok()) {
      out = "E " + scene.status().message();
    } else {
      const Mesh mesh = osteon::merge_parts(std::move(scene.value()));
      rusage before{};
      getrusage(RUSAGE_SELF, &before);
      const double start = thread_seconds();
      osteon::Result<osteon::Segmentation> seg = osteon::segment(mesh, options);
      const double seconds = thread_seconds() - start;
      rusage after{};
      getrusage(RUSAGE_SELF, &after);
      if (!seg.ok()) {
        out = "E " + seg.status().message();
      } else {
        std::vector<uint32_t> sizes(seg->count, 0);
        for (uint32_t label : seg->labels) ++sizes[label];
        const uint32_t largest = sizes.empty() ? 0 : *std::max_element(sizes.begin(), sizes.end());
        out = "O " + std::to_string(mesh.triangle_count()) + " " + std::to_string(seg->count) +
              " " + std::to_string(largest) + " " + std::to_string(seconds) + " " +
              std::to_string(before.ru_maxrss / 1024.0) + " " +
              std::to_string(after.ru_maxrss / 1024.0);
      }
    }
    const ssize_t written = write(fds[1], out.data(), out.size());
    _exit(written == static_cast<ssize_t>(out.size()) ? 0 : 1);
  }
  close(fds[1]);
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fds[0], buffer, sizeof buffer)) > 0) text.append(buffer, static_cast<size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (text.rfind("O ", 0) == 0) {
    std::istringstream in(text.substr(2));
    in >> run.triangles >> run.components >> run.largest >> run.seconds >> run.read_mb >>
        run.peak_mb;
    run.ok = static_cast<bool>(in);
  } else {
    run.error = text.size() > 2 ? text.substr(2) : "the child process failed";
  }
  return run;
}

/// Speed and memory on the dense meshes, and `osteon segment` on every mesh file of the data.
std::string speed_and_coverage(const fs::path& data, uint32_t stream_limit) {
  std::ostringstream md;
  md << "\n### Speed and memory (dense meshes, one thread)\n\n"
        "Each run in a child process: CPU time of segment() alone, peak resident memory of the "
        "process (the mesh as read, then the segmentation).\n\n"
        "| mesh | triangles | options | components | largest | seconds | M triangles/s | "
        "MB read | MB peak | bytes / triangle over the read mesh |\n"
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|\n";
  std::vector<fs::path> dense;
  for (const char* name : {"ct-like/hip_mcs.ply", "ct-like/skull_mc.ply"}) {
    if (fs::exists(data / name)) dense.push_back(data / name);
  }
  for (const fs::path& path : dense) {
    for (uint32_t limit : {0u, stream_limit}) {
      osteon::SegmentOptions options;
      options.max_triangles = limit;
      std::fprintf(stderr, "segmentation_bench: speed on %s (max %u) ...\n",
                   path.filename().c_str(), limit);
      const SpeedRun run = segment_in_child(path.string(), options);
      const std::string label =
          limit == 0 ? std::string("defaults") : "--max-triangles " + std::to_string(limit);
      if (!run.ok) {
        md << "| " << path.filename().string() << " | | " << label << " | failed: " << run.error
           << " | | | | | | |\n";
        continue;
      }
      md << "| " << path.parent_path().filename().string() << "/" << path.filename().string()
         << " | " << fixed(run.triangles, 0) << " | " << label << " | "
         << fixed(run.components, 0) << " | " << fixed(run.largest, 0) << " | "
         << fixed(run.seconds, 2) << " | " << fixed(run.triangles / run.seconds / 1e6, 2)
         << " | " << fixed(run.read_mb, 0) << " | " << fixed(run.peak_mb, 0) << " | "
         << fixed((run.peak_mb - run.read_mb) * 1048576.0 / run.triangles, 0) << " |\n";
    }
  }

  // Every mesh file under the data folder, as `osteon pack` will segment it for streaming.
  size_t files = 0, failed = 0, over = 0;
  double triangles = 0, components = 0, seconds = 0, largest = 0;
  std::string failures;
  std::vector<fs::path> paths;
  for (const auto& entry : fs::recursive_directory_iterator(data)) {
    if (!entry.is_regular_file()) continue;
    if (osteon::format_from_extension(entry.path().string()) != osteon::Format::kUnknown) {
      paths.push_back(entry.path());
    }
  }
  std::sort(paths.begin(), paths.end());
  for (const fs::path& path : paths) {
    osteon::SegmentOptions options;
    options.max_triangles = stream_limit;
    std::fprintf(stderr, "segmentation_bench: coverage %zu/%zu %s\n", files + 1, paths.size(),
                 path.c_str());
    const SpeedRun run = segment_in_child(path.string(), options);
    ++files;
    if (!run.ok) {
      // Files osteon cannot read at all (reported by the readers' own tests) are not the
      // segmenter's failures, but are listed.
      ++failed;
      failures += "- " + fs::relative(path, data).string() + ": " + run.error + "\n";
      continue;
    }
    triangles += run.triangles;
    components += run.components;
    seconds += run.seconds;
    largest = std::max(largest, run.largest);
    if (run.largest > stream_limit) ++over;
  }
  md << "\n### `osteon segment` on every mesh file in ../shared/data\n\n"
     << "With `--max-triangles " << stream_limit << "` (what the streaming stage asks for): "
     << files << " files, " << (files - failed) << " segmented, " << failed << " not ("
     << "listed below), " << fixed(triangles, 0) << " triangles into " << fixed(components, 0)
     << " components in " << fixed(seconds, 1) << " s of CPU ("
     << fixed(seconds > 0 ? triangles / seconds / 1e6 : 0, 2) << " M triangles/s); the largest "
     << "component has " << fixed(largest, 0) << " triangles; components over the limit: " << over
     << ".\n";
  if (!failures.empty()) md << "\n" << failures;
  return md.str();
}

}  // namespace
}  // namespace osteon_bench

int main(int argc, char** argv) {
  using namespace osteon_bench;
  CLI::App app{"osteon segmentation benchmark: the Princeton Segmentation Benchmark's measures"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path, json_path, only;
  bool no_cgal = false;
  app.add_option("--data", data, "folder of real meshes (../shared/data)");
  app.add_option("--write", write_path,
                 "replace the section '## Segmentation' of this Markdown file");
  app.add_option("--json", json_path, "write every model's scores to this JSON file");
  app.add_option("--only", only, "one category (e.g. Chair) or model id (e.g. 101)");
  app.add_flag("--no-cgal", no_cgal, "skip CGAL's SDF segmentation");
  bool no_speed = false;
  uint32_t stream_limit = 20000;
  app.add_flag("--no-speed", no_speed,
               "skip the dense meshes' speed and the run over every mesh file");
  app.add_option("--max-triangles", stream_limit,
                 "the streaming limit for the speed and coverage runs (default 20000)");
  CLI11_PARSE(app, argc, argv);

  fs::path benchmark = fs::path(data) / "cearto__zen__MeshsegBenchmark";
  std::vector<Model> models = load_models(benchmark / "data", only);
  if (models.empty()) {
    std::fprintf(stderr, "segmentation_bench: no benchmark models under %s\n",
                 (benchmark / "data").string().c_str());
    return 1;
  }
  size_t human = 0;
  for (const Model& m : models) human += m.human.size();
  std::fprintf(stderr, "segmentation_bench: %zu models, %zu human segmentations\n", models.size(),
               human);
  std::vector<std::string> notes;
  std::map<int, int> published = published_targets(benchmark);
  for (const Model& m : models) {
    auto it = published.find(m.id);
    if (it != published.end() && it->second != m.target) {
      notes.push_back("model " + std::to_string(m.id) + ": K " + std::to_string(m.target) +
                      " here, " + std::to_string(it->second) + " in nSeg-ByModel.txt");
    }
  }

  // The methods under test, each run on every model. A segmentation method is added here.
  std::vector<Method> methods = {
      {"None", "one segment",
       [](const Mesh& m, int) { return std::vector<uint32_t>(m.triangle_count(), 0); }},
      {"Every", "one segment per triangle",
       [](const Mesh& m, int) {
         std::vector<uint32_t> labels(m.triangle_count());
         for (size_t t = 0; t < labels.size(); ++t) labels[t] = static_cast<uint32_t>(t);
         return labels;
       }},
  };
  std::vector<bool> timed = {false, false};
  auto osteon_segment = [](double phi) {
    return [phi](const Mesh& m, int k) {
      osteon::SegmentOptions options;
      options.segments = static_cast<uint32_t>(k);
      options.phi = phi;
      osteon::Result<osteon::Segmentation> seg = osteon::segment(m, options);
      return seg.ok() ? seg->labels : std::vector<uint32_t>();
    };
  };
  methods.push_back({"osteon", "Dijkstra region diffusion on GD (phi 300), K segments",
                     osteon_segment(300)});
  timed.push_back(true);
  methods.push_back({"osteon, phi 0", "the same without the angular distance (ablation)",
                     osteon_segment(0)});
  timed.push_back(true);
#if OSTEON_HAVE_CGAL
  auto cgal = std::make_shared<CgalSdf>();
  std::string cgal_version = CGAL_VERSION_STR;
  if (!no_cgal) {
    methods.push_back({"CGAL SDF " + cgal_version + ", defaults",
                       "sdf_values + segmentation_from_sdf_values (5 clusters, lambda 0.26); time "
                       "of both",
                       [cgal](const Mesh& m, int) { return cgal->segment(m, std::nullopt); }});
    timed.push_back(true);
    methods.push_back({"CGAL SDF " + cgal_version + ", K clusters",
                       "the same SDF values, segmentation_from_sdf_values with K clusters (SDF "
                       "levels, not segments: on model 1, 15 clusters give 1 segment); time of "
                       "the segmentation step alone",
                       [cgal](const Mesh& m, int k) { return cgal->segment(m, k); }});
    timed.push_back(true);
  }
#else
  if (!no_cgal) notes.push_back("CGAL was not found at configure time: its rows are missing");
#endif

  std::vector<Row> rows;
  rows.push_back(human_row(models));
  for (size_t i = 0; i < methods.size(); ++i)
    rows.push_back(run_method(models, methods[i], timed[i]));

  std::string table = markdown(rows, models);
  for (const std::string& note : notes) table += "\nNote: " + note + "\n";
  if (only.empty() && !no_speed) table += speed_and_coverage(data, stream_limit);
  std::printf("%s", table.c_str());

  if (!json_path.empty()) {
    json j = json::object();
    for (const Row& row : rows) j[row.name] = row.per_model;
    std::string text = j.dump(1);
    if (!osteon::write_file_atomic(json_path, text.data(), text.size()).ok()) {
      std::fprintf(stderr, "segmentation_bench: cannot write %s\n", json_path.c_str());
      return 1;
    }
  }
  if (!write_path.empty()) {
    char date[32];
    std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%d", std::gmtime(&now));
    std::string command = "build-bench/segmentation_bench" +
                          (only.empty() ? std::string() : " --only " + only) +
                          (no_cgal ? " --no-cgal" : "") + (no_speed ? " --no-speed" : "") +
                          " --write " + write_path;
    std::ostringstream body;
    body << "The Princeton Segmentation Benchmark's measures (Chen, Golovinskiy, Funkhouser 2009; "
            "osteon's evaluator `tools/support/segeval.hpp`, definitions in docs/DESIGN.md) on "
         << models.size() << " of its models (" << human
         << " human segmentations) in ../shared/data: each segmentation is scored against every "
            "human segmentation of its model and averaged over them, then over models. All "
            "measures are errors (lower is better); CD is undefined for a segmentation without a "
            "cut and averaged over the models where it is defined. Methods that take a segment "
            "count get K, the most common human segment count of the model. Times are the "
            "thread's CPU time (one thread), per triangle of the input.\n\n"
         << "Machine: " << cpu_model() << ", " << sysconf(_SC_NPROCESSORS_ONLN)
         << " cores. Date: " << date << ". Command (Release build, from the repository root):\n\n"
         << "```\ncmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release "
            "-DOSTEON_BUILD_BENCH=ON -DOSTEON_BUILD_TESTS=OFF\ncmake --build build-bench --target "
            "segmentation_bench\n"
         << command << "\n```\n\n"
         << table;
    if (!write_section(write_path, "## Segmentation", body.str())) {
      std::fprintf(stderr, "segmentation_bench: cannot write %s\n", write_path.c_str());
      return 1;
    }
  }
  return 0;
}
