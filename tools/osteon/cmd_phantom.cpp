// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

// osteon phantom -o DIR: writes the generated test skeleton, one file per part, and truth.json.

namespace osteon::cli {

namespace {

struct PhantomArgs {
  std::string out_dir;
  uint64_t seed = 1;
  int detail = 3;
  std::string format = "stl";
};

const char* kind_name(PhantomKind kind) {
  switch (kind) {
    case PhantomKind::kOriginal:
      return "original";
    case PhantomKind::kExactCopy:
      return "exact_copy";
    case PhantomKind::kRotatedCopy:
      return "rotated_copy";
    case PhantomKind::kMirroredCopy:
      return "mirrored_copy";
    case PhantomKind::kNoisyCopy:
      return "noisy_copy";
    case PhantomKind::kWithHoles:
      return "with_holes";
    case PhantomKind::kGenusOne:
      return "genus_one";
    case PhantomKind::kNonManifold:
      return "nonmanifold";
  }
  return "unknown";
}

int run_phantom(const PhantomArgs& args) {
  if (args.format != "stl" && args.format != "ply" && args.format != "obj") {
    return fail("--format must be stl, ply or obj, not '" + args.format + "'");
  }
  if (args.detail < 1 || args.detail > 6) return fail("--detail must be between 1 and 6");
  std::error_code ec;
  std::filesystem::create_directories(args.out_dir, ec);
  if (ec) return fail(args.out_dir + ": cannot create the folder: " + ec.message());

  PhantomOptions options;
  options.seed = args.seed;
  options.detail = args.detail;
  Phantom phantom = make_phantom(options);
  nlohmann::json truth = {{"generator", "osteon phantom"},
                          {"seed", args.seed},
                          {"detail", args.detail},
                          {"unit", "mm"},
                          {"parts", nlohmann::json::array()}};
  size_t triangles = 0;
  for (size_t i = 0; i < phantom.scene.parts.size(); ++i) {
    const Mesh& mesh = phantom.scene.parts[i];
    const PhantomPart& part = phantom.truth[i];
    std::string file = part.name + "." + args.format;
    Status status = write_mesh((std::filesystem::path(args.out_dir) / file).string(), mesh);
    if (!status.ok()) return fail(status);
    triangles += mesh.triangle_count();
    truth["parts"].push_back({{"name", part.name},
                              {"file", file},
                              {"kind", kind_name(part.kind)},
                              {"copy_of", part.copy_of},
                              {"matrix", part.transform},
                              {"noise", part.noise},
                              {"triangles", mesh.triangle_count()},
                              {"boundary_loops", part.boundary_loops},
                              {"genus", part.genus},
                              {"nonmanifold_edges", part.nonmanifold_edges}});
  }
  std::string text = truth.dump(2) + "\n";
  Status status = write_file_atomic((std::filesystem::path(args.out_dir) / "truth.json").string(),
                                    text.data(), text.size());
  if (!status.ok()) return fail(status);
  std::printf("wrote %zu parts (%zu triangles) and truth.json to %s\n", phantom.scene.parts.size(),
              triangles, args.out_dir.c_str());
  return kExitOk;
}

}  // namespace

void register_phantom(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<PhantomArgs>();
  CLI::App* cmd = app.add_subcommand(
      "phantom", "Write a generated test skeleton with known truth (copies, mirrors, holes, ...)");
  cmd->add_option("-o,--output", args->out_dir, "Folder to write the parts and truth.json into")
      ->required();
  cmd->add_option("--seed", args->seed, "Random seed (same seed, same bytes)");
  cmd->add_option("--detail", args->detail,
                  "Subdivision level 1..6 (3: a few thousand triangles "
                  "a bone)");
  cmd->add_option("--format", args->format, "File format of the parts: stl, ply or obj");
  cmd->callback([args, run] { *run = [args] { return run_phantom(*args); }; });
}

}  // namespace osteon::cli
