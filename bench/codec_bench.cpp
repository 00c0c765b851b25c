// SPDX-License-Identifier: Apache-2.0
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <draco/core/draco_version.h>
#include <meshoptimizer.h>
#include <openssl/evp.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_markdown.hpp"
#include "codec_peers.hpp"
#include "osteon/codec.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/volume.hpp"

// The mesh codec against its peers, in one run: osteon, Draco 1.5.5 at compression
// levels 7 and 10 (in-process, libdraco-dev), meshoptimizer 0.18's vertex and index codecs under
// gzip (both in codec_peers.cpp, which says exactly how each is called and timed), and the
// WebAssembly decoders of osteon and Draco (npm draco3d) in one Node process (bench/codec_wasm.mjs,
// run as a child on the streams this program writes).
//
// Every codec gets the same mesh: read_path (exactly-equal positions welded), all parts of a file
// merged, degenerate triangles left in (osteon removes and counts them; Draco drops them too).
// Positions only, no normals, quantized to the same bits (step = largest bbox side / (2^bits - 1)).
// osteon's encode time is encode(): mesh in, bytes out; its decode time decode(): bytes in,
// osteon::Mesh out, including the smooth vertex normals the decoder computes (the peers compute
// none). Times: see Timing in codec_peers.hpp (thread CPU time by default, best of N).
// Max error is the largest per-coordinate |decoded - input|: osteon's from its EncodeReport,
// Draco's and meshopt's measured after decoding.

#ifndef OSTEON_SHARED_DATA_DIR
#define OSTEON_SHARED_DATA_DIR "../shared/data"
#endif
#ifndef OSTEON_SOURCE_DIR
#define OSTEON_SOURCE_DIR "."
#endif

namespace osteon_bench {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kKiB = 1024.0;
constexpr double kConnectivityTarget = 1.8;  // bits per vertex, closed meshes
constexpr double kWasmTrianglesPerSecond = 25e6;
constexpr double kSizeTarget = 0.90;  // of Draco cl10's bytes
constexpr double kDecoderDownloadTarget = 25000;  // gzipped bytes (25 KB, the stricter reading)

std::optional<std::vector<uint8_t>> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), {});
}

bool write_bytes(const fs::path& path, const void* data, size_t size) {
  return osteon::write_file_atomic(path.string(), data, size).ok();
}

// ---- inputs --------------------------------------------------------------------------------

struct Group {
  std::string name;
  std::string description;
  std::vector<fs::path> files;
  /// Each part of a file is a row of its own, read with `read` (label volumes: one surface per
  /// label, as osteon pack reads them); otherwise a file's parts are merged into one mesh.
  bool per_part = false;
  osteon::ReadOptions read;
  /// > 0: each file's meshes are first voxelized at this voxel size (mm) into a label volume,
  /// which is then read with `read` (surfaces from a segmentation of known bones).
  double voxelize = 0;
};

/// Every part of a file in one mesh (a codec stream holds one mesh), as `osteon encode` does.
std::optional<osteon::Mesh> read_mesh(const fs::path& path, std::string* error) {
  auto scene = osteon::read_path(path.string());
  if (!scene.ok()) {
    *error = scene.status().message();
    return std::nullopt;
  }
  if (scene->parts.size() == 1) return std::move(scene->parts[0]);
  osteon::Mesh merged;
  merged.name = path.stem().string();
  merged.source = path.string();
  for (osteon::Mesh& part : scene->parts) {
    uint32_t base = static_cast<uint32_t>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), part.positions.begin(), part.positions.end());
    for (uint32_t i : part.indices) merged.indices.push_back(base + i);
  }
  return merged;
}

std::vector<fs::path> files_matching(const fs::path& dir, const std::string& extension,
                                     const std::string& name_contains = "") {
  std::vector<fs::path> files;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const fs::path& p = entry.path();
    if (entry.is_regular_file() && p.extension() == extension &&
        p.filename().string().find(name_contains) != std::string::npos)
      files.push_back(p);
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<Group> find_groups(const fs::path& data, int largest_parts) {
  std::vector<Group> groups;
  auto add = [&](Group group, const fs::path& where) {
    if (group.files.empty()) {
      std::fprintf(stderr, "codec_bench: skipping %s: nothing under %s\n", group.name.c_str(),
                   where.c_str());
      return;
    }
    groups.push_back(std::move(group));
  };

  Group ct{"ct-like", "marching-cubes surfaces of CT-like volumes (ct-like/*.ply)", {}};
  for (const char* name : {"hip_mcs.ply", "skull_mc.ply"}) {
    std::error_code ec;
    if (fs::exists(data / "ct-like" / name, ec)) ct.files.push_back(data / "ct-like" / name);
  }
  add(ct, data / "ct-like");

  // BodyParts3D: the parts with the most triangles (reading all 235 GLB files takes well under a
  // second).
  fs::path bp3d = data / "aHer-dev__3DAnatomy/models/bones";
  std::vector<std::pair<size_t, fs::path>> counted;
  for (const fs::path& file : files_matching(bp3d, ".glb")) {
    std::string error;
    auto mesh = read_mesh(file, &error);
    if (mesh) counted.emplace_back(mesh->triangle_count(), file);
  }
  std::sort(counted.begin(), counted.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  Group parts{"BodyParts3D",
              "the " + std::to_string(largest_parts) +
                  " BodyParts3D bones with the most triangles (aHer-dev__3DAnatomy/models/bones)",
              {}};
  for (size_t i = 0; i < counted.size() && int(i) < largest_parts; ++i)
    parts.files.push_back(counted[i].second);
  add(parts, bp3d);

  fs::path vhf = data / "ingvilddevold__muscle-growth/data/VHF_surfaces";
  add({"Visible Human", "Visible Human female bones (VHF_surfaces/*/*Bone*.stl; no cartilage)",
       files_matching(vhf, ".stl", "_Bone_")},
      vhf);

  fs::path psb = data / "cearto__zen__MeshsegBenchmark/data/off";
  add({"PSB", "Princeton Segmentation Benchmark meshes (MeshsegBenchmark data/off/*.off)",
       files_matching(psb, ".off")},
      psb);

  // Surfaces from a CT segmentation, each bone's as osteon pack makes it from the label volume
  // (Surface Nets, constrained smoothing, simplified to pack's default fraction of a voxel).
  fs::path seg = data / "wasserth__TotalSegmentator/tests/reference_files";
  Group volume{"label volume",
               "TotalSegmentator's segmentation of its example CT (example_seg.nii.gz, 3 mm "
               "voxels), every bone label surfaced as osteon pack does by default",
               {},
               true,
               osteon::PackOptions{}.read};
  volume.read.labels = {"bones"};
  std::error_code ec;
  if (fs::exists(seg / "example_seg.nii.gz", ec))
    volume.files.push_back(seg / "example_seg.nii.gz");
  add(volume, seg);

  // Dense surfaces from a label volume: the same BodyParts3D bones, each voxelized at 0.5 mm (a
  // thin-slice CT's resolution) and surfaced as osteon pack does by default.
  Group voxelized{"voxelized BodyParts3D",
                  "the BodyParts3D bones above, each voxelized at 0.5 mm (osteon voxelize) and "
                  "its label surfaced as osteon pack does by default",
                  parts.files,
                  true,
                  osteon::PackOptions{}.read,
                  0.5};
  add(voxelized, bp3d);
  return groups;
}

// ---- the codecs ----------------------------------------------------------------------------

/// The SHA-256 of each array a decode returns (positions and normals as float32, indices as
/// uint32: their bytes, little-endian), in hex, as bench/codec_wasm.mjs prints them.
struct DecodedDigests {
  std::string positions, indices, normals;
};

std::string sha256_hex(const void* data, size_t size) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_Digest(data, size, digest, &length, EVP_sha256(), nullptr);
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) {
    static constexpr char kHex[] = "0123456789abcdef";
    hex += kHex[digest[i] >> 4];
    hex += kHex[digest[i] & 15];
  }
  return hex;
}

DecodedDigests digests(const osteon::Mesh& mesh) {
  static_assert(sizeof(osteon::Vec3) == 3 * sizeof(float), "positions are float[3 * n]");
  return {sha256_hex(mesh.positions.data(), mesh.positions.size() * sizeof(osteon::Vec3)),
          sha256_hex(mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t)),
          sha256_hex(mesh.normals.data(), mesh.normals.size() * sizeof(osteon::Vec3))};
}

struct OsteonResult {
  std::string error;  ///< empty on success
  osteon::EncodeReport report;
  double encode_ms = 0, decode_ms = 0;
  size_t decoded_triangles = 0;
  DecodedDigests native;  ///< of the native decode
  std::string stream;     ///< where the stream was written (empty: not written)
  double wasm_ms = -1;
  std::string wasm_error;
  /// The WebAssembly decode's arrays against the native decode's: "" when not compared, else
  /// "identical" or the arrays that differ.
  std::string wasm_identity;
  /// The same mesh at EncodeOptions::effort 0 (no search), timed like the default.
  osteon::EncodeReport fast;
  double fast_encode_ms = 0;
  std::string fast_error;  ///< empty on success (decoded to as many triangles)
};

struct Row {
  std::string group;
  std::string label;
  fs::path file;
  uintmax_t file_bytes = 0;
  size_t vertices = 0, triangles = 0;
  bool closed = false;
  std::string error;  ///< the mesh could not be read
  OsteonResult osteon;
  DracoRun draco;
  /// Over the size target: Draco cl10's connectivity and headers alone
  /// (draco_connectivity_bytes); 0 otherwise.
  size_t draco_connectivity = 0;
  MeshoptResult meshopt;
};

OsteonResult run_osteon(const osteon::Mesh& mesh, int bits, const Timing& timing,
                        const std::string& stream) {
  OsteonResult r;
  osteon::EncodeOptions options;
  options.bits = bits;
  // The best time of encoding with `with`; its stream, report and error (empty on success).
  auto timed_encode = [&](const osteon::EncodeOptions& with, std::vector<uint8_t>* out,
                          osteon::EncodeReport* report, std::string* error) {
    return best_ms(timing, [&] {
      auto encoded = osteon::encode(mesh, with, report);
      if (!encoded.ok()) {
        *error = "encode: " + encoded.status().message();
        return false;
      }
      *out = std::move(encoded).value();
      return true;
    });
  };
  std::vector<uint8_t> bytes;
  r.encode_ms = timed_encode(options, &bytes, &r.report, &r.error);
  if (!r.error.empty()) return r;
  osteon::Mesh decoded;  // the last decode's, hashed once the decodes are timed
  r.decode_ms = best_ms(timing, [&] {
    auto back = osteon::decode(bytes.data(), bytes.size(), fs::path(stream).filename().string());
    if (!back.ok()) {
      r.error = "decode: " + back.status().message();
      return false;
    }
    r.decoded_triangles = back->triangle_count();
    decoded = std::move(back).value();
    return true;
  });
  if (!r.error.empty()) return r;
  r.native = digests(decoded);
  // Effort 0: the encoder without its search.
  osteon::EncodeOptions fast = options;
  fast.effort = 0;
  std::vector<uint8_t> fast_bytes;
  r.fast_encode_ms = timed_encode(fast, &fast_bytes, &r.fast, &r.fast_error);
  if (r.fast_error.empty()) {
    auto back = osteon::decode(fast_bytes.data(), fast_bytes.size(), "effort 0");
    if (!back.ok()) {
      r.fast_error = "decode: " + back.status().message();
    } else if (back->triangle_count() != r.fast.triangles) {
      r.fast_error = "decoded " + std::to_string(back->triangle_count()) + " triangles, coded " +
                     std::to_string(r.fast.triangles);
    }
  }
  if (r.decoded_triangles != r.report.triangles)
    r.error = "decoded " + std::to_string(r.decoded_triangles) + " triangles, coded " +
              std::to_string(r.report.triangles);
  if (write_bytes(stream, bytes.data(), bytes.size())) r.stream = stream;
  return r;
}

// ---- the WebAssembly decoders (Node child) -------------------------------------------------

struct WasmRun {
  std::string unavailable;  ///< why nothing was measured (no node, the script failed)
  json report;
};

std::optional<std::string> find_in_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return std::nullopt;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
    if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return std::nullopt;
}

/// Runs `node bench/codec_wasm.mjs --repeat N --min-ms M [--decoder DIR] FILE...` and parses
/// its JSON.
WasmRun run_wasm(const fs::path& source_dir, const fs::path& decoder_dir,
                 const std::vector<std::string>& files, const Timing& timing) {
  WasmRun run;
  auto node = find_in_path("node");
  fs::path script = source_dir / "bench/codec_wasm.mjs";
  if (!node) {
    run.unavailable = "node not found in PATH";
    return run;
  }
  if (!fs::exists(script)) {
    run.unavailable = script.string() + " not found";
    return run;
  }
  std::vector<std::string> args = {*node,      script.string(),
                                   "--repeat", std::to_string(timing.repeat),
                                   "--min-ms", std::to_string(int(timing.min_seconds * 1e3))};
  if (!decoder_dir.empty()) args.insert(args.end(), {"--decoder", decoder_dir.string()});
  args.insert(args.end(), files.begin(), files.end());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  int fds[2];
  if (pipe(fds) != 0) {
    run.unavailable = "pipe failed";
    return run;
  }
  std::fflush(stdout);
  pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    close(fds[0]);
    close(fds[1]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  std::string output;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fds[0], buffer, sizeof(buffer))) > 0) output.append(buffer, size_t(n));
  close(fds[0]);
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    run.unavailable = "bench/codec_wasm.mjs failed (status " + std::to_string(status) + ")";
    return run;
  }
  run.report = json::parse(output, nullptr, false);
  if (run.report.is_discarded()) run.unavailable = "bench/codec_wasm.mjs printed no JSON";
  return run;
}

/// Fills the WASM columns from the Node run; a stream the WebAssembly decoder decodes to another
/// triangle count than the native decoder is an error.
void merge_wasm(const WasmRun& run, std::vector<Row>& rows) {
  std::map<std::string, const json*> by_file;
  if (run.unavailable.empty())
    for (const json& r : run.report["results"]) by_file[r.value("file", "")] = &r;
  auto fill = [&](const std::string& stream, size_t native_triangles, double& ms,
                  std::string& error) {
    if (stream.empty()) return;
    auto it = by_file.find(stream);
    if (!run.unavailable.empty()) {
      error = run.unavailable;
    } else if (it == by_file.end()) {
      error = "not measured";
    } else if (!it->second->contains("ms")) {
      error = it->second->value("error", std::string("failed"));
    } else if (it->second->value("triangles", size_t{0}) != native_triangles) {
      error = "WASM decoded " + std::to_string(it->second->value("triangles", size_t{0})) +
              " triangles, native " + std::to_string(native_triangles);
    } else {
      ms = (*it->second)["ms"].get<double>();
    }
  };
  for (Row& row : rows) {
    fill(row.osteon.stream, row.osteon.decoded_triangles, row.osteon.wasm_ms,
         row.osteon.wasm_error);
    auto decoded = by_file.find(row.osteon.stream);
    if (row.osteon.wasm_ms >= 0 && decoded != by_file.end() &&
        decoded->second->contains("sha256")) {
      const json& h = (*decoded->second)["sha256"];
      const DecodedDigests wasm{h.value("positions", ""), h.value("indices", ""),
                                h.value("normals", "")};
      const DecodedDigests& native = row.osteon.native;
      std::string differ;
      if (wasm.positions != native.positions) differ += " positions";
      if (wasm.indices != native.indices) differ += " indices";
      if (wasm.normals != native.normals) differ += " normals";
      row.osteon.wasm_identity = differ.empty() ? "identical" : "differ:" + differ;
    }
    for (DracoResult& d : row.draco.level)
      fill(d.stream, d.decoded_triangles, d.wasm_ms, d.wasm_error);
    MeshoptResult& m = row.meshopt;
    fill(m.buffers_file, row.triangles, m.v1_wasm_ms, m.v1_error);
    auto it = by_file.find(m.buffers_file);
    if (m.v1_error.empty() && it != by_file.end()) m.v1_bytes = it->second->value("bytes", size_t{0});
  }
}

// ---- the report ----------------------------------------------------------------------------



/// Bytes as KB (1024 bytes): one decimal below 100 KB.
std::string kb(double bytes) {
  double k = bytes / kKiB;
  return k < 100 ? fixed(k, 1) : grouped(uint64_t(std::llround(k)));
}

std::string ms_text(double ms) {
  if (ms < 0) return "-";
  return ms < 10 ? fixed(ms, 2) : ms < 100 ? fixed(ms, 1) : fixed(ms, 0);
}


std::string wasm_text(double ms, const std::string& error) {
  if (ms >= 0) return ms_text(ms);
  if (error.find("decoder not built") != std::string::npos) return "n/a (decoder not built)";
  if (error.empty()) return "-";
  bool failed = error.rfind("osteon:", 0) == 0 || error.rfind("draco:", 0) == 0 ||
                error.rfind("WASM decoded", 0) == 0;
  return failed ? "fails" : "n/a";
}

bool osteon_ok(const Row& r) {
  return r.error.empty() && r.osteon.error.empty();
}
bool draco_ok(const Row& r, int i) {
  return r.error.empty() && r.draco.level[i].error.empty();
}

std::string table(const std::vector<const Row*>& rows) {
  std::ostringstream md;
  md << "| mesh | triangles | original MB (indexed / file) | osteon KB | conn bpv | geom bpv | "
        "total bpv | max err | enc ms | dec ms native | dec ms WASM | Draco cl7 KB | "
        "Draco cl10 KB | osteon / cl10 | Draco enc ms cl7 / cl10 | Draco dec ms native cl7 / "
        "cl10 | Draco dec ms WASM cl7 / cl10 | Draco max err | meshopt+gzip KB | meshopt enc / "
        "dec ms |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        "---:|---:|\n";
  for (const Row* row : rows) {
    const Row& r = *row;
    md << "| " << r.label << " | ";
    if (!r.error.empty()) {
      md << "- | cannot read: " << r.error << " |" << std::string(17, '|') << "\n";
      continue;
    }
    md << grouped(r.triangles) << " | " << fixed((12.0 * r.vertices + 12.0 * r.triangles) / 1e6, 2)
       << " / " << fixed(double(r.file_bytes) / 1e6, 2) << " | ";
    if (osteon_ok(r)) {
      const osteon::EncodeReport& e = r.osteon.report;
      md << kb(double(e.bytes)) << " | " << fixed(e.connectivity_bits_per_vertex, 2) << " | "
         << fixed(e.geometry_bits_per_vertex, 2) << " | "
         << fixed(e.vertices ? 8.0 * double(e.bytes) / double(e.vertices) : 0.0, 2) << " | "
         << sig(e.max_error) << " | " << ms_text(r.osteon.encode_ms) << " | "
         << ms_text(r.osteon.decode_ms) << " | " << wasm_text(r.osteon.wasm_ms, r.osteon.wasm_error)
         << " | ";
    } else {
      std::string why = r.osteon.error;
      std::replace(why.begin(), why.end(), '|', '/');
      if (why.size() > 60) why = why.substr(0, 57) + "...";
      md << "fails: " << why << " | - | - | - | - | - | - | - | ";
    }
    auto draco_cell = [&](auto&& f) {
      std::string a = draco_ok(r, 0) ? f(r.draco.level[0]) : "fails";
      std::string b = draco_ok(r, 1) ? f(r.draco.level[1]) : "fails";
      return a + " / " + b;
    };
    md << (draco_ok(r, 0) ? kb(double(r.draco.level[0].bytes)) : "fails: " + r.draco.level[0].error)
       << " | "
       << (draco_ok(r, 1) ? kb(double(r.draco.level[1].bytes)) : "fails: " + r.draco.level[1].error)
       << " | "
       << (osteon_ok(r) && draco_ok(r, 1)
               ? fixed(double(r.osteon.report.bytes) / double(r.draco.level[1].bytes), 3)
               : "-")
       << " | " << draco_cell([](const DracoResult& d) { return ms_text(d.encode_ms); }) << " | "
       << draco_cell([](const DracoResult& d) { return ms_text(d.decode_ms); }) << " | "
       << draco_cell([](const DracoResult& d) { return wasm_text(d.wasm_ms, d.wasm_error); })
       << " | " << (r.draco.max_error >= 0 ? sig(r.draco.max_error) : "-") << " | ";
    if (r.meshopt.error.empty())
      md << kb(double(r.meshopt.bytes)) << " | " << ms_text(r.meshopt.encode_ms) << " / "
         << ms_text(r.meshopt.decode_ms) << " |\n";
    else
      md << "fails: " << r.meshopt.error << " | - |\n";
  }
  return md.str();
}

/// Sums over a set of rows (only rows where every codec succeeded, so the sums compare).
struct Totals {
  size_t meshes = 0, triangles = 0;
  double osteon = 0, cl7 = 0, cl10 = 0, meshopt = 0, meshopt_v1 = 0;
  double osteon_enc = 0, cl7_enc = 0;
  double osteon_dec = 0, cl7_dec = 0;
  double osteon_wasm = 0, cl7_wasm = 0, cl10_wasm = 0, meshopt_v1_wasm = 0;
  bool wasm_osteon = true, wasm_draco = true, wasm_meshopt = true;
  double fast = 0, fast_enc = 0;  // effort 0
  bool fast_ok = true;
};

bool comparable(const Row& r) {
  return osteon_ok(r) && draco_ok(r, 0) && draco_ok(r, 1) && r.meshopt.error.empty();
}

Totals totals(const std::vector<const Row*>& rows) {
  Totals t;
  for (const Row* row : rows) {
    const Row& r = *row;
    if (!comparable(r)) continue;
    ++t.meshes;
    t.triangles += r.triangles;
    t.osteon += double(r.osteon.report.bytes);
    t.cl7 += double(r.draco.level[0].bytes);
    t.cl10 += double(r.draco.level[1].bytes);
    t.meshopt += double(r.meshopt.bytes);
    t.meshopt_v1 += double(r.meshopt.v1_bytes);
    t.wasm_meshopt = t.wasm_meshopt && r.meshopt.v1_wasm_ms >= 0;
    t.meshopt_v1_wasm += r.meshopt.v1_wasm_ms;
    t.osteon_enc += r.osteon.encode_ms;
    t.cl7_enc += r.draco.level[0].encode_ms;
    t.osteon_dec += r.osteon.decode_ms;
    t.cl7_dec += r.draco.level[0].decode_ms;
    t.wasm_osteon = t.wasm_osteon && r.osteon.wasm_ms >= 0;
    t.wasm_draco = t.wasm_draco && r.draco.level[0].wasm_ms >= 0 && r.draco.level[1].wasm_ms >= 0;
    t.osteon_wasm += r.osteon.wasm_ms;
    t.cl7_wasm += r.draco.level[0].wasm_ms;
    t.cl10_wasm += r.draco.level[1].wasm_ms;
    t.fast_ok = t.fast_ok && r.osteon.fast_error.empty();
    t.fast += double(r.osteon.fast.bytes);
    t.fast_enc += r.osteon.fast_encode_ms;
  }
  return t;
}

std::string summary_row(const std::string& label, const Totals& t) {
  std::ostringstream md;
  if (t.meshes == 0) return "| " + label + " | 0 |" + std::string(15, '|') + "\n";
  md << "| " << label << " | " << t.meshes << " | " << grouped(t.triangles) << " | " << kb(t.osteon)
     << " | " << kb(t.cl7) << " | " << kb(t.cl10) << " | " << kb(t.meshopt) << " | "
     << (t.wasm_meshopt ? kb(t.meshopt_v1) : "n/a") << " | "
     << fixed(t.osteon / t.cl10, 3) << " | " << ms_text(t.osteon_enc) << " | " << ms_text(t.cl7_enc)
     << " | " << ms_text(t.osteon_dec) << " | " << ms_text(t.cl7_dec) << " | "
     << (t.wasm_osteon ? ms_text(t.osteon_wasm) : "n/a") << " | "
     << (t.wasm_draco ? ms_text(t.cl7_wasm) + " / " + ms_text(t.cl10_wasm) : "n/a") << " | "
     << (t.wasm_meshopt ? ms_text(t.meshopt_v1_wasm) : "n/a") << " | "
     << (t.wasm_osteon ? fixed(double(t.triangles) / t.osteon_wasm / 1e3, 1) : "n/a") << " |\n";
  return md.str();
}

struct Report {
  std::string markdown;
  json targets = json::array();
};

/// The median mesh by triangle count over every mesh measured (the lower median).
const Row* median_row(const std::vector<Row>& rows) {
  std::vector<const Row*> ok;
  for (const Row& r : rows)
    if (comparable(r)) ok.push_back(&r);
  if (ok.empty()) return nullptr;
  std::sort(ok.begin(), ok.end(), [](const Row* a, const Row* b) {
    return a->triangles != b->triangles ? a->triangles < b->triangles : a->label < b->label;
  });
  return ok[(ok.size() - 1) / 2];
}

struct DecoderSize {
  std::string text;  ///< what was measured, or why not
  double gzipped = -1;
};

/// The folder of a built osteon WebAssembly decoder (osteon_decoder.wasm beside
/// osteon_decoder.mjs): `wanted` when given, else build/wasm (web/decoder/build.sh's output), else
/// web/decoder; empty when none holds both files.
fs::path find_decoder_dir(const fs::path& source_dir, const std::string& wanted) {
  std::vector<fs::path> dirs;
  if (!wanted.empty()) {
    dirs.push_back(wanted);
  } else {
    dirs = {source_dir / "build/wasm", source_dir / "web/decoder"};
  }
  for (const fs::path& dir : dirs) {
    std::error_code ec;
    if (fs::exists(dir / "osteon_decoder.mjs", ec) && fs::exists(dir / "osteon_decoder.wasm", ec))
      return fs::absolute(dir);
  }
  return {};
}

/// What a page downloads to decode: osteon_decoder.wasm + its wrapper osteon_decoder.mjs, each
/// under gzip -9 (as web/decoder/build.sh counts it); worker.mjs and pool.mjs reported beside.
DecoderSize decoder_size(const fs::path& source_dir, const fs::path& dir) {
  DecoderSize size;
  if (dir.empty()) {
    size.text = "no built decoder (osteon_decoder.wasm) in build/wasm or web/decoder";
    return size;
  }
  double raw = 0, gz = 0;
  for (const char* name : {"osteon_decoder.wasm", "osteon_decoder.mjs"}) {
    auto bytes = read_bytes(dir / name);
    if (!bytes) {
      size.text = (dir / name).string() + " cannot be read";
      return size;
    }
    raw += double(bytes->size());
    gz += double(gzip(*bytes, 9).size());
  }
  size.gzipped = gz;
  fs::path shown = dir.lexically_relative(fs::absolute(source_dir));
  if (shown.empty() || *shown.begin() == "..") shown = dir;
  size.text = shown.string() +
              "/osteon_decoder.wasm + osteon_decoder.mjs: " + grouped(uint64_t(raw)) + " bytes, " +
              grouped(uint64_t(gz)) + " under gzip -9";
  double extra = 0;
  for (const char* name : {"worker.mjs", "pool.mjs"})
    if (auto bytes = read_bytes(dir / name)) extra += double(gzip(*bytes, 9).size());
  if (extra > 0) size.text += " (worker.mjs + pool.mjs add " + grouped(uint64_t(extra)) + ")";
  return size;
}

/// Draco's WebAssembly decoder from npm, for scale (the full decoder; three.js's glTF build is
/// smaller).
std::string draco_decoder_size(const fs::path& source_dir) {
  fs::path dir = source_dir / "bench/node_modules/draco3d";
  double raw = 0, gz = 0;
  for (const char* name : {"draco_decoder.wasm", "draco_decoder_nodejs.js"}) {
    auto bytes = read_bytes(dir / name);
    if (!bytes) return "";
    raw += double(bytes->size());
    gz += double(gzip(*bytes, 9).size());
  }
  return "npm draco3d's draco_decoder.wasm + draco_decoder_nodejs.js: " + grouped(uint64_t(raw)) +
         " bytes, " + grouped(uint64_t(gz)) + " under gzip -9";
}

Report build_report(const std::vector<Row>& rows, const std::vector<Group>& groups,
                    const fs::path& source_dir, const fs::path& decoder_dir, const WasmRun& wasm,
                    int bits) {
  Report report;
  std::ostringstream md;
  std::vector<std::pair<const Group*, std::vector<const Row*>>> by_group;
  std::vector<const Row*> all;
  for (const Group& g : groups) {
    std::vector<const Row*> in_group;
    for (const Row& r : rows)
      if (r.group == g.name) in_group.push_back(&r);
    if (in_group.empty()) continue;
    by_group.emplace_back(&g, in_group);
    all.insert(all.end(), in_group.begin(), in_group.end());
    md << "### " << g.name << "\n\n" << g.description << ".\n\n" << table(in_group) << "\n";
  }

  // Summary.
  const Row* median = median_row(rows);
  std::vector<const Row*> ct;
  for (const Row& r : rows)
    if (r.group == "ct-like") ct.push_back(&r);
  const Totals overall = totals(all);
  md << "### Summary\n\nSums over the meshes every codec coded; Mtri/s is triangles over the "
        "summed osteon WASM decode time. meshopt 1.x: npm meshoptimizer's newest vertex codec "
        "(version 1, level 3) and its index codec on the same buffers as the meshopt+gzip "
        "column, then gzip -9, coded and decoded (gunzip included) in the Node process of the "
        "WASM columns (bench/codec_wasm.mjs).\n\n"
     << "| set | meshes | triangles | osteon KB | Draco cl7 KB | Draco cl10 KB | meshopt+gzip KB | "
        "meshopt 1.x v1+gzip KB | osteon / cl10 | osteon enc ms | Draco cl7 enc ms | osteon dec ms "
        "native | Draco cl7 dec ms native | osteon dec ms WASM | Draco dec ms WASM cl7 / cl10 | "
        "meshopt 1.x dec ms WASM | osteon WASM Mtri/s |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  if (median)
    md << summary_row("median mesh: " + median->group + " " + median->label, totals({median}));
  for (const Row* r : ct) md << summary_row("ct-like " + r->label, totals({r}));
  for (const auto& [g, in_group] : by_group) md << summary_row("all " + g->name, totals(in_group));
  md << summary_row("**all meshes**", overall) << "\n";

  // Where the bytes of the meshes over the size target go, against Draco's.
  std::ostringstream over;
  size_t over_rows = 0;
  for (const Row& r : rows) {
    if (!comparable(r) || r.draco_connectivity == 0 || r.vertices == 0) continue;
    const osteon::EncodeReport& e = r.osteon.report;
    const double v = double(r.vertices), cl10 = double(r.draco.level[1].bytes);
    const double ours_geometry = 8.0 * double(e.geometry_bytes) / v;
    const double ours_rest = 8.0 * double(e.bytes - e.geometry_bytes) / v;
    const double draco_rest = 8.0 * double(r.draco_connectivity) / v;
    const double draco_geometry = 8.0 * (cl10 - double(r.draco_connectivity)) / v;
    const double geometry = ours_geometry / draco_geometry, rest = ours_rest / draco_rest;
    std::string why = geometry > kSizeTarget ? "geometry " + fixed(geometry, 3) + "x Draco's"
                                             : "connectivity and header " + fixed(rest, 3) + "x";
    if (geometry > kSizeTarget && rest > kSizeTarget)
      why += ", connectivity and header " + fixed(rest, 3) + "x";
    over << "| " << r.group << " " << r.label << " | " << fixed(double(e.bytes) / cl10, 3) << " | "
         << fixed(ours_geometry, 2) << " / " << fixed(draco_geometry, 2) << " | "
         << fixed(ours_rest, 2) << " / " << fixed(draco_rest, 2) << " | " << why << " |\n";
    ++over_rows;
  }
  if (over_rows > 0) {
    md << "### Over the size target: where the bytes go\n\n"
       << "Each mesh over " << fixed(kSizeTarget, 2) << "x Draco cl10, its bits per vertex split "
          "in two: geometry, and the rest (connectivity, headers, checksum). Draco's rest is its "
          "cl10 stream of the same mesh with every position but two made one point (next to no "
          "geometry: draco_connectivity_bytes in bench/codec_peers.cpp; its position attribute's "
          "headers stay in it), its geometry the difference. Why: the part that is over the "
          "target against Draco's same part.\n\n"
       << "| mesh | osteon / cl10 | geometry bpv, osteon / Draco | the rest bpv, osteon / Draco "
          "| why |\n|---|---:|---:|---:|---|\n"
       << over.str() << "\n";
  }

  // What the meshes that encode slower than Draco cl7 spend it on: each mesh of a group whose
  // sum misses the encode target, and each ct-like mesh that misses it, where osteon is slower.
  std::ostringstream slower;
  for (const auto& [g, in_group] : by_group) {
    Totals gt = totals(in_group);
    for (const Row* r : in_group) {
      if (!comparable(*r) || r->triangles == 0) continue;
      const bool group_misses = gt.meshes > 0 && gt.osteon_enc > gt.cl7_enc;
      if (!(group_misses || r->group == "ct-like")) continue;
      if (r->osteon.encode_ms <= r->draco.level[0].encode_ms) continue;
      const osteon::EncodeReport& e = r->osteon.report;
      const double t = double(r->triangles);
      slower << "| " << r->group << " " << r->label << " | " << r->triangles << " | "
             << ms_text(r->osteon.encode_ms) << " / " << ms_text(r->draco.level[0].encode_ms)
             << " | " << fixed(1e6 * r->osteon.encode_ms / t, 0) << " / "
             << fixed(1e6 * r->draco.level[0].encode_ms / t, 0) << " | "
             << fixed(e.geometry_passes, 2) << " | " << e.connectivity_models << " | "
             << (e.geometry_passes >= 1.5
                     ? "the search: " + fixed(e.geometry_passes, 1) +
                           " passes of geometry prediction and " +
                           std::to_string(e.connectivity_models) +
                           " connectivity models planned, where Draco cl7 codes once"
                     : "the coding itself: one pass of geometry prediction, slower a vertex "
                       "than Draco cl7's")
             << " |\n";
    }
  }
  if (!slower.str().empty()) {
    md << "### Slower to encode than Draco cl7: where the time goes\n\n"
       << "Each mesh that encodes slower than Draco cl7 in a group whose sum misses the encode "
          "target (and each ct-like mesh that misses it). Passes: the vertices osteon's encoder "
          "predicted in every geometry coding it measured before choosing one, and in the one it "
          "kept, over the vertex count (EncodeReport::geometry_passes; 1 is one pass). Models: the "
          "connectivity context models whose tables it planned (EncodeReport::"
          "connectivity_models).\n\n"
       << "| mesh | triangles | enc ms, osteon / Draco cl7 | ns a triangle, osteon / Draco cl7 | "
          "passes | models | why |\n|---|---:|---:|---:|---:|---:|---|\n"
       << slower.str() << "\n";
  }

  // Why the ct-like meshes decode under the WASM target: the native decoder's own rate beside.
  std::ostringstream slow_decode;
  for (const Row* r : ct) {
    if (!osteon_ok(*r) || r->osteon.wasm_ms <= 0 || r->osteon.decode_ms <= 0) continue;
    const double t = double(r->triangles), wasm_rate = t / (r->osteon.wasm_ms / 1e3);
    if (wasm_rate >= kWasmTrianglesPerSecond) continue;
    const double native_rate = t / (r->osteon.decode_ms / 1e3);
    auto rate = [&](double ms) { return ms > 0 ? fixed(t / ms / 1e3, 1) : std::string("n/a"); };
    slow_decode
        << "| " << r->label << " | " << fixed(wasm_rate / 1e6, 1) << " | "
        << fixed(native_rate / 1e6, 1) << " | " << rate(r->draco.level[0].wasm_ms) << " | "
        << rate(r->meshopt.v1_wasm_ms) << " | "
        << (native_rate < kWasmTrianglesPerSecond
                ? "the native decoder is under the target too (" + fixed(native_rate / 1e6, 1) +
                      "M): each vertex's prediction and residual contexts wait on its decoded "
                      "neighbours (docs/DESIGN.md, \"Decode speed\")"
                : "WebAssembly " + fixed(r->osteon.wasm_ms / r->osteon.decode_ms, 2) +
                      "x the native decode time") +
               " |\n";
  }
  if (!slow_decode.str().empty()) {
    md << "### Under the decode target: why\n\n"
       << "Each ct-like mesh decoded under " << fixed(kWasmTrianglesPerSecond / 1e6, 0)
       << "M triangles/s by osteon's WebAssembly decoder, in M triangles/s, beside its native "
          "decoder's rate (same stream, same machine) and the WebAssembly peers' (meshopt 1.x: "
          "gunzip included).\n\n"
       << "| mesh | osteon WASM | osteon native | Draco cl7 WASM | meshopt 1.x WASM | why |\n"
          "|---|---:|---:|---:|---:|---|\n"
       << slow_decode.str() << "\n";
  }

  // The encoder without its search (EncodeOptions::effort 0), against the default and the peers.
  {
    auto fast_row = [&](const std::string& label, const Totals& t) {
      if (t.meshes == 0 || !t.fast_ok)
        return "| " + label + " | " + std::to_string(t.meshes) + " | n/a | n/a | n/a | n/a |\n";
      return "| " + label + " | " + std::to_string(t.meshes) + " | " + kb(t.osteon) + " / " +
             kb(t.fast) + " | " + fixed(t.fast / t.osteon, 3) + " | " + fixed(t.fast / t.cl10, 3) +
             " / " + fixed(t.fast / t.cl7, 3) + " | " + ms_text(t.osteon_enc) + " / " +
             ms_text(t.fast_enc) + " / " + ms_text(t.cl7_enc) + " |\n";
    };
    md << "### Effort 0: the encoder without its search\n\n"
       << "osteon encode's `--effort 0` (EncodeOptions::effort): one coding chosen up front (the "
          "mean of the parallelograms on the tangent plane, or lattice coding on a lattice; the "
          "plain parallelogram; a fixed extrapolation weight; one connectivity context model), "
          "the same decoder. Every mesh again, timed like the default.\n\n"
       << "| set | meshes | osteon KB, default / effort 0 | effort 0 / default | effort 0 / "
          "Draco cl10 / cl7 | enc ms, default / effort 0 / Draco cl7 |\n"
       << "|---|---:|---:|---:|---:|---:|\n";
    for (const Row* r : ct) md << fast_row("ct-like " + r->label, totals({r}));
    for (const auto& [g, in_group] : by_group) md << fast_row("all " + g->name, totals(in_group));
    md << fast_row("**all meshes**", overall) << "\n";
  }

  // Targets, each computed.
  md << "### Targets (at " << bits << "-bit positions)\n\n";
  auto target = [&](const std::string& name, std::optional<bool> met, const std::string& detail) {
    std::string verdict = !met ? "not measured" : *met ? "**met**" : "**not met**";
    std::string text = detail;
    while (!text.empty() && (text.back() == ' ' || text.back() == ';')) text.pop_back();
    md << "- " << name << ": " << verdict << ". " << text << "\n";
    report.targets.push_back(
        {{"target", name}, {"met", met ? json(*met) : json(nullptr)}, {"detail", text}});
  };

  {  // Size: at most kSizeTarget of Draco cl10 summed over every group, and on skull_mc.ply;
     // the meshes over it are named.
    std::map<std::string, std::pair<double, double>> group_bytes;  // osteon, cl10
    std::vector<std::string> group_order;
    std::string misses;
    size_t over_count = 0, coded = 0;
    bool skull_over = false, skull_seen = false;
    for (const Row& r : rows) {
      if (!comparable(r)) continue;
      ++coded;
      const double ours = double(r.osteon.report.bytes), cl10 = double(r.draco.level[1].bytes);
      if (!group_bytes.count(r.group)) group_order.push_back(r.group);
      group_bytes[r.group].first += ours;
      group_bytes[r.group].second += cl10;
      const double ratio = ours / cl10;
      if (r.label == "skull_mc.ply") {
        skull_seen = true;
        skull_over = ratio > kSizeTarget;
      }
      if (ratio > kSizeTarget) {
        ++over_count;
        if (misses.size() < 600) misses += " " + r.label + " (" + fixed(ratio, 3) + ")";
      }
    }
    std::string detail;
    bool groups_over = false;
    for (const std::string& g : group_order) {
      const double ratio = group_bytes[g].first / group_bytes[g].second;
      groups_over = groups_over || ratio > kSizeTarget;
      detail += g + " " + fixed(ratio, 3) + "x; ";
    }
    detail += std::to_string(coded - over_count) + " of " + std::to_string(coded) +
              " meshes at most " + fixed(kSizeTarget, 2) + "x";
    if (!misses.empty()) detail += "; over:" + misses;
    target("size at most 0.90x Draco cl10 on every group and on skull_mc.ply",
           coded == 0 || !skull_seen ? std::nullopt
                                     : std::optional<bool>(!groups_over && !skull_over),
           detail);
  }
  {  // Connectivity under 1.8 bpv on closed meshes.
    size_t closed = 0, under = 0;
    std::string misses;
    double worst = 0;
    for (const Row& r : rows) {
      if (!osteon_ok(r) || !r.closed) continue;
      ++closed;
      double bpv = r.osteon.report.connectivity_bits_per_vertex;
      worst = std::max(worst, bpv);
      if (bpv < kConnectivityTarget) {
        ++under;
      } else if (misses.size() < 400) {
        misses += " " + r.group + " " + r.label + " (" + fixed(bpv, 2) + ")";
      }
    }
    std::string detail = std::to_string(under) + " of " + std::to_string(closed) +
                         " closed meshes under " + fixed(kConnectivityTarget, 1) + " bpv; worst " +
                         fixed(worst, 2) + " bpv";
    if (!misses.empty()) detail += "; over:" + misses;
    target("connectivity under 1.8 bits per vertex on closed meshes",
           closed ? std::optional<bool>(under == closed) : std::nullopt, detail);
  }
  {  // WASM decode >= 25M triangles/s, on the ct-like meshes (the 1M-triangle bones).
    std::optional<bool> met;
    std::string detail;
    for (const Row* r : ct) {
      if (!osteon_ok(*r) || r->osteon.wasm_ms < 0) {
        met = std::nullopt;
        detail = "osteon WASM: " +
                 (r->osteon.wasm_error.empty() ? std::string("no stream") : r->osteon.wasm_error);
        break;
      }
      double rate = double(r->triangles) / (r->osteon.wasm_ms / 1e3);
      met = met.value_or(true) && rate >= kWasmTrianglesPerSecond;
      detail += r->label + " " + fixed(rate / 1e6, 1) + "M triangles/s (" +
                ms_text(r->osteon.wasm_ms) + " ms); ";
    }
    if (ct.empty()) detail = "no ct-like mesh";
    target("WASM decode at least 25M triangles/s single-threaded (ct-like meshes)", met, detail);
  }
  // Encode no slower than Draco cl7, on each ct-like mesh and summed over each group: at the
  // default effort, or (fast) at effort 0, with the bytes that costs.
  auto against_cl7 = [&](bool fast) {
    bool met = overall.meshes > 0;
    std::string detail;
    for (const Row* r : ct) {
      if (!comparable(*r)) continue;
      met = met && (!fast || r->osteon.fast_error.empty());
      const double ms = fast ? r->osteon.fast_encode_ms : r->osteon.encode_ms;
      met = met && ms <= r->draco.level[0].encode_ms;
      detail +=
          r->label + " " + ms_text(ms) + " vs " + ms_text(r->draco.level[0].encode_ms) + " ms; ";
    }
    for (const auto& [g, in_group] : by_group) {
      Totals gt = totals(in_group);
      if (gt.meshes == 0) continue;
      const double ms = fast ? gt.fast_enc : gt.osteon_enc;
      met = met && (!fast || gt.fast_ok) && ms <= gt.cl7_enc;
      detail += "all " + g->name + " " + ms_text(ms) + " vs " + ms_text(gt.cl7_enc) + " ms" +
                (fast ? " (" + fixed(gt.fast / gt.cl10, 3) + "x Draco cl10's bytes)" : "") + "; ";
    }
    return std::make_pair(met, detail);
  };
  {
    auto [met, detail] = against_cl7(false);
    size_t faster = 0;
    for (const Row* r : all)
      if (comparable(*r) && r->osteon.encode_ms <= r->draco.level[0].encode_ms) ++faster;
    detail += std::to_string(faster) + " of " + std::to_string(overall.meshes) +
              " meshes encode no slower than Draco cl7";
    target("encode no slower than Draco cl7 (each ct-like mesh and each group's sum)",
           overall.meshes ? std::optional<bool>(met) : std::nullopt, detail);
  }
  {  // The same at effort 0 (no search).
    auto [met, detail] = against_cl7(true);
    std::string failed;
    double worst = 0;
    for (const Row* r : all) {
      if (!comparable(*r)) continue;
      if (!r->osteon.fast_error.empty()) {
        failed += " " + r->label + " (" + r->osteon.fast_error + ")";
      } else if (r->osteon.fast.grid_step > 0) {
        worst = std::max(worst, r->osteon.fast.max_error / r->osteon.fast.grid_step);
      }
    }
    detail += failed.empty() ? "every effort-0 stream decoded to as many triangles"
                             : "effort 0 failed on:" + failed;
    detail += ", worst position error " + fixed(worst, 3) + " step";
    target("encode no slower than Draco cl7 at effort 0 (each ct-like mesh and each group's sum)",
           overall.meshes ? std::optional<bool>(met) : std::nullopt, detail);
  }
  {  // Decoder download.
    DecoderSize size = decoder_size(source_dir, decoder_dir);
    std::string draco = draco_decoder_size(source_dir);
    target("decoder download at most 25 KB (25,000 bytes) gzipped",
           size.gzipped >= 0 ? std::optional<bool>(size.gzipped <= kDecoderDownloadTarget)
                             : std::nullopt,
           size.text + (draco.empty() ? "" : "; for scale, " + draco));
  }
  {  // Exact: every position within half a grid step, every triangle decoded.
    size_t meshes = 0, exact = 0;
    double worst = 0;
    std::string misses;
    for (const Row& r : rows) {
      if (!r.error.empty()) continue;
      ++meshes;
      if (!osteon_ok(r)) {
        misses += " " + r.label + " (" + r.osteon.error.substr(0, 80) + ")";
        continue;
      }
      const osteon::EncodeReport& e = r.osteon.report;
      // Half a step, plus float rounding of the decoded coordinate.
      double scale = std::max({std::fabs(e.grid.origin.x), std::fabs(e.grid.origin.y),
                               std::fabs(e.grid.origin.z)}) +
                     double((uint64_t{1} << bits)) * e.grid_step;
      double bound = 0.5 * e.grid_step + scale * std::ldexp(1.0, -23);
      worst = std::max(worst, e.max_error / e.grid_step);
      if (e.max_error <= bound)
        ++exact;
      else
        misses += " " + r.label + " (" + fixed(e.max_error / e.grid_step, 3) + " step)";
    }
    std::string detail = std::to_string(exact) + " of " + std::to_string(meshes) +
                         " meshes coded with every position within half a grid step (worst " +
                         fixed(worst, 3) +
                         " step, float rounding allowed) and as many triangles "
                         "decoded as coded; identical connectivity is checked by the round-trip "
                         "tests, not here";
    if (!misses.empty()) detail += "; misses:" + misses;
    target("exact", meshes ? std::optional<bool>(exact == meshes) : std::nullopt, detail);
  }

  {  // The WebAssembly decoder gives the native decoder's arrays, bit for bit.
    size_t compared = 0, identical = 0;
    std::string misses;
    for (const Row& r : rows) {
      if (r.osteon.wasm_identity.empty()) continue;
      ++compared;
      if (r.osteon.wasm_identity == "identical") {
        ++identical;
      } else if (misses.size() < 400) {
        misses += " " + r.label + " (" + r.osteon.wasm_identity + ")";
      }
    }
    size_t coded = 0;
    for (const Row& r : rows) coded += osteon_ok(r) ? 1 : 0;
    std::string detail = std::to_string(identical) + " of " + std::to_string(coded) +
                         " meshes decoded by the WebAssembly decoder to the native decoder's "
                         "positions, indices and smooth normals, bit for bit (SHA-256 of each "
                         "array)";
    if (compared < coded) {
      detail += "; " + std::to_string(coded - compared) + " not compared (no WASM decode)";
    }
    if (!misses.empty()) detail += "; differ:" + misses;
    target("WASM decoder bit-identical to the native one",
           compared ? std::optional<bool>(identical == coded) : std::nullopt, detail);
  }

  // Peers that were not measured.
  std::vector<std::string> notes;
  if (!wasm.unavailable.empty()) notes.push_back("WASM decoders: " + wasm.unavailable);
  if (wasm.unavailable.empty()) {
    if (wasm.report["osteon"].contains("unavailable"))
      notes.push_back("osteon WASM: " + wasm.report["osteon"]["unavailable"].get<std::string>());
    if (wasm.report["draco3d"].contains("unavailable"))
      notes.push_back("Draco WASM: " + wasm.report["draco3d"]["unavailable"].get<std::string>());
  }
  {  // Streams a WASM decoder rejected (an osteon decoder built from another tree than the
     // encoder, for one).
    std::map<std::string, std::pair<size_t, std::string>> failed;  // codec: count, first error
    auto count = [&](const std::string& codec, double ms, const std::string& error) {
      if (ms >= 0 || wasm_text(ms, error) != "fails") return;
      auto& [n, first] = failed[codec];
      if (n++ == 0) first = error;
    };
    for (const Row& r : rows) {
      count("osteon", r.osteon.wasm_ms, r.osteon.wasm_error);
      for (const DracoResult& d : r.draco.level) count("Draco", d.wasm_ms, d.wasm_error);
    }
    for (const auto& [codec, what] : failed)
      notes.push_back(codec + " WASM decoder failed on " + std::to_string(what.first) +
                      " streams; first: " + what.second);
  }
  for (const Row& r : rows) {
    if (!r.error.empty()) notes.push_back(r.label + ": " + r.error);
    for (int i = 0; i < 2; ++i)
      if (r.error.empty() && r.draco.level[i].error.empty() &&
          r.draco.level[i].decoded_triangles != r.triangles)
        notes.push_back(r.label + ": Draco cl" + std::to_string(kDracoLevels[i]) + " decoded " +
                        std::to_string(r.draco.level[i].decoded_triangles) + " of " +
                        std::to_string(r.triangles) + " triangles");
    if (!r.draco.max_error_note.empty())
      notes.push_back(r.label + ": Draco max error not measured (" + r.draco.max_error_note + ")");
    if (osteon_ok(r) && r.osteon.report.degenerate_removed > 0)
      notes.push_back(r.label + ": osteon removed " +
                      std::to_string(r.osteon.report.degenerate_removed) +
                      " degenerate triangles before coding");
  }
  if (!notes.empty()) {
    md << "\nNotes:\n\n";
    for (const std::string& n : notes) md << "- " << n << "\n";
  }
  report.markdown = md.str();
  return report;
}

std::string safe_name(std::string name) {
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return name;
}

}  // namespace
}  // namespace osteon_bench

int main(int argc, char** argv) {
  using namespace osteon_bench;
  CLI::App app{"osteon codec benchmark: osteon against Draco and meshoptimizer, native and WASM"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string source_dir = OSTEON_SOURCE_DIR;
  std::string write_path, json_path, keep_dir, only;
  int bits = 14;
  int largest_parts = 10;
  bool no_wasm = false;
  std::string clock = "cpu";
  std::string wasm_dir;
  Timing timing;
  app.add_option("--bits", bits, "position bits for every codec (8..24)")->check(CLI::Range(8, 24));
  app.add_option("--data", data, "folder of real meshes (../shared/data)");
  app.add_option("--source", source_dir,
                 "the repository (for bench/codec_wasm.mjs, bench/node_modules, build/wasm)");
  app.add_option("--wasm-dir", wasm_dir,
                 "the built osteon WASM decoder (default: build/wasm, then web/decoder)");
  app.add_option("--repeat", timing.repeat, "runs per time; the best counts")
      ->check(CLI::Range(1, 100));
  app.add_option("--min-seconds", timing.min_seconds,
                 "keep running a small mesh until this much time has passed (at most 100 runs)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--clock", clock, "native times: cpu (thread CPU time) or wall")
      ->check(CLI::IsMember({"cpu", "wall"}));
  app.add_option("--parts", largest_parts, "how many of the largest BodyParts3D bones")
      ->check(CLI::Range(0, 1000));
  app.add_option("--only", only, "measure only meshes whose group or name contains this text");
  app.add_flag("--no-wasm", no_wasm, "skip the Node run (WASM columns n/a)");
  app.add_option("--keep", keep_dir, "write the .ostm and .drc streams here and keep them");
  app.add_option("--json", json_path, "write every measurement as JSON to this file");
  app.add_option("--write", write_path,
                 "replace the section '## Mesh codec' of this Markdown file");
  CLI11_PARSE(app, argc, argv);
  timing.wall = clock == "wall";

  fs::path decoder_dir = find_decoder_dir(source_dir, wasm_dir);
  fs::path scratch = keep_dir.empty() ? fs::temp_directory_path() /
                                            ("osteon_codec_bench_" + std::to_string(getpid()))
                                      : fs::path(keep_dir);
  fs::create_directories(scratch);
  scratch = fs::absolute(scratch);

  std::vector<Group> groups = find_groups(data, largest_parts);
  if (groups.empty()) {
    std::fprintf(stderr, "codec_bench: no inputs under %s\n", data.c_str());
    return 1;
  }

  std::vector<Row> rows;
  auto wanted = [&](const Group& group, const std::string& label) {
    return only.empty() || label.find(only) != std::string::npos ||
           group.name.find(only) != std::string::npos;
  };
  // Codes one mesh (or records why it could not be read) as a row.
  auto measure = [&](Row row, const std::optional<osteon::Mesh>& mesh) {
    std::fprintf(stderr, "codec_bench: %s %s ...\n", row.group.c_str(), row.label.c_str());
    if (!mesh) {
      rows.push_back(row);
      return;
    }
    row.vertices = mesh->vertex_count();
    row.triangles = mesh->triangle_count();
    row.closed = osteon::diagnose(*mesh).closed;
    std::string stem = scratch / (std::to_string(rows.size()) + "_" + safe_name(row.label));
    row.osteon = run_osteon(*mesh, bits, timing, stem + ".ostm");
    row.draco = run_draco(*mesh, bits, timing, stem);
    const size_t cl10 = row.draco.level[1].error.empty() ? row.draco.level[1].bytes : 0;
    if (row.osteon.error.empty() && cl10 > 0 &&
        double(row.osteon.report.bytes) > kSizeTarget * double(cl10))
      row.draco_connectivity = draco_connectivity_bytes(*mesh, bits);
    row.meshopt = run_meshopt(*mesh, bits, timing);
    if (write_bytes(stem + ".mvb", row.meshopt.buffers.data(), row.meshopt.buffers.size()))
      row.meshopt.buffers_file = stem + ".mvb";
    row.meshopt.buffers = {};
    rows.push_back(std::move(row));
  };
  for (const Group& group : groups) {
    for (const fs::path& file : group.files) {
      Row row;
      row.group = group.name;
      row.label = file.filename().string();
      row.file = file;
      std::error_code ec;
      row.file_bytes = fs::file_size(file, ec);
      if (!group.per_part) {
        if (wanted(group, row.label)) measure(row, read_mesh(file, &row.error));
        continue;
      }
      fs::path input = file;
      if (group.voxelize > 0) {  // the file's meshes as a label volume, in the scratch folder
        if (!wanted(group, row.label)) continue;
        input = scratch / (safe_name(file.stem().string()) + ".nii.gz");
        osteon::Result<osteon::Scene> meshes = osteon::read_path(file.string());
        osteon::VoxelizeOptions options;
        options.voxel = group.voxelize;
        osteon::Status written = meshes.ok() ? osteon::voxelize(*meshes, input.string(), options)
                                             : meshes.status();
        if (!written.ok()) {
          row.error = written.message();
          if (wanted(group, row.label)) measure(row, std::nullopt);
          continue;
        }
      }
      auto scene = osteon::read_path(input.string(), group.read);
      if (!scene.ok()) {
        row.error = scene.status().message();
        if (wanted(group, row.label)) measure(row, std::nullopt);
        continue;
      }
      for (osteon::Mesh& part : scene->parts) {
        Row part_row = row;
        // A voxelized file's one label is the file itself.
        if (group.voxelize == 0) part_row.label = row.label + ": " + part.name;
        if (wanted(group, part_row.label)) measure(part_row, std::move(part));
      }
    }
  }

  WasmRun wasm;
  if (no_wasm) {
    wasm.unavailable = "skipped (--no-wasm)";
  } else {
    std::vector<std::string> streams;
    for (const Row& r : rows) {
      if (!r.osteon.stream.empty()) streams.push_back(r.osteon.stream);
      for (const DracoResult& d : r.draco.level)
        if (!d.stream.empty()) streams.push_back(d.stream);
      if (!r.meshopt.buffers_file.empty()) streams.push_back(r.meshopt.buffers_file);
    }
    std::fprintf(stderr,
                 "codec_bench: WASM decoders (node bench/codec_wasm.mjs, %zu streams) ...\n",
                 streams.size());
    wasm = run_wasm(source_dir, decoder_dir, streams, timing);
  }
  merge_wasm(wasm, rows);
  if (keep_dir.empty()) fs::remove_all(scratch);

  Report report = build_report(rows, groups, source_dir, decoder_dir, wasm, bits);
  std::printf("%s", report.markdown.c_str());

  if (!json_path.empty()) {
    json out = json::array();
    for (const Row& r : rows) {
      json j = {{"group", r.group},           {"mesh", r.label},        {"file", r.file.string()},
                {"file_bytes", r.file_bytes}, {"vertices", r.vertices}, {"triangles", r.triangles},
                {"closed", r.closed},         {"error", r.error}};
      const osteon::EncodeReport& e = r.osteon.report;
      j["osteon"] = {{"error", r.osteon.error},
                     {"bytes", e.bytes},
                     {"connectivity_bits_per_vertex", e.connectivity_bits_per_vertex},
                     {"geometry_bits_per_vertex", e.geometry_bits_per_vertex},
                     {"max_error", e.max_error},
                     {"grid_step", e.grid_step},
                     {"encode_ms", r.osteon.encode_ms},
                     {"decode_ms", r.osteon.decode_ms},
                     {"wasm_decode_ms", r.osteon.wasm_ms},
                     {"wasm_error", r.osteon.wasm_error},
                     {"wasm_identity", r.osteon.wasm_identity},
                     {"geometry_passes", r.osteon.report.geometry_passes},
                     {"connectivity_models", r.osteon.report.connectivity_models},
                     {"effort0_bytes", r.osteon.fast.bytes},
                     {"effort0_encode_ms", r.osteon.fast_encode_ms},
                     {"effort0_error", r.osteon.fast_error}};
      for (int i = 0; i < 2; ++i)
        j["draco_cl" + std::to_string(kDracoLevels[i])] = {
            {"error", r.draco.level[i].error},
            {"bytes", r.draco.level[i].bytes},
            {"encode_ms", r.draco.level[i].encode_ms},
            {"decode_ms", r.draco.level[i].decode_ms},
            {"wasm_decode_ms", r.draco.level[i].wasm_ms},
            {"wasm_error", r.draco.level[i].wasm_error},
            {"decoded_triangles", r.draco.level[i].decoded_triangles}};
      j["draco_max_error"] = r.draco.max_error;
      j["meshopt_gzip"] = {{"error", r.meshopt.error},
                           {"bytes", r.meshopt.bytes},
                           {"encode_ms", r.meshopt.encode_ms},
                           {"decode_ms", r.meshopt.decode_ms},
                           {"max_error", r.meshopt.max_error}};
      j["meshopt_v1_gzip"] = {{"error", r.meshopt.v1_error},
                              {"bytes", r.meshopt.v1_bytes},
                              {"wasm_decode_ms", r.meshopt.v1_wasm_ms}};
      out.push_back(j);
    }
    json doc = {{"bits", bits}, {"clock", clock}, {"rows", out}, {"targets", report.targets}};
    if (wasm.unavailable.empty())
      doc["wasm"] = {{"node", wasm.report["node"]},
                     {"draco3d", wasm.report["draco3d"]},
                     {"osteon", wasm.report["osteon"]}};
    std::ofstream(json_path) << doc.dump(1) << "\n";
  }

  if (!write_path.empty()) {
    char date[32];
    std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%d", std::gmtime(&now));
    char min_seconds[32];
    std::snprintf(min_seconds, sizeof(min_seconds), "%g", timing.min_seconds);
    std::string command = "build-bench/codec_bench --bits " + std::to_string(bits) + " --repeat " +
                          std::to_string(timing.repeat) + " --min-seconds " + min_seconds +
                          (clock == "wall" ? " --clock wall" : "") +
                          (wasm_dir.empty() ? "" : " --wasm-dir " + wasm_dir) +
                          (only.empty() ? "" : " --only '" + only + "'") + " --write " + write_path;
    std::string node_line;
    if (wasm.unavailable.empty())
      node_line = "Node " + wasm.report.value("node", std::string("?")) + ", npm draco3d " +
                  wasm.report["draco3d"].value("version", std::string("not installed")) +
                  ", npm meshoptimizer " +
                  wasm.report["meshoptimizer"].value("version", std::string("not installed")) +
                  ". ";
    std::ostringstream body;
    body << "osteon against Draco " << draco::kDracoVersion
         << " (libdraco-dev, in-process, compression levels 7 and 10, positions only) and "
            "meshoptimizer "
         << MESHOPTIMIZER_VERSION / 1000 << "." << MESHOPTIMIZER_VERSION % 1000 / 10
         << " (vertex + index codecs on positions quantized to the same grid, then gzip -9), at "
         << bits
         << "-bit positions, every codec given the same welded mesh. WASM decode: osteon's "
            "WebAssembly decoder (web/decoder/build.sh) and npm draco3d's in one Node process, "
            "each decode copying positions and indices out to JavaScript arrays. Native times "
            "are the best of at least "
         << timing.repeat << " runs and of at least " << min_seconds << " s, "
         << (clock == "wall" ? "wall clock" : "thread CPU time (CLOCK_THREAD_CPUTIME_ID)")
         << "; WASM times the best of as many, wall clock (performance.now). osteon's decode "
            "includes computing smooth vertex normals; Draco's and meshopt's compute none. KB are "
            "1024 bytes; bpv is bits per vertex; max err the largest per-coordinate |decoded - "
            "input|, in mesh units. See bench/README.md.\n\n"
         << "Machine: " << osteon_bench::cpu_model() << ", " << sysconf(_SC_NPROCESSORS_ONLN)
         << " cores (shared). " << node_line << "Date: " << date
         << ". Commands (from the repository root; the encoder and the WASM decoder built from the "
            "same tree):\n\n"
         << "```\napt-get install -y libdraco-dev libmeshoptimizer-dev zlib1g-dev nodejs npm "
            "emscripten\n(cd bench && npm ci)\nbash web/decoder/build.sh\n"
            "cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release "
            "-DOSTEON_BUILD_BENCH=ON -DOSTEON_BUILD_TESTS=OFF\ncmake --build build-bench --target "
            "codec_bench\n"
         << command << "\n```\n\n"
         << report.markdown;
    if (!osteon_bench::write_section(write_path, "## Mesh codec", body.str())) {
      std::fprintf(stderr, "codec_bench: cannot write %s\n", write_path.c_str());
      return 1;
    }
  }
  return 0;
}
