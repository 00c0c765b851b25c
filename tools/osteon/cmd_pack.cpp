// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/pack.hpp"

// osteon pack INPUT... -o DIR [--bits N | --precision E] [--repeat-tolerance X]
//             [--max-triangles N] [--names FILE] [--json]
// Runs the whole pipeline (read, clean, repeats, segment, encode) and writes the package that
// docs/FORMAT.md ("Package (osteon pack)") specifies. The viewer is not written yet.

namespace osteon::cli {

namespace {

struct PackArgs {
  std::vector<std::string> inputs;
  PackOptions options;
  bool json = false;
};

int run_pack(const PackArgs& args) {
  if (stderr_is_tty() && !args.json) std::fprintf(stderr, "osteon: packing ...\n");
  Result<PackReport> result = pack(args.inputs, args.options);
  if (!result.ok()) return fail(result.status());
  const PackReport& r = result.value();
  if (args.json) {
    nlohmann::json j = {{"output", args.options.output},
                        {"manifest", r.manifest},
                        {"input_bytes", r.input_bytes},
                        {"output_bytes", r.output_bytes},
                        {"parts", r.parts},
                        {"prototypes", r.prototypes},
                        {"components", r.components},
                        {"files", r.files},
                        {"instances", r.instances},
                        {"triangles_in", r.triangles_in},
                        {"triangles_out", r.triangles_out},
                        {"time_ms",
                         {{"read", r.timings.read_ms},
                          {"clean", r.timings.clean_ms},
                          {"repeats", r.timings.repeats_ms},
                          {"segment", r.timings.segment_ms},
                          {"encode", r.timings.encode_ms},
                          {"write", r.timings.write_ms},
                          {"total", r.timings.total_ms}}}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "%s: %zu parts (%zu stored, %zu instanced) -> %zu components in %zu files, "
        "%zu instances; %llu -> %llu bytes, %.1f ms\n",
        args.options.output.c_str(), r.parts, r.prototypes, r.parts - r.prototypes, r.components,
        r.files, r.instances, static_cast<unsigned long long>(r.input_bytes),
        static_cast<unsigned long long>(r.output_bytes), r.timings.total_ms);
  }
  return kExitOk;
}

}  // namespace

void register_pack(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<PackArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pack", "Read, clean, find repeats, segment and encode parts into a package folder");
  cmd->add_option("inputs", args->inputs, "mesh files or folders of parts")->required();
  cmd->add_option("-o,--output", args->options.output, "package folder")->required();
  CLI::Option* bits = cmd->add_option("--bits", args->options.bits,
                                      "bits per coordinate over a part's size (8..24, default 14)")
                          ->check(CLI::Range(8, 24));
  CLI::Option* precision =
      cmd->add_option("--precision", args->options.precision,
                      "largest coordinate error in mesh units (instead of --bits)")
          ->check(CLI::PositiveNumber);
  bits->excludes(precision);
  cmd->add_option("--repeat-tolerance", args->options.repeat_tolerance,
                  "tolerance of a repeat in mesh units (default: the codec's bound)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--max-triangles", args->options.max_triangles,
                  "largest component in triangles (default 20000; 0: never segment)");
  cmd->add_option("--names", args->options.names,
                  "JSON or CSV mapping file stems to display names and groups");
  cmd->add_flag("--json", args->json, "print a JSON summary");
  cmd->callback([args, run] { *run = [args] { return run_pack(*args); }; });
}

}  // namespace osteon::cli
