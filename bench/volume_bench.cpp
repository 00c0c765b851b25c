// SPDX-License-Identifier: Apache-2.0
// Bone surfaces from label volumes: osteon's Surface Nets with constrained smoothing against 3D
// Slicer's current pipeline in VTK 9.1 (vtkDiscreteFlyingEdges3D, then
// vtkWindowedSincPolyDataFilter), on the same volumes in one run. Reports, per method: time,
// triangles, the Hausdorff distance to the label boundary (the voxel faces between the label and
// the rest), watertightness (closed, manifold, oriented), and for osteon the peak memory (each
// osteon run in a forked child) and the triangles after simplification at --precision 0.05 mm.
//
// Volumes: TotalSegmentator's example segmentation (its 17 skeletal labels, 3 mm voxels), and
// the BodyParts3D skeleton voxelized by osteon voxelize into a grid of about 157 M voxels (the
// size of a 512 x 512 x 600 whole-body CT), generated here and deleted afterwards.
//
//   build-bench/volume_bench [--data DIR] [--voxels 157000000] [--write docs/BENCHMARKS.md]
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#ifdef OSTEON_HAVE_VTK
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnsignedShortArray.h>
#include <vtkWindowedSincPolyDataFilter.h>
#endif

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

/// What one method made of one volume.
struct Outcome {
  std::string method;
  double read_ms = 0;
  double extract_ms = 0;  ///< surfaces (and smoothing)
  uint64_t triangles = 0;
  uint64_t simplified_triangles = 0;  ///< osteon at 0.05 mm; 0 when not run
  double simplify_ms = 0;
  double hausdorff_max = 0;   ///< mm, the largest over the labels (symmetric)
  double hausdorff_mean = 0;  ///< mm, mean over the labels of the symmetric means
  size_t labels = 0;
  size_t closed = 0;  ///< labels whose surface is closed, manifold and oriented
  double peak_mib = 0;
  uint64_t voxel_bytes = 0;  ///< the label volume's voxels in memory (osteon)
  std::string error;
};

/// Closedness and distance of each label's surface to its voxel boundary, into `out`.
void measure(const osteon::LabelVolume& volume, const std::vector<osteon::Mesh>& surfaces,
             const std::vector<uint32_t>& values, Outcome* out) {
  out->labels = surfaces.size();
  double mean_sum = 0;
  for (size_t s = 0; s < surfaces.size(); ++s) {
    out->triangles += surfaces[s].triangle_count();
    const osteon::DiagnosisReport d = osteon::diagnose(surfaces[s]);
    if (d.closed && d.oriented && d.nonmanifold_vertices == 0) ++out->closed;
    osteon::Result<osteon::Mesh> boundary = osteon::voxel_faces(volume, values[s]);
    if (!boundary.ok()) continue;
    osteon::HausdorffOptions options;
    options.samples_per_face = 2;
    osteon::Result<osteon::HausdorffReport> h =
        osteon::hausdorff(surfaces[s], boundary.value(), options);
    if (!h.ok()) continue;
    out->hausdorff_max = std::max(out->hausdorff_max, h->symmetric.max);
    mean_sum += h->symmetric.mean;
  }
  if (!surfaces.empty()) out->hausdorff_mean = mean_sum / double(surfaces.size());
}

/// The figures both methods report from their child, as its JSON names them.
void read_measured(const nlohmann::json& j, Outcome* out) {
  out->extract_ms = j["extract_ms"];
  out->triangles = j["triangles"];
  out->hausdorff_max = j["hmax"];
  out->hausdorff_mean = j["hmean"];
  out->labels = j["labels"];
  out->closed = j["closed"];
}

/// osteon's extraction of `path`'s selected labels, in a forked child for its peak memory.
Outcome run_osteon(const std::string& path, const std::vector<std::string>& labels) {
  Outcome out;
  out.method = "osteon Surface Nets + constrained smoothing";
  const std::string text = osteon_bench::run_in_child([&] {
    nlohmann::json j;
    auto start = Clock::now();
    osteon::Result<osteon::LabelVolume> volume = osteon::read_volume(path);
    const double read_ms = ms_since(start);
    osteon::Result<std::vector<uint32_t>> chosen =
        volume.ok() ? osteon::select_labels(volume.value(), labels)
                    : osteon::Result<std::vector<uint32_t>>(volume.status());
    if (!chosen.ok()) {
      j["error"] = chosen.status().message();
    } else {
      osteon::SurfaceOptions options;
      options.labels = chosen.value();
      start = Clock::now();
      osteon::Result<std::vector<osteon::LabelSurface>> surfaces =
          osteon::extract_surfaces(volume.value(), options);
      const double extract_ms = ms_since(start);
      rusage usage{};
      getrusage(RUSAGE_SELF, &usage);  // the peak of reading and extracting, before measuring
      if (!surfaces.ok()) {
        j["error"] = surfaces.status().message();
      } else {
        Outcome o;
        std::vector<osteon::Mesh> meshes;
        std::vector<uint32_t> values;
        for (const osteon::LabelSurface& s : surfaces.value()) {
          meshes.push_back(s.mesh);
          values.push_back(s.value);
        }
        measure(volume.value(), meshes, values, &o);
        options.precision = 0.05;
        start = Clock::now();
        osteon::Result<std::vector<osteon::LabelSurface>> simplified =
            osteon::extract_surfaces(volume.value(), options);
        const double simplify_ms = ms_since(start);
        uint64_t simplified_triangles = 0;
        if (simplified.ok()) {
          for (const osteon::LabelSurface& s : simplified.value()) {
            simplified_triangles += s.mesh.triangle_count();
          }
        }
        j = {{"read_ms", read_ms},
             {"extract_ms", extract_ms},
             {"triangles", o.triangles},
             {"simplified", simplified_triangles},
             {"simplify_ms", simplify_ms},
             {"hmax", o.hausdorff_max},
             {"hmean", o.hausdorff_mean},
             {"labels", o.labels},
             {"closed", o.closed},
             {"peak_kib", usage.ru_maxrss},
             {"voxel_bytes", volume->voxel_count() * uint64_t(volume->bytes_per_voxel)}};
      }
    }
    return j.dump();
  });
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || j.contains("error")) {
    out.error = j.is_discarded() ? "the child died" : j["error"].get<std::string>();
    return out;
  }
  read_measured(j, &out);
  out.read_ms = j["read_ms"];
  out.simplified_triangles = j["simplified"];
  out.simplify_ms = j["simplify_ms"];
  out.peak_mib = double(j["peak_kib"].get<uint64_t>()) / 1024.0;
  out.voxel_bytes = j["voxel_bytes"];
  return out;
}

#ifdef OSTEON_HAVE_VTK
/// Slicer's pipeline in VTK 9.1 on the same labels: discrete flying edges for every selected
/// label in one pass, then windowed-sinc smoothing (Slicer's defaults for a smoothing factor of
/// 0.5: 20 iterations, pass band 10^(-4 * 0.5), non-manifold smoothing, normalized
/// coordinates), split by label for measuring. Index space in, osteon's world out.
Outcome run_vtk(const osteon::LabelVolume& volume, const std::vector<uint32_t>& values) {
  Outcome out;
  out.method = "VTK 9.1 discrete flying edges + windowed sinc (Slicer's pipeline)";
  const auto [nx, ny, nz] = volume.size;
  vtkNew<vtkImageData> image;
  image->SetDimensions(int(nx), int(ny), int(nz));
  image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  auto* scalars = static_cast<unsigned short*>(image->GetScalarPointer());
  for (size_t i = 0; i < volume.voxel_count(); ++i) {
    scalars[i] = static_cast<unsigned short>(volume.values[volume.id(i)]);
  }
  auto start = Clock::now();
  vtkNew<vtkDiscreteFlyingEdges3D> edges;
  edges->SetInputData(image);
  for (size_t k = 0; k < values.size(); ++k) edges->SetValue(int(k), double(values[k]));
  edges->ComputeNormalsOff();
  edges->ComputeGradientsOff();
  edges->ComputeScalarsOn();
  vtkNew<vtkWindowedSincPolyDataFilter> smooth;
  smooth->SetInputConnection(edges->GetOutputPort());
  smooth->SetNumberOfIterations(20);
  smooth->SetPassBand(std::pow(10.0, -4.0 * 0.5));
  smooth->BoundarySmoothingOff();
  smooth->FeatureEdgeSmoothingOff();
  smooth->NonManifoldSmoothingOn();
  smooth->NormalizeCoordinatesOn();
  smooth->Update();
  out.extract_ms = ms_since(start);
  vtkPolyData* poly = smooth->GetOutput();
  vtkDataArray* labels = poly->GetPointData()->GetScalars();
  std::map<uint32_t, osteon::Mesh> by_label;
  vtkCellArray* polys = poly->GetPolys();
  vtkIdType count = 0;
  const vtkIdType* ids = nullptr;
  polys->InitTraversal();
  std::map<uint32_t, std::vector<int64_t>> remap;
  while (polys->GetNextCell(count, ids)) {
    if (count != 3) continue;
    const uint32_t value = labels ? uint32_t(labels->GetTuple1(ids[0])) : 0;
    osteon::Mesh& mesh = by_label[value];
    std::vector<int64_t>& map = remap[value];
    if (map.empty()) map.assign(size_t(poly->GetNumberOfPoints()), -1);
    for (int c = 0; c < 3; ++c) {
      int64_t& v = map[size_t(ids[c])];
      if (v < 0) {
        double p[3];
        poly->GetPoint(ids[c], p);
        v = int64_t(mesh.positions.size());
        mesh.positions.push_back(osteon::transform_point(
            volume.index_to_world, osteon::Vec3{float(p[0]), float(p[1]), float(p[2])}));
      }
      mesh.indices.push_back(uint32_t(v));
    }
  }
  std::vector<osteon::Mesh> meshes;
  std::vector<uint32_t> kept;
  for (uint32_t value : values) {
    auto it = by_label.find(value);
    if (it == by_label.end()) continue;
    meshes.push_back(std::move(it->second));
    kept.push_back(value);
  }
  measure(volume, meshes, kept, &out);
  return out;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Bone surfaces from label volumes: osteon against VTK 9.1 (Slicer's pipeline)"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  double target_voxels = 157e6;
  app.add_option("--data", data, "The real data folder (../shared/data)");
  app.add_option("--voxels", target_voxels, "Voxels of the voxelized BodyParts3D volume");
  app.add_option("--write", write_path, "Replace the section in this Markdown file");
  CLI11_PARSE(app, argc, argv);

  struct Set {
    std::string label;
    std::string path;
    std::vector<std::string> labels;
    bool generated = false;
  };
  std::vector<Set> sets;
  const fs::path root(data);
  const fs::path seg = root / "wasserth__TotalSegmentator/tests/reference_files/example_seg.nii.gz";
  if (fs::exists(seg)) {
    sets.push_back({"TotalSegmentator example (122 x 101 x 30, 3 mm), --labels bones",
                    seg.string(),
                    {"bones"}});
  }
  const fs::path bones = root / "aHer-dev__3DAnatomy/models/bones";
  const fs::path scratch =
      fs::temp_directory_path() / ("osteon_volume_bench_" + std::to_string(getpid()));
  fs::create_directories(scratch);
  if (fs::is_directory(bones)) {
    // Voxelized in a child, so that this process does not hold the skeleton's meshes (and the
    // osteon children forked later start small).
    const std::string out = (scratch / "bp3d.nii.gz").string();
    const std::string label = osteon_bench::run_in_child([&] {
      osteon::Result<osteon::Scene> scene = osteon::read_path(bones.string());
      if (!scene.ok()) return std::string();
      osteon::Aabb box;
      for (const osteon::Mesh& part : scene->parts) expand(box, osteon::bounding_box(part));
      const double volume_mm3 =
          double(box.max.x - box.min.x) * (box.max.y - box.min.y) * (box.max.z - box.min.z);
      osteon::VoxelizeOptions options;
      options.voxel = std::cbrt(volume_mm3 / target_voxels);
      osteon::VoxelizeReport report;
      const auto start = Clock::now();
      if (!osteon::voxelize(scene.value(), out, options, &report).ok()) return std::string();
      std::printf("voxelized BodyParts3D at %.3f mm: %u x %u x %u in %.0f ms\n", options.voxel,
                  report.size[0], report.size[1], report.size[2], ms_since(start));
      char text[160];
      std::snprintf(text, sizeof(text),
                    "BodyParts3D voxelized (%u x %u x %u = %.0f M voxels, %.2f mm), %zu labels",
                    report.size[0], report.size[1], report.size[2], double(report.voxels) / 1e6,
                    options.voxel, scene->parts.size());
      return std::string(text);
    });
    if (!label.empty()) sets.push_back({label, out, {}, true});
  }

  std::ostringstream table;
  table << "| volume | method | read ms | surfaces ms | triangles | after 0.05 mm simplification | "
           "Hausdorff to the label boundary, max / mean (mm) | closed, manifold, oriented | "
           "peak memory |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Set& set : sets) {
    std::printf("== %s\n", set.label.c_str());
    std::vector<Outcome> outcomes = {run_osteon(set.path, set.labels)};
#ifdef OSTEON_HAVE_VTK
    // In a child too: TBB's thread pool does not survive fork(), so parallel work here (the
    // reader, the measurement) would leave every later osteon child on one thread.
    const std::string text = osteon_bench::run_in_child([&] {
      osteon::Result<osteon::LabelVolume> volume = osteon::read_volume(set.path);
      if (!volume.ok()) return std::string();
      osteon::Result<std::vector<uint32_t>> values =
          osteon::select_labels(volume.value(), set.labels);
      if (!values.ok()) return std::string();
      const Outcome o = run_vtk(volume.value(), values.value());
      return nlohmann::json{{"method", o.method},
                            {"error", o.error},
                            {"extract_ms", o.extract_ms},
                            {"triangles", o.triangles},
                            {"hmax", o.hausdorff_max},
                            {"hmean", o.hausdorff_mean},
                            {"labels", o.labels},
                            {"closed", o.closed}}
          .dump();
    });
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_discarded() && j.contains("method")) {
      Outcome o;
      o.method = j["method"].get<std::string>();
      o.error = j["error"].get<std::string>();
      read_measured(j, &o);
      outcomes.push_back(o);
    }
#endif
    for (const Outcome& o : outcomes) {
      if (!o.error.empty()) {
        std::printf("  %s: %s\n", o.method.c_str(), o.error.c_str());
        continue;
      }
      std::printf(
          "  %-60s read %.0f ms, surfaces %.0f ms, %llu triangles (%llu at 0.05 mm), "
          "Hausdorff %.3f / %.3f mm, %zu of %zu closed, peak %.0f MiB\n",
          o.method.c_str(), o.read_ms, o.extract_ms, (unsigned long long)o.triangles,
          (unsigned long long)o.simplified_triangles, o.hausdorff_max, o.hausdorff_mean, o.closed,
          o.labels, o.peak_mib);
      table << "| " << set.label << " | " << o.method << " | "
            << (o.read_ms > 0 ? osteon_bench::fixed(o.read_ms, 0) : std::string("(same)")) << " | "
            << osteon_bench::fixed(o.extract_ms, 0) << " | " << osteon_bench::grouped(o.triangles)
            << " | "
            << (o.simplified_triangles > 0 ? osteon_bench::grouped(o.simplified_triangles) + " (" +
                                                 osteon_bench::fixed(o.simplify_ms, 0) + " ms)"
                                           : std::string("-"))
            << " | " << osteon_bench::sig(o.hausdorff_max, 3) << " / "
            << osteon_bench::sig(o.hausdorff_mean, 3) << " | " << o.closed << " of " << o.labels
            << " | "
            << (o.peak_mib > 0
                    ? osteon_bench::fixed(o.peak_mib, 0) + " MiB (" +
                          osteon_bench::fixed(
                              o.peak_mib * 1048576.0 / double(std::max<uint64_t>(o.voxel_bytes, 1)),
                              2) +
                          "x the voxels)"
                    : "-")
            << " |\n";
    }
  }
  fs::remove_all(scratch);
  std::string section =
      "Command: `build-bench/volume_bench --write docs/BENCHMARKS.md` (" +
      osteon_bench::cpu_model() + ", " + std::to_string(std::thread::hardware_concurrency()) +
      " threads; a shared machine: compare ratios).\n\n" + table.str() +
      "\nosteon's runs each in a forked child: its peak memory is that process's largest resident "
      "set while reading and extracting. VTK gets the same label volume in memory (index space) "
      "and does every selected label in one pass; 'read' is osteon's NIfTI reader. The label "
      "boundary is the voxel faces between a label and the rest; the Hausdorff figures are "
      "osteon's sampled symmetric distance (2 samples a triangle), the largest over the labels "
      "and the mean of the labels' means. Closed: no boundary edge, no non-manifold edge or "
      "vertex, consistent orientation (osteon diagnose). Simplification: "
      "extract_surfaces with precision 0.05 mm (meshoptimizer, locked borders where regions "
      "meet).\n";
  std::printf("%s", section.c_str());
  if (!write_path.empty() &&
      !osteon_bench::write_section(write_path, "## Bone surfaces from label volumes", section)) {
    return 1;
  }
  return 0;
}
