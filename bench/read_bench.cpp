// SPDX-License-Identifier: Apache-2.0
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/version.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_markdown.hpp"
#include "osteon/io.hpp"

// Reading and welding throughput, osteon against Assimp, on the real meshes of ../shared/data.
//
// Every measurement runs in its own child process (this binary, `--one LIB INPUT`), so the peak
// resident memory a library needs is the child's ru_maxrss, measured by wait4() in the driver
// and never mixed with another library's allocations. A child that reads nothing (`--one none`)
// gives the floor every child starts from (the program, libstdc++ and libassimp mapped in).
//
// Both libraries produce the same thing: indexed triangles with exactly-equal positions merged.
// osteon: read_path with default options (weld on). Assimp: aiImportFile with
// JoinIdenticalVertices | Triangulate | DropNormals (without DropNormals, Assimp's STL and glTF
// importers keep a normal per corner and JoinIdenticalVertices cannot merge across facets, so it
// would return a different, larger mesh). Times are the best of at least --repeat reads (and of at
// least one second of reading), wall clock, file already in the page cache after the first run.

#ifndef OSTEON_SHARED_DATA_DIR
#define OSTEON_SHARED_DATA_DIR "../shared/data"
#endif

namespace {

namespace fs = std::filesystem;
using osteon_bench::fixed;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr unsigned kAssimpFlags =
    aiProcess_JoinIdenticalVertices | aiProcess_Triangulate | aiProcess_DropNormals;

bool is_mesh_file(const fs::path& path) {
  return osteon::format_from_extension(path.string()) != osteon::Format::kUnknown;
}

/// The mesh files of an input: itself, or every mesh file below a folder, in sorted order.
std::vector<fs::path> mesh_files(const fs::path& input) {
  std::vector<fs::path> files;
  if (fs::is_directory(input)) {
    for (const auto& entry : fs::recursive_directory_iterator(input)) {
      if (entry.is_regular_file() && is_mesh_file(entry.path())) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(input);
  }
  return files;
}

struct Counts {
  uint64_t triangles = 0;
  uint64_t vertices = 0;
};

std::optional<Counts> read_osteon(const fs::path& input, std::string* error) {
  auto scene = osteon::read_path(input.string());
  if (!scene.ok()) {
    *error = scene.status().message();
    return std::nullopt;
  }
  Counts counts;
  for (const osteon::Mesh& part : scene->parts) {
    counts.triangles += part.triangle_count();
    counts.vertices += part.vertex_count();
  }
  return counts;
}

std::optional<Counts> read_assimp(const std::vector<fs::path>& files, std::string* error) {
  Counts counts;
  for (const fs::path& file : files) {
    const aiScene* scene = aiImportFile(file.c_str(), kAssimpFlags);
    if (scene == nullptr) {
      *error = file.filename().string() + ": " + aiGetErrorString();
      return std::nullopt;
    }
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
      const aiMesh* mesh = scene->mMeshes[m];
      counts.vertices += mesh->mNumVertices;
      for (unsigned f = 0; f < mesh->mNumFaces; ++f)
        counts.triangles += mesh->mFaces[f].mNumIndices == 3;
    }
    aiReleaseImport(scene);
  }
  return counts;
}

/// Child mode: reads `input` at least `repeat` times (and for at least a second) with one library
/// and prints one JSON object with the best time.
int run_one(const std::string& library, const fs::path& input, int repeat) {
  json out = {{"library", library}, {"input", input.string()}};
  std::vector<fs::path> files = mesh_files(input);
  uint64_t bytes = 0;
  for (const fs::path& file : files) bytes += fs::file_size(file);
  out["files"] = files.size();
  out["bytes"] = bytes;
  if (library == "none") {
    out["ok"] = true;
    std::printf("%s\n", out.dump().c_str());
    return 0;
  }
  // Small files read in milliseconds, where one preemption doubles a time: keep reading until a
  // second has passed (at most 100 reads), and keep the best.
  constexpr double kMinSeconds = 1.0;
  double best = 1e300, total = 0;
  Counts counts;
  int reads = 0;
  for (; reads < repeat || (total < kMinSeconds && reads < 100); ++reads) {
    std::string error;
    auto start = Clock::now();
    std::optional<Counts> got =
        library == "osteon" ? read_osteon(input, &error) : read_assimp(files, &error);
    double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (!got) {
      out["ok"] = false;
      out["error"] = error;
      std::printf("%s\n", out.dump().c_str());
      return 0;
    }
    counts = *got;
    best = std::min(best, seconds);
    total += seconds;
  }
  out["ok"] = true;
  out["triangles"] = counts.triangles;
  out["vertices"] = counts.vertices;
  out["seconds"] = best;
  out["reads"] = reads;
  out["mesh_bytes"] = 12 * counts.vertices + 12 * counts.triangles;
  std::printf("%s\n", out.dump().c_str());
  return 0;
}

struct ChildResult {
  json report;
  double peak_rss_mb = 0;
};

/// Runs `self --one library input --repeat n` and collects its JSON and its peak RSS.
ChildResult run_child(const std::string& self, const std::string& library, const fs::path& input,
                      int repeat) {
  ChildResult result;
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) {
    result.report = {{"ok", false}, {"error", "pipe failed"}};
    return result;
  }
  std::fflush(stdout);
  pid_t pid = fork();
  if (pid == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    std::string repeat_text = std::to_string(repeat);
    execl(self.c_str(), self.c_str(), "--one", library.c_str(), input.c_str(), "--repeat",
          repeat_text.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  close(pipe_fds[1]);
  std::string output;
  char buffer[4096];
  ssize_t n;
  while ((n = read(pipe_fds[0], buffer, sizeof(buffer))) > 0) output.append(buffer, size_t(n));
  close(pipe_fds[0]);
  int status = 0;
  rusage usage{};
  if (pid < 0 || wait4(pid, &status, 0, &usage) < 0) {
    result.report = {{"ok", false}, {"error", "fork or wait failed"}};
    return result;
  }
  result.peak_rss_mb = double(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
  json parsed = json::parse(output, nullptr, /*allow_exceptions=*/false);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || parsed.is_discarded()) {
    result.report = {{"ok", false},
                     {"error", "child failed (status " + std::to_string(status) + ")"}};
  } else {
    result.report = parsed;
  }
  return result;
}

// ---- inputs --------------------------------------------------------------------------------

struct Input {
  std::string label;
  std::string format;
  fs::path path;
};

std::optional<fs::path> largest(const fs::path& dir, const std::string& extension) {
  std::optional<fs::path> best;
  uintmax_t best_size = 0;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return std::nullopt;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().extension() != extension) continue;
    if (entry.file_size() > best_size) {
      best_size = entry.file_size();
      best = entry.path();
    }
  }
  return best;
}

/// True when a .stl file is ASCII (not 84 + 50 * count bytes, and starts with "solid").
bool is_ascii_stl(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char head[84] = {};
  in.read(head, sizeof(head));
  if (std::strncmp(head, "solid", 5) != 0) return false;
  uint32_t count = 0;
  std::memcpy(&count, head + 80, 4);
  return fs::file_size(path) != 84 + uint64_t{count} * 50;
}

/// Writes `mesh` as ASCII STL (what CAD exporters write: %e floats, a normal per facet).
bool write_ascii_stl(const fs::path& path, const osteon::Mesh& mesh) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) return false;
  std::fprintf(f, "solid %s\n", mesh.name.c_str());
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    std::fprintf(f, "  facet normal 0 0 0\n    outer loop\n");
    for (int k = 0; k < 3; ++k) {
      const osteon::Vec3& p = mesh.positions[mesh.indices[3 * t + k]];
      std::fprintf(f, "      vertex %.9e %.9e %.9e\n", p.x, p.y, p.z);
    }
    std::fprintf(f, "    endloop\n  endfacet\n");
  }
  std::fprintf(f, "endsolid %s\n", mesh.name.c_str());
  return std::fclose(f) == 0;
}

std::vector<Input> find_inputs(const fs::path& data, const fs::path& scratch) {
  std::vector<Input> inputs;
  auto add = [&](const std::string& label, const std::string& format, const fs::path& path) {
    std::error_code ec;
    if (fs::exists(path, ec)) {
      inputs.push_back({label, format, path});
    } else {
      std::fprintf(stderr, "read_bench: skipping %s: %s is absent\n", label.c_str(), path.c_str());
    }
  };
  add("skull_mc.ply", "PLY binary", data / "ct-like/skull_mc.ply");
  add("hip_mcs.ply", "PLY binary", data / "ct-like/hip_mcs.ply");
  auto vhf = largest(data / "ingvilddevold__muscle-growth", ".stl");
  if (vhf) add(vhf->filename().string(), "STL binary", *vhf);
  auto myo = largest(data / "MyoHub__myo_sim", ".stl");
  if (myo) add(myo->filename().string(), "STL binary", *myo);
  auto vtk = largest(data / "stity__spl-abdominal-atlas", ".vtk");
  if (vtk) add(vtk->filename().string(), "VTK binary", *vtk);
  auto off = largest(data / "cearto__zen__MeshsegBenchmark", ".off");
  if (off) add(off->filename().string(), "OFF", *off);
  add("BodyParts3D bones/ (folder)", "GLB", data / "aHer-dev__3DAnatomy/models/bones");

  // An ASCII STL: a real one if the data has one, else the largest binary STL written as ASCII.
  std::optional<fs::path> ascii;
  std::error_code ec;
  if (fs::is_directory(data, ec)) {
    for (const auto& entry : fs::recursive_directory_iterator(data)) {
      if (entry.is_regular_file() && entry.path().extension() == ".stl" &&
          is_ascii_stl(entry.path()) && (!ascii || fs::file_size(*ascii) < entry.file_size()))
        ascii = entry.path();
    }
  }
  if (ascii) {
    add(ascii->filename().string(), "STL ASCII", *ascii);
  } else if (vhf) {
    auto scene = osteon::read_path(vhf->string());
    fs::path out = scratch / (vhf->stem().string() + "_ascii.stl");
    if (scene.ok() && scene->parts.size() == 1 && write_ascii_stl(out, scene->parts[0]))
      add(vhf->stem().string() + " as ASCII (generated)", "STL ASCII", out);
  }
  return inputs;
}

// ---- the report ----------------------------------------------------------------------------


struct Row {
  Input input;
  ChildResult osteon;
  ChildResult assimp;
};

std::string markdown(const std::vector<Row>& rows, double floor_mb) {
  std::ostringstream md;
  md << "| input | format | size MB | triangles | library | vertices | MB/s | Mtriangles/s | "
        "peak RSS MB | peak / final mesh | (peak - floor) / final mesh | osteon / Assimp |\n"
     << "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& row : rows) {
    const json& o = row.osteon.report;
    const json& a = row.assimp.report;
    double osteon_speed =
        o.value("ok", false) ? o["bytes"].get<double>() / o["seconds"].get<double>() : 0.0;
    double assimp_speed =
        a.value("ok", false) ? a["bytes"].get<double>() / a["seconds"].get<double>() : 0.0;
    for (const ChildResult* child : {&row.osteon, &row.assimp}) {
      const json& r = child->report;
      bool is_osteon = child == &row.osteon;
      double mb = r.value("bytes", 0.0) / 1e6;
      md << "| " << row.input.label << " | " << row.input.format << " | " << fixed(mb, 2)
         << " | ";
      if (!r.value("ok", false)) {
        std::string why = r.value("error", std::string("failed"));
        std::replace(why.begin(), why.end(), '|', '/');
        if (why.size() > 80) why = why.substr(0, 77) + "...";
        md << "- | " << (is_osteon ? "osteon" : "Assimp") << " | fails: " << why
           << " | - | - | - | - | - | - |\n";
        continue;
      }
      double seconds = r["seconds"].get<double>();
      double triangles = r["triangles"].get<double>();
      double mesh_mb = r["mesh_bytes"].get<double>() / 1e6;
      md << r["triangles"].get<uint64_t>() << " | " << (is_osteon ? "**osteon**" : "Assimp")
         << " | " << r["vertices"].get<uint64_t>() << " | " << fixed(mb / seconds, 1)
         << " | " << fixed(triangles / seconds / 1e6, 2) << " | "
         << fixed(child->peak_rss_mb, 1) << " | "
         << fixed(child->peak_rss_mb / mesh_mb, 2) << " | "
         << fixed((child->peak_rss_mb - floor_mb) / mesh_mb, 2) << " | ";
      if (is_osteon && assimp_speed > 0)
        md << "**" << fixed(osteon_speed / assimp_speed, 1) << "x**";
      md << " |\n";
    }
  }
  md << "\nFloor: a child that reads nothing peaks at " << fixed(floor_mb, 1)
     << " MB RSS; every peak above includes it.\n";
  return md.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"osteon read benchmark: read + weld throughput and peak memory against Assimp"};
  std::vector<std::string> one;
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  std::string only;
  int repeat = 3;
  app.add_option("--one", one, "child mode: LIB INPUT (LIB is osteon, assimp or none)")
      ->expected(2);
  app.add_option("--data", data, "folder of real meshes (../shared/data)");
  app.add_option("--repeat", repeat, "reads per measurement; the best time counts")
      ->check(CLI::Range(1, 100));
  app.add_option("--write", write_path,
                 "replace the section '## Reading and welding' of this Markdown file");
  app.add_option("--only", only, "measure only inputs whose label contains this text");
  CLI11_PARSE(app, argc, argv);

  if (!one.empty()) {
    if (one[0] != "osteon" && one[0] != "assimp" && one[0] != "none") {
      std::fprintf(stderr, "read_bench: unknown library '%s'\n", one[0].c_str());
      return 2;
    }
    return run_one(one[0], one[1], repeat);
  }

  std::string self = fs::read_symlink("/proc/self/exe").string();
  fs::path scratch = fs::temp_directory_path() / ("osteon_read_bench_" + std::to_string(getpid()));
  fs::create_directories(scratch);
  std::vector<Input> inputs = find_inputs(data, scratch);
  if (inputs.empty()) {
    std::fprintf(stderr, "read_bench: no inputs under %s\n", data.c_str());
    fs::remove_all(scratch);
    return 1;
  }

  ChildResult floor = run_child(self, "none", inputs.front().path, 1);
  std::vector<Row> rows;
  for (const Input& input : inputs) {
    if (!only.empty() && input.label.find(only) == std::string::npos) continue;
    std::fprintf(stderr, "read_bench: %s ...\n", input.label.c_str());
    Row row{input, run_child(self, "osteon", input.path, repeat),
            run_child(self, "assimp", input.path, repeat)};
    rows.push_back(row);
  }
  fs::remove_all(scratch);

  std::string table = markdown(rows, floor.peak_rss_mb);
  std::printf("%s", table.c_str());
  if (!write_path.empty()) {
    char date[32];
    std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%d", std::gmtime(&now));
    std::string command = "build-bench/read_bench --repeat " + std::to_string(repeat) +
                          (only.empty() ? "" : " --only '" + only + "'") + " --write " + write_path;
    std::ostringstream body;
    body << "Read + weld (exactly-equal positions merged) of the largest real meshes in "
            "../shared/data and of the whole BodyParts3D skeleton folder, osteon (`read_path`, "
            "default options) against Assimp "
         << aiGetVersionMajor() << "." << aiGetVersionMinor() << "." << aiGetVersionPatch()
         << " (`aiImportFile` with JoinIdenticalVertices | Triangulate | DropNormals). Each "
            "library runs in its own child process; the time is the best of at least "
         << repeat
         << " reads and of at least 1 s of reading, files in the page cache. Peak RSS is the "
            "child's `ru_maxrss`; the final "
            "mesh is 12 bytes a vertex + 12 bytes a triangle.\n\n"
         << "Targets: at least 5x Assimp's throughput on binary STL and PLY; peak "
            "memory under 3x the final indexed mesh.\n\n"
         << "Machine: " << osteon_bench::cpu_model() << ", " << sysconf(_SC_NPROCESSORS_ONLN)
         << " cores. Date: " << date << ". Command (Release build, from the repository root):\n\n"
         << "```\ncmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release "
            "-DOSTEON_BUILD_BENCH=ON -DOSTEON_BUILD_TESTS=OFF\ncmake --build build-bench --target "
            "read_bench\n"
         << command << "\n```\n\n"
         << table;
    if (!osteon_bench::write_section(write_path, "## Reading and welding", body.str())) {
      std::fprintf(stderr, "read_bench: cannot write %s\n", write_path.c_str());
      return 1;
    }
  }
  return 0;
}
