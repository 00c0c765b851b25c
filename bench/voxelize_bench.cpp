// SPDX-License-Identifier: Apache-2.0
// Meshes to a label volume and back. Two measurements, in one run:
//
//  - The round trip (osteon voxelize, then Surface Nets with constrained smoothing) on every
//    bone of BodyParts3D and of the Visible Human female, at 1 mm: each bone voxelized alone,
//    and the whole set in one volume (where a voxel inside two overlapping parts goes to one).
//    Per bone, the Hausdorff distance both ways: from the original to the surface (what was
//    lost) and from the surface to the original (what was added: a hole in an open mesh comes
//    back capped).
//  - The dense skeleton: BodyParts3D voxelized at 0.5 mm (about 2 G voxels, the density of a
//    thin-slice CT), generated here and deleted afterwards; its surfaces extracted, and
//    simplified at each --precision, against the triangles of the meshes it came from. Each
//    step runs in a forked child, for its own peak memory.
//
//   build-bench/voxelize_bench [--data DIR] [--voxel 1] [--dense-voxel 0.5]
//                              [--precision 0.05,0.125] [--write docs/BENCHMARKS.md]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_child.hpp"
#include "bench_markdown.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/volume.hpp"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

using osteon_bench::ms_since;

/// One bone's round trip: the distances in mm (negative lost: no surface came back).
struct Trip {
  std::string name;
  double lost = -1;   ///< max distance from the original to the surface
  double added = -1;  ///< max distance from the surface to the original
  double mean = 0;    ///< symmetric mean
  bool open = false;  ///< the original has boundary edges
};

/// Voxelizes `parts` at `voxel` mm into `file`, extracts every label's surface and measures each
/// against its part. Parts that get no surface keep lost = -1.
std::vector<Trip> round_trip(const osteon::Scene& parts, double voxel, const std::string& file) {
  std::vector<Trip> trips(parts.parts.size());
  for (size_t k = 0; k < parts.parts.size(); ++k) {
    trips[k].name = fs::path(parts.parts[k].name).stem().string();
  }
  osteon::VoxelizeOptions options;
  options.voxel = voxel;
  if (!osteon::voxelize(parts, file, options).ok()) return trips;
  osteon::Result<osteon::LabelVolume> volume = osteon::read_volume(file);
  if (!volume.ok()) return trips;
  osteon::Result<std::vector<osteon::LabelSurface>> surfaces =
      osteon::extract_surfaces(volume.value());
  if (!surfaces.ok()) return trips;
  for (const osteon::LabelSurface& s : surfaces.value()) {
    if (s.value == 0 || s.value > parts.parts.size()) continue;
    osteon::HausdorffOptions h_options;
    h_options.samples_per_face = 2;
    osteon::Result<osteon::HausdorffReport> h =
        osteon::hausdorff(parts.parts[s.value - 1], s.mesh, h_options);
    if (!h.ok()) continue;
    Trip& trip = trips[s.value - 1];
    trip.lost = h->forward.max;
    trip.added = h->backward.max;
    trip.mean = h->symmetric.mean;
  }
  return trips;
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[size_t(std::lround(q * double(values.size() - 1)))];
}

/// One table row for a list of round trips.
std::string trip_row(const std::string& set, const std::string& how, const std::vector<Trip>& trips,
                     double voxel, double ms) {
  size_t within = 0, within_lost = 0, within_added = 0, within_half = 0, missing = 0;
  size_t open_over = 0, over = 0;
  std::vector<double> worst;
  const Trip* max_trip = nullptr;
  for (const Trip& t : trips) {
    if (t.lost < 0) {
      ++missing;
      continue;
    }
    const double m = std::max(t.lost, t.added);
    worst.push_back(m);
    within += m <= voxel;
    within_half += m <= 1.5 * voxel;
    within_lost += t.lost <= voxel;
    within_added += t.added <= voxel;
    if (m > voxel) {
      ++over;
      open_over += t.open;
    }
    if (max_trip == nullptr || m > std::max(max_trip->lost, max_trip->added)) max_trip = &t;
  }
  std::printf("  %s, %s: %zu of %zu within one voxel (%zu lost nothing, %zu added nothing), "
              "%zu within 1.5, %zu missing; median %.3f, 95%% %.3f, max %.3f mm (%s)\n",
              set.c_str(), how.c_str(), within, trips.size(), within_lost, within_added,
              within_half, missing, quantile(worst, 0.5), quantile(worst, 0.95),
              worst.empty() ? 0.0 : *std::max_element(worst.begin(), worst.end()),
              max_trip ? max_trip->name.c_str() : "-");
  std::ostringstream row;
  row << "| " << set << " | " << how << " | " << trips.size() << " | " << within << " | "
      << within_lost << " | " << within_added << " | " << within_half << " | " << missing << " | "
      << over - open_over << " of " << over << " | " << osteon_bench::fixed(quantile(worst, 0.5), 3)
      << " / " << osteon_bench::fixed(quantile(worst, 0.95), 3) << " / "
      << osteon_bench::fixed(worst.empty() ? 0.0 : *std::max_element(worst.begin(), worst.end()), 2)
      << " (" << (max_trip ? max_trip->name : std::string("-")) << ") | "
      << osteon_bench::fixed(ms / 1000.0, 1) << " |\n";
  return row.str();
}

/// The round trip of `folder`'s bones: each alone, then all in one volume.
std::string measure_set(const std::string& set, const std::string& folder, double voxel,
                        const fs::path& scratch) {
  osteon::Result<osteon::Scene> scene = osteon::read_path(folder);
  if (!scene.ok()) {
    std::printf("  %s: %s\n", set.c_str(), scene.status().message().c_str());
    return {};
  }
  std::printf("== %s: %zu parts at %.2f mm\n", set.c_str(), scene->parts.size(), voxel);
  std::vector<bool> open(scene->parts.size());
  for (size_t k = 0; k < scene->parts.size(); ++k) {
    open[k] = osteon::diagnose(scene->parts[k]).boundary_edges > 0;
  }
  auto start = Clock::now();
  std::vector<Trip> alone;
  for (const osteon::Mesh& part : scene->parts) {
    osteon::Scene one;
    one.parts.push_back(part);
    alone.push_back(round_trip(one, voxel, (scratch / "alone.nii.gz").string()).front());
  }
  for (size_t k = 0; k < alone.size(); ++k) alone[k].open = open[k];
  const double alone_ms = ms_since(start);
  start = Clock::now();
  std::vector<Trip> together = round_trip(scene.value(), voxel, (scratch / "set.nii.gz").string());
  for (size_t k = 0; k < together.size(); ++k) together[k].open = open[k];
  const double together_ms = ms_since(start);
  std::string rows = trip_row(set, "each bone alone", alone, voxel, alone_ms);
  return rows + trip_row(set, "the whole set in one volume", together, voxel, together_ms);
}

/// The dense skeleton: voxelize `bones` at `voxel` mm, then extract and simplify, each in a
/// child process. Returns the table.
std::string measure_dense(const std::string& bones, double voxel,
                          const std::vector<double>& precisions, const fs::path& scratch) {
  const std::string file = (scratch / "dense.nii.gz").string();
  uint64_t source_triangles = 0;
  rusage usage{};
  const std::string made = osteon_bench::run_in_child(
      [&] {
        osteon::Result<osteon::Scene> scene = osteon::read_path(bones);
        if (!scene.ok()) return std::string();
        uint64_t triangles = 0;
        for (const osteon::Mesh& part : scene->parts) triangles += part.triangle_count();
        osteon::VoxelizeOptions options;
        options.voxel = voxel;
        osteon::VoxelizeReport report;
        if (!osteon::voxelize(scene.value(), file, options, &report).ok()) return std::string();
        return nlohmann::json{{"size", report.size},
                              {"voxels", report.voxels},
                              {"ms", report.ms},
                              {"parts", scene->parts.size()},
                              {"triangles", triangles},
                              {"bytes", fs::file_size(file)}}
            .dump();
      },
      &usage);
  const nlohmann::json m = nlohmann::json::parse(made, nullptr, false);
  if (m.is_discarded()) {
    std::printf("  the dense skeleton could not be made\n");
    return {};
  }
  source_triangles = m["triangles"];
  const double voxelize_peak = double(usage.ru_maxrss) / 1024.0;
  std::printf("== dense skeleton: %u x %u x %u voxels of %.2f mm in %.0f ms, %.0f MiB peak, "
              "%llu bytes\n",
              m["size"][0].get<uint32_t>(), m["size"][1].get<uint32_t>(),
              m["size"][2].get<uint32_t>(), voxel, m["ms"].get<double>(), voxelize_peak,
              (unsigned long long)m["bytes"].get<uint64_t>());

  std::ostringstream table;
  table << "Dense skeleton: BodyParts3D's " << m["parts"].get<size_t>() << " bones ("
        << osteon_bench::grouped(source_triangles) << " triangles) voxelized at "
        << osteon_bench::fixed(voxel, 2) << " mm: " << m["size"][0].get<uint32_t>() << " x "
        << m["size"][1].get<uint32_t>() << " x " << m["size"][2].get<uint32_t>() << " = "
        << osteon_bench::fixed(m["voxels"].get<double>() / 1e9, 2) << " G voxels in "
        << osteon_bench::fixed(m["ms"].get<double>() / 1000.0, 1) << " s at a "
        << osteon_bench::fixed(voxelize_peak, 0) << " MiB peak, a "
        << osteon_bench::fixed(double(m["bytes"].get<uint64_t>()) / 1048576.0, 1)
        << " MiB .nii.gz.\n\n"
        << "| surfaces | triangles | x the source meshes | ms (read + surfaces + simplification) "
           "| peak memory |\n|---|---:|---:|---:|---:|\n";
  std::vector<double> runs = {0};
  runs.insert(runs.end(), precisions.begin(), precisions.end());
  for (double precision : runs) {
    const std::string text = osteon_bench::run_in_child(
        [&] {
          const auto start = Clock::now();
          osteon::Result<osteon::LabelVolume> volume = osteon::read_volume(file);
          if (!volume.ok()) return std::string();
          const uint64_t voxel_bytes = volume->voxels.size();
          osteon::SurfaceOptions options;
          options.precision = precision;
          osteon::Result<std::vector<osteon::LabelSurface>> surfaces =
              osteon::extract_surfaces(volume.value(), options);
          if (!surfaces.ok()) return std::string();
          uint64_t triangles = 0;
          for (const osteon::LabelSurface& s : surfaces.value()) {
            triangles += s.mesh.triangle_count();
          }
          const double ms = ms_since(start);
          return nlohmann::json{{"triangles", triangles},
                                {"ms", ms},
                                {"voxel_bytes", voxel_bytes},
                                {"labels", surfaces->size()}}
              .dump();
        },
        &usage);
    const nlohmann::json r = nlohmann::json::parse(text, nullptr, false);
    if (r.is_discarded()) {
      std::printf("  precision %.3f: the child failed\n", precision);
      continue;
    }
    const uint64_t triangles = r["triangles"];
    const double peak = double(usage.ru_maxrss) / 1024.0;
    const std::string what = precision > 0 ? "simplified to " + osteon_bench::sig(precision, 3) +
                                                 " mm"
                                           : std::string("extracted (Surface Nets, 16 passes)");
    std::printf("  %-40s %llu triangles (%.1fx the source), %.0f ms, %.0f MiB peak\n",
                what.c_str(), (unsigned long long)triangles,
                double(triangles) / double(std::max<uint64_t>(source_triangles, 1)),
                r["ms"].get<double>(), peak);
    table << "| " << what << " | " << osteon_bench::grouped(triangles) << " | "
          << osteon_bench::fixed(double(triangles) / double(std::max<uint64_t>(source_triangles, 1)),
                                 1)
          << " | " << osteon_bench::fixed(r["ms"].get<double>(), 0) << " | "
          << osteon_bench::fixed(peak, 0) << " MiB ("
          << osteon_bench::fixed(peak * 1048576.0 /
                                     double(std::max<uint64_t>(r["voxel_bytes"].get<uint64_t>(), 1)),
                                 2)
          << "x the voxels) |\n";
  }
  return table.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Meshes to a label volume and back: the round trip, and the dense skeleton"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  double voxel = 1.0, dense_voxel = 0.5;
  std::vector<double> precisions = {0.05, 0.125};
  app.add_option("--data", data, "The real data folder (../shared/data)");
  app.add_option("--voxel", voxel, "The round trip's voxel size in mm (0: skip)");
  app.add_option("--dense-voxel", dense_voxel, "The dense skeleton's voxel size in mm (0: skip)");
  app.add_option("--precision", precisions, "Simplify the dense skeleton to these errors (mm)")
      ->delimiter(',');
  app.add_option("--write", write_path, "Replace the section in this Markdown file");
  CLI11_PARSE(app, argc, argv);

  const fs::path root(data);
  const fs::path scratch =
      fs::temp_directory_path() / ("osteon_voxelize_bench_" + std::to_string(getpid()));
  fs::create_directories(scratch);
  const std::string bones = (root / "aHer-dev__3DAnatomy/models/bones").string();
  const std::string vhf = (root / "ingvilddevold__muscle-growth/data/VHF_surfaces").string();

  std::string trips =
      "| set | voxelized | bones | within one voxel | lost nothing beyond a voxel | added "
      "nothing beyond a voxel | within 1.5 voxels | no surface | over a voxel: closed of all | "
      "worst distance, median / 95% / max (mm) | s |\n"
      "|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|\n";
  // Each round trip in a child, as the dense skeleton's steps are: TBB's thread pool does not
  // survive fork(), so parallel work in this process would leave those children on one thread.
  if (voxel > 0 && fs::is_directory(bones)) {
    trips += osteon_bench::run_in_child(
        [&] { return measure_set("BodyParts3D", bones, voxel, scratch); });
  }
  if (voxel > 0 && fs::is_directory(vhf)) {
    trips += osteon_bench::run_in_child(
        [&] { return measure_set("Visible Human female", vhf, voxel, scratch); });
  }
  std::string dense;
  if (dense_voxel > 0 && fs::is_directory(bones)) {
    dense = measure_dense(bones, dense_voxel, precisions, scratch);
  }
  fs::remove_all(scratch);

  std::string joined;
  for (size_t i = 0; i < precisions.size(); ++i) {
    joined += (i ? "," : "") + osteon_bench::sig(precisions[i], 3);
  }
  const std::string section =
      "Command: `build-bench/voxelize_bench --write docs/BENCHMARKS.md` (" +
      osteon_bench::cpu_model() + ", " + std::to_string(std::thread::hardware_concurrency()) +
      " threads; a shared machine: compare ratios).\n\n"
      "Round trip at " +
      osteon_bench::fixed(voxel, 2) +
      " mm: osteon voxelize, then extract_surfaces (Surface Nets, 16 constrained smoothing "
      "passes), each surface against its bone by osteon's sampled Hausdorff distance (2 samples a "
      "triangle) both ways. 'Lost' is the original's distance to the surface, 'added' the "
      "surface's distance to the original (a hole in an open mesh comes back capped). In one "
      "volume a voxel inside two overlapping bones goes to one of them.\n\n" +
      trips + "\n" + dense +
      (dense.empty() ? std::string()
                     : "\nEach row in a forked child: its peak is that process's largest resident "
                       "set; the time includes reading the volume. Simplification: "
                       "extract_surfaces with that precision (meshoptimizer, borders locked where "
                       "labels meet); --precision " +
                           joined + ".\n");
  std::printf("%s", section.c_str());
  if (!write_path.empty() &&
      !osteon_bench::write_section(write_path, "## Voxelize round trip and the dense skeleton",
                                   section)) {
    return 1;
  }
  return 0;
}
