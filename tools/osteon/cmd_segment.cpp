// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/io.hpp"
#include "osteon/segment.hpp"

// osteon segment IN -o OUT.seg [--colored OUT.ply] [--phi F] [--segments K] [--max-triangles N]
//                  [--json]
// OUT.seg is the Princeton Segmentation Benchmark's format: one component id per line, one line per
// triangle, in the input's triangle order (a multi-part input: its parts' triangles in order).

namespace osteon::cli {

namespace {

struct SegmentArgs {
  std::string input;
  std::string output;
  std::string colored;
  SegmentOptions options;
  bool json = false;
};

/// A colour per component, spread around the hue circle by the golden angle.
void component_colour(uint32_t id, uint8_t rgb[3]) {
  const double hue = std::fmod(id * 0.618033988749895, 1.0) * 6;
  const double s = 0.65, v = 0.95;
  const int sector = static_cast<int>(hue);
  const double f = hue - sector;
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  const double table[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
  for (int k = 0; k < 3; ++k) rgb[k] = static_cast<uint8_t>(std::lround(255 * table[sector % 6][k]));
}

/// Binary little-endian PLY with a colour per face (MeshLab shows face colours).
std::vector<uint8_t> coloured_ply(const Mesh& mesh, const std::vector<uint32_t>& labels) {
  const std::string header = "ply\nformat binary_little_endian 1.0\ncomment osteon segment\n"
                             "element vertex " + std::to_string(mesh.positions.size()) +
                             "\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face " + std::to_string(mesh.triangle_count()) +
                             "\nproperty list uchar int vertex_indices\nproperty uchar red\n"
                             "property uchar green\nproperty uchar blue\nend_header\n";
  std::vector<uint8_t> out(header.begin(), header.end());
  auto put = [&out](const void* data, size_t size) {
    const auto* b = static_cast<const uint8_t*>(data);
    out.insert(out.end(), b, b + size);
  };
  for (const Vec3& p : mesh.positions) put(&p, sizeof p);
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const uint8_t three = 3;
    put(&three, 1);
    put(&mesh.indices[3 * t], 3 * sizeof(uint32_t));
    uint8_t rgb[3];
    component_colour(labels[t], rgb);
    put(rgb, 3);
  }
  return out;
}

int run_segment(const SegmentArgs& args) {
  Result<Scene> scene = read_path(args.input);
  if (!scene.ok()) return fail(scene.status());
  const size_t files_parts = scene->parts.size();
  Mesh mesh = merge_parts(std::move(scene.value()));
  if (mesh.source.empty()) mesh.source = args.input;
  const auto start = std::chrono::steady_clock::now();
  Result<Segmentation> result = segment(mesh, args.options);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!result.ok()) return fail(result.status());
  const Segmentation& seg = result.value();

  std::string text;
  text.reserve(seg.labels.size() * 3);
  for (uint32_t label : seg.labels) {
    text += std::to_string(label);
    text += '\n';
  }
  Status written = write_file_atomic(args.output, text.data(), text.size());
  if (!written.ok()) return fail(written);
  if (!args.colored.empty()) {
    const std::vector<uint8_t> ply = coloured_ply(mesh, seg.labels);
    written = write_file_atomic(args.colored, ply.data(), ply.size());
    if (!written.ok()) return fail(written);
  }
  std::vector<uint32_t> sizes(seg.count, 0);
  for (uint32_t label : seg.labels) ++sizes[label];
  const uint32_t largest = sizes.empty() ? 0 : *std::max_element(sizes.begin(), sizes.end());
  if (args.json) {
    nlohmann::json j = {{"input", args.input},
                        {"output", args.output},
                        {"triangles", seg.labels.size()},
                        {"input_parts", files_parts},
                        {"connected_parts", seg.parts},
                        {"components", seg.count},
                        {"largest_component", largest},
                        {"segment_ms", ms}};
    if (!args.colored.empty()) j["colored"] = args.colored;
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("%s: %zu triangles, %u connected parts -> %u components (largest %u triangles), "
                "%.1f ms\n",
                args.output.c_str(), seg.labels.size(), seg.parts, seg.count, largest, ms);
  }
  return kExitOk;
}

}  // namespace

void register_segment(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<SegmentArgs>();
  CLI::App* cmd = app.add_subcommand(
      "segment", "Split a mesh into components: connected parts, then Dijkstra region diffusion");
  cmd->add_option("input", args->input, "mesh file or folder of parts")->required();
  cmd->add_option("-o,--output", args->output, "segment ids, one per triangle (.seg)")->required();
  cmd->add_option("--colored", args->colored, "also write a PLY coloured by component");
  cmd->add_option("--phi", args->options.phi, "weight of the angular distance in GD (default 300)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--segments", args->options.segments,
                  "target number of components (default: as the creases call for)");
  cmd->add_option("--max-triangles", args->options.max_triangles,
                  "largest component wanted, in triangles (default: no limit)");
  cmd->add_option("--iterations", args->options.iterations,
                  "rounds of re-centring the regions (default 3)");
  cmd->add_flag("--json", args->json, "print a JSON summary");
  cmd->callback([args, run] { *run = [args] { return run_segment(*args); }; });
}

}  // namespace osteon::cli
