// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/pack.hpp"
#include "progress.hpp"

#ifndef OSTEON_VIEWER_DIR
#define OSTEON_VIEWER_DIR "build/viewer"
#endif

// osteon pack INPUT... -o DIR [--bits N | --precision E] [--repeat-tolerance X] [--no-repeats]
//             [--max-triangles N] [--lod-min-triangles N] [--levels N | --no-lod]
//             [--names FILE] [--regions names|fma:DIR] [--viewer DIR | --no-viewer]
//             [--threads T] [--json]
// Runs the whole pipeline (read, clean, repeats, segment, levels, encode) and writes the package that
// docs/FORMAT.md ("Package (osteon pack)") specifies, with the viewer's files, a complete static
// site. A progress bar per stage on a terminal.

namespace osteon::cli {

namespace {

struct PackArgs {
  std::vector<std::string> inputs;
  PackOptions options;
  bool no_viewer = false;
  bool no_repeats = false;
  bool no_lod = false;
  bool json = false;
};

/// The viewer folder: --viewer, else $OSTEON_VIEWER, else the source tree's build/viewer (the
/// folder `npm run build:viewer` writes), fixed at compile time.
std::string viewer_folder(const PackArgs& args) {
  if (args.no_viewer) return "";
  if (!args.options.viewer.empty()) return args.options.viewer;
  if (const char* env = std::getenv("OSTEON_VIEWER"); env != nullptr && *env != 0) return env;
  return OSTEON_VIEWER_DIR;
}

int run_pack(const PackArgs& args) {
  PackOptions options = args.options;
  options.viewer = viewer_folder(args);
  options.repeats = !args.no_repeats;
  if (args.no_lod) options.levels = 1;
  // One bar per stage; a stage's bar ends its line when the next stage starts.
  std::unique_ptr<ProgressBar> bar;
  PackStage current = PackStage::kRead;
  options.progress = [&](PackStage stage, uint64_t done, uint64_t total) {
    if (bar == nullptr || stage != current) {
      if (bar != nullptr) bar->finish(true);
      bar = std::make_unique<ProgressBar>(stage_name(stage), stage_unit(stage), total);
      current = stage;
    }
    bar->update(done);
  };
  Result<PackReport> result = pack(args.inputs, options);
  if (bar != nullptr) bar->finish(true);
  if (!result.ok()) return fail(result.status());
  const PackReport& r = result.value();
  if (args.json) {
    nlohmann::json j = {{"output", args.options.output},
                        {"manifest", r.manifest},
                        {"input_bytes", r.input_bytes},
                        {"output_bytes", r.output_bytes},
                        {"manifest_gzip_bytes", r.manifest_gzip_bytes},
                        {"viewer_bytes", r.viewer_bytes},
                        {"viewer_files", r.viewer_files},
                        {"parts", r.parts},
                        {"prototypes", r.prototypes},
                        {"components", r.components},
                        {"files", r.files},
                        {"instances", r.instances},
                        {"triangles_in", r.triangles_in},
                        {"triangles_out", r.triangles_out},
                        {"level_streams", r.level_streams},
                        {"level_triangles", r.level_triangles},
                        {"level_bytes", r.level_bytes},
                        {"first_bytes", r.first_bytes},
                        {"time_ms",
                         {{"read", r.timings.read_ms},
                          {"clean", r.timings.clean_ms},
                          {"repeats", r.timings.repeats_ms},
                          {"segment", r.timings.segment_ms},
                          {"levels", r.timings.levels_ms},
                          {"encode", r.timings.encode_ms},
                          {"write", r.timings.write_ms},
                          {"total", r.timings.total_ms}}}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "%s: %zu parts (%zu stored, %zu instanced) -> %zu components in %zu chunk files, "
        "%zu instances, %zu coarser levels; %llu -> %llu bytes (whole skeleton at its coarsest in "
        "the first %llu), %.1f ms\n",
        args.options.output.c_str(), r.parts, r.prototypes, r.parts - r.prototypes, r.components,
        r.files, r.instances, r.level_streams, static_cast<unsigned long long>(r.input_bytes),
        static_cast<unsigned long long>(r.output_bytes),
        static_cast<unsigned long long>(r.first_bytes), r.timings.total_ms);
  }
  return kExitOk;
}

}  // namespace

void register_pack(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<PackArgs>();
  // The help's defaults are PackOptions' own (args->options is not parsed yet).
  const PackOptions& defaults = args->options;
  const auto number = [](double value) {
    std::ostringstream text;
    text << value;
    return text.str();
  };
  CLI::App* cmd = app.add_subcommand(
      "pack", "Read, clean, find repeats, segment and encode parts into a package folder");
  cmd->add_option("inputs", args->inputs, "mesh files, folders of parts or label volumes (.nii, .nii.gz, .nrrd, .nhdr)")->required();
  cmd->add_option("-o,--output", args->options.output,
                  "package folder: absent, empty or a package, replaced whole when done")
      ->required();
  CLI::Option* bits = cmd->add_option("--bits", args->options.bits,
                                      "bits per coordinate over a part's size (8..24), instead of the default 0.05 mm")
                          ->check(CLI::Range(8, 24));
  CLI::Option* precision =
      cmd->add_option("--precision", args->options.precision,
                      "largest coordinate error in mesh units (default: 0.05 mm in the parts' unit)")
          ->check(CLI::PositiveNumber);
  bits->excludes(precision);
  cmd->add_option("--repeat-tolerance", args->options.repeat_tolerance,
                  "tolerance of a repeat in mesh units (default: the codec's bound)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--max-triangles", args->options.max_triangles,
                  "largest component in triangles (default " +
                      std::to_string(PackOptions::kPieceTrianglesWithLevels) +
                      " with levels of detail, " + std::to_string(PackOptions::kPieceTriangles) +
                      " with --no-lod; 0: never segment)");
  cmd->add_option("--lod-min-triangles", args->options.lod_min_triangles,
                  "components with more triangles get coarser levels of detail (default " +
                      std::to_string(defaults.lod_min_triangles) + "; 0: none)");
  CLI::Option* levels =
      cmd->add_option("--levels", args->options.levels,
                      "at most N levels of detail per component, full one included (default: as "
                      "many as a chain of quarters gives)")
          ->check(CLI::Range(1, 32));
  CLI::Option* share =
      cmd->add_option("--level-share", args->options.level_share,
                      "what a component's coarser levels may cost, besides its coarsest and the "
                      "one the whole view needs, as a share of its full level's bytes (default " +
                          number(defaults.level_share) + ")")
          ->check(CLI::NonNegativeNumber);
  CLI::Option* view =
      cmd->add_option("--lod-view-pixels", args->options.lod_view_pixels,
                      "a component also keeps its first level within one pixel of a view this "
                      "many pixels high showing the whole package (default " +
                          number(defaults.lod_view_pixels) + "; 0: the share alone)")
          ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-lod", args->no_lod, "no levels of detail: full resolution only")
      ->excludes(levels)
      ->excludes(share)
      ->excludes(view);
  cmd->add_option("--chunk-bytes", args->options.chunk_bytes,
                  "largest chunk file: streams are concatenated in stream order (default " +
                      std::to_string(defaults.chunk_bytes) + ")")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 40));
  cmd->add_option("--names", args->options.names,
                  "JSON or CSV mapping file stems to display names and groups");
  cmd->add_option("--regions", args->options.regions,
                  "Group parts the names file does not place: 'names' (by the words of their "
                  "names, as TotalSegmentator and Slicer name bones) or 'fma:DIR' (BodyParts3D's "
                  "ontology tables in DIR)");
  CLI::Option* viewer = cmd->add_option(
      "--viewer", args->options.viewer,
      "folder of viewer files to copy in (default: $OSTEON_VIEWER, else " OSTEON_VIEWER_DIR ")");
  cmd->add_flag("--no-viewer", args->no_viewer, "write the data only, no viewer files")
      ->excludes(viewer);
  cmd->add_flag("--no-repeats", args->no_repeats,
                "store every part's own components (no repeat search)");
  cmd->add_option("--threads", args->options.threads, "worker threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  add_volume_options(cmd, &args->options.read);
  cmd->add_flag("--json", args->json, "print a JSON summary");
  cmd->callback([args, run] { *run = [args] { return run_pack(*args); }; });
}

}  // namespace osteon::cli
