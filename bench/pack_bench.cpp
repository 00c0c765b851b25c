// SPDX-License-Identifier: Apache-2.0
// osteon pack on whole skeletons: package size against the input's bytes at
// a 0.05 mm error bound, pack time per stage on every core, peak memory, and the Hausdorff
// distance of what the package draws (read_package) against the input, part by part.
//
//   build-bench/pack_bench [--data DIR] [--runs N] [--write docs/BENCHMARKS.md]
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
               {"t", {t.read_ms, t.clean_ms, t.repeats_ms, t.segment_ms, t.encode_ms, t.write_ms,
                      t.total_ms}}};
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
  const std::vector<double> t = j["t"];
  p.timings = {t[0], t[1], t[2], t[3], t[4], t[5], t[6]};
  run->peak_mib = double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
  return true;
}

struct Distance {
  double max = 0;   // largest symmetric Hausdorff distance over the parts, in mm
  double mean = 0;  // sample-weighted mean of the symmetric means, in mm
  size_t parts = 0;
};

/// Every part of the package against the input part of the same name.
bool measure(const Dataset& set, const std::string& package, Distance* out, std::string* failure) {
  osteon::Result<osteon::Scene> original = osteon::read_path(set.input);
  osteon::Result<osteon::Scene> drawn = osteon::read_path(package);
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
    osteon::Result<osteon::HausdorffReport> h = osteon::hausdorff(input, part, {});
    if (!h.ok()) {
      *failure = h.status().message();
      return false;
    }
    const osteon::OneSidedDistance& d = h->symmetric;
    out->max = std::max(out->max, d.max * set.mm_per_unit);
    weighted += d.mean * set.mm_per_unit * double(d.samples);
    samples += d.samples;
    ++out->parts;
  }
  out->mean = samples > 0 ? weighted / double(samples) : 0;
  return true;
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
      std::vector<Run> done;
      for (int r = 0; r < runs; ++r) {
        fs::remove_all(options.output);
        Run run;
        std::string failure;
        if (!pack_in_child(set, options, &run, &failure)) {
          std::fprintf(stderr, "pack_bench: %s: %s\n", set.label.c_str(), failure.c_str());
          return 2;
        }
        done.push_back(run);
      }
      std::sort(done.begin(), done.end(), [](const Run& a, const Run& b) {
        return a.report.timings.total_ms < b.report.timings.total_ms;
      });
      const Run& median = done[done.size() / 2];
      double peak = 0;
      for (const Run& run : done) peak = std::max(peak, run.peak_mib);
      Distance distance;
      std::string failure;
      if (!measure(set, options.output, &distance, &failure)) {
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
  fs::remove_all(scratch);

  std::ostringstream body;
  body << "Command: `build-bench/pack_bench --runs " << runs
       << " --write docs/BENCHMARKS.md` on " << osteon_bench::cpu_model() << ", "
       << std::thread::hardware_concurrency()
       << " hardware threads (pack uses every core). `osteon pack` defaults otherwise "
          "(--max-triangles 20000, repeat tolerance the codec's bound), no viewer files.\n\n"
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
  return 0;
}
