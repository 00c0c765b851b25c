// SPDX-License-Identifier: Apache-2.0
// A package as one glTF 2.0 file (docs/FORMAT.md "glTF export"; the what and why in
// docs/DESIGN.md "glTF export").
//
// Based on: the glTF 2.0 specification (node hierarchy, TRS, a node whose world matrix has a
// negative determinant flips the winding; GLB container), and the Khronos registry's
// KHR_mesh_quantization (integer positions, int8 normalised normals), EXT_mesh_gpu_instancing
// (per-instance TRANSLATION / ROTATION / SCALE applied before the node's own transform) and
// EXT_meshopt_compression (compressed views over a fallback buffer without data; the ATTRIBUTES
// and TRIANGLES modes, the OCTAHEDRAL filter) specifications, the way gltfpack writes them: the
// dequantisation (grid origin and step) folded into the node or instance transform.
//
// How, per package:
//   1. every component is decoded (full resolution) and its grid read from its stream header, so
//      each decoded vertex's integer grid coordinates are recovered exactly;
//   2. each part is its prototype's component list drawn under one matrix; parts with the same
//      component list share one glTF mesh (one primitive per component), on the components'
//      common grid (16-bit, relative to the mesh's smallest grid point) or, when they have none,
//      in float;
//   3. a mesh drawn by one part is that part's node; one drawn by several is an instancing node
//      per handedness: mirrored instances go under a node that mirrors (scale -1, 1, 1), so that
//      every instance transform keeps a positive determinant (engines, three.js among them,
//      cannot flip the winding per instance; they do flip it for a node);
//   4. vertex and index buffers reordered for the vertex cache and fetch (meshoptimizer), then
//      encoded with meshoptimizer's codecs.

#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/export.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/vec.hpp"

namespace osteon {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr const char* kMeshopt = "EXT_meshopt_compression";
constexpr const char* kQuantization = "KHR_mesh_quantization";
constexpr const char* kInstancing = "EXT_mesh_gpu_instancing";
/// Largest grid span a 16-bit integer position holds.
constexpr int64_t kMaxSpan = 65535;
/// A matrix counts as a similarity when A^T A is s^2 I to this relative tolerance (the
/// manifest's matrices are rounded to float).
constexpr double kSimilarityTolerance = 1e-5;
constexpr int kNormalBits = 8;

constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125, kByte = 5120;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// ---- transforms --------------------------------------------------------------------------------

/// A glTF TRS: translation, rotation quaternion (x, y, z, w), scale.
struct Trs {
  std::array<double, 3> t{0, 0, 0};
  std::array<double, 4> r{0, 0, 0, 1};
  std::array<double, 3> s{1, 1, 1};
};

/// T * R * S as a column-major matrix (the glTF reader's formula).
Mat4 compose(const Trs& trs) {
  const auto [x, y, z, w] = trs.r;
  const auto [sx, sy, sz] = trs.s;
  Mat4 m = {(1 - 2 * (y * y + z * z)) * sx,
            (2 * (x * y + z * w)) * sx,
            (2 * (x * z - y * w)) * sx,
            0,
            (2 * (x * y - z * w)) * sy,
            (1 - 2 * (x * x + z * z)) * sy,
            (2 * (y * z + x * w)) * sy,
            0,
            (2 * (x * z + y * w)) * sz,
            (2 * (y * z - x * w)) * sz,
            (1 - 2 * (x * x + y * y)) * sz,
            0,
            trs.t[0],
            trs.t[1],
            trs.t[2],
            1};
  return m;
}

/// True when the linear part of `m` is a uniform scale times a rotation or a reflection.
bool is_similarity(const Mat4& m) {
  double g[3][3];
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      g[a][b] = m[4 * a] * m[4 * b] + m[4 * a + 1] * m[4 * b + 1] + m[4 * a + 2] * m[4 * b + 2];
    }
  }
  const double s2 = (g[0][0] + g[1][1] + g[2][2]) / 3;
  if (!(s2 > 0) || !std::isfinite(s2)) return false;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      if (std::abs(g[a][b] - (a == b ? s2 : 0.0)) > kSimilarityTolerance * s2) return false;
    }
  }
  return m[3] == 0 && m[7] == 0 && m[11] == 0 && m[15] == 1;
}

/// The TRS of a similarity (is_similarity): scale (+-s, s, s), a mirror taken on x.
Trs decompose(const Mat4& m) {
  Trs out;
  out.t = {m[12], m[13], m[14]};
  const double det = determinant3(m);
  const double s = std::cbrt(std::abs(det));
  const double sx = det < 0 ? -s : s;
  out.s = {sx, s, s};
  // R = A * diag(1/sx, 1/s, 1/s); r[row][col].
  double r[3][3];
  for (int c = 0; c < 3; ++c) {
    const double k = c == 0 ? 1 / sx : 1 / s;
    for (int row = 0; row < 3; ++row) r[row][c] = m[4 * c + row] * k;
  }
  // Shepperd's method: the largest of w, x, y, z first, for stability.
  const double trace = r[0][0] + r[1][1] + r[2][2];
  double x, y, z, w;
  if (trace > 0) {
    const double q = std::sqrt(trace + 1) * 2;
    w = q / 4, x = (r[2][1] - r[1][2]) / q, y = (r[0][2] - r[2][0]) / q,
    z = (r[1][0] - r[0][1]) / q;
  } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
    const double q = std::sqrt(1 + r[0][0] - r[1][1] - r[2][2]) * 2;
    w = (r[2][1] - r[1][2]) / q, x = q / 4, y = (r[0][1] + r[1][0]) / q,
    z = (r[0][2] + r[2][0]) / q;
  } else if (r[1][1] > r[2][2]) {
    const double q = std::sqrt(1 + r[1][1] - r[0][0] - r[2][2]) * 2;
    w = (r[0][2] - r[2][0]) / q, x = (r[0][1] + r[1][0]) / q, y = q / 4,
    z = (r[1][2] + r[2][1]) / q;
  } else {
    const double q = std::sqrt(1 + r[2][2] - r[0][0] - r[1][1]) * 2;
    w = (r[1][0] - r[0][1]) / q, x = (r[0][2] + r[2][0]) / q, y = (r[1][2] + r[2][1]) / q,
    z = q / 4;
  }
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  if (w < 0) x = -x, y = -y, z = -z, w = -w;
  out.r = {x / n, y / n, z / n, w / n};
  return out;
}

json trs_json(const Trs& trs, json node) {
  if (trs.t != std::array<double, 3>{0, 0, 0}) node["translation"] = trs.t;
  if (trs.r != std::array<double, 4>{0, 0, 0, 1}) node["rotation"] = trs.r;
  if (trs.s != std::array<double, 3>{1, 1, 1}) node["scale"] = trs.s;
  return node;
}

const Mat4 kMirrorX = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// ---- the package, decoded and grouped -------------------------------------------------------

struct Component {
  Mesh mesh;
  QuantizationGrid grid;
};

/// How one part is drawn: its components (indices into the manifest's) under one matrix, or,
/// when its instances disagree on the matrix or it is not a similarity, baked.
struct PartDraw {
  std::vector<size_t> components;
  Mat4 matrix = kIdentityMatrix;
  bool baked = false;
  std::vector<Mat4> baked_matrices;  ///< per component, when baked
  double error_bound = 0;
};

/// One glTF mesh: components, the parts that draw it, its dequantisation.
struct MeshPlan {
  std::vector<size_t> components;
  std::vector<size_t> parts;
  bool quantized = false;
  Vec3d offset{0, 0, 0};  ///< world of integer 0 in the mesh frame
  double step = 1;
  std::array<int64_t, 3> q_min{0, 0, 0};
  std::array<int64_t, 3> q_max{0, 0, 0};
  std::vector<Mat4> baked;  ///< per component (a baked part's mesh); empty otherwise
};

/// The dequantisation matrix: mesh integers -> the prototype's frame.
Mat4 dequantization(const MeshPlan& mesh) {
  if (!mesh.quantized) return kIdentityMatrix;
  const double s = mesh.step;
  return {s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, mesh.offset.x, mesh.offset.y, mesh.offset.z, 1};
}

int64_t grid_coordinate(float p, float origin, double step) {
  return std::llround((double(p) - double(origin)) / step);
}

/// Chooses integer positions for a mesh when every component is on one grid whose span fits.
void plan_quantization(const std::vector<Component>& decoded, MeshPlan* mesh) {
  const QuantizationGrid& g = decoded[mesh->components.front()].grid;
  std::array<int64_t, 3> lo{std::numeric_limits<int64_t>::max(),
                            std::numeric_limits<int64_t>::max(),
                            std::numeric_limits<int64_t>::max()};
  std::array<int64_t, 3> hi{std::numeric_limits<int64_t>::min(),
                            std::numeric_limits<int64_t>::min(),
                            std::numeric_limits<int64_t>::min()};
  for (size_t c : mesh->components) {
    const QuantizationGrid& h = decoded[c].grid;
    if (!(h.origin == g.origin) || h.step != g.step) return;
    for (const Vec3& p : decoded[c].mesh.positions) {
      const int64_t q[3] = {grid_coordinate(p.x, g.origin.x, g.step),
                            grid_coordinate(p.y, g.origin.y, g.step),
                            grid_coordinate(p.z, g.origin.z, g.step)};
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], q[a]), hi[a] = std::max(hi[a], q[a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (hi[a] - lo[a] > kMaxSpan) return;
  }
  mesh->quantized = true;
  mesh->step = g.step;
  mesh->q_min = lo;
  mesh->q_max = hi;
  mesh->offset = {double(g.origin.x) + double(lo[0]) * g.step,
                  double(g.origin.y) + double(lo[1]) * g.step,
                  double(g.origin.z) + double(lo[2]) * g.step};
}

// ---- buffers -------------------------------------------------------------------------------

/// The binary buffer and its views: compressed views in buffer 0 over a fallback buffer 1 (no
/// data), or plain views in buffer 0.
class Buffers {
 public:
  explicit Buffers(bool compress) : compress_(compress) {}

  /// A vertex (ATTRIBUTES) or index (TRIANGLES) view; `raw` is what a decoder restores,
  /// `filtered` what the codec encodes (equal without a filter).
  int add(const std::vector<uint8_t>& raw, const std::vector<uint8_t>& filtered, size_t count,
          size_t stride, bool indices, const char* filter, json* views) {
    json view;
    if (!compress_) {
      view = {{"buffer", 0}, {"byteOffset", append(raw)}, {"byteLength", raw.size()}};
    } else {
      std::vector<uint8_t> encoded;
      if (indices) {
        encoded.resize(meshopt_encodeIndexBufferBound(count, count));
        if (stride == 2) {
          encoded.resize(meshopt_encodeIndexBuffer(encoded.data(), encoded.size(),
                                                   reinterpret_cast<const uint16_t*>(raw.data()),
                                                   count));
        } else {
          encoded.resize(meshopt_encodeIndexBuffer(encoded.data(), encoded.size(),
                                                   reinterpret_cast<const uint32_t*>(raw.data()),
                                                   count));
        }
      } else {
        encoded.resize(meshopt_encodeVertexBufferBound(count, stride));
        encoded.resize(meshopt_encodeVertexBuffer(encoded.data(), encoded.size(), filtered.data(),
                                                  count, stride));
      }
      json ext = {{"buffer", 0},
                  {"byteOffset", append(encoded)},
                  {"byteLength", encoded.size()},
                  {"byteStride", stride},
                  {"count", count},
                  {"mode", indices ? "TRIANGLES" : "ATTRIBUTES"}};
      if (std::strcmp(filter, "NONE") != 0) ext["filter"] = filter;
      view = {{"buffer", 1},
              {"byteOffset", fallback_bytes_},
              {"byteLength", raw.size()},
              {"extensions", {{kMeshopt, ext}}}};
      fallback_bytes_ += (raw.size() + 3) / 4 * 4;
    }
    if (!indices) view["byteStride"] = stride;
    view["target"] = indices ? kElementArrayBuffer : kArrayBuffer;
    views->push_back(std::move(view));
    return int(views->size() - 1);
  }

  /// A plain view in buffer 0 (instance transforms: small, and read by the CPU).
  int add_plain(const std::vector<uint8_t>& raw, json* views) {
    views->push_back({{"buffer", 0}, {"byteOffset", append(raw)}, {"byteLength", raw.size()}});
    return int(views->size() - 1);
  }

  std::vector<uint8_t>& bin() { return bin_; }
  uint64_t fallback_bytes() const { return fallback_bytes_; }

 private:
  size_t append(const std::vector<uint8_t>& bytes) {
    const size_t at = bin_.size();
    bin_.insert(bin_.end(), bytes.begin(), bytes.end());
    while (bin_.size() % 4 != 0) bin_.push_back(0);
    return at;
  }

  bool compress_;
  std::vector<uint8_t> bin_;
  uint64_t fallback_bytes_ = 0;
};

template <class T>
std::vector<uint8_t> bytes_of(const std::vector<T>& values) {
  std::vector<uint8_t> out(values.size() * sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), values.data(), out.size());
  return out;
}

/// A primitive's accessors: POSITION, NORMAL (-1: none), indices.
struct PrimitiveAccessors {
  int position = -1;
  int normal = -1;
  int indices = -1;
};

/// Writes a mesh's vertices and triangles (reordered for the vertex cache and fetch) as
/// accessors: positions as 16-bit integers on `grid` relative to the mesh's smallest grid point
/// when the mesh is quantised, else float.
PrimitiveAccessors write_primitive(const Mesh& m, const MeshPlan& mesh,
                                   const QuantizationGrid& grid, const ExportOptions& options,
                                   Buffers* buffers, json* doc) {
  const size_t vertex_count = m.positions.size();
  const size_t index_count = m.indices.size();
  std::vector<uint32_t> indices(index_count);
  meshopt_optimizeVertexCache(indices.data(), m.indices.data(), index_count, vertex_count);
  std::vector<uint32_t> remap(vertex_count);
  const size_t used =
      meshopt_optimizeVertexFetchRemap(remap.data(), indices.data(), index_count, vertex_count);
  meshopt_remapIndexBuffer(indices.data(), indices.data(), index_count, remap.data());
  std::vector<Vec3> positions(used), normals(m.normals.empty() ? 0 : used);
  for (size_t v = 0; v < vertex_count; ++v) {
    if (remap[v] == ~0u) continue;
    positions[remap[v]] = m.positions[v];
    if (!normals.empty()) normals[remap[v]] = m.normals[v];
  }

  json& accessors = (*doc)["accessors"];
  json& views = (*doc)["bufferViews"];
  PrimitiveAccessors out;
  if (mesh.quantized) {
    std::vector<uint16_t> q(4 * used, 0);
    std::array<int64_t, 3> lo{kMaxSpan, kMaxSpan, kMaxSpan}, hi{0, 0, 0};
    for (size_t v = 0; v < used; ++v) {
      const int64_t c[3] = {grid_coordinate(positions[v].x, grid.origin.x, grid.step),
                            grid_coordinate(positions[v].y, grid.origin.y, grid.step),
                            grid_coordinate(positions[v].z, grid.origin.z, grid.step)};
      for (int a = 0; a < 3; ++a) {
        const int64_t value = c[a] - mesh.q_min[a];
        q[4 * v + a] = uint16_t(value);
        lo[a] = std::min(lo[a], value), hi[a] = std::max(hi[a], value);
      }
    }
    const std::vector<uint8_t> raw = bytes_of(q);
    const int view = buffers->add(raw, raw, used, 8, false, "NONE", &views);
    accessors.push_back({{"bufferView", view},
                         {"componentType", kUnsignedShort},
                         {"count", used},
                         {"type", "VEC3"},
                         {"min", lo},
                         {"max", hi}});
  } else {
    std::vector<float> f(3 * used);
    std::array<float, 3> lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                            std::numeric_limits<float>::max()};
    std::array<float, 3> hi{-lo[0], -lo[1], -lo[2]};
    for (size_t v = 0; v < used; ++v) {
      const float c[3] = {positions[v].x, positions[v].y, positions[v].z};
      for (int a = 0; a < 3; ++a) {
        f[3 * v + a] = c[a];
        lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
      }
    }
    const std::vector<uint8_t> raw = bytes_of(f);
    const int view = buffers->add(raw, raw, used, 12, false, "NONE", &views);
    accessors.push_back({{"bufferView", view},
                         {"componentType", kFloat},
                         {"count", used},
                         {"type", "VEC3"},
                         {"min", lo},
                         {"max", hi}});
  }
  out.position = int(accessors.size() - 1);

  if (options.normals && !normals.empty()) {
    // Unit vectors (a zero normal, from a vertex of zero-area fans, becomes +z).
    std::vector<float> unit(4 * used, 0.0f);
    for (size_t v = 0; v < used; ++v) {
      Vec3d n = to_double(normals[v]);
      n = squared_length(n) > 0 ? normalize(n) : Vec3d{0, 0, 1};
      unit[4 * v] = float(n.x), unit[4 * v + 1] = float(n.y), unit[4 * v + 2] = float(n.z);
    }
    std::vector<int8_t> snorm(4 * used, 0);
    std::vector<uint8_t> filtered;
    if (options.compress) {
      // The octahedral filter: what the decoder restores is its 8-bit xyz.
      filtered.resize(4 * used);
      meshopt_encodeFilterOct(filtered.data(), used, 4, kNormalBits, unit.data());
      std::vector<uint8_t> restored = filtered;
      meshopt_decodeFilterOct(restored.data(), used, 4);
      std::memcpy(snorm.data(), restored.data(), restored.size());
    } else {
      for (size_t i = 0; i < unit.size(); ++i) {
        snorm[i] = int8_t(std::lround(std::clamp(unit[i], -1.0f, 1.0f) * 127.0f));
      }
    }
    const std::vector<uint8_t> raw = bytes_of(snorm);
    const int view = buffers->add(raw, options.compress ? filtered : raw, used, 4, false,
                                  options.compress ? "OCTAHEDRAL" : "NONE", &views);
    accessors.push_back({{"bufferView", view},
                         {"componentType", kByte},
                         {"normalized", true},
                         {"count", used},
                         {"type", "VEC3"}});
    out.normal = int(accessors.size() - 1);
  }

  std::vector<uint8_t> raw;
  size_t stride = 4;
  if (used <= 65535) {
    std::vector<uint16_t> narrow(indices.begin(), indices.end());
    raw = bytes_of(narrow);
    stride = 2;
  } else {
    raw = bytes_of(indices);
  }
  const int view = buffers->add(raw, raw, index_count, stride, true, "NONE", &views);
  accessors.push_back({{"bufferView", view},
                       {"componentType", stride == 2 ? kUnsignedShort : kUnsignedInt},
                       {"count", index_count},
                       {"type", "SCALAR"}});
  out.indices = int(accessors.size() - 1);
  return out;
}

/// The largest distance between the exported vertices of component `c` under `exported` (mesh
/// frame -> world, in double) and the package's decoded vertices under `drawn`.
double deviation(const Component& c, const MeshPlan& mesh, const Mat4& exported,
                 const Mat4& drawn) {
  double worst = 0;
  for (const Vec3& p : c.mesh.positions) {
    Vec3d local = to_double(p);
    if (mesh.quantized) {
      local = {double(grid_coordinate(p.x, c.grid.origin.x, c.grid.step) - mesh.q_min[0]),
               double(grid_coordinate(p.y, c.grid.origin.y, c.grid.step) - mesh.q_min[1]),
               double(grid_coordinate(p.z, c.grid.origin.z, c.grid.step) - mesh.q_min[2])};
    }
    const Vec3d a = transform_point(exported, local);
    const Vec3d b = to_double(transform_point(drawn, p));
    worst = std::max(worst, length(a - b));
  }
  return worst;
}

/// The part's identifiers, as its node's (or its instance's) extras.
json part_json(const Manifest& manifest, size_t p) {
  const ManifestPart& part = manifest.parts[p];
  json j = {{"id", p},
            {"name", part.name},
            {"display_name", part.display_name},
            {"group", part.group},
            {"source", part.source},
            {"triangles", part.triangles},
            {"prototype", part.prototype}};
  // BodyParts3D file names carry the FMA id ("FJ3158_BP8545_FMA24474_Left_femur").
  static const std::regex kFma("(?:^|[^A-Za-z0-9])FMA([0-9]+)");
  std::smatch match;
  if (std::regex_search(part.name, match, kFma)) j["fma"] = "FMA" + match[1].str();
  if (part.has_color) j["color"] = {part.color.x, part.color.y, part.color.z};
  // Its regions, outermost first ("Skeleton", "Lower limb", "Left"), and its other names.
  if (part.path >= 0) {
    json path = json::array();
    for (int64_t g = part.path; g >= 0; g = manifest.groups[size_t(g)].parent) {
      path.insert(path.begin(), manifest.groups[size_t(g)].name);
    }
    j["path"] = std::move(path);
  }
  if (!part.names.empty()) j["names"] = part.names;
  if (!part.system.empty()) j["system"] = part.system;
  return j;
}

std::string node_name(const ManifestPart& part) {
  return part.display_name.empty() ? part.name : part.display_name;
}

Status check_path(const std::string& path, bool* glb) {
  const std::string extension = fs::path(path).extension().string();
  std::string lower = extension;
  for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (lower != ".glb" && lower != ".gltf") {
    return error(ErrorCode::kInvalidArgument, path, "the output must end in .glb or .gltf");
  }
  *glb = lower == ".glb";
  fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) parent = ".";
  std::error_code ec;
  if (!fs::is_directory(parent, ec)) {
    return error(ErrorCode::kIoError, path,
                 "cannot write: the folder " + parent.string() + " does not exist");
  }
  if (fs::is_directory(path, ec)) {
    return error(ErrorCode::kIoError, path, "cannot write: it is a folder");
  }
  return {};
}

void put_le32(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

Status export_gltf(const PackageData& package, const std::string& path,
                   const ExportOptions& options, ExportReport* report_out) {
  bool glb = true;
  OSTEON_RETURN_IF_ERROR(check_path(path, &glb));
  const Manifest& manifest = package.manifest;
  ExportReport report;
  report.parts = manifest.parts.size();

  // 1. Components, decoded, with their grids.
  std::map<std::string, size_t> index_of;
  std::vector<Component> decoded(manifest.components.size());
  for (size_t c = 0; c < manifest.components.size(); ++c) {
    const ManifestComponent& mc = manifest.components[c];
    if (mc.chunk >= package.chunks.size() ||
        mc.offset + mc.bytes > package.chunks[mc.chunk].size()) {
      return error(ErrorCode::kInvalidData, package.source,
                   "components[" + std::to_string(c) + "]: its byte range is not in its chunk");
    }
    const uint8_t* bytes = package.chunks[mc.chunk].data() + mc.offset;
    const std::string source = package.source + ": " + manifest.chunks[mc.chunk].file +
                               " at byte " + std::to_string(mc.offset);
    OSTEON_ASSIGN_OR_RETURN(decoded[c].mesh, decode(bytes, mc.bytes, source));
    OSTEON_ASSIGN_OR_RETURN(decoded[c].grid, stream_grid(bytes, mc.bytes, source));
    index_of.emplace(mc.id, c);
  }

  // 2. Each part: its components under one matrix (or baked), grouped into meshes.
  std::vector<PartDraw> draws(manifest.parts.size());
  std::vector<std::vector<Mat4>> matrices(manifest.parts.size());
  for (size_t i = 0; i < manifest.instances.size(); ++i) {
    const ManifestInstance& instance = manifest.instances[i];
    auto it = index_of.find(instance.component);
    if (instance.part >= manifest.parts.size() || it == index_of.end()) {
      return error(ErrorCode::kInvalidData, package.source,
                   "instances[" + std::to_string(i) + "]: unknown part or component");
    }
    draws[instance.part].components.push_back(it->second);
    matrices[instance.part].push_back(instance.matrix);
    draws[instance.part].error_bound =
        std::max(draws[instance.part].error_bound, instance.error_bound);
    report.error_bound = std::max(report.error_bound, instance.error_bound);
  }
  std::vector<MeshPlan> meshes;
  std::map<std::vector<size_t>, size_t> mesh_of;  // component list -> mesh (unbaked parts)
  std::vector<size_t> part_mesh(manifest.parts.size(), SIZE_MAX);
  for (size_t p = 0; p < manifest.parts.size(); ++p) {
    PartDraw& d = draws[p];
    if (d.components.empty()) continue;
    const bool one_matrix = std::all_of(matrices[p].begin(), matrices[p].end(),
                                        [&](const Mat4& m) { return m == matrices[p].front(); });
    d.matrix = matrices[p].front();
    if (!one_matrix || !is_similarity(d.matrix)) {
      d.baked = true;
      d.baked_matrices = matrices[p];
      MeshPlan mesh;
      mesh.components = d.components;
      mesh.parts = {p};
      mesh.baked = matrices[p];
      part_mesh[p] = meshes.size();
      meshes.push_back(std::move(mesh));
      continue;
    }
    auto [it, fresh] = mesh_of.emplace(d.components, meshes.size());
    if (fresh) {
      MeshPlan mesh;
      mesh.components = d.components;
      if (options.quantize) plan_quantization(decoded, &mesh);
      meshes.push_back(std::move(mesh));
    }
    meshes[it->second].parts.push_back(p);
    part_mesh[p] = it->second;
  }

  // 3. The document: materials, meshes.
  json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", "osteon export"}};
  doc["accessors"] = json::array();
  doc["bufferViews"] = json::array();
  doc["meshes"] = json::array();
  doc["nodes"] = json::array();
  doc["materials"] = json::array();
  std::map<std::array<float, 3>, size_t> material_of;
  auto material = [&](size_t p) {
    const ManifestPart& part = manifest.parts[p];
    const std::array<float, 3> color =
        part.has_color ? std::array<float, 3>{part.color.x, part.color.y, part.color.z}
                       : std::array<float, 3>{0.89f, 0.85f, 0.79f};  // the viewer's bone
    auto [it, fresh] = material_of.emplace(color, doc["materials"].size());
    if (fresh) {
      // sRGB -> linear for baseColorFactor.
      std::array<double, 4> linear{0, 0, 0, 1};
      for (int k = 0; k < 3; ++k) {
        const double c = color[k];
        linear[k] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
      }
      doc["materials"].push_back(
          {{"name", part.has_color ? "part colour" : "bone"},
           {"pbrMetallicRoughness",
            {{"baseColorFactor", linear}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.7}}}});
    }
    return it->second;
  };
  Buffers buffers(options.compress);
  for (MeshPlan& mesh : meshes) {
    // The package's components (segments of one bone, on one grid) as one primitive: one draw
    // call, and a few hundred bytes of JSON less per segment. Vertices are concatenated, never
    // welded, so the connectivity is the package's.
    Mesh joined;
    for (size_t k = 0; k < mesh.components.size(); ++k) {
      const Mesh& decoded_piece = decoded[mesh.components[k]].mesh;
      const Mesh piece =
          mesh.baked.empty() ? decoded_piece : transform_mesh(decoded_piece, mesh.baked[k]);
      const auto base = static_cast<uint32_t>(joined.positions.size());
      joined.positions.insert(joined.positions.end(), piece.positions.begin(),
                              piece.positions.end());
      joined.normals.insert(joined.normals.end(), piece.normals.begin(), piece.normals.end());
      for (uint32_t i : piece.indices) joined.indices.push_back(base + i);
    }
    if (joined.normals.size() != joined.positions.size()) joined.normals.clear();
    const PrimitiveAccessors a = write_primitive(
        joined, mesh, decoded[mesh.components.front()].grid, options, &buffers, &doc);
    json attributes = {{"POSITION", a.position}};
    if (a.normal >= 0) attributes["NORMAL"] = a.normal;
    json primitives = json::array({{{"attributes", attributes},
                                    {"indices", a.indices},
                                    {"material", material(mesh.parts.front())},
                                    {"mode", 4}}});
    report.vertices += doc["accessors"][size_t(a.position)]["count"].get<uint64_t>();
    if (!mesh.quantized) ++report.float_meshes;
    doc["meshes"].push_back(
        {{"name", node_name(manifest.parts[mesh.parts.front()])}, {"primitives", primitives}});
  }
  report.meshes = meshes.size();

  // 4. Nodes: the root, the groups, the parts and the instancing nodes.
  json& nodes = doc["nodes"];
  const std::string stem = fs::path(path).stem().string();
  nodes.push_back({{"name", stem},
                   {"extras",
                    {{"osteon",
                      {{"format", "osteon-gltf-export"},
                       {"version", 1},
                       {"unit", unit_name(manifest.unit)},
                       {"error_bound", report.error_bound}}}}}});
  if (!manifest.languages.empty()) nodes[0]["extras"]["osteon"]["languages"] = manifest.languages;
  std::vector<size_t> root_children;
  std::map<std::string, size_t> group_node;
  std::vector<std::vector<size_t>> group_children;
  auto parent_of = [&](const std::string& group) -> std::vector<size_t>& {
    if (group.empty()) return root_children;
    auto [it, fresh] = group_node.emplace(group, nodes.size());
    if (fresh) {
      nodes.push_back({{"name", group}, {"extras", {{"osteon", {{"group", group}}}}}});
      root_children.push_back(it->second);
      group_children.resize(nodes.size());
    }
    return group_children[it->second];
  };
  std::array<std::vector<float>, 3> instance_data;  // TRANSLATION, ROTATION, SCALE
  // Placing parts in part order keeps the groups in the order of their first part.
  std::vector<char> placed(manifest.parts.size(), 0);
  for (size_t p = 0; p < manifest.parts.size(); ++p) {
    if (placed[p]) continue;
    const ManifestPart& part = manifest.parts[p];
    if (part_mesh[p] == SIZE_MAX) {  // nothing to draw: the identifiers only
      placed[p] = 1;
      std::vector<size_t>& siblings = parent_of(part.group);
      siblings.push_back(nodes.size());
      nodes.push_back(
          {{"name", node_name(part)}, {"extras", {{"osteon", part_json(manifest, p)}}}});
      ++report.part_nodes;
      continue;
    }
    const MeshPlan& mesh = meshes[part_mesh[p]];
    const Mat4 dq = dequantization(mesh);
    const bool instanced = options.instancing && mesh.parts.size() >= 2;
    if (!instanced) {
      placed[p] = 1;
      const PartDraw& d = draws[p];
      const Mat4 m = d.baked ? kIdentityMatrix : multiply(d.matrix, dq);
      const Trs trs = decompose(m);
      std::vector<size_t>& siblings = parent_of(part.group);
      siblings.push_back(nodes.size());
      nodes.push_back(trs_json(trs, {{"name", node_name(part)},
                                     {"mesh", part_mesh[p]},
                                     {"extras", {{"osteon", part_json(manifest, p)}}}}));
      ++report.part_nodes;
      for (size_t c : mesh.components) report.triangles += decoded[c].mesh.triangle_count();
      const Mat4 exported = compose(trs);
      for (size_t k = 0; k < mesh.components.size(); ++k) {
        const Component& c = decoded[mesh.components[k]];
        const Mat4& drawn = d.baked ? d.baked_matrices[k] : d.matrix;
        // Baked vertices are the package's, transformed (as read_package does) and written.
        if (!d.baked) {
          report.max_deviation =
              std::max(report.max_deviation, deviation(c, mesh, exported, drawn));
        }
      }
      continue;
    }
    // Every part drawing this mesh, as instances: one instancing node per handedness.
    std::string group = part.group;
    for (size_t q : mesh.parts) {
      placed[q] = 1;
      if (manifest.parts[q].group != group) group.clear();
    }
    for (const bool mirrored : {false, true}) {
      std::vector<size_t> members;
      for (size_t q : mesh.parts) {
        if ((determinant3(draws[q].matrix) < 0) == mirrored) members.push_back(q);
      }
      if (members.empty()) continue;
      std::vector<float> translation, rotation, scale;
      json listed = json::array();
      for (size_t q : members) {
        const Mat4 m =
            multiply(mirrored ? kMirrorX : kIdentityMatrix, multiply(draws[q].matrix, dq));
        const Trs trs = decompose(m);
        for (double v : trs.t) translation.push_back(float(v));
        for (double v : trs.r) rotation.push_back(float(v));
        for (double v : trs.s) scale.push_back(float(v));
        listed.push_back(part_json(manifest, q));
        for (size_t c : mesh.components) report.triangles += decoded[c].mesh.triangle_count();
        // What an engine draws: node (mirror or identity) * instance (as stored, in float).
        Trs stored;
        for (int a = 0; a < 3; ++a) stored.t[a] = float(trs.t[a]), stored.s[a] = float(trs.s[a]);
        for (int a = 0; a < 4; ++a) stored.r[a] = float(trs.r[a]);
        const Mat4 exported = multiply(mirrored ? kMirrorX : kIdentityMatrix, compose(stored));
        for (size_t c : mesh.components) {
          report.max_deviation = std::max(report.max_deviation,
                                          deviation(decoded[c], mesh, exported, draws[q].matrix));
        }
      }
      // Every instancing node's transforms share three views (one per attribute), written last.
      json& accessors = doc["accessors"];
      auto vec_accessor = [&](const std::vector<float>& values, int attribute, const char* type,
                              size_t width) {
        std::vector<float>& shared = instance_data[attribute];
        accessors.push_back({{"bufferView", -1 - attribute},
                             {"byteOffset", shared.size() * sizeof(float)},
                             {"componentType", kFloat},
                             {"count", values.size() / width},
                             {"type", type}});
        shared.insert(shared.end(), values.begin(), values.end());
        return int(accessors.size() - 1);
      };
      json attributes = {{"TRANSLATION", vec_accessor(translation, 0, "VEC3", 3)},
                         {"ROTATION", vec_accessor(rotation, 1, "VEC4", 4)},
                         {"SCALE", vec_accessor(scale, 2, "VEC3", 3)}};
      const ManifestPart& first = manifest.parts[members.front()];
      json node = {
          {"name", node_name(first) + (mirrored ? " (mirrored instances)" : " (instances)")},
          {"mesh", part_mesh[p]},
          {"extensions", {{kInstancing, {{"attributes", attributes}}}}},
          {"extras", {{"osteon", {{"instances", listed}}}}}};
      if (mirrored) node["scale"] = {-1.0, 1.0, 1.0};
      std::vector<size_t>& siblings = parent_of(group);
      siblings.push_back(nodes.size());
      nodes.push_back(std::move(node));
      ++report.instancing_nodes;
      report.instances += members.size();
      if (mirrored) report.mirrored_instances += members.size();
    }
  }
  // The shared instance views, and the accessors pointed at them.
  std::array<int, 3> instance_view{-1, -1, -1};
  for (int k = 0; k < 3; ++k) {
    if (!instance_data[k].empty()) {
      instance_view[k] = buffers.add_plain(bytes_of(instance_data[k]), &doc["bufferViews"]);
    }
  }
  for (json& accessor : doc["accessors"]) {
    const int view = accessor["bufferView"].get<int>();
    if (view < 0) accessor["bufferView"] = instance_view[-1 - view];
  }
  nodes[0]["children"] = root_children;
  for (const auto& [name, index] : group_node) nodes[index]["children"] = group_children[index];
  doc["scenes"] = json::array({{{"name", stem}, {"nodes", {0}}}});
  doc["scene"] = 0;

  // 5. Extensions and buffers.
  json used = json::array(), required = json::array();
  if (std::any_of(meshes.begin(), meshes.end(), [](const MeshPlan& m) { return m.quantized; }) ||
      options.normals) {
    used.push_back(kQuantization);
    required.push_back(kQuantization);
  }
  if (report.instancing_nodes > 0) {
    used.push_back(kInstancing);
    required.push_back(kInstancing);
  }
  std::vector<uint8_t>& bin = buffers.bin();
  if (bin.empty()) bin.resize(4, 0);
  const std::string bin_name = stem + ".bin";
  json buffer0 = {{"byteLength", bin.size()}};
  if (!glb) buffer0["uri"] = bin_name;
  doc["buffers"] = json::array({buffer0});
  if (options.compress && buffers.fallback_bytes() > 0) {
    used.push_back(kMeshopt);
    required.push_back(kMeshopt);
    doc["buffers"].push_back({{"byteLength", buffers.fallback_bytes()},
                              {"extensions", {{kMeshopt, {{"fallback", true}}}}}});
  }
  if (!used.empty()) doc["extensionsUsed"] = used;
  if (!required.empty()) doc["extensionsRequired"] = required;
  if (doc["materials"].empty()) doc.erase("materials");
  if (doc["meshes"].empty()) doc.erase("meshes");
  if (doc["accessors"].empty()) doc.erase("accessors");
  if (doc["bufferViews"].empty()) doc.erase("bufferViews");

  std::string text = doc.dump(-1, ' ', false, json::error_handler_t::replace);
  report.bin_bytes = bin.size();
  if (glb) {
    while (text.size() % 4 != 0) text.push_back(' ');
    const uint64_t total = 12 + 8 + text.size() + 8 + bin.size();
    if (total > std::numeric_limits<uint32_t>::max()) {
      return error(ErrorCode::kUnsupported, path, "a GLB of 4 GiB or more");
    }
    std::vector<uint8_t> out;
    out.reserve(size_t(total));
    put_le32(&out, 0x46546C67);  // "glTF"
    put_le32(&out, 2);
    put_le32(&out, uint32_t(total));
    put_le32(&out, uint32_t(text.size()));
    put_le32(&out, 0x4E4F534A);  // "JSON"
    out.insert(out.end(), text.begin(), text.end());
    put_le32(&out, uint32_t(bin.size()));
    put_le32(&out, 0x004E4942);  // "BIN\0"
    out.insert(out.end(), bin.begin(), bin.end());
    OSTEON_RETURN_IF_ERROR(write_file_atomic(path, out.data(), out.size()));
    report.bytes = out.size();
  } else {
    const std::string bin_path = (fs::path(path).parent_path() / bin_name).string();
    OSTEON_RETURN_IF_ERROR(write_file_atomic(bin_path, bin.data(), bin.size()));
    const Status written = write_file_atomic(path, text.data(), text.size());
    if (!written.ok()) {
      std::error_code ec;
      fs::remove(bin_path, ec);
      return written;
    }
    report.bytes = text.size() + bin.size();
  }
  if (report_out != nullptr) *report_out = report;
  return {};
}

}  // namespace osteon
