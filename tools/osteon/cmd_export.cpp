// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/export.hpp"
#include "osteon/pack.hpp"
#include "osteon/package.hpp"

// osteon export INPUT... -o OUT.glb|OUT.gltf [--no-compress] [--float] [--no-normals]
//               [--no-instancing] [pack's options: --bits | --precision, --names, ...] [--json]
// Writes a package, or the inputs packed in memory as `osteon pack` packs them, as one glTF 2.0
// file (docs/FORMAT.md "glTF export").

namespace osteon::cli {

namespace {

struct ExportArgs {
  std::vector<std::string> inputs;
  std::string output;
  PackOptions pack;
  ExportOptions options;
  bool no_compress = false;
  bool float_positions = false;
  bool no_normals = false;
  bool no_instancing = false;
  bool no_repeats = false;
  bool json = false;
};

int run_export(const ExportArgs& args) {
  ExportOptions options = args.options;
  options.compress = !args.no_compress;
  options.quantize = !args.float_positions;
  options.normals = !args.no_normals;
  options.instancing = !args.no_instancing;
  PackageData package;
  bool packed = false;
  if (args.inputs.size() == 1 && is_package(args.inputs.front())) {
    Result<PackageData> loaded = load_package(args.inputs.front());
    if (!loaded.ok()) return fail(loaded.status());
    package = std::move(loaded).value();
  } else {
    PackOptions pack = args.pack;
    pack.repeats = !args.no_repeats;
    pack.levels = 1;  // levels of detail are not exported
    Result<PackageData> built = pack_in_memory(args.inputs, pack);
    if (!built.ok()) return fail(built.status());
    package = std::move(built).value();
    packed = true;
  }
  ExportReport r;
  const Status status = export_gltf(package, args.output, options, &r);
  if (!status.ok()) return fail(status);
  const char* unit = unit_name(package.manifest.unit);
  const double bits_per_triangle =
      r.triangles > 0 ? 8.0 * double(r.bytes) / double(r.triangles) : 0;
  if (args.json) {
    nlohmann::json j = {{"output", args.output},
                        {"packed_in_memory", packed},
                        {"bytes", r.bytes},
                        {"bin_bytes", r.bin_bytes},
                        {"parts", r.parts},
                        {"meshes", r.meshes},
                        {"part_nodes", r.part_nodes},
                        {"instancing_nodes", r.instancing_nodes},
                        {"instances", r.instances},
                        {"mirrored_instances", r.mirrored_instances},
                        {"float_meshes", r.float_meshes},
                        {"triangles", r.triangles},
                        {"vertices", r.vertices},
                        {"bits_per_triangle", bits_per_triangle},
                        {"unit", unit},
                        {"error_bound", r.error_bound},
                        {"max_deviation", r.max_deviation}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "%s: %zu parts (%zu nodes, %zu instances in %zu instancing nodes, %zu of them mirrored), "
        "%llu triangles, %llu vertices in %zu meshes, %llu bytes (%.2f bits/triangle); vertices "
        "within %.3g %s of the package's (bound %.3g %s from the input)\n",
        args.output.c_str(), r.parts, r.part_nodes, r.instances, r.instancing_nodes,
        r.mirrored_instances, static_cast<unsigned long long>(r.triangles),
        static_cast<unsigned long long>(r.vertices), r.meshes,
        static_cast<unsigned long long>(r.bytes), bits_per_triangle, r.max_deviation, unit,
        r.error_bound, unit);
  }
  return kExitOk;
}

}  // namespace

void register_export(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write a package (or inputs, packed in memory) as one glTF 2.0 file (.glb or .gltf + .bin)");
  cmd->footer(
      "Writes a node per group, then a node per part (display name as its name, the part's id, "
      "name, FMA id, group and source in extras.osteon); a mesh drawn by several parts as "
      "EXT_mesh_gpu_instancing (mirrored instances under a node that mirrors, so every instance "
      "keeps a positive determinant; extras.osteon.instances lists the parts in instance order); "
      "positions on the package's grid as KHR_mesh_quantization integers, the grid folded into "
      "the node and instance transforms, so no vertex moves off the package's grid; buffers "
      "compressed with meshoptimizer (EXT_meshopt_compression, normals octahedral-filtered). "
      "KHR_meshopt_compression is not written: it needs meshoptimizer's v1 vertex codec, which "
      "Debian 12's libmeshoptimizer 0.18 lacks. See docs/FORMAT.md \"glTF export\".");
  cmd->add_option("inputs", args->inputs,
                  "an osteon package folder, or mesh files, folders of parts or label volumes "
                  "(packed in memory as osteon pack packs them)")
      ->required();
  cmd->add_option("-o,--output", args->output, "the .glb or .gltf to write")->required();
  cmd->add_flag("--no-compress", args->no_compress,
                "plain buffer views (no EXT_meshopt_compression); positions stay quantised");
  cmd->add_flag("--float", args->float_positions,
                "float positions (no KHR_mesh_quantization grid): input for tools that "
                "re-quantise, such as gltfpack");
  cmd->add_flag("--no-normals", args->no_normals, "no NORMAL attribute (engines shade flat)");
  cmd->add_flag("--no-instancing", args->no_instancing,
                "no EXT_mesh_gpu_instancing: every part its own node, sharing the mesh");
  // When packing: pack's quantisation, repeats, segmentation and names.
  CLI::Option* bits = cmd->add_option("--bits", args->pack.bits,
                                      "when packing: bits per coordinate over a part's size "
                                      "(8..24), instead of the default 0.05 mm")
                          ->check(CLI::Range(8, 24));
  CLI::Option* precision =
      cmd->add_option("--precision", args->pack.precision,
                      "when packing: largest coordinate error in mesh units (default: 0.05 mm)")
          ->check(CLI::PositiveNumber);
  bits->excludes(precision);
  cmd->add_option("--repeat-tolerance", args->pack.repeat_tolerance,
                  "when packing: tolerance of a repeat in mesh units (default: the codec's bound)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-repeats", args->no_repeats, "when packing: no repeat search");
  cmd->add_option("--max-triangles", args->pack.max_triangles,
                  "when packing: largest component (a primitive) in triangles (default 20000)");
  cmd->add_option("--names", args->pack.names,
                  "when packing: JSON or CSV mapping file stems to display names and groups");
  cmd->add_option("--threads", args->pack.threads, "worker threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  add_volume_options(cmd, &args->pack.read);
  cmd->add_flag("--json", args->json, "print a JSON summary");
  cmd->callback([args, run] { *run = [args] { return run_export(*args); }; });
}

}  // namespace osteon::cli
