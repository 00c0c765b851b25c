// SPDX-License-Identifier: Apache-2.0
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.hpp"
#include "osteon/codec.hpp"
#include "osteon/io.hpp"

// osteon encode IN -o OUT [--bits N | --precision E] [--json]
// osteon decode IN -o OUT.{ply,stl,obj}

namespace osteon::cli {

namespace {

struct EncodeArgs {
  std::string input;
  std::string output;
  int bits = 14;
  double precision = 0;
  bool normals = false;
  int normal_bits = 10;
  int effort = 1;
  bool json = false;
  ReadOptions read;  ///< label volumes' options
};

struct DecodeArgs {
  std::string input;
  std::string output;
  bool json = false;
};

int run_encode(const EncodeArgs& args) {
  Result<Scene> scene = read_path(args.input, args.read);
  if (!scene.ok()) return fail(scene.status());
  size_t parts = scene->parts.size();
  Mesh mesh = merge_parts(std::move(scene.value()));
  EncodeOptions options;
  options.bits = args.bits;
  options.precision = args.precision;
  options.normals = args.normals;
  options.normal_bits = args.normal_bits;
  options.effort = args.effort;
  EncodeReport report;
  auto start = std::chrono::steady_clock::now();
  Result<std::vector<uint8_t>> bytes = encode(mesh, options, &report);
  double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!bytes.ok()) return fail(args.input + ": " + bytes.status().message());
  Status written = write_file_atomic(args.output, bytes->data(), bytes->size());
  if (!written.ok()) return fail(written);
  if (args.json) {
    nlohmann::json j = {
        {"input", args.input},
        {"output", args.output},
        {"parts", parts},
        {"vertices", report.vertices},
        {"triangles", report.triangles},
        {"degenerate_removed", report.degenerate_removed},
        {"unreferenced_removed", report.unreferenced_removed},
        {"bytes", report.bytes},
        {"connectivity_bytes", report.connectivity_bytes},
        {"geometry_bytes", report.geometry_bytes},
        {"connectivity_bits_per_vertex", report.connectivity_bits_per_vertex},
        {"geometry_bits_per_vertex", report.geometry_bits_per_vertex},
        {"bits_per_vertex", report.vertices ? 8.0 * report.bytes / report.vertices : 0.0},
        {"max_error", report.max_error},
        {"grid_step", report.grid_step},
        {"prediction_mode", report.prediction_mode},  // docs/FORMAT.md, geometry section
        {"triangle_shape", {report.shape_scale, report.shape_apex}},
        {"refinements", {report.extrapolation, report.curvature}},
        {"effort", args.effort},
        {"geometry_passes", report.geometry_passes},
        {"connectivity_models", report.connectivity_models},
        {"encode_ms", ms}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "%s: %zu vertices, %zu triangles -> %zu bytes (connectivity %.3f, geometry %.3f "
        "bits/vertex), "
        "grid step %.6g, max error %.6g, %.1f ms\n",
        args.output.c_str(), report.vertices, report.triangles, report.bytes,
        report.connectivity_bits_per_vertex, report.geometry_bits_per_vertex, report.grid_step,
        report.max_error, ms);
  }
  return kExitOk;
}

int run_decode(const DecodeArgs& args) {
  Result<std::vector<uint8_t>> read = read_file(args.input);
  if (!read.ok()) return fail(read.status());
  const std::vector<uint8_t>& bytes = read.value();
  auto start = std::chrono::steady_clock::now();
  Result<Mesh> mesh = decode(bytes.data(), bytes.size(), args.input);
  double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!mesh.ok()) return fail(mesh.status());
  Status written = write_mesh(args.output, mesh.value());
  if (!written.ok()) return fail(written);
  if (args.json) {
    nlohmann::json j = {{"input", args.input},
                        {"output", args.output},
                        {"vertices", mesh->vertex_count()},
                        {"triangles", mesh->triangle_count()},
                        {"bytes", bytes.size()},
                        {"decode_ms", ms}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("%s: %zu vertices, %zu triangles, decoded in %.1f ms\n", args.output.c_str(),
                mesh->vertex_count(), mesh->triangle_count(), ms);
  }
  return kExitOk;
}

}  // namespace

void register_encode(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<EncodeArgs>();
  CLI::App* cmd = app.add_subcommand("encode", "Compress one mesh (all parts of IN merged)");
  cmd->add_option("IN", args->input, "Mesh file or folder")->required();
  cmd->add_option("-o,--output", args->output, "The compressed stream to write")->required();
  auto* bits = cmd->add_option("--bits", args->bits, "Position bits, 8..24 (default 14)")
                   ->check(CLI::Range(8, 24));
  cmd->add_option("--precision", args->precision,
                  "Largest position error, in mesh units (e.g. 0.05 for 0.05 mm)")
      ->check(CLI::PositiveNumber)
      ->excludes(bits);
  cmd->add_flag("--normals", args->normals,
                "Transmit normals (the mesh's own, else its smooth normals), octahedral");
  cmd->add_option("--normal-bits", args->normal_bits, "Bits per octahedral component, 8..16")
      ->check(CLI::Range(8, 16));
  cmd->add_option("--effort", args->effort,
                  "1 (default): search for the smallest stream; 0: no search, several times "
                  "faster on small meshes, a few percent larger")
      ->check(CLI::Range(0, 1));
  cmd->add_flag("--json", args->json, "Print a JSON report");
  add_volume_options(cmd, &args->read);
  cmd->callback([args, run] { *run = [args] { return run_encode(*args); }; });
}

void register_decode(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<DecodeArgs>();
  CLI::App* cmd = app.add_subcommand("decode", "Decompress a stream to PLY, STL or OBJ");
  cmd->add_option("IN", args->input, "The compressed stream")->required();
  cmd->add_option("-o,--output", args->output, "Mesh file to write (.ply, .stl or .obj)")
      ->required();
  cmd->add_flag("--json", args->json, "Print a JSON report");
  cmd->callback([args, run] { *run = [args] { return run_decode(*args); }; });
}

}  // namespace osteon::cli
