// SPDX-License-Identifier: Apache-2.0
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/io.hpp"
#include "osteon/repeats.hpp"

// osteon repeats PATH... [--json] [--repeat-tolerance X] [--bits N | --precision E] [--split]

namespace osteon::cli {

namespace {

struct RepeatsArgs {
  std::vector<std::string> inputs;
  bool json = false;
  double tolerance = 0;
  int bits = 14;
  double precision = 0;
  bool split = false;
  bool rigid = false;
  int threads = 0;
};

nlohmann::json counters_json(const RepeatCounters& c) {
  return {{"components", c.components},
          {"skipped", c.skipped},
          {"pairs_total", c.pairs_total},
          {"pairs_considered", c.pairs_considered},
          {"pairs_descriptor", c.pairs_descriptor},
          {"pairs_aabb", c.pairs_aabb},
          {"pairs_phi_evaluated", c.pairs_phi_evaluated},
          {"pairs_phi", c.pairs_phi},
          {"pairs_verified", c.pairs_verified},
          {"pairs_accepted", c.pairs_accepted},
          {"rejected_hausdorff", c.rejected_hausdorff},
          {"pose_alternatives", c.pose_alternatives}};
}

int run_repeats(const RepeatsArgs& args) {
  std::vector<Mesh> components;
  for (const std::string& input : args.inputs) {
    Result<Scene> scene = read_path(input);
    if (!scene.ok()) return fail(scene.status());
    for (Mesh& part : scene->parts) {
      if (part.name.empty()) part.name = input;
      if (!args.split) {
        components.push_back(std::move(part));
        continue;
      }
      for (Mesh& piece : split_connected(part)) components.push_back(std::move(piece));
    }
  }
  RepeatOptions options;
  options.tolerance = args.tolerance;
  options.bits = args.bits;
  options.precision = args.precision;
  options.allow_scale = !args.rigid;
  options.threads = args.threads;
  Result<RepeatReport> found = find_repeats(components, options);
  if (!found.ok()) return fail(found.status());
  const RepeatReport& report = found.value();

  if (args.json) {
    nlohmann::json groups = nlohmann::json::array();
    for (const RepeatGroup& g : report.groups) {
      nlohmann::json members = nlohmann::json::array();
      for (const RepeatMember& m : g.members) {
        members.push_back({{"part", components[m.part].name},
                           {"index", m.part},
                           {"matrix", m.matrix},
                           {"mirror", m.mirror},
                           {"scale", m.scale},
                           {"hausdorff", m.hausdorff},
                           {"tolerance", m.tolerance},
                           {"phi", m.phi},
                           {"jaccard", m.jaccard},
                           {"triangles", components[m.part].triangle_count()}});
      }
      groups.push_back({{"prototype", components[g.prototype].name},
                        {"index", g.prototype},
                        {"triangles", components[g.prototype].triangle_count()},
                        {"members", std::move(members)}});
    }
    const RepeatTimings& t = report.timings;
    nlohmann::json j = {{"components", components.size()},
                        {"groups", std::move(groups)},
                        {"members", report.members},
                        {"triangles_saved", report.triangles_saved},
                        {"bytes_saved", report.bytes_saved},
                        {"largest_error", report.largest_error},
                        {"counters", counters_json(report.counters)},
                        {"timings_ms",
                         {{"pose", t.pose_ms},
                          {"candidates", t.candidates_ms},
                          {"phi", t.phi_ms},
                          {"verify", t.verify_ms},
                          {"total", t.total_ms}}}};
    std::cout << j.dump(2) << "\n";
    return kExitOk;
  }

  const RepeatCounters& c = report.counters;
  std::printf(
      "%zu components: %zu groups, %zu members drawn as instances; %llu triangles saved "
      "(about %llu bytes); largest error %.3g\n",
      components.size(), report.groups.size(), report.members,
      static_cast<unsigned long long>(report.triangles_saved),
      static_cast<unsigned long long>(report.bytes_saved), report.largest_error);
  for (const RepeatGroup& g : report.groups) {
    std::printf("%s (%zu triangles)\n", components[g.prototype].name.c_str(),
                components[g.prototype].triangle_count());
    for (const RepeatMember& m : g.members) {
      std::printf("  %-40s %-6s scale %.6g  hausdorff %.3g (tolerance %.3g)\n",
                  components[m.part].name.c_str(), m.mirror ? "mirror" : "", m.scale, m.hausdorff,
                  m.tolerance);
    }
  }
  std::printf(
      "pairs: %llu of %llu in neighbouring descriptor cells, %llu pass the descriptor, %llu the "
      "AABB, "
      "%llu of %llu Phi, %llu verified, %llu rejected by Hausdorff; %.0f ms\n",
      static_cast<unsigned long long>(c.pairs_considered),
      static_cast<unsigned long long>(c.pairs_total),
      static_cast<unsigned long long>(c.pairs_descriptor),
      static_cast<unsigned long long>(c.pairs_aabb), static_cast<unsigned long long>(c.pairs_phi),
      static_cast<unsigned long long>(c.pairs_phi_evaluated),
      static_cast<unsigned long long>(c.pairs_verified),
      static_cast<unsigned long long>(c.rejected_hausdorff), report.timings.total_ms);
  return kExitOk;
}

}  // namespace

void register_repeats(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<RepeatsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "repeats", "Find repeated components (moved, rotated, mirrored, scaled copies), verified");
  cmd->add_option("PATH", args->inputs, "Mesh files or folders; every part is a component")
      ->required();
  cmd->add_flag("--json", args->json, "Print a JSON report");
  cmd->add_option("--repeat-tolerance", args->tolerance,
                  "Largest substitution error accepted, in mesh units (default: the codec's "
                  "error bound at --bits or --precision)")
      ->check(CLI::PositiveNumber);
  auto* bits = cmd->add_option("--bits", args->bits,
                               "Position bits the tolerance follows, 8..24 (default 14)")
                   ->check(CLI::Range(8, 24));
  cmd->add_option("--precision", args->precision,
                  "Codec precision the tolerance follows, in mesh units (tolerance = sqrt(3) x it)")
      ->check(CLI::PositiveNumber)
      ->excludes(bits);
  cmd->add_flag("--split", args->split,
                "Split every part into its vertex-connected pieces (a file holding many bones)");
  cmd->add_flag("--rigid", args->rigid, "Do not accept copies of another size");
  cmd->add_option("--threads", args->threads, "Worker threads (default: every core)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([args, run] { *run = [args] { return run_repeats(*args); }; });
}

}  // namespace osteon::cli
