// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <vector>

#include "cli.hpp"
#include "osteon/io.hpp"
#include "osteon/volume.hpp"

// osteon voxelize MESHES... -o OUT.nii[.gz] [--voxel 0.5] [--margin 2] [--threads T] [--json]:
// every part of every input becomes one label (part k is label k + 1) of a NIfTI label volume.

namespace osteon::cli {

namespace {

namespace fs = std::filesystem;

struct VoxelizeArgs {
  std::vector<std::string> inputs;
  std::string output;
  double voxel = 0.5;
  uint32_t margin = 2;
  int threads = 0;
  bool json = false;
};

int run_voxelize(const VoxelizeArgs& args) {
  // The output's folder is checked before the inputs are read: reading and voxelizing a
  // skeleton takes a while.
  fs::path folder = fs::path(args.output).parent_path();
  std::error_code ec;
  if (!folder.empty() && !fs::is_directory(folder, ec))
    return fail(args.output + ": the folder " + folder.string() + " does not exist");
  Scene scene;
  for (const std::string& input : args.inputs) {
    Result<Scene> read = read_path(input);
    if (!read.ok()) return fail(read.status());
    for (Mesh& mesh : read->parts) scene.parts.push_back(std::move(mesh));
  }
  VoxelizeOptions options;
  options.voxel = args.voxel;
  options.margin = args.margin;
  options.threads = args.threads;
  VoxelizeReport report;
  Status written = voxelize(scene, args.output, options, &report);
  if (!written.ok()) return fail(written);
  uint64_t bytes = fs::file_size(args.output, ec);
  if (args.json) {
    nlohmann::json j = {
        {"inputs", args.inputs},   {"output", args.output},       {"parts", scene.parts.size()},
        {"voxel", args.voxel},     {"margin", args.margin},       {"size", report.size},
        {"voxels", report.voxels}, {"labelled", report.labelled}, {"bytes", bytes},
        {"ms", report.ms}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "%s: %zu parts -> %u x %u x %u voxels of %g mm, %llu labelled, %llu bytes, %.0f ms\n",
        args.output.c_str(), scene.parts.size(), report.size[0], report.size[1], report.size[2],
        args.voxel, static_cast<unsigned long long>(report.labelled),
        static_cast<unsigned long long>(bytes), report.ms);
  }
  return kExitOk;
}

}  // namespace

void register_voxelize(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<VoxelizeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "voxelize",
      "Meshes to a NIfTI label volume: part k is label k + 1, named in the header's label table");
  cmd->add_option("MESHES", args->inputs, "Mesh files or folders (every part becomes a label)")
      ->required();
  cmd->add_option("-o,--output", args->output, "The label volume to write (.nii or .nii.gz)")
      ->required();
  cmd->add_option("--voxel", args->voxel,
                  "Voxel size in mm, the same along x, y and z (default 0.5)");
  cmd->add_option("--margin", args->margin,
                  "Empty voxels around the parts on every side (default 2)");
  cmd->add_option("--threads", args->threads, "Worker threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--json", args->json, "Print a JSON report");
  cmd->footer(
      "A voxel is inside a part when the rays through its centre along x, y and z cross the\n"
      "part's surface an odd number of times, two rays of three deciding, so a mesh with holes\n"
      "still fills. Where parts overlap, the later one's label wins. The grid covers every part\n"
      "plus --margin voxels; the names (file names without extension) go into the header's\n"
      "label table as TotalSegmentator writes it.");
  cmd->callback([args, run] { *run = [args] { return run_voxelize(*args); }; });
}

}  // namespace osteon::cli
