// SPDX-License-Identifier: Apache-2.0
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <tiny_gltf.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_markdown.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"
#include "osteon/repeats.hpp"

// Repeated components on the real data: every substitution osteon's find_repeats makes
// on the MyoSim meshes (the single-part files, then every file split into its connected pieces)
// and on the BodyParts3D bones (at the default tolerance and at 0.5 mm), listed by name so that a
// wrong one can be seen; what gltfpack -mi (npm gltfpack, bench/package.json) instances on the
// same parts; and the time for 10,000 generated components.

#ifndef OSTEON_SHARED_DATA_DIR
#define OSTEON_SHARED_DATA_DIR "../shared/data"
#endif

namespace {

namespace fs = std::filesystem;
using osteon_bench::fixed;
using osteon_bench::grouped;
using osteon_bench::sig;
using Clock = std::chrono::steady_clock;
using osteon::Mesh;
using osteon::RepeatOptions;
using osteon::RepeatReport;




double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool strip_prefix(std::string& s, const std::string& prefix) {
  if (s.rfind(prefix, 0) != 0) return false;
  s = s.substr(prefix.size());
  return true;
}

bool strip_suffix(std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size() || s.compare(s.size() - suffix.size(), suffix.size(), suffix) != 0) {
    return false;
  }
  s.resize(s.size() - suffix.size());
  return true;
}

// A MyoSim file name without the marks of side and model ("arm_r_", "ground_", "_lvs", ...): two
// parts that are the same bone have the same key.
std::string myosim_key(const std::string& name) {
  std::string s = lower(name);
  const size_t hash = s.find('#');
  std::string piece;
  if (hash != std::string::npos) {
    piece = s.substr(hash);
    s.resize(hash);
  }
  for (const char* p : {"arm_r_", "hand_", "ground_r_", "ground_", "hat_", "l_", "r_"}) {
    if (strip_prefix(s, p)) break;
  }
  for (const char* x : {"_lvs", "_rvs", "_lv", "_rv"}) {
    if (strip_suffix(s, x)) break;
  }
  return s + piece;
}

// A BodyParts3D label without "Left"/"Right" ("Left fifth rib" -> "fifth rib").
std::string side_free_label(const std::string& label) {
  std::istringstream words(lower(label));
  std::string word, out;
  while (words >> word) {
    if (word == "left" || word == "right") continue;
    out += (out.empty() ? "" : " ") + word;
  }
  return out;
}

struct Run {
  std::string label;
  RepeatReport report;
  double seconds = 0;
  uint64_t triangles = 0;  // of all components
  bool ok = false;
  std::string error;
};

Run run_repeats(const std::string& label, const std::vector<Mesh>& parts,
                const RepeatOptions& options) {
  Run run;
  run.label = label;
  for (const Mesh& m : parts) run.triangles += m.triangle_count();
  std::fprintf(stderr, "repeats_bench: %s (%zu components) ...\n", label.c_str(), parts.size());
  const auto start = Clock::now();
  osteon::Result<RepeatReport> r = osteon::find_repeats(parts, options);
  run.seconds = seconds_since(start);
  if (!r.ok()) {
    run.error = r.status().message();
    std::fprintf(stderr, "repeats_bench: %s: %s\n", label.c_str(), run.error.c_str());
    return run;
  }
  run.report = std::move(r).value();
  run.ok = true;
  return run;
}

std::string summary_header() {
  return "| run | components | triangles | groups | members | mirrored | triangles saved | bytes "
         "saved (est.) | largest error | largest error / tolerance | pairs: neighbouring cells / "
         "descriptor "
         "/ AABB / Phi (of evaluated) / verified / rejected | time s |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n";
}

std::string summary_row(const Run& run) {
  if (!run.ok) return "| " + run.label + " | fails: " + run.error + " |\n";
  const RepeatReport& r = run.report;
  const osteon::RepeatCounters& c = r.counters;
  size_t mirrored = 0;
  double worst_ratio = 0;
  for (const osteon::RepeatGroup& g : r.groups) {
    for (const osteon::RepeatMember& m : g.members) {
      mirrored += m.mirror ? 1 : 0;
      if (m.tolerance > 0) worst_ratio = std::max(worst_ratio, m.hausdorff / m.tolerance);
    }
  }
  std::ostringstream out;
  out << "| " << run.label << " | " << grouped(c.components) << " | " << grouped(run.triangles)
      << " | " << r.groups.size() << " | " << r.members << " | " << mirrored << " | "
      << grouped(r.triangles_saved) << " ("
      << fixed(run.triangles ? 100.0 * double(r.triangles_saved) / double(run.triangles) : 0.0, 1)
      << "%) | " << grouped(r.bytes_saved) << " | " << sig(r.largest_error, 3) << " | "
      << fixed(worst_ratio, 2) << " | " << grouped(c.pairs_considered) << " / "
      << grouped(c.pairs_descriptor) << " / " << grouped(c.pairs_aabb) << " / "
      << grouped(c.pairs_phi) << " (" << grouped(c.pairs_phi_evaluated) << ") / "
      << grouped(c.pairs_verified) << " / " << grouped(c.rejected_hausdorff) << " | "
      << fixed(run.seconds, 2) << " |\n";
  return out.str();
}

// Every substitution of a run, one row each; `same_bone` says whether the names pair up.
template <class SameBone>
std::string listing(const Run& run, const std::vector<Mesh>& parts,
                    const std::vector<std::string>& names, SameBone same_bone, size_t* odd) {
  std::ostringstream out;
  out << "| member | drawn from (prototype) | mirror | scale | Hausdorff | tolerance | names |\n"
         "|---|---|:-:|---:|---:|---:|---|\n";
  *odd = 0;
  for (const osteon::RepeatGroup& g : run.report.groups) {
    for (const osteon::RepeatMember& m : g.members) {
      const bool same = same_bone(m.part, g.prototype);
      if (!same) ++*odd;
      out << "| " << names[m.part] << " | " << names[g.prototype] << " | "
          << (m.mirror ? "yes" : "") << " | " << fixed(m.scale, 6) << " | " << sig(m.hausdorff, 3)
          << " | " << sig(m.tolerance, 3) << " | " << (same ? "pair" : "**differ**") << " |\n";
    }
  }
  (void)parts;
  return out.str();
}

// The substitutions of a run of pieces ("file#k"), counted by the files of member and prototype.
std::string by_file(const Run& run, const std::vector<std::string>& names) {
  struct Tally {
    size_t count = 0, mirrored = 0;
    double largest = 0;
  };
  std::map<std::pair<std::string, std::string>, Tally> tally;
  auto file_of = [](const std::string& name) { return name.substr(0, name.find('#')); };
  for (const osteon::RepeatGroup& g : run.report.groups) {
    for (const osteon::RepeatMember& m : g.members) {
      Tally& t = tally[{file_of(names[m.part]), file_of(names[g.prototype])}];
      ++t.count;
      t.mirrored += m.mirror ? 1 : 0;
      t.largest = std::max(t.largest, m.hausdorff);
    }
  }
  std::ostringstream out;
  out << "| member's file | prototype's file | substitutions | mirrored | largest Hausdorff |\n"
         "|---|---|---:|---:|---:|\n";
  for (const auto& [files, t] : tally) {
    out << "| " << files.first << " | " << files.second << " | " << t.count << " | " << t.mirrored
        << " | " << sig(t.largest, 3) << " |\n";
  }
  return out.str();
}

std::string details(const std::string& summary, const std::string& body) {
  return "<details><summary>" + summary + "</summary>\n\n" + body + "\n</details>\n";
}

// ---- gltfpack -mi ------------------------------------------------------------------------

// Writes `parts` as one GLB: a mesh (positions and indices) and a named node for each part.
bool write_glb(const std::vector<Mesh>& parts, const std::string& path) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "osteon repeats_bench";
  tinygltf::Buffer buffer;
  tinygltf::Scene scene;
  for (const Mesh& part : parts) {
    auto append = [&](const void* data, size_t bytes) {
      while (buffer.data.size() % 4 != 0) buffer.data.push_back(0);
      const size_t offset = buffer.data.size();
      const auto* p = static_cast<const unsigned char*>(data);
      buffer.data.insert(buffer.data.end(), p, p + bytes);
      return offset;
    };
    tinygltf::BufferView positions_view;
    positions_view.buffer = 0;
    positions_view.byteOffset = append(part.positions.data(), part.positions.size() * 12);
    positions_view.byteLength = part.positions.size() * 12;
    positions_view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
    tinygltf::BufferView indices_view;
    indices_view.buffer = 0;
    indices_view.byteOffset = append(part.indices.data(), part.indices.size() * 4);
    indices_view.byteLength = part.indices.size() * 4;
    indices_view.target = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
    const int first_view = int(model.bufferViews.size());
    model.bufferViews.push_back(positions_view);
    model.bufferViews.push_back(indices_view);

    tinygltf::Accessor positions;
    positions.bufferView = first_view;
    positions.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    positions.type = TINYGLTF_TYPE_VEC3;
    positions.count = part.positions.size();
    const osteon::Aabb box = osteon::bounding_box(part);
    positions.minValues = {box.min.x, box.min.y, box.min.z};
    positions.maxValues = {box.max.x, box.max.y, box.max.z};
    tinygltf::Accessor indices;
    indices.bufferView = first_view + 1;
    indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    indices.type = TINYGLTF_TYPE_SCALAR;
    indices.count = part.indices.size();
    const int first_accessor = int(model.accessors.size());
    model.accessors.push_back(positions);
    model.accessors.push_back(indices);

    tinygltf::Primitive primitive;
    primitive.attributes["POSITION"] = first_accessor;
    primitive.indices = first_accessor + 1;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh mesh;
    mesh.name = part.name;
    mesh.primitives.push_back(primitive);
    model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = part.name;
    node.mesh = int(model.meshes.size()) - 1;
    scene.nodes.push_back(int(model.nodes.size()));
    model.nodes.push_back(node);
  }
  model.buffers.push_back(std::move(buffer));
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  tinygltf::TinyGLTF writer;
  return writer.WriteGltfSceneToFile(&model, path, true, true, false, true);
}

struct GltfpackResult {
  bool ok = false;
  std::string note;
  size_t meshes = 0;              // meshes in the output
  size_t instanced_nodes = 0;     // nodes with EXT_mesh_gpu_instancing
  size_t instances = 0;           // instances those nodes draw
  size_t shared_meshes = 0;       // meshes drawn more than once (instancing or several nodes)
  uint64_t triangles_stored = 0;  // each mesh once
  uint64_t triangles_drawn = 0;   // each mesh times its instances
  double seconds = 0;
};

// Runs `node cli.js -i in.glb -o out.glb -kn -mi` (-kn keeps every named node, so parts are not
// merged into one mesh) and counts what the output instances.
GltfpackResult run_gltfpack(const std::vector<Mesh>& parts, const fs::path& cli,
                            const fs::path& scratch, const std::string& stem) {
  GltfpackResult out;
  if (!fs::exists(cli)) {
    out.note = "npm gltfpack not installed (cd bench && npm ci)";
    return out;
  }
  const fs::path in = scratch / (stem + ".glb"), result = scratch / (stem + "_packed.glb");
  if (!write_glb(parts, in.string())) {
    out.note = "could not write " + in.string();
    return out;
  }
  const std::string command = "node '" + cli.string() + "' -i '" + in.string() + "' -o '" +
                              result.string() + "' -kn -mi > '" +
                              (scratch / "gltfpack.log").string() + "' 2>&1";
  const auto start = Clock::now();
  const int status = std::system(command.c_str());
  out.seconds = seconds_since(start);
  if (status != 0) {
    out.note = "gltfpack failed (see " + (scratch / "gltfpack.log").string() + ")";
    return out;
  }
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  if (!loader.LoadBinaryFromFile(&model, &err, &warn, result.string())) {
    out.note = "cannot read gltfpack's output: " + err;
    return out;
  }
  std::vector<size_t> uses(model.meshes.size(), 0);
  for (const tinygltf::Node& node : model.nodes) {
    if (node.mesh < 0) continue;
    size_t count = 1;
    auto ext = node.extensions.find("EXT_mesh_gpu_instancing");
    if (ext != node.extensions.end() && ext->second.Has("attributes")) {
      const tinygltf::Value& attributes = ext->second.Get("attributes");
      for (const std::string& key : attributes.Keys()) {
        const int accessor = attributes.Get(key).GetNumberAsInt();
        if (accessor >= 0 && size_t(accessor) < model.accessors.size()) {
          count = model.accessors[size_t(accessor)].count;
          break;
        }
      }
      ++out.instanced_nodes;
      out.instances += count;
    }
    uses[size_t(node.mesh)] += count;
  }
  for (size_t m = 0; m < model.meshes.size(); ++m) {
    uint64_t triangles = 0;
    for (const tinygltf::Primitive& p : model.meshes[m].primitives) {
      if (p.indices >= 0) triangles += model.accessors[size_t(p.indices)].count / 3;
    }
    out.triangles_stored += triangles;
    out.triangles_drawn += triangles * uses[m];
    if (uses[m] > 1) ++out.shared_meshes;
  }
  out.meshes = model.meshes.size();
  out.ok = true;
  return out;
}

std::string gltfpack_row(const std::string& label, const std::vector<Mesh>& parts,
                         const GltfpackResult& g, const Run& osteon_run) {
  uint64_t triangles = 0;
  for (const Mesh& m : parts) triangles += m.triangle_count();
  std::ostringstream out;
  out << "| " << label << " | " << parts.size() << " | ";
  if (!g.ok) {
    out << "n/a: " << g.note << " | | | | " << osteon_run.report.members << " |\n";
    return out.str();
  }
  const uint64_t saved = triangles > g.triangles_stored ? triangles - g.triangles_stored : 0;
  out << g.meshes << " | " << g.shared_meshes << " (" << g.instanced_nodes << " instancing nodes, "
      << g.instances << " instances) | " << grouped(saved) << " | " << fixed(g.seconds, 2) << " | "
      << osteon_run.report.members << " (" << grouped(osteon_run.report.triangles_saved)
      << " triangles) |\n";
  return out.str();
}

// ---- 10,000 components -----------------------------------------------------------------------

using Matrix = std::array<double, 16>;

Matrix compose(const Matrix& a, const Matrix& b) {  // a * b
  return osteon::multiply(a, b);
}

// A uniformly random rotation (from a random unit quaternion).
Matrix random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  double q[4], len = 0;
  for (double& x : q) {
    x = n(rng);
    len += x * x;
  }
  len = std::sqrt(len);
  for (double& x : q) x /= len;
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  Matrix m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[size_t(4 * j + i)] = r[i][j];
  }
  return m;
}

struct ScaleResult {
  size_t components = 0, shapes = 0, copies = 0;
  uint64_t triangles = 0;
  Run run;
  size_t copies_found = 0;  // copies in a group with their shape
  size_t wrong = 0;         // members whose shape differs from their prototype's
};

// `count` components: half distinct shapes (the phantom's bones, each stretched by its own random
// factors along randomly turned axes), half copies of them moved, turned, mirrored (a third) or
// scaled (a quarter).
ScaleResult scale_run(size_t count) {
  osteon::PhantomOptions po;
  po.detail = 1;
  const osteon::Phantom phantom = osteon::make_phantom(po);
  std::vector<const Mesh*> bones;
  for (size_t i = 0; i < phantom.scene.parts.size(); ++i) {
    if (phantom.truth[i].copy_of.empty()) bones.push_back(&phantom.scene.parts[i]);
  }
  ScaleResult out;
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> stretch(0.6, 1.6), unit(0, 1);
  std::vector<Mesh> components;
  std::vector<size_t> shape_of;
  const size_t shapes = count / 2;
  for (size_t k = 0; k < shapes; ++k) {
    const Matrix turn = random_rotation(rng);
    Matrix back = turn;  // the inverse rotation: the transpose
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) back[size_t(4 * j + i)] = turn[size_t(4 * i + j)];
    }
    Matrix s{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    s[0] = stretch(rng);
    s[5] = stretch(rng);
    s[10] = stretch(rng);
    Mesh m = osteon::transform_mesh(*bones[k % bones.size()], compose(back, compose(s, turn)));
    m.name = "shape" + std::to_string(k);
    components.push_back(std::move(m));
    shape_of.push_back(k);
  }
  for (size_t k = shapes; k < count; ++k) {
    const size_t shape = size_t(rng() % shapes);
    Matrix m = random_rotation(rng);
    m[12] = 1000 * unit(rng);
    m[13] = 1000 * unit(rng);
    m[14] = 1000 * unit(rng);
    if (k % 3 == 0) {
      Matrix mirror{-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
      m = compose(m, mirror);
    }
    if (k % 4 == 0) {
      Matrix grow{1.5, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, 1};
      m = compose(m, grow);
    }
    Mesh c = osteon::transform_mesh(components[shape], m);
    c.name = "copy" + std::to_string(k) + "_of_shape" + std::to_string(shape);
    components.push_back(std::move(c));
    shape_of.push_back(shape);
  }
  out.components = components.size();
  out.shapes = shapes;
  out.copies = count - shapes;
  for (const Mesh& m : components) out.triangles += m.triangle_count();
  out.run = run_repeats(grouped(count) + " generated components", components, {});
  if (!out.run.ok) return out;
  std::vector<size_t> group_of(components.size(), SIZE_MAX);
  for (const osteon::RepeatGroup& g : out.run.report.groups) {
    group_of[g.prototype] = g.prototype;
    for (const osteon::RepeatMember& m : g.members) {
      group_of[m.part] = g.prototype;
      if (shape_of[m.part] != shape_of[g.prototype]) ++out.wrong;
    }
  }
  for (size_t k = shapes; k < count; ++k) {
    const size_t original = shape_of[k];
    if (group_of[k] != SIZE_MAX && group_of[k] == group_of[original]) ++out.copies_found;
  }
  return out;
}

// ---- the data --------------------------------------------------------------------------------

// Reads one mesh file as its parts (names: the file stem; "stem#k" for pieces when splitting).
std::vector<Mesh> read_parts(const fs::path& file, bool split) {
  osteon::Result<osteon::Scene> scene = osteon::read_path(file.string());
  std::vector<Mesh> out;
  if (!scene.ok()) {
    std::fprintf(stderr, "repeats_bench: %s\n", scene.status().message().c_str());
    return out;
  }
  for (Mesh& part : scene->parts) {
    if (part.name.empty()) part.name = file.stem().string();
    if (!split) {
      out.push_back(std::move(part));
      continue;
    }
    for (Mesh& piece : osteon::split_connected(part)) out.push_back(std::move(piece));
  }
  return out;
}

std::vector<fs::path> files_in(const fs::path& dir, const std::string& extension) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && lower(entry.path().extension().string()) == extension) {
      out.push_back(entry.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Pairs of parts with the same vertex and triangle counts whose vertex lists (in file order) are
// one similarity apart: every triangle edge and every chord from vertex i to vertex i + V/2 keeps
// its length times one scale, within `within`. Exact copies by an oracle that shares nothing with
// find_repeats (it needs the copy to keep its vertex order, which MyoSim's do).
std::vector<std::pair<size_t, size_t>> exact_copies_by_vertex_list(const std::vector<Mesh>& parts,
                                                                   double within) {
  auto length = [](const osteon::Vec3& a, const osteon::Vec3& b) {
    const double x = double(a.x) - b.x, y = double(a.y) - b.y, z = double(a.z) - b.z;
    return std::sqrt(x * x + y * y + z * z);
  };
  std::vector<std::pair<size_t, size_t>> out;
  for (size_t a = 0; a < parts.size(); ++a) {
    for (size_t b = a + 1; b < parts.size(); ++b) {
      const Mesh& p = parts[a];
      const Mesh& q = parts[b];
      const size_t v = p.vertex_count();
      if (v < 3 || v != q.vertex_count() || p.triangle_count() != q.triangle_count()) continue;
      std::vector<std::pair<uint32_t, uint32_t>> chords;
      for (size_t i = 0; i < p.indices.size(); ++i) {
        chords.push_back({p.indices[i], p.indices[i - i % 3 + (i + 1) % 3]});
      }
      for (uint32_t i = 0; i < v; ++i) chords.push_back({i, uint32_t((i + v / 2) % v)});
      double sum_p = 0, sum_q = 0;
      for (auto [i, j] : chords) {
        sum_p += length(p.positions[i], p.positions[j]);
        sum_q += length(q.positions[i], q.positions[j]);
      }
      if (!(sum_p > 0)) continue;
      const double scale = sum_q / sum_p;
      bool same = true;
      for (auto [i, j] : chords) {
        if (std::fabs(length(q.positions[i], q.positions[j]) -
                      scale * length(p.positions[i], p.positions[j])) > within) {
          same = false;
          break;
        }
      }
      if (same) out.push_back({a, b});
    }
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Repeated components: osteon's find_repeats on MyoSim and BodyParts3D, gltfpack -mi "
      "on the same parts, and 10,000 generated components"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  std::string gltfpack_cli;
  size_t scale_components = 10000;
  bool skip_gltfpack = false;
  app.add_option("--data", data, "The shared data folder (default ../shared/data)");
  app.add_option("--write", write_path, "Replace the section in this Markdown file");
  app.add_option("--gltfpack", gltfpack_cli,
                 "gltfpack's cli.js (default: bench/node_modules/gltfpack/cli.js beside this "
                 "source tree)");
  app.add_option("--components", scale_components, "Generated components for the timing run");
  app.add_flag("--no-gltfpack", skip_gltfpack, "Do not run gltfpack");
  CLI11_PARSE(app, argc, argv);
  if (gltfpack_cli.empty()) {
    gltfpack_cli = (fs::path(__FILE__).parent_path() / "node_modules/gltfpack/cli.js").string();
  }
  const fs::path scratch =
      fs::temp_directory_path() / ("osteon_repeats_bench_" + std::to_string(getpid()));
  fs::create_directories(scratch);

  std::ostringstream summary, lists, notes, peers;
  summary << summary_header();

  // ---- MyoSim ----
  const fs::path myosim = fs::path(data) / "MyoHub__myo_sim/meshes";
  const std::vector<fs::path> stl = files_in(myosim, ".stl");
  std::vector<Mesh> myo_parts, myo_pieces;
  for (const fs::path& f : stl) {
    for (Mesh& m : read_parts(f, false)) myo_parts.push_back(std::move(m));
    for (Mesh& m : read_parts(f, true)) myo_pieces.push_back(std::move(m));
  }
  Run myo, myo_split, bp_default, bp_half;
  std::vector<Mesh> bp_parts;
  std::vector<std::string> bp_names;
  if (myo_parts.empty()) {
    notes << "- MyoSim: " << myosim.string() << " is absent: skipped.\n";
  } else {
    std::vector<std::string> names, piece_names;
    for (const Mesh& m : myo_parts) names.push_back(m.name);
    for (const Mesh& m : myo_pieces) piece_names.push_back(m.name);
    myo = run_repeats("MyoSim, " + std::to_string(myo_parts.size()) + " files", myo_parts, {});
    myo_split = run_repeats("MyoSim, every file split into connected pieces", myo_pieces, {});
    summary << summary_row(myo) << summary_row(myo_split);
    auto same_myo = [&](const std::vector<std::string>& n) {
      return [&n](size_t a, size_t b) { return myosim_key(n[a]) == myosim_key(n[b]); };
    };
    size_t odd = 0, odd_split = 0;
    const std::string myo_list = listing(myo, myo_parts, names, same_myo(names), &odd);
    const std::string split_list =
        listing(myo_split, myo_pieces, piece_names, same_myo(piece_names), &odd_split);
    // The oracle: exact copies that kept their vertex order, found pair by pair.
    const auto oracle = exact_copies_by_vertex_list(myo_parts, 4e-6);
    std::map<size_t, size_t> group_of;
    for (const osteon::RepeatGroup& g : myo.report.groups) {
      group_of[g.prototype] = g.prototype;
      for (const osteon::RepeatMember& m : g.members) group_of[m.part] = g.prototype;
    }
    size_t together = 0;
    std::string missed;
    for (auto [a, b] : oracle) {
      if (group_of.count(a) && group_of.count(b) && group_of[a] == group_of[b]) {
        ++together;
      } else {
        missed += " " + names[a] + "/" + names[b];
      }
    }
    std::string differing;
    for (const osteon::RepeatGroup& g : myo.report.groups) {
      for (const osteon::RepeatMember& m : g.members) {
        if (myosim_key(names[m.part]) == myosim_key(names[g.prototype])) continue;
        differing += std::string(differing.empty() ? "" : ", ") + "`" + names[m.part] + "` from `" +
                     names[g.prototype] + "` (scale " + fixed(m.scale, 4) + ", " +
                     sig(m.hausdorff * 1e6, 2) + " µm)";
      }
    }
    notes << "- MyoSim, files: " << myo.report.members << " substitutions, " << odd
          << " whose names do not pair up"
          << (differing.empty() ? std::string()
                                : ": " + differing +
                                      ": meshes not named for one bone, copies of one "
                                      "another at another scale")
          << ". Exact copies that kept "
             "their vertex order (an independent check: pairs with equal vertex and triangle "
             "counts whose edges and long chords all keep their lengths, times one scale, within "
             "4 µm): "
          << oracle.size() << ", of which " << together << " are in one group in the full run"
          << (missed.empty() ? "" : " (missed:" + missed + ")") << ".\n";
    double largest_split = 0;
    for (const osteon::RepeatGroup& g : myo_split.report.groups) {
      for (const osteon::RepeatMember& m : g.members) {
        largest_split = std::max(largest_split, m.hausdorff);
      }
    }
    notes << "- MyoSim, pieces: " << myo_split.report.members << " substitutions among "
          << myo_pieces.size() << " pieces, " << odd_split
          << " between pieces whose names do not say they are one bone: pieces of a file are "
             "numbered, not named, and several files hold the same bones under other names "
             "(`hat_spine` is `hat_cervical` + `hat_thoracic` + `hat_lumbar`, `thorax`'s ribs are "
             "`hat_ribs_scap`'s, a foot's toes repeat one phalanx); see the table by file. Every "
             "one is within "
          << sig(largest_split * 1e6, 2)
          << " µm, the precision the files were written with: the same shape, whatever the "
             "name.\n";
    lists << details(
                 "MyoSim, files: every substitution (" + std::to_string(myo.report.members) + ")",
                 myo_list)
          << "\n"
          << details("MyoSim, pieces: substitutions by file (" +
                         std::to_string(myo_split.report.members) + ")",
                     by_file(myo_split, piece_names))
          << "\n"
          << details("MyoSim, pieces: every substitution (" +
                         std::to_string(myo_split.report.members) + ")",
                     split_list)
          << "\n";
  }

  // ---- BodyParts3D ----
  const fs::path bodyparts = fs::path(data) / "aHer-dev__3DAnatomy";
  std::map<std::string, std::string> labels;  // file name -> label
  {
    std::ifstream in(bodyparts / "meta.json");
    if (in) {
      const nlohmann::json meta = nlohmann::json::parse(in, nullptr, false);
      if (meta.is_array()) {
        for (const auto& e : meta) {
          if (e.contains("filename") && e.contains("label")) {
            labels[fs::path(e["filename"].get<std::string>()).filename().string()] =
                e["label"].get<std::string>();
          }
        }
      }
    }
  }
  for (const fs::path& f : files_in(bodyparts / "models/bones", ".glb")) {
    std::vector<Mesh> parts = read_parts(f, false);
    for (Mesh& m : parts) {
      const auto label = labels.find(f.filename().string());
      bp_names.push_back(label != labels.end() ? label->second : m.name);
      bp_parts.push_back(std::move(m));
    }
  }
  if (bp_parts.empty()) {
    notes << "- BodyParts3D: " << bodyparts.string() << " is absent: skipped.\n";
  } else {
    RepeatOptions half;
    half.tolerance = 0.5;
    bp_default =
        run_repeats("BodyParts3D, " + std::to_string(bp_parts.size()) + " bones, default tolerance",
                    bp_parts, {});
    bp_half = run_repeats("BodyParts3D, 0.5 mm", bp_parts, half);
    summary << summary_row(bp_default) << summary_row(bp_half);
    auto same_bp = [&](size_t a, size_t b) {
      return side_free_label(bp_names[a]) == side_free_label(bp_names[b]);
    };
    size_t odd_default = 0, odd_half = 0;
    const std::string default_list = listing(bp_default, bp_parts, bp_names, same_bp, &odd_default);
    const std::string half_list = listing(bp_half, bp_parts, bp_names, same_bp, &odd_half);
    // Every left/right pair by label: where each stops, measured on the pair alone with an
    // unbounded tolerance (so the distance is reported whatever it is).
    std::map<std::string, std::vector<size_t>> by_label;
    for (size_t i = 0; i < bp_parts.size(); ++i) {
      const std::string l = lower(bp_names[i]);
      if (l.find("left") != std::string::npos || l.find("right") != std::string::npos) {
        by_label[side_free_label(bp_names[i])].push_back(i);
      }
    }
    size_t pairs = 0, at_descriptor = 0, at_aabb = 0, at_phi = 0, measured = 0;
    std::vector<double> distances;
    std::vector<double> relative;  // distance / the bone's largest side
    for (const auto& [label, members] : by_label) {
      if (members.size() != 2) continue;
      ++pairs;
      RepeatOptions o;
      o.tolerance = 1e9;
      osteon::Result<RepeatReport> r =
          osteon::find_repeats({bp_parts[members[0]], bp_parts[members[1]]}, o);
      if (!r.ok()) continue;
      const osteon::RepeatCounters& c = r->counters;
      if (c.pairs_descriptor == 0) {
        ++at_descriptor;
      } else if (c.pairs_aabb == 0) {
        ++at_aabb;
      } else if (c.pairs_phi == 0) {
        ++at_phi;
      } else if (r->members == 1) {
        ++measured;
        distances.push_back(r->largest_error);
      }
    }
    std::sort(distances.begin(), distances.end());
    auto count_below = [&](double d) {
      return size_t(std::upper_bound(distances.begin(), distances.end(), d) - distances.begin());
    };
    notes << "- BodyParts3D: " << pairs
          << " left/right pairs by label. Each pair on its own, tolerance unbounded: "
          << at_descriptor << " stop at the pose descriptor, " << at_aabb << " at the AABB, "
          << at_phi << " at Phi/Jaccard; " << measured
          << " are measured after ICP: symmetric Hausdorff "
          << (distances.empty() ? std::string("-")
                                : "median " + sig(distances[distances.size() / 2], 3) + " mm")
          << "; " << count_below(0.25) << " within 0.25 mm, " << count_below(0.5)
          << " within 0.5 mm, " << count_below(1.0) << " within 1 mm, " << count_below(2.0)
          << " within 2 mm. Substitutions whose labels do not pair up: " << odd_default
          << " at the default tolerance, " << odd_half << " at 0.5 mm.\n";
    lists << details("BodyParts3D, default tolerance: every substitution (" +
                         std::to_string(bp_default.report.members) + ")",
                     default_list)
          << "\n"
          << details("BodyParts3D, 0.5 mm: every substitution (" +
                         std::to_string(bp_half.report.members) + ")",
                     half_list)
          << "\n";
  }

  // ---- gltfpack -mi on the same parts ----
  std::string gltfpack_version = "not run";
  if (!skip_gltfpack) {
    peers << "| parts | components | gltfpack meshes out | meshes drawn more than once | "
             "triangles saved | gltfpack s | osteon members (triangles saved) |\n"
             "|---|---:|---:|---|---:|---:|---|\n";
    if (!myo_parts.empty()) {
      peers << gltfpack_row("MyoSim files", myo_parts,
                            run_gltfpack(myo_parts, gltfpack_cli, scratch, "myosim"), myo);
      // The control: one part twice, byte for byte (what gltfpack can instance).
      std::vector<Mesh> control = myo_parts;
      control.push_back(myo_parts.front());
      control.back().name += "_duplicate";
      Run control_run = run_repeats("control", control, {});
      peers << gltfpack_row(
          "MyoSim files + a byte-identical duplicate of " + myo_parts.front().name + " (control)",
          control, run_gltfpack(control, gltfpack_cli, scratch, "control"), control_run);
    }
    if (!bp_parts.empty()) {
      peers << gltfpack_row("BodyParts3D bones", bp_parts,
                            run_gltfpack(bp_parts, gltfpack_cli, scratch, "bodyparts"), bp_default);
    }
    const std::string v = "node '" + gltfpack_cli + "' -v 2>/dev/null";
    if (FILE* p = popen(v.c_str(), "r")) {
      char buf[128] = {0};
      if (fgets(buf, sizeof(buf), p) != nullptr) {
        gltfpack_version = buf;
        while (!gltfpack_version.empty() &&
               std::isspace(static_cast<unsigned char>(gltfpack_version.back()))) {
          gltfpack_version.pop_back();
        }
      }
      pclose(p);
    }
  }

  // ---- scale ----
  ScaleResult scale;
  if (scale_components > 1) {
    scale = scale_run(scale_components);
    summary << summary_row(scale.run);
    notes << "- Generated: " << grouped(scale.components) << " components ("
          << grouped(scale.shapes) << " distinct shapes: the phantom's 10 bones at detail 1, each "
          << "stretched by its own random factors 0.6-1.6 along randomly turned axes; "
          << grouped(scale.copies)
          << " copies of them, randomly turned and moved, a third mirrored, a quarter scaled "
             "1.5x), "
          << grouped(scale.triangles) << " triangles: " << grouped(scale.copies_found) << " of "
          << grouped(scale.copies) << " copies found with their shape, " << scale.wrong
          << " members of another shape; " << fixed(scale.run.seconds, 1) << " s ("
          << "pose and voxels " << fixed(scale.run.report.timings.pose_ms / 1000, 1)
          << " s, candidates " << fixed(scale.run.report.timings.candidates_ms / 1000, 2)
          << " s, Phi " << fixed(scale.run.report.timings.phi_ms / 1000, 1) << " s, verification "
          << fixed(scale.run.report.timings.verify_ms / 1000, 1) << " s).\n";
  }
  fs::remove_all(scratch);

  std::ostringstream tables;
  tables << summary.str() << "\n" << notes.str();
  if (!skip_gltfpack) {
    tables
        << "\ngltfpack (" << gltfpack_version
        << ", `-kn -mi`) on the same parts, written as one GLB (a mesh and a named node each):\n\n"
        << peers.str();
  }
  std::printf("%s\n%s", tables.str().c_str(), lists.str().c_str());

  if (!write_path.empty()) {
    char date[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%d", std::gmtime(&now));
    std::string command = "build-bench/repeats_bench";
    if (scale_components != 10000) command += " --components " + std::to_string(scale_components);
    if (skip_gltfpack) command += " --no-gltfpack";
    command += " --write " + write_path;
    std::ostringstream body;
    body << "osteon's `find_repeats` (include/osteon/repeats.hpp; the steps in docs/DESIGN.md, "
            "\"Repeated components\") at its defaults: a substitution is accepted when the "
            "symmetric Hausdorff distance between the transformed prototype and the member is "
            "within the codec's error bound at 14 bits for the member (half a grid step times "
            "sqrt(3), the step the member's largest side / 16383), or within the rounding of the "
            "stored coordinates where that is larger (MyoSim's are printed to 1 µm), or within "
            "0.5 mm where the row says so. Parts are read with `read_path` (MyoSim in metres, "
            "BodyParts3D in millimetres); \"pieces\" splits every file into its vertex-connected "
            "components (`split_connected`). Bytes saved are estimated at 1.6 bytes a triangle "
            "less 64 bytes a matrix. The names column says whether the member's and the "
            "prototype's names are one bone (MyoSim: the file name without `arm_r_`, `ground_`, "
            "`hat_`, `l_`/`r_`, `_lvs`/`_rvs`, ...; BodyParts3D: the meta.json label without "
            "Left/Right). Largest error / tolerance is the largest ratio over the members. "
            "Times are wall clock, one run, on a shared machine. See bench/README.md.\n\n"
         << "Machine: " << osteon_bench::cpu_model() << ", " << sysconf(_SC_NPROCESSORS_ONLN)
         << " cores (shared). Date: " << date << ". Commands (from the repository root):\n\n"
         << "```\n(cd bench && npm ci)   # gltfpack, pinned in bench/package-lock.json\n"
            "cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release "
            "-DOSTEON_BUILD_BENCH=ON -DOSTEON_BUILD_TESTS=OFF\n"
            "cmake --build build-bench --target repeats_bench\n"
         << command << "\n```\n\n"
         << tables.str() << "\n"
         << lists.str();
    if (!osteon_bench::write_section(write_path, "## Repeated components", body.str())) {
      std::fprintf(stderr, "repeats_bench: cannot write %s\n", write_path.c_str());
      return 1;
    }
  }
  return 0;
}
