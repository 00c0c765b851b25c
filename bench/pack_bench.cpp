// SPDX-License-Identifier: Apache-2.0
// osteon pack on whole skeletons: package size against the input's bytes at
// a 0.05 mm error bound, pack time per stage on every core, peak memory, and the Hausdorff
// distance of what the package draws (read_package) against the input, part by part.
//
//   build-bench/pack_bench [--data DIR] [--runs N] [--dense-voxel 0.5] [--write docs/BENCHMARKS.md]
//
// Then levels of detail: each skeleton packed at full resolution alone (--no-lod) and with levels
// (the default), side by side: bytes, what the levels add, the bytes before the whole skeleton is
// drawn (the first chunks), pack time and peak memory, and the coarsest level's measured error
// against what the manifest records. With --dense-voxel, also the dense skeleton: BodyParts3D
// voxelized at that voxel size and surfaced without simplification (generated, never kept).
//
// Each pack runs in a forked child, so its peak resident memory (getrusage RUSAGE_CHILDREN) is
// its own; the time is the median of the runs. Falls back to the generated phantom skeleton (and
// says so) when the shared data is absent.

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "bench_gzip.hpp"
#include "bench_child.hpp"
#include "bench_markdown.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/package.hpp"
#include "osteon/volume.hpp"
#include "support/phantom.hpp"

namespace fs = std::filesystem;
using osteon_bench::fixed;
using osteon_bench::grouped;

namespace {

struct Dataset {
  std::string label;
  std::string input;
  std::string names;     // --names file, or ""
  double mm_per_unit;    // 1 for mm, 1000 for metres
  double surface_voxels = 0;  // label volumes: ReadOptions::surface_precision_voxels
  bool dense = false;  // the dense skeleton: one run, a sparser read-back, the pack targets
};

struct Run {
  osteon::PackReport report;
  double peak_mib = 0;
};

/// Packs in a forked child; the child sends the report back as JSON through a pipe.
bool pack_in_child(const Dataset& set, const osteon::PackOptions& options, Run* run,
                   std::string* failure) {
  rusage usage{};
  const std::string text = osteon_bench::run_in_child(
      [&] {
        osteon::Result<osteon::PackReport> r = osteon::pack({set.input}, options);
        nlohmann::json j;
        if (!r.ok()) {
          j["error"] = r.status().message();
        } else {
          const osteon::PackReport& p = r.value();
          const osteon::PackTimings& t = p.timings;
          j = {{"input_bytes", p.input_bytes}, {"output_bytes", p.output_bytes},
               {"parts", p.parts}, {"prototypes", p.prototypes}, {"components", p.components},
               {"instances", p.instances}, {"triangles_in", p.triangles_in},
               {"level_streams", p.level_streams}, {"level_bytes", p.level_bytes},
               {"first_bytes", p.first_bytes},
               {"t", {t.read_ms, t.clean_ms, t.repeats_ms, t.segment_ms, t.encode_ms, t.write_ms,
                      t.total_ms, t.levels_ms}}};
        }
        return j.dump();
      },
      &usage);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || j.contains("error")) {
    *failure = j.is_discarded() ? "the pack child died" : j["error"].get<std::string>();
    return false;
  }
  osteon::PackReport& p = run->report;
  p.input_bytes = j["input_bytes"];
  p.output_bytes = j["output_bytes"];
  p.parts = j["parts"];
  p.prototypes = j["prototypes"];
  p.components = j["components"];
  p.instances = j["instances"];
  p.triangles_in = j["triangles_in"];
  p.level_streams = j["level_streams"];
  p.level_bytes = j["level_bytes"];
  p.first_bytes = j["first_bytes"];
  const std::vector<double> t = j["t"];
  p.timings.read_ms = t[0];
  p.timings.clean_ms = t[1];
  p.timings.repeats_ms = t[2];
  p.timings.segment_ms = t[3];
  p.timings.encode_ms = t[4];
  p.timings.write_ms = t[5];
  p.timings.total_ms = t[6];
  p.timings.levels_ms = t[7];
  run->peak_mib = double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
  return true;
}

struct Distance {
  double max = 0;   // largest symmetric Hausdorff distance over the parts, in mm
  double mean = 0;  // sample-weighted mean of the symmetric means, in mm
  size_t parts = 0;
};

/// Every part of the package (at `level`, -1 full resolution) against the input part of the same
/// name. Per part, the measured symmetric max goes to `part_max` when given.
bool measure(const Dataset& set, const std::string& package, Distance* out, std::string* failure,
             int level = -1, std::map<std::string, double>* part_max = nullptr,
             double samples_per_face = 10) {
  osteon::ReadOptions read;
  read.surface_precision_voxels = set.surface_voxels;
  osteon::Result<osteon::Scene> original = osteon::read_path(set.input, read);
  osteon::ReadOptions at_level;
  at_level.package_level = level;
  osteon::Result<osteon::Scene> drawn = osteon::read_path(package, at_level);
  if (!original.ok() || !drawn.ok()) {
    *failure = !original.ok() ? original.status().message() : drawn.status().message();
    return false;
  }
  std::map<std::string, const osteon::Mesh*> by_name;
  for (const osteon::Mesh& part : original->parts) by_name[part.name] = &part;
  double weighted = 0;
  uint64_t samples = 0;
  for (const osteon::Mesh& part : drawn->parts) {
    auto it = by_name.find(part.name);
    if (it == by_name.end()) {
      *failure = "no input part named " + part.name;
      return false;
    }
    osteon::Mesh input = *it->second;
    osteon::remove_degenerate_triangles(input);
    osteon::remove_unreferenced_vertices(input);
    osteon::HausdorffOptions density;
    density.samples_per_face = samples_per_face;
    osteon::Result<osteon::HausdorffReport> h = osteon::hausdorff(input, part, density);
    if (!h.ok()) {
      *failure = h.status().message();
      return false;
    }
    const osteon::OneSidedDistance& d = h->symmetric;
    if (part_max != nullptr) (*part_max)[part.name] = d.max;
    out->max = std::max(out->max, d.max * set.mm_per_unit);
    weighted += d.mean * set.mm_per_unit * double(d.samples);
    samples += d.samples;
    ++out->parts;
  }
  out->mean = samples > 0 ? weighted / double(samples) : 0;
  return true;
}

/// measure() in a child process, as every pack is: TBB's thread pool does not survive fork(), so
/// once this process had run its own parallel work a later pack's child would run on one thread.
bool measure_in_child(const Dataset& set, const std::string& package, Distance* out,
                      std::string* failure, int level = -1,
                      std::map<std::string, double>* part_max = nullptr,
                      double samples_per_face = 10) {
  const std::string text = osteon_bench::run_in_child(
      [&] {
        Distance d;
        std::string why;
        std::map<std::string, double> maxima;
        nlohmann::json j;
        j["ok"] = measure(set, package, &d, &why, level, &maxima, samples_per_face);
        j["failure"] = why;
        j["max"] = d.max;
        j["mean"] = d.mean;
        j["parts"] = d.parts;
        j["part_max"] = maxima;
        return j.dump();
      },
      nullptr);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.contains("ok")) {
    *failure = "the measuring child failed";
    return false;
  }
  if (!j["ok"].get<bool>()) {
    *failure = j["failure"].get<std::string>();
    return false;
  }
  out->max = j["max"];
  out->mean = j["mean"];
  out->parts = j["parts"];
  if (part_max != nullptr) *part_max = j["part_max"].get<std::map<std::string, double>>();
  return true;
}

/// Packs `set` `runs` times in children; the median run by time, the largest peak, and the
/// package left in options.output.
bool pack_median(const Dataset& set, const osteon::PackOptions& options, int runs, Run* median) {
  std::vector<Run> done;
  for (int r = 0; r < runs; ++r) {
    fs::remove_all(options.output);
    Run run;
    std::string failure;
    if (!pack_in_child(set, options, &run, &failure)) {
      std::fprintf(stderr, "pack_bench: %s: %s\n", set.label.c_str(), failure.c_str());
      return false;
    }
    done.push_back(run);
  }
  std::sort(done.begin(), done.end(), [](const Run& a, const Run& b) {
    return a.report.timings.total_ms < b.report.timings.total_ms;
  });
  *median = done[done.size() / 2];
  for (const Run& run : done) median->peak_mib = std::max(median->peak_mib, run.peak_mib);
  return true;
}

/// Per part of the package at `dir`: the error its manifest records for level 0 (each
/// instance's coarsest level, or its full one, plus the repeat's tolerance); parts whose every
/// component is at full resolution are left out.
std::map<std::string, double> recorded_coarsest(const std::string& dir) {
  std::map<std::string, double> out;
  std::ifstream in(dir + "/manifest.json", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  osteon::Result<osteon::Manifest> m = osteon::parse_manifest(
      reinterpret_cast<const uint8_t*>(text.data()), text.size(), dir + "/manifest.json");
  if (!m.ok()) return out;
  std::map<std::string, const osteon::ManifestComponent*> by_id;
  for (const osteon::ManifestComponent& c : m->components) by_id[c.id] = &c;
  std::map<uint64_t, std::pair<double, bool>> of_part;
  for (const osteon::ManifestInstance& instance : m->instances) {
    const osteon::ManifestComponent& c = *by_id.at(instance.component);
    const double e = (c.levels.empty() ? c.error_bound : c.levels.front().error) +
                     instance.error_bound - c.error_bound;
    auto& [error, coarser] = of_part[instance.part];
    error = std::max(error, e);
    coarser = coarser || !c.levels.empty();
  }
  for (const auto& [part, entry] : of_part) {
    if (entry.second) out[m->parts[part].name] = entry.first;
  }
  return out;
}

/// The levels table's two targets, judged separately.
struct LevelTargets {
  bool bytes = true;           // levels add at most 15% on every skeleton
  bool pack_measured = false;  // the dense skeleton was in the table
  bool pack = false;           // and packed with levels in under 60 s, peak under 4 GB
};

/// The levels-of-detail table: each skeleton at full resolution alone and with levels.
bool levels_table(const std::vector<Dataset>& sets, int runs, const fs::path& scratch,
                  std::string* table_out, LevelTargets* met) {
  std::ostringstream table;
  table << "| skeleton | triangles | full resolution only | with levels | levels add | the "
           "share alone adds (coarser levels) | the whole chain adds (coarser levels) | whole "
           "skeleton drawn after | coarser levels | pack time, full / with levels (simplifying "
           "the levels) | peak memory, full / with levels | coarsest level: measured / recorded "
           "error, median (max) |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|\n";
  *met = LevelTargets{};
  for (const Dataset& set : sets) {
    osteon::PackOptions options;
    options.output = (scratch / "lod").string();
    options.names = set.names;
    options.read.surface_precision_voxels = set.surface_voxels;
    const int set_runs = set.dense ? 1 : runs;  // the dense skeleton takes minutes a pack
    // Full resolution alone in the same pieces, so that the difference is the levels alone
    // (--no-lod's own default cuts pieces of 20,000 triangles).
    osteon::PackOptions flat = options;
    flat.levels = 1;
    flat.max_triangles = osteon::PackOptions::kPieceTrianglesWithLevels;
    // Every level of the chain kept (no share), and the levels the share keeps alone (no view):
    // what each rule of pack's choice keeps. One run each: only their bytes are reported.
    osteon::PackOptions whole = options;
    whole.level_share = std::numeric_limits<double>::infinity();
    osteon::PackOptions share = options;
    share.lod_view_pixels = 0;
    Run full, lod, chain, shared;
    if (!pack_median(set, flat, set_runs, &full) || !pack_median(set, whole, 1, &chain) ||
        !pack_median(set, share, 1, &shared) || !pack_median(set, options, set_runs, &lod)) {
      return false;
    }
    // What compare measures at the coarsest level, against what the manifest says.
    std::map<std::string, double> measured;
    Distance distance;
    std::string failure;
    if (!measure_in_child(set, options.output, &distance, &failure, 0, &measured,
                          set.dense ? 1 : 10)) {
      std::fprintf(stderr, "pack_bench: %s: %s\n", set.label.c_str(), failure.c_str());
      return false;
    }
    std::vector<double> ratios;
    for (const auto& [name, recorded] : recorded_coarsest(options.output)) {
      auto it = measured.find(name);
      if (it != measured.end() && recorded > 0) ratios.push_back(it->second / recorded);
    }
    std::sort(ratios.begin(), ratios.end());
    const osteon::PackReport& a = full.report;
    const osteon::PackReport& b = lod.report;
    const double overhead = 100.0 * (double(b.output_bytes) / double(a.output_bytes) - 1);
    met->bytes = met->bytes && overhead <= 15;
    if (set.dense) {
      met->pack_measured = true;
      met->pack = b.timings.total_ms < 60000 && lod.peak_mib < 4096;
    }
    table << "| " << set.label << " | " << grouped(b.triangles_in) << " | "
          << fixed(double(a.output_bytes) / 1e6, 3) << " MB | "
          << fixed(double(b.output_bytes) / 1e6, 3) << " MB | " << fixed(overhead, 1) << "% | "
          << fixed(100.0 * (double(shared.report.output_bytes) / double(a.output_bytes) - 1), 1)
          << "% (" << shared.report.level_streams << ") | "
          << fixed(100.0 * (double(chain.report.output_bytes) / double(a.output_bytes) - 1), 1)
          << "% (" << chain.report.level_streams << ") | "
          << fixed(double(b.first_bytes) / 1e6, 3) << " MB ("
          << fixed(100.0 * double(b.first_bytes) / double(b.output_bytes), 1) << "%) | "
          << b.level_streams << " | " << fixed(a.timings.total_ms / 1000, 1) << " / "
          << fixed(b.timings.total_ms / 1000, 1) << " s (" << fixed(b.timings.levels_ms / 1000, 1)
          << " s) | " << fixed(full.peak_mib, 0) << " / " << fixed(lod.peak_mib, 0) << " MiB | ";
    if (ratios.empty()) {
      table << "- |\n";
    } else {
      table << fixed(ratios[ratios.size() / 2], 2) << " (" << fixed(ratios.back(), 2) << ") over "
            << ratios.size() << " parts |\n";
    }
    std::printf("%s: levels add %.1f%%, whole skeleton after %.3f MB of %.3f MB, pack %.1f s "
                "(levels %.1f s), %.0f MiB\n",
                set.label.c_str(), overhead, double(b.first_bytes) / 1e6,
                double(b.output_bytes) / 1e6, b.timings.total_ms / 1000,
                b.timings.levels_ms / 1000, lod.peak_mib);
    std::fflush(stdout);
  }
  *table_out = table.str();
  return true;
}

/// BodyParts3D voxelized at `voxel` mm into `file` (in a child: its peak is not ours).
bool make_dense(const std::string& bones, double voxel, const std::string& file) {
  const std::string made = osteon_bench::run_in_child(
      [&] {
        osteon::Result<osteon::Scene> scene = osteon::read_path(bones);
        if (!scene.ok()) return std::string("no");
        osteon::VoxelizeOptions options;
        options.voxel = voxel;
        return osteon::voxelize(scene.value(), file, options).ok() ? std::string("ok")
                                                                   : std::string("no");
      },
      nullptr);
  return made == "ok";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"osteon pack on whole skeletons: size, time, memory and error at 0.05 mm"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  int runs = 3;
  double bound_mm = 0.05;
  app.add_option("--data", data, "The shared data folder (default ../shared/data)");
  app.add_option("--runs", runs, "Pack runs per row (median time)")->check(CLI::Range(1, 20));
  app.add_option("--bound", bound_mm, "Error bound in mm (default 0.05)");
  app.add_option("--write", write_path, "Replace the section in this Markdown file");
  double dense_voxel = 0;
  app.add_option("--dense-voxel", dense_voxel,
                 "Levels table: also the dense skeleton, BodyParts3D voxelized at this voxel "
                 "size in mm (0.5: 16 M triangles; default 0: skip)");
  bool levels_only = false;
  app.add_flag("--levels-only", levels_only, "Only the levels-of-detail table");
  CLI11_PARSE(app, argc, argv);

  const fs::path scratch = fs::temp_directory_path() / ("osteon_pack_bench_" + std::to_string(getpid()));
  fs::create_directories(scratch);
  std::vector<Dataset> sets;
  const fs::path root(data);
  const fs::path bp3d = root / "aHer-dev__3DAnatomy";
  if (fs::is_directory(bp3d / "models/bones")) {
    sets.push_back({"BodyParts3D skeleton (235 GLB, with meta.json names)",
                    (bp3d / "models/bones").string(), (bp3d / "meta.json").string(), 1});
    sets.push_back({"MyoSim bone set (200 STL, metres)",
                    (root / "MyoHub__myo_sim/meshes").string(), "", 1000});
    sets.push_back({"Visible Human female lower limb (40 STL)",
                    (root / "ingvilddevold__muscle-growth/data/VHF_surfaces").string(), "", 1});
    sets.push_back({"SPL abdominal atlas (27 VTK)",
                    (root / "stity__spl-abdominal-atlas/Data").string(), "", 1});
  } else {
    std::printf("%s is absent: packing the generated phantom skeleton instead\n", data.c_str());
    osteon::PhantomOptions options;
    const osteon::Phantom phantom = osteon::make_phantom(options);
    const fs::path dir = scratch / "phantom";
    fs::create_directories(dir);
    for (const osteon::Mesh& part : phantom.scene.parts) {
      if (!osteon::write_mesh((dir / (part.name + ".stl")).string(), part).ok()) return 2;
    }
    sets.push_back({"generated phantom skeleton", dir.string(), "", 1});
  }

  if (!levels_only) {
  std::ostringstream table;
  table << "| skeleton | error bound | input | package | of input | manifest (gzip) | parts "
           "(stored) | components | instances | triangles | pack time | read / clean / repeats "
           "/ segment / encode / write (ms) | peak memory | Hausdorff max / mean (mm) |\n"
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|\n";
  bool all_met = true;
  for (const Dataset& set : sets) {
    // Two readings of "0.05 mm": every vertex within 0.05 mm (coordinates within 0.05 / sqrt 3),
    // and every coordinate within 0.05 mm (vertices within 0.087 mm).
    for (const bool euclidean : {true, false}) {
      osteon::PackOptions options;
      options.output = (scratch / "package").string();
      options.names = set.names;
      options.precision = (euclidean ? bound_mm / std::sqrt(3.0) : bound_mm) / set.mm_per_unit;
      Run median;
      if (!pack_median(set, options, runs, &median)) return 2;
      Distance distance;
      std::string failure;
      if (!measure_in_child(set, options.output, &distance, &failure)) {
        std::fprintf(stderr, "pack_bench: %s: %s\n", set.label.c_str(), failure.c_str());
        return 2;
      }
      const std::string manifest = options.output + "/manifest.json";
      std::vector<uint8_t> manifest_bytes;
      {
        std::ifstream in(manifest, std::ios::binary);
        manifest_bytes.assign(std::istreambuf_iterator<char>(in), {});
      }
      const size_t manifest_gzip = osteon_bench::gzip(manifest_bytes).size();
      const osteon::PackReport& p = median.report;
      const osteon::PackTimings& t = p.timings;
      const double share = 100.0 * double(p.output_bytes) / double(p.input_bytes);
      if (euclidean) all_met = all_met && share <= 5.0 && t.total_ms < 10000;
      table << "| " << set.label << " | "
            << (euclidean ? "vertex " : "coordinate ") << fixed(bound_mm, 2) << " mm | "
            << fixed(double(p.input_bytes) / 1e6, 2) << " MB | "
            << fixed(double(p.output_bytes) / 1e6, 3) << " MB | " << fixed(share, 2) << "% | "
            << grouped(manifest_bytes.size()) << " (" << grouped(manifest_gzip) << ") | "
            << p.parts << " (" << p.prototypes << ") | " << p.components << " | " << p.instances
            << " | " << grouped(p.triangles_in) << " | " << fixed(t.total_ms / 1000, 2) << " s | "
            << fixed(t.read_ms, 0) << " / " << fixed(t.clean_ms, 0) << " / "
            << fixed(t.repeats_ms, 0) << " / " << fixed(t.segment_ms, 0) << " / "
            << fixed(t.encode_ms, 0) << " / " << fixed(t.write_ms, 0) << " | "
            << fixed(median.peak_mib, 0) << " MiB | " << osteon_bench::sig(distance.max, 3)
            << " / " << osteon_bench::sig(distance.mean, 3) << " |\n";
      std::printf("%s, %s bound: %.2f%% of the input, %.2f s, Hausdorff max %.4f mm\n",
                  set.label.c_str(), euclidean ? "vertex" : "coordinate", share,
                  t.total_ms / 1000, distance.max);
      std::fflush(stdout);
    }
  }
  std::ostringstream body;
  body << "Command: `build-bench/pack_bench --runs " << runs
       << " --write docs/BENCHMARKS.md` on " << osteon_bench::cpu_model() << ", "
       << std::thread::hardware_concurrency()
       << " hardware threads (pack uses every core). `osteon pack` defaults otherwise "
          "(levels of detail, pieces of at most 80,000 triangles, repeat tolerance the codec's "
          "bound), no viewer files.\n\n"
       << table.str()
       << "\nError bound: *vertex* means every decoded vertex within the bound (`--precision` = "
          "bound / sqrt 3, each coordinate within it); *coordinate* means `--precision` = the "
          "bound (each coordinate within it, a vertex within sqrt 3 times it). Package = the "
          "component files plus manifest.json, as stored (the manifest compresses to the "
          "gzip figure on the wire). Pack time: the median of the runs, wall clock, each in its "
          "own process; peak memory is that process's largest resident set. Hausdorff: "
          "symmetric, each part of the package (read back with read_package, as the viewer "
          "draws it) against the input part of the same name; max over parts, mean weighted by "
          "samples.\n\nTargets: package at most 5% of the input's bytes and pack under "
          "10 s at the vertex bound: "
       << (all_met ? "met on every skeleton." : "**not met on every skeleton** (see the rows).")
       << "\n";
  std::printf("\n%s", body.str().c_str());
  if (!write_path.empty() &&
      !osteon_bench::write_section(write_path, "## Packing whole skeletons", body.str())) {
    std::fprintf(stderr, "pack_bench: cannot write %s\n", write_path.c_str());
    return 2;
  }
  }

  // Levels of detail: the real skeletons of the first table that a viewer draws whole (the
  // first two), and the dense one.
  std::vector<Dataset> lod_sets(sets.begin(), sets.begin() + std::min<size_t>(2, sets.size()));
  const std::string dense_file = (scratch / "dense.nii.gz").string();
  if (dense_voxel > 0 && fs::is_directory(bp3d / "models/bones")) {
    std::printf("== voxelizing BodyParts3D at %.2f mm\n", dense_voxel);
    std::fflush(stdout);
    if (!make_dense((bp3d / "models/bones").string(), dense_voxel, dense_file)) {
      std::fprintf(stderr, "pack_bench: the dense skeleton could not be made\n");
      return 2;
    }
    char label[96];
    std::snprintf(label, sizeof(label), "dense skeleton (BodyParts3D voxelized at %.2g mm, not simplified)",
                  dense_voxel);
    Dataset dense{label, dense_file, "", 1};
    dense.dense = true;
    lod_sets.push_back(dense);
  }
  std::string lod_table;
  LevelTargets lod_met;
  if (!levels_table(lod_sets, runs, scratch, &lod_table, &lod_met)) return 2;
  fs::remove_all(scratch);
  const osteon::PackOptions defaults;
  std::ostringstream lod_body;
  lod_body << "Command: `build-bench/pack_bench --runs " << runs
           << (dense_voxel > 0 ? " --dense-voxel " + fixed(dense_voxel, 2) : std::string())
           << (levels_only ? " --levels-only" : "") << " --write docs/BENCHMARKS.md` on "
           << osteon_bench::cpu_model() << ", " << std::thread::hardware_concurrency()
           << " hardware threads. Each skeleton packed at the default 0.05 mm twice: `--no-lod` "
              "(full resolution alone) and with levels (the default: components above "
           << defaults.lod_min_triangles
           << " triangles get a chain of quarters down to 256, of which pack keeps the coarsest, "
              "those within `--level-share` "
           << defaults.level_share
           << " of the full level's bytes, and the first level within a pixel of the view of the "
              "whole skeleton at `--lod-view-pixels` "
           << defaults.lod_view_pixels << "), both in pieces of at most "
           << grouped(osteon::PackOptions::kPieceTrianglesWithLevels)
           << " triangles, pack's default with levels; and once each with the share alone "
              "(`--lod-view-pixels 0`) and with the whole chain (`--level-share` without a "
              "limit), for what they add. Whole skeleton drawn after: the "
              "first chunks, which hold every component's coarsest level (a viewer reading them "
              "has every bone). Pack time: median of the runs (one run for the dense skeleton), "
              "each in its own process, with its peak resident memory. Coarsest level: every "
              "part read back at level 0 (`read_package`, as `osteon compare ORIGINAL PACKAGE "
              "--level 0` does) against the input part, the measured symmetric Hausdorff max "
              "(10 samples a triangle; 1 for the dense skeleton) over the error the manifest "
              "records for that part; both are sampled lower bounds.\n\n"
           << lod_table
           << "\nTargets: levels add at most 15% to the package: "
           << (lod_met.bytes ? "met" : "**not met** (see the rows)")
           << "; the dense skeleton packs with levels in under 60 s with a peak under 4 GB: "
           << (!lod_met.pack_measured ? "not measured (no --dense-voxel)"
               : lod_met.pack         ? "met"
                                      : "**not met** (see its row)")
           << ".\n";
  std::printf("\n%s", lod_body.str().c_str());
  if (!write_path.empty() &&
      !osteon_bench::write_section(write_path, "## Levels of detail in packages", lod_body.str())) {
    std::fprintf(stderr, "pack_bench: cannot write %s\n", write_path.c_str());
    return 2;
  }
  return 0;
}
