// SPDX-License-Identifier: Apache-2.0
#include "osteon/pack.hpp"

#include <openssl/evp.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include "geometry.hpp"
#include "osteon/codec.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/repeats.hpp"
#include "osteon/segment.hpp"

// Based on: FIPS 180-4 SHA-256 (through OpenSSL's EVP interface) for content-addressed file
// names, as static hosts and CDNs cache immutable hashed assets.

namespace osteon {

namespace {

using Clock = std::chrono::steady_clock;
using Matrix = std::array<double, 16>;
constexpr Matrix kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Lower-case hex SHA-256 of `bytes`.
std::string sha256_hex(const std::vector<uint8_t>& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr);
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < length; ++i) {
    out += kHex[digest[i] >> 4];
    out += kHex[digest[i] & 15];
  }
  return out;
}

/// The file stem of a part name or path: the last path component, without the extension and
/// without a "/node" suffix's parent. "bones/FJ43_x.glb" -> "FJ43_x".
std::string stem_of(const std::string& name) {
  std::string s = name;
  const size_t slash = s.find_last_of("/\\");
  if (slash != std::string::npos) s = s.substr(slash + 1);
  const size_t dot = s.find_last_of('.');
  if (dot != std::string::npos && dot > 0) s = s.substr(0, dot);
  return s;
}

struct DisplayName {
  std::string name;
  std::string group;
};

/// Splits one CSV line (fields may be double-quoted, "" an escaped quote).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

/// Reads a names file: a JSON array of objects {filename|file|name, label|display_name, group},
/// a JSON object {stem: "display name"} or {stem: {display_name|label, group}}, or a CSV of
/// stem,display_name[,group] lines (a first line starting with "file" or "stem" is a header).
Result<std::map<std::string, DisplayName>> read_names(const std::string& path) {
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(path));
  const std::string text(bytes.begin(), bytes.end());
  std::map<std::string, DisplayName> names;
  size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && (text[first] == '[' || text[first] == '{')) {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) return error(ErrorCode::kInvalidData, path, "not valid JSON");
    auto text_of = [](const nlohmann::json& o, std::initializer_list<const char*> keys) {
      for (const char* key : keys) {
        auto it = o.find(key);
        if (it != o.end() && it->is_string()) return it->get<std::string>();
      }
      return std::string();
    };
    if (j.is_array()) {
      for (const nlohmann::json& entry : j) {
        if (!entry.is_object()) continue;
        const std::string file = text_of(entry, {"filename", "file", "stem", "name"});
        if (file.empty()) continue;
        names[stem_of(file)] = {text_of(entry, {"label", "display_name", "name"}),
                                text_of(entry, {"group"})};
      }
    } else {
      for (auto it = j.begin(); it != j.end(); ++it) {
        if (it->is_string()) {
          names[stem_of(it.key())] = {it->get<std::string>(), {}};
        } else if (it->is_object()) {
          names[stem_of(it.key())] = {text_of(*it, {"display_name", "label", "name"}),
                                      text_of(*it, {"group"})};
        }
      }
    }
    return names;
  }
  std::istringstream lines(text);
  std::string line;
  bool first_line = true;
  while (std::getline(lines, line)) {
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> f = csv_fields(line);
    if (first_line) {
      first_line = false;
      if (f[0].rfind("file", 0) == 0 || f[0].rfind("stem", 0) == 0) continue;
    }
    if (f.size() < 2) return error(ErrorCode::kInvalidData, path, "a CSV line needs 2 fields");
    names[stem_of(f[0])] = {f[1], f.size() > 2 ? f[2] : std::string()};
  }
  return names;
}

/// The triangles of `mesh` labelled `label`, with only their vertices (in first-use order).
Mesh extract(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t label) {
  Mesh out;
  out.name = mesh.name;
  out.source = mesh.source;
  out.unit = mesh.unit;
  out.unit_source = mesh.unit_source;
  std::vector<uint32_t> remap(mesh.positions.size(), UINT32_MAX);
  for (size_t t = 0; t < labels.size(); ++t) {
    if (labels[t] != label) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + k];
      if (remap[v] == UINT32_MAX) {
        remap[v] = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(mesh.positions[v]);
      }
      out.indices.push_back(remap[v]);
    }
  }
  out.stored_vertices = out.positions.size();
  return out;
}

Vec3 apply(const Matrix& m, const Vec3& p) {
  return {static_cast<float>(m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12]),
          static_cast<float>(m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13]),
          static_cast<float>(m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14])};
}

/// The world box of `box` under `m` (its eight corners transformed).
Aabb transform_box(const Aabb& box, const Matrix& m) {
  Aabb out;
  for (int c = 0; c < 8; ++c) {
    const Vec3 p{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                 (c & 4) ? box.max.z : box.min.z};
    expand(out, apply(m, p));
  }
  return out;
}

/// The largest face area of a box: its projected area seen along the best axis.
double projected_area(const Aabb& box) {
  const double dx = box.max.x - box.min.x, dy = box.max.y - box.min.y, dz = box.max.z - box.min.z;
  return std::max({dx * dy, dy * dz, dx * dz});
}

/// gzip -9 of `text` with a zero timestamp, so the same manifest gives the same bytes.
Result<std::vector<uint8_t>> gzip_deterministic(const std::string& text, const std::string& name) {
  z_stream z{};
  if (deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) != Z_OK) {
    return error(ErrorCode::kIoError, name, "zlib could not start");
  }
  std::vector<uint8_t> out(deflateBound(&z, text.size()) + 64);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) return error(ErrorCode::kIoError, name, "zlib could not compress");
  return out;
}

/// `value` as the float nearest it, printed shortest: bounds and matrices are drawn in float, and
/// the manifest stays compact (12.3456, not 12.345600128173828).
double as_float(double value) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof(text), static_cast<float>(value));
  return ec == std::errc() ? std::strtod(std::string(text, end).c_str(), nullptr) : value;
}

/// A bound rounded up to a float: never below `value`.
double bound_up(double value) {
  float f = static_cast<float>(value);
  if (static_cast<double>(f) < value) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return as_float(f);
}

nlohmann::json vec_json(const Vec3& v) {
  return nlohmann::json::array({as_float(v.x), as_float(v.y), as_float(v.z)});
}
nlohmann::json matrix_json(const Matrix& m) {
  nlohmann::json out = nlohmann::json::array();
  for (double v : m) out.push_back(as_float(v));
  return out;
}
nlohmann::json box_json(const Aabb& box) {
  return {{"min", vec_json(box.min)}, {"max", vec_json(box.max)}};
}

struct Component {
  std::string id;
  std::string hash;  ///< SHA-256 of the stream (hex): equal streams are stored once
  std::vector<uint8_t> bytes;
  size_t chunk = 0;   ///< where the stream is stored: chunk index, byte offset in it
  size_t offset = 0;
  size_t triangles = 0;
  size_t vertices = 0;
  Aabb bounds;  ///< in the prototype's frame, of the input positions
  double error_bound = 0;
  double stream_area = 0;  ///< summed projected area of its instances' world boxes
};

struct Instance {
  size_t part = 0;
  size_t component = 0;
  Matrix matrix = kIdentity;
  bool mirror = false;
  double error_bound = 0;
};

/// The viewer's files: (path relative to `root`, bytes), sorted by path, so packages are
/// byte-identical whatever order the file system lists them in.
Result<std::vector<std::pair<std::string, std::vector<uint8_t>>>> read_viewer(
    const std::string& root) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    return error(ErrorCode::kIoError, root,
                 "the viewer folder does not exist (build it: cd web && npm ci && npm run "
                 "build:viewer)");
  }
  std::vector<std::pair<std::string, std::vector<uint8_t>>> files;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string relative = fs::relative(it->path(), root, ec).generic_string();
    if (relative == "manifest.json" || relative.rfind("c/", 0) == 0) {
      return error(ErrorCode::kInvalidArgument, it->path().string(),
                   "a viewer file may not be named manifest.json or live under c/ (the "
                   "package's own files)");
    }
    OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(it->path().string()));
    files.emplace_back(relative, std::move(bytes));
  }
  if (ec) return error(ErrorCode::kIoError, root, "cannot list the viewer folder: " + ec.message());
  if (files.empty()) return error(ErrorCode::kIoError, root, "the viewer folder is empty");
  std::sort(files.begin(), files.end());
  return files;
}

uint64_t file_size_or_zero(const std::string& path) {
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  return ec ? 0 : size;
}

}  // namespace

const char* stage_name(PackStage stage) {
  switch (stage) {
    case PackStage::kRead: return "read";
    case PackStage::kClean: return "clean";
    case PackStage::kRepeats: return "repeats";
    case PackStage::kSegment: return "segment";
    case PackStage::kEncode: return "encode";
    case PackStage::kWrite: return "write";
  }
  return "?";
}

const char* stage_unit(PackStage stage) {
  switch (stage) {
    case PackStage::kRead: return "inputs";
    case PackStage::kClean:
    case PackStage::kRepeats:
    case PackStage::kSegment: return "parts";
    case PackStage::kEncode: return "components";
    case PackStage::kWrite: return "files";
  }
  return "?";
}

Result<PackReport> pack(const std::vector<std::string>& inputs, const PackOptions& options) {
  const auto start_total = Clock::now();
  PackReport report;
  if (inputs.empty()) return error(ErrorCode::kInvalidArgument, "pack", "no input given");
  if (options.output.empty()) {
    return error(ErrorCode::kInvalidArgument, "pack", "no output folder given");
  }
  if (options.bits < 8 || options.bits > 24) {
    return error(ErrorCode::kInvalidArgument, "pack", "bits must be in 8..24");
  }
  if (options.chunk_bytes == 0) {
    return error(ErrorCode::kInvalidArgument, "pack", "chunk bytes must be at least 1");
  }
  if (!(options.precision >= 0) || !std::isfinite(options.precision) ||
      !(options.repeat_tolerance >= 0) || !std::isfinite(options.repeat_tolerance)) {
    return error(ErrorCode::kInvalidArgument, "pack",
                 "precision and repeat tolerance must be finite and >= 0");
  }
  auto progress = [&](PackStage stage, uint64_t done, uint64_t total) {
    if (options.progress) options.progress(stage, done, total);
  };
  // More threads than cores only makes TBB warn; the output does not depend on the count.
  tbb::task_arena arena(options.threads > 0
                            ? std::min(options.threads, tbb::info::default_concurrency())
                            : tbb::task_arena::automatic);

  // Read (and the viewer's files, so that a missing viewer fails before any work).
  auto stage = Clock::now();
  std::vector<std::pair<std::string, std::vector<uint8_t>>> viewer_files;
  if (!options.viewer.empty()) {
    OSTEON_ASSIGN_OR_RETURN(viewer_files, read_viewer(options.viewer));
  }
  std::map<std::string, DisplayName> names;
  if (!options.names.empty()) {
    OSTEON_ASSIGN_OR_RETURN(names, read_names(options.names));
  }
  std::vector<Mesh> parts;
  for (size_t i = 0; i < inputs.size(); ++i) {
    progress(PackStage::kRead, i, inputs.size());
    OSTEON_ASSIGN_OR_RETURN(Scene scene, read_path(inputs[i]));
    for (Mesh& part : scene.parts) {
      if (part.source.empty()) part.source = inputs[i];
      parts.push_back(std::move(part));
    }
  }
  progress(PackStage::kRead, inputs.size(), inputs.size());
  std::set<std::string> sources;
  for (const Mesh& part : parts) sources.insert(part.source);
  for (const std::string& source : sources) report.input_bytes += file_size_or_zero(source);
  report.timings.read_ms = ms_since(stage);

  // Clean: degenerate triangles and unreferenced vertices go; parts left empty are dropped.
  stage = Clock::now();
  std::vector<Mesh> kept;
  for (size_t i = 0; i < parts.size(); ++i) {
    progress(PackStage::kClean, i, parts.size());
    remove_degenerate_triangles(parts[i]);
    remove_unreferenced_vertices(parts[i]);
    if (parts[i].triangle_count() > 0) kept.push_back(std::move(parts[i]));
  }
  progress(PackStage::kClean, parts.size(), parts.size());
  parts = std::move(kept);
  if (parts.empty()) {
    return error(ErrorCode::kInvalidData, inputs.front(), "no part has triangles");
  }
  report.parts = parts.size();
  for (const Mesh& part : parts) report.triangles_in += part.triangle_count();
  report.timings.clean_ms = ms_since(stage);

  // Repeats, bone by bone: each member part is drawn as its prototype's components.
  stage = Clock::now();
  std::vector<size_t> prototype_of(parts.size());
  std::vector<Matrix> matrix_of(parts.size(), kIdentity);
  std::vector<bool> mirror_of(parts.size(), false);
  std::vector<double> repeat_error(parts.size(), 0.0);
  for (size_t i = 0; i < parts.size(); ++i) prototype_of[i] = i;
  if (options.repeats) {
    progress(PackStage::kRepeats, 0, parts.size());
    RepeatOptions repeat_options;
    repeat_options.tolerance = options.repeat_tolerance;
    repeat_options.bits = options.bits;
    repeat_options.precision = options.precision;
    repeat_options.threads = options.threads;
    OSTEON_ASSIGN_OR_RETURN(RepeatReport repeats, find_repeats(parts, repeat_options));
    for (const RepeatGroup& group : repeats.groups) {
      for (const RepeatMember& member : group.members) {
        prototype_of[member.part] = group.prototype;
        matrix_of[member.part] = member.matrix;
        mirror_of[member.part] = member.mirror;
        repeat_error[member.part] = member.tolerance;
      }
    }
  }
  progress(PackStage::kRepeats, parts.size(), parts.size());
  report.timings.repeats_ms = ms_since(stage);

  // Segment each prototype part larger than max_triangles into components (in parallel over
  // parts; each part's result lands in its own slot, so the output does not depend on timing).
  stage = Clock::now();
  std::vector<size_t> prototypes;
  for (size_t p = 0; p < parts.size(); ++p) {
    if (prototype_of[p] == p) prototypes.push_back(p);
  }
  report.prototypes = prototypes.size();
  std::vector<std::vector<Mesh>> pieces_of(parts.size());
  std::vector<Status> segment_status(parts.size());
  std::vector<size_t> to_segment;
  for (size_t p : prototypes) {
    if (options.max_triangles == 0 || parts[p].triangle_count() <= options.max_triangles) {
      pieces_of[p].push_back(parts[p]);
    } else {
      to_segment.push_back(p);
    }
  }
  progress(PackStage::kSegment, 0, to_segment.size());
  // Largest first, so the long ones start early; one part per task.
  std::stable_sort(to_segment.begin(), to_segment.end(), [&](size_t a, size_t b) {
    return parts[a].triangle_count() > parts[b].triangle_count();
  });
  arena.execute([&] {
    tbb::parallel_for(size_t(0), to_segment.size(), [&](size_t i) {
      const size_t p = to_segment[i];
      SegmentOptions segment_options;
      segment_options.max_triangles = options.max_triangles;
      Result<Segmentation> seg = segment(parts[p], segment_options);
      if (!seg.ok()) {
        segment_status[p] = seg.status();
        return;
      }
      for (uint32_t label = 0; label < seg.value().count; ++label) {
        Mesh piece = extract(parts[p], seg.value().labels, label);
        if (piece.triangle_count() > 0) pieces_of[p].push_back(std::move(piece));
      }
    });
  });
  for (size_t p : to_segment) OSTEON_RETURN_IF_ERROR(segment_status[p]);
  progress(PackStage::kSegment, to_segment.size(), to_segment.size());
  report.timings.segment_ms = ms_since(stage);

  // Encode every piece on its part's own grid (so the components of one part meet without
  // cracks), in parallel over pieces.
  stage = Clock::now();
  std::vector<Component> components;
  std::vector<std::vector<size_t>> components_of(parts.size());
  std::vector<std::pair<size_t, size_t>> jobs;  // (part, piece)
  for (size_t p : prototypes) {
    for (size_t k = 0; k < pieces_of[p].size(); ++k) {
      components_of[p].push_back(components.size());
      components.emplace_back();
      jobs.emplace_back(p, k);
    }
  }
  // Each part's grid, chosen once as the codec would for the whole part (--bits over its largest
  // side, or 2 * --precision), then shared by its pieces.
  std::vector<QuantizationGrid> grid_of(parts.size());
  for (size_t p : prototypes) {
    EncodeOptions part_options;
    part_options.bits = options.bits;
    part_options.precision = options.precision;
    Result<QuantizationGrid> grid = detail::choose_grid(parts[p].positions, part_options);
    if (!grid.ok()) return error(grid.status().code(), parts[p].source, grid.status().message());
    grid_of[p] = grid.value();
  }
  std::vector<Status> encode_status(jobs.size());
  progress(PackStage::kEncode, 0, jobs.size());
  arena.execute([&] {
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      const Mesh& piece = pieces_of[jobs[j].first][jobs[j].second];
      EncodeOptions encode_options;
      encode_options.grid = grid_of[jobs[j].first];
      EncodeReport encoded;
      Result<std::vector<uint8_t>> bytes = encode(piece, encode_options, &encoded);
      if (!bytes.ok()) {
        encode_status[j] = bytes.status();
        return;
      }
      Component& c = components[j];
      // Formatted, not concatenated: g++ 12 warns (-Wrestrict, a false positive) on string
      // appends here.
      char id[32];
      std::snprintf(id, sizeof(id), "c%zu", j);
      c.id = id;
      c.hash = sha256_hex(bytes.value());
      c.bytes = std::move(bytes.value());
      c.triangles = encoded.triangles;
      c.vertices = encoded.vertices;
      c.bounds = bounding_box(piece);
      // Every coordinate within half a step: the position within sqrt(3) / 2 steps.
      c.error_bound = std::sqrt(3.0) / 2 * encoded.grid_step;
    });
  });
  for (const Status& status : encode_status) OSTEON_RETURN_IF_ERROR(status);
  for (const Component& c : components) report.triangles_out += c.triangles;
  progress(PackStage::kEncode, jobs.size(), jobs.size());
  report.timings.encode_ms = ms_since(stage);

  // Instances: every part draws each of its prototype's components with its matrix.
  std::vector<Instance> instances;
  Aabb world;
  for (size_t p = 0; p < parts.size(); ++p) {
    expand(world, bounding_box(parts[p]));
    for (size_t c : components_of[prototype_of[p]]) {
      Instance instance;
      instance.part = p;
      instance.component = c;
      instance.matrix = matrix_of[p];
      instance.mirror = mirror_of[p];
      instance.error_bound = bound_up(components[c].error_bound + repeat_error[p]);
      components[c].stream_area +=
          projected_area(transform_box(components[c].bounds, instance.matrix));
      instances.push_back(instance);
    }
  }
  std::vector<size_t> stream(components.size());
  for (size_t i = 0; i < stream.size(); ++i) stream[i] = i;
  std::stable_sort(stream.begin(), stream.end(), [&](size_t a, size_t b) {
    return components[a].stream_area > components[b].stream_area;
  });

  // Chunks: the streams concatenated in stream order, each chunk at most chunk_bytes (a larger
  // stream gets one of its own), so the viewer makes a few requests, not one per component, and
  // reads each as a stream, decoding every component the moment its last byte arrives.
  struct Chunk {
    std::vector<uint8_t> bytes;
    std::string file;  ///< "c/<hash24>.ostc"
  };
  std::vector<Chunk> chunks;
  std::map<std::string, size_t> stored;  // stream hash -> component that holds its bytes
  for (size_t c : stream) {
    Component& component = components[c];
    auto first = stored.find(component.hash);
    if (first != stored.end()) {
      component.chunk = components[first->second].chunk;
      component.offset = components[first->second].offset;
      continue;
    }
    stored.emplace(component.hash, c);
    if (chunks.empty() ||
        (!chunks.back().bytes.empty() &&
         chunks.back().bytes.size() + component.bytes.size() > options.chunk_bytes)) {
      chunks.emplace_back();
    }
    component.chunk = chunks.size() - 1;
    component.offset = chunks.back().bytes.size();
    chunks.back().bytes.insert(chunks.back().bytes.end(), component.bytes.begin(),
                               component.bytes.end());
  }
  nlohmann::json chunks_json = nlohmann::json::array();
  for (Chunk& chunk : chunks) {
    chunk.file = "c/";
    chunk.file += sha256_hex(chunk.bytes).substr(0, 24);
    chunk.file += ".ostc";
    chunks_json.push_back({{"file", chunk.file}, {"bytes", chunk.bytes.size()}});
  }

  // The manifest.
  nlohmann::json manifest;
  manifest["format"] = "osteon-package";
  manifest["version"] = 2;
  manifest["chunks"] = std::move(chunks_json);
  manifest["unit"] = unit_name(parts.front().unit);
  manifest["bounds"] = box_json(world);
  nlohmann::json parts_json = nlohmann::json::array();
  for (size_t p = 0; p < parts.size(); ++p) {
    const std::string stem = stem_of(parts[p].name);
    auto named = names.find(stem);
    DisplayName display{parts[p].name, ""};
    if (named != names.end()) {
      if (!named->second.name.empty()) display.name = named->second.name;
      display.group = named->second.group;
    }
    parts_json.push_back({{"id", p},
                          {"name", parts[p].name},
                          {"display_name", display.name},
                          {"group", display.group},
                          {"source", std::filesystem::path(parts[p].source).filename().string()},
                          {"triangles", parts[p].triangle_count()},
                          {"prototype", prototype_of[p]}});
  }
  manifest["parts"] = std::move(parts_json);
  nlohmann::json components_json = nlohmann::json::array();
  for (const Component& c : components) {
    components_json.push_back({{"id", c.id},
                               {"chunk", c.chunk},
                               {"offset", c.offset},
                               {"bytes", c.bytes.size()},
                               {"triangles", c.triangles},
                               {"vertices", c.vertices},
                               {"bounds", box_json(c.bounds)},
                               {"error_bound", bound_up(c.error_bound)}});
  }
  manifest["components"] = std::move(components_json);
  nlohmann::json instances_json = nlohmann::json::array();
  for (const Instance& instance : instances) {
    instances_json.push_back({{"part", instance.part},
                              {"component", components[instance.component].id},
                              {"matrix", matrix_json(instance.matrix)},
                              {"mirror", instance.mirror},
                              {"error_bound", instance.error_bound}});
  }
  manifest["instances"] = std::move(instances_json);
  nlohmann::json order = nlohmann::json::array();
  for (size_t c : stream) order.push_back(components[c].id);
  manifest["stream_order"] = std::move(order);
  // Compact: the manifest is the first thing a viewer fetches (about 1 KB per part).
  const std::string manifest_text = manifest.dump() + "\n";

  // Write: the viewer's files, the chunk files, then the manifest.
  stage = Clock::now();
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(options.output) / "c", ec);
  if (ec) {
    return error(ErrorCode::kIoError, options.output, "cannot create the folder: " + ec.message());
  }
  const uint64_t file_count = viewer_files.size() + chunks.size() + 1;
  uint64_t files_done = 0;
  progress(PackStage::kWrite, 0, file_count);
  for (const auto& [relative, bytes] : viewer_files) {
    const std::filesystem::path path = std::filesystem::path(options.output) / relative;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) {
      return error(ErrorCode::kIoError, path.parent_path().string(),
                   "cannot create the folder: " + ec.message());
    }
    OSTEON_RETURN_IF_ERROR(write_file_atomic(path.string(), bytes.data(), bytes.size()));
    report.viewer_bytes += bytes.size();
    progress(PackStage::kWrite, ++files_done, file_count);
  }
  report.viewer_files = viewer_files.size();
  for (const Chunk& chunk : chunks) {
    progress(PackStage::kWrite, ++files_done, file_count);
    report.output_bytes += chunk.bytes.size();
    const std::string path = (std::filesystem::path(options.output) / chunk.file).string();
    OSTEON_RETURN_IF_ERROR(write_file_atomic(path, chunk.bytes.data(), chunk.bytes.size()));
  }
  report.manifest = (std::filesystem::path(options.output) / "manifest.json").string();
  // The manifest precompressed beside it (6x smaller): osteon serve, nginx's gzip_static and
  // most CDNs send it to browsers that accept gzip. Written before the manifest, which stays last.
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> manifest_gz,
                          gzip_deterministic(manifest_text, report.manifest + ".gz"));
  OSTEON_RETURN_IF_ERROR(
      write_file_atomic(report.manifest + ".gz", manifest_gz.data(), manifest_gz.size()));
  report.manifest_gzip_bytes = manifest_gz.size();
  OSTEON_RETURN_IF_ERROR(
      write_file_atomic(report.manifest, manifest_text.data(), manifest_text.size()));
  report.output_bytes += manifest_text.size();
  progress(PackStage::kWrite, file_count, file_count);
  report.timings.write_ms = ms_since(stage);

  report.components = components.size();
  report.files = chunks.size();
  report.instances = instances.size();
  report.timings.total_ms = ms_since(start_total);
  return report;
}

}  // namespace osteon
