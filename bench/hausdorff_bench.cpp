// SPDX-License-Identifier: Apache-2.0
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_markdown.hpp"
#include "osteon/codec.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"

// osteon's Hausdorff distance against MeshLab's "Hausdorff Distance" filter (Debian's meshlab,
// run headless: xvfb-run -a meshlabserver -i A -i B -s script.mlx -l log) on a 1M-triangle
// CT-like surface and three processed copies: quantized to 10 and 14 bits by osteon's codec
// (encode + decode) and displaced along its normals.
//
// Fair terms. Both tools sample the same mesh files with the same split: MeshLab's SampleNum K
// takes every vertex (when K >= vertices), K points on the edges and K on the faces; osteon runs
// at V + 2K samples, which its HausdorffOptions split the same way (all vertices, K edge points at
// Metro's evenly spaced positions, which are MeshLab's, and K face points, stratified where
// MeshLab's are plain Monte Carlo). K is chosen so that V + 2K is osteon's default, 10 samples a
// triangle. MaxDist is twice the bounding-box diagonal, so no sample is dropped. MeshLab's time
// is its run minus a run of an empty script on the same inputs (start-up and loading), so both
// columns time the same work: the search structure on the target mesh plus every sample.
// osteon's time is DistanceQuery::build plus one_sided_distance, on every core.
//
// Tightness: the same measurement at --dense times the samples; for the quantized copies also
// the certified upper bound (every vertex within half a grid step per coordinate, so every point
// within sqrt(3)/2 steps, plus float rounding).

#ifndef OSTEON_SHARED_DATA_DIR
#define OSTEON_SHARED_DATA_DIR "../shared/data"
#endif

namespace {

namespace fs = std::filesystem;
using osteon_bench::fixed;
using osteon_bench::grouped;
using osteon_bench::sig;
using Clock = std::chrono::steady_clock;

struct Figures {
  bool ok = false;
  std::string error;
  double max = 0, mean = 0, rms = 0;
  uint64_t samples = 0;
  double seconds = 0;      // wall clock of the measurement
  double cpu_seconds = 0;  // CPU time of every thread (osteon) or of the child (MeshLab)
};

struct Direction {
  std::string label;  // "A -> B"
  const osteon::Mesh* sampled = nullptr;
  const osteon::Mesh* target = nullptr;
  fs::path sampled_path, target_path;
  int sampled_index = 0;  // in MeshLab's mesh list (-i order)
  Figures osteon, meshlab, dense;
  uint64_t k = 0;  // MeshLab's SampleNum
};

struct Pair {
  std::string label;
  std::string what;
  fs::path a_path, b_path;
  osteon::Mesh a, b;
  double certified = 0;  // an upper bound of the true distance, when known (0: none)
  double meshlab_load_seconds = 0;
  Direction forward, backward;
};

double cpu_seconds_self() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double cpu_seconds_children() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}




std::string percent(double ours, double theirs) {
  if (theirs == 0) return ours == 0 ? "0%" : "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%+.2f%%", 100.0 * (ours - theirs) / theirs);
  return text;
}

double diagonal(const osteon::Mesh& a, const osteon::Mesh& b) {
  osteon::Aabb box = osteon::bounding_box(a);
  osteon::expand(box, osteon::bounding_box(b));
  double dx = double(box.max.x) - box.min.x, dy = double(box.max.y) - box.min.y,
         dz = double(box.max.z) - box.min.z;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

bool on_path(const std::string& program) {
  return std::system(("command -v " + program + " >/dev/null 2>&1").c_str()) == 0;
}

std::optional<osteon::Mesh> read_one(const fs::path& path, std::string* error) {
  osteon::Result<osteon::Scene> scene = osteon::read_path(path.string());
  if (!scene.ok()) {
    *error = scene.status().message();
    return std::nullopt;
  }
  if (scene->parts.size() != 1) {
    *error = path.string() + ": expected one part";
    return std::nullopt;
  }
  return std::move(scene->parts[0]);
}

// ---- the processed copies ------------------------------------------------------------------

// Encodes and decodes `mesh` at `bits`, writes the result as PLY; the certified bound goes to
// *bound.
bool write_quantized(const osteon::Mesh& mesh, int bits, const fs::path& out, double* bound) {
  osteon::EncodeReport report;
  auto bytes = osteon::encode(mesh, {.bits = bits}, &report);
  if (!bytes.ok()) return false;
  auto decoded = osteon::decode(bytes->data(), bytes->size());
  if (!decoded.ok()) return false;
  osteon::Aabb box = osteon::bounding_box(mesh);
  double largest = std::max({std::fabs(box.min.x), std::fabs(box.min.y), std::fabs(box.min.z),
                             std::fabs(box.max.x), std::fabs(box.max.y), std::fabs(box.max.z)});
  *bound = std::sqrt(3.0) * (0.5 * report.grid_step + largest * 0x1p-24);
  return osteon::write_mesh(out.string(), decoded.value()).ok();
}

// Every vertex moved along its smooth normal by between 0 and `amplitude`, a smooth field over
// space (wavelength `wavelength`), so the distance varies over the surface.
bool write_displaced(const osteon::Mesh& mesh, double amplitude, double wavelength,
                     const fs::path& out) {
  osteon::Mesh moved = mesh;
  std::vector<osteon::Vec3> normals = osteon::compute_vertex_normals(mesh);
  const double k = 2 * M_PI / wavelength;
  for (size_t v = 0; v < moved.positions.size(); ++v) {
    osteon::Vec3& p = moved.positions[v];
    double d =
        amplitude * 0.5 * (1 + std::sin(k * p.x) * std::sin(k * p.y + 1) * std::sin(k * p.z + 2));
    p = {float(p.x + d * normals[v].x), float(p.y + d * normals[v].y),
         float(p.z + d * normals[v].z)};
  }
  moved.normals.clear();
  return osteon::write_mesh(out.string(), moved).ok();
}

// ---- the two tools -------------------------------------------------------------------------

Figures run_osteon(const osteon::Mesh& sampled, const osteon::Mesh& target, uint64_t samples,
                   int threads) {
  Figures f;
  double cpu0 = cpu_seconds_self();
  auto start = Clock::now();
  auto query = osteon::DistanceQuery::build(target);
  if (!query.ok()) {
    f.error = query.status().message();
    return f;
  }
  osteon::HausdorffOptions options;
  options.samples = samples;
  options.threads = threads;
  auto d = osteon::one_sided_distance(sampled, *query, options);
  f.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  f.cpu_seconds = cpu_seconds_self() - cpu0;
  if (!d.ok()) {
    f.error = d.status().message();
    return f;
  }
  f.ok = true;
  f.max = d->max;
  f.mean = d->mean;
  f.rms = d->rms;
  f.samples = d->samples;
  return f;
}

std::string meshlab_script(int sampled, int target, uint64_t k, double max_dist) {
  std::ostringstream s;
  s << "<!DOCTYPE FilterScript>\n<FilterScript>\n";
  if (k > 0) {
    s << " <filter name=\"Hausdorff Distance\">\n"
      << "  <Param type=\"RichMesh\" value=\"" << sampled << "\" name=\"SampledMesh\"/>\n"
      << "  <Param type=\"RichMesh\" value=\"" << target << "\" name=\"TargetMesh\"/>\n"
      << "  <Param type=\"RichBool\" value=\"false\" name=\"SaveSample\"/>\n"
      << "  <Param type=\"RichBool\" value=\"true\" name=\"SampleVert\"/>\n"
      << "  <Param type=\"RichBool\" value=\"true\" name=\"SampleEdge\"/>\n"
      << "  <Param type=\"RichBool\" value=\"false\" name=\"SampleFauxEdge\"/>\n"
      << "  <Param type=\"RichBool\" value=\"true\" name=\"SampleFace\"/>\n"
      << "  <Param type=\"RichInt\" value=\"" << k << "\" name=\"SampleNum\"/>\n"
      << "  <Param type=\"RichAbsPerc\" value=\"" << max_dist << "\" min=\"0\" max=\"" << max_dist
      << "\" name=\"MaxDist\"/>\n"
      << " </filter>\n";
  }
  s << "</FilterScript>\n";
  return s.str();
}

// Runs meshlabserver on (a, b) with the script; the wall and CPU time of the whole run.
Figures run_meshlab(const fs::path& a, const fs::path& b, const std::string& script,
                    const fs::path& scratch, const std::string& tag) {
  Figures f;
  fs::path script_path = scratch / ("meshlab_" + tag + ".mlx");
  fs::path log = scratch / ("meshlab_" + tag + ".log");
  fs::path out = scratch / ("meshlab_" + tag + ".out");
  {
    std::ofstream s(script_path);
    s << script;
  }
  fs::remove(log);
  std::string command = "xvfb-run -a meshlabserver -i '" + a.string() + "' -i '" + b.string() +
                        "' -s '" + script_path.string() + "' -l '" + log.string() + "' >'" +
                        out.string() + "' 2>&1";
  double cpu0 = cpu_seconds_children();
  auto start = Clock::now();
  int status = std::system(command.c_str());
  f.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  f.cpu_seconds = cpu_seconds_children() - cpu0;
  if (status != 0) {
    f.error = "meshlabserver failed (status " + std::to_string(status) + "), see " + out.string();
    return f;
  }
  std::ifstream in(log);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  std::smatch sampled, values;
  if (!std::regex_search(text, sampled, std::regex(R"(Sampled (\d+) pts)")) ||
      !std::regex_search(text, values,
                         std::regex(R"(min : (\S+)\s+max (\S+)\s+mean : (\S+)\s+RMS : (\S+))"))) {
    f.ok = script.find("Hausdorff") == std::string::npos;  // the empty script logs nothing
    if (!f.ok) f.error = "no Hausdorff figures in " + log.string();
    return f;
  }
  f.ok = true;
  f.samples = std::stoull(sampled[1]);
  f.max = std::stod(values[2]);
  f.mean = std::stod(values[3]);
  f.rms = std::stod(values[4]);
  return f;
}

// ---- the report ----------------------------------------------------------------------------

std::string agreement_table(const std::vector<Pair>& pairs, bool meshlab) {
  std::ostringstream md;
  md << "| pair | direction | samples osteon / MeshLab | max osteon | max MeshLab | diff | mean "
        "osteon | mean MeshLab | diff | RMS osteon | RMS MeshLab | diff | osteon s (CPU s) | "
        "MeshLab s | speed-up |\n"
     << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Pair& pair : pairs) {
    for (const Direction* d : {&pair.forward, &pair.backward}) {
      const Figures& o = d->osteon;
      const Figures& m = d->meshlab;
      md << "| " << pair.label << " | " << d->label << " | ";
      if (!o.ok) {
        md << "osteon fails: " << o.error << " | | | | | | | | | | | | |\n";
        continue;
      }
      bool mo = meshlab && m.ok;
      md << grouped(o.samples) << " / " << (mo ? grouped(m.samples) : "-") << " | " << sig(o.max)
         << " | " << (mo ? sig(m.max) : "-") << " | " << (mo ? percent(o.max, m.max) : "-") << " | "
         << sig(o.mean) << " | " << (mo ? sig(m.mean) : "-") << " | "
         << (mo ? percent(o.mean, m.mean) : "-") << " | " << sig(o.rms) << " | "
         << (mo ? sig(m.rms) : "-") << " | " << (mo ? percent(o.rms, m.rms) : "-") << " | "
         << fixed(o.seconds, 2) << " (" << fixed(o.cpu_seconds, 2) << ") | ";
      double meshlab_seconds = m.seconds - pair.meshlab_load_seconds;
      if (mo) {
        md << fixed(meshlab_seconds, 2) << " | **" << fixed(meshlab_seconds / o.seconds, 1)
           << "x** |\n";
      } else {
        md << (meshlab ? "fails: " + m.error : std::string("-")) << " | - |\n";
      }
    }
  }
  return md.str();
}

std::string tightness_table(const std::vector<Pair>& pairs, double per_face, int dense) {
  std::ostringstream md;
  md << "| pair | direction | max at " << sig(per_face) << " / triangle | max at "
     << sig(per_face * dense)
     << " / triangle | default / dense | certified upper bound | default / bound |\n"
     << "|---|---|---:|---:|---:|---:|---:|\n";
  for (const Pair& pair : pairs) {
    for (const Direction* d : {&pair.forward, &pair.backward}) {
      if (!d->osteon.ok || !d->dense.ok) continue;
      md << "| " << pair.label << " | " << d->label << " | " << sig(d->osteon.max) << " | "
         << sig(d->dense.max) << " | " << fixed(100 * d->osteon.max / d->dense.max, 2) << "% | ";
      if (pair.certified > 0) {
        md << sig(pair.certified) << " | " << fixed(100 * d->osteon.max / pair.certified, 1)
           << "% |\n";
      } else {
        md << "- | - |\n";
      }
    }
  }
  return md.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"osteon Hausdorff benchmark: osteon against MeshLab's Hausdorff filter"};
  std::string data = OSTEON_SHARED_DATA_DIR;
  std::string write_path;
  std::string only;
  std::string keep;
  double per_face = 10;
  int dense = 10;
  int threads = 0;
  bool no_meshlab = false;
  app.add_option("--data", data, "folder of real meshes (../shared/data)");
  app.add_option("--write", write_path,
                 "replace the section '## Hausdorff distance' of this Markdown file");
  app.add_option("--only", only, "measure only pairs whose label contains this text");
  app.add_option("--keep", keep,
                 "write the processed copies and MeshLab's logs here and keep them");
  app.add_option("--samples-per-face", per_face, "osteon's samples a triangle (10)")
      ->check(CLI::Range(1.0, 1000.0));
  app.add_option("--dense", dense, "tightness: also measure at this many times the samples (0: no)")
      ->check(CLI::Range(0, 1000));
  app.add_option("--threads", threads, "osteon's threads (0: every core)")
      ->check(CLI::Range(0, 4096));
  app.add_flag("--no-meshlab", no_meshlab, "osteon only");
  CLI11_PARSE(app, argc, argv);

  bool meshlab = !no_meshlab && on_path("meshlabserver") && on_path("xvfb-run");
  if (!no_meshlab && !meshlab) {
    std::fprintf(stderr,
                 "hausdorff_bench: meshlabserver or xvfb-run not found (apt-get install -y "
                 "--no-install-recommends meshlab xvfb xauth); osteon only\n");
  }
  fs::path scratch = keep.empty() ? fs::temp_directory_path() /
                                        ("osteon_hausdorff_bench_" + std::to_string(getpid()))
                                  : fs::path(keep);
  fs::create_directories(scratch);

  double load_start[1] = {0};
  getloadavg(load_start, 1);
  fs::path hip_path = fs::path(data) / "ct-like" / "hip_mcs.ply";
  std::string error;
  std::optional<osteon::Mesh> hip = read_one(hip_path, &error);
  if (!hip) {
    std::fprintf(stderr, "hausdorff_bench: %s\n", error.c_str());
    return 1;
  }
  double hip_diagonal = diagonal(*hip, *hip);

  std::vector<Pair> pairs;
  auto add_pair = [&](const std::string& label, const std::string& what, const fs::path& b_path,
                      double certified) {
    if (!only.empty() && label.find(only) == std::string::npos) return;
    std::optional<osteon::Mesh> b = read_one(b_path, &error);
    if (!b) {
      std::fprintf(stderr, "hausdorff_bench: %s\n", error.c_str());
      return;
    }
    Pair pair;
    pair.label = label;
    pair.what = what;
    pair.a_path = hip_path;
    pair.b_path = b_path;
    pair.a = *hip;
    pair.b = std::move(*b);
    pair.certified = certified;
    pairs.push_back(std::move(pair));
  };
  for (int bits : {10, 14}) {
    fs::path out = scratch / ("hip_mcs_q" + std::to_string(bits) + ".ply");
    double bound = 0;
    if (!write_quantized(*hip, bits, out, &bound)) {
      std::fprintf(stderr, "hausdorff_bench: cannot write %s\n", out.c_str());
      return 1;
    }
    add_pair("hip " + std::to_string(bits) + "-bit",
             "hip_mcs.ply encoded at " + std::to_string(bits) + " bits and decoded", out, bound);
  }
  {
    fs::path out = scratch / "hip_mcs_displaced.ply";
    double amplitude = 1e-3 * hip_diagonal;
    if (!write_displaced(*hip, amplitude, hip_diagonal / 8, out)) {
      std::fprintf(stderr, "hausdorff_bench: cannot write %s\n", out.c_str());
      return 1;
    }
    add_pair("hip displaced",
             "hip_mcs.ply with every vertex moved along its normal by 0 to " + fixed(amplitude, 3) +
                 " (a smooth field, wavelength diagonal / 8)",
             out, 0);
  }

  for (Pair& pair : pairs) {
    pair.forward = {"A -> B", &pair.a, &pair.b, pair.a_path, pair.b_path, 0};
    pair.backward = {"B -> A", &pair.b, &pair.a, pair.b_path, pair.a_path, 1};
    double max_dist = 2 * diagonal(pair.a, pair.b);
    if (meshlab) {
      std::fprintf(stderr, "hausdorff_bench: %s: MeshLab loading ...\n", pair.label.c_str());
      Figures load =
          run_meshlab(pair.a_path, pair.b_path, meshlab_script(0, 1, 0, max_dist), scratch, "load");
      pair.meshlab_load_seconds = load.seconds;
    }
    for (Direction* d : {&pair.forward, &pair.backward}) {
      // K so that V + 2K is 10 samples a triangle: MeshLab samples every vertex when K >= V.
      uint64_t vertices = d->sampled->vertex_count();
      uint64_t total = uint64_t(std::llround(per_face * double(d->sampled->triangle_count())));
      d->k = (total - std::min(total, vertices)) / 2;
      uint64_t samples = vertices + 2 * d->k;
      std::fprintf(stderr, "hausdorff_bench: %s %s: osteon, %s samples ...\n", pair.label.c_str(),
                   d->label.c_str(), grouped(samples).c_str());
      d->osteon = run_osteon(*d->sampled, *d->target, samples, threads);
      if (dense > 0) {
        d->dense = run_osteon(*d->sampled, *d->target, samples * uint64_t(dense), threads);
      }
      if (meshlab) {
        std::fprintf(stderr, "hausdorff_bench: %s %s: MeshLab, SampleNum %s ...\n",
                     pair.label.c_str(), d->label.c_str(), grouped(d->k).c_str());
        d->meshlab =
            run_meshlab(pair.a_path, pair.b_path,
                        meshlab_script(d->sampled_index, 1 - d->sampled_index, d->k, max_dist),
                        scratch, d->sampled_index == 0 ? "forward" : "backward");
      }
    }
  }
  if (keep.empty()) fs::remove_all(scratch);
  double load_end[1] = {0};
  getloadavg(load_end, 1);

  std::ostringstream tables;
  tables << agreement_table(pairs, meshlab);
  if (dense > 0) {
    tables << "\nTightness of the sampled lower bound (osteon, the same seed):\n\n"
           << tightness_table(pairs, per_face, dense);
  }
  std::printf("%s", tables.str().c_str());

  // The targets: within 2% on max, mean and RMS; at least 5x MeshLab's speed on the 1M pairs.
  std::ostringstream verdict;
  if (meshlab) {
    double worst = 0, slowest = 1e300;
    for (const Pair& pair : pairs) {
      for (const Direction* d : {&pair.forward, &pair.backward}) {
        if (!d->osteon.ok || !d->meshlab.ok) continue;
        for (auto [o, m] :
             {std::pair{d->osteon.max, d->meshlab.max}, std::pair{d->osteon.mean, d->meshlab.mean},
              std::pair{d->osteon.rms, d->meshlab.rms}}) {
          if (m > 0) worst = std::max(worst, std::fabs(o - m) / m);
        }
        slowest =
            std::min(slowest, (d->meshlab.seconds - pair.meshlab_load_seconds) / d->osteon.seconds);
      }
    }
    verdict << "\nTargets: agreement within 2% on max, mean and RMS: largest difference "
            << fixed(100 * worst, 2) << "% (" << (worst <= 0.02 ? "met" : "**not met**")
            << "); at least 5x MeshLab's speed at equal sample count on the 1M-triangle pairs: "
               "slowest "
            << fixed(slowest, 1) << "x on " << sysconf(_SC_NPROCESSORS_ONLN) << " cores ("
            << (slowest >= 5 ? "met" : "**not met**") << ").\n";
    std::printf("%s", verdict.str().c_str());
  }

  if (!write_path.empty()) {
    char date[32];
    std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof(date), "%Y-%m-%d", std::gmtime(&now));
    std::string command = "build-bench/hausdorff_bench";
    if (per_face != 10) command += " --samples-per-face " + sig(per_face);
    if (dense != 10) command += " --dense " + std::to_string(dense);
    if (threads != 0) command += " --threads " + std::to_string(threads);
    if (!only.empty()) command += " --only '" + only + "'";
    command += " --write " + write_path;
    std::ostringstream body;
    body << "osteon's `hausdorff` (include/osteon/hausdorff.hpp) against MeshLab 2020.09's "
            "\"Hausdorff Distance\" filter (Debian 12's `meshlab`, run headless by `xvfb-run -a "
            "meshlabserver`), one-sided both ways, on `ct-like/hip_mcs.ply` ("
         << grouped(hip->triangle_count()) << " triangles, bounding-box diagonal "
         << fixed(hip_diagonal, 1) << " mm) as A against three copies as B:\n\n";
    for (const Pair& pair : pairs) body << "- **" << pair.label << "**: " << pair.what << "\n";
    body
        << "\nSame files, same sample split: MeshLab's SampleNum K takes every vertex, K points on "
           "the edges (evenly spaced along them) and K on the faces (Monte Carlo); osteon runs at "
           "V + 2K samples, which it splits the same way (its edge points are MeshLab's very "
           "points; its face points are stratified by area), K chosen so that V + 2K is 10 "
           "samples a triangle, osteon's default. MaxDist is twice the diagonal, so MeshLab drops "
           "no sample. MeshLab prints six decimals. Times: osteon's is DistanceQuery::build on "
           "the target plus one_sided_distance on every core, wall clock (CPU time of all "
           "threads in brackets); MeshLab's is the meshlabserver run minus a run of an empty "
           "script on the same inputs (start-up and loading), so both time the search structure "
           "and the samples. MeshLab's filter is single-threaded. One run each, on a shared "
           "machine: the times are indicative to a few tens of percent. See bench/README.md.\n\n"
        << "Machine: " << osteon_bench::cpu_model() << ", " << sysconf(_SC_NPROCESSORS_ONLN)
        << " cores (shared; load average " << fixed(load_start[0], 1) << " at the start, "
        << fixed(load_end[0], 1)
        << " at the end: where other jobs ran, osteon's threads shared the cores, as its CPU "
           "time against its wall time shows). Date: "
        << date << ". Commands (from the repository root):\n\n"
        << "```\napt-get install -y --no-install-recommends meshlab xvfb xauth\n"
           "cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release "
           "-DOSTEON_BUILD_BENCH=ON -DOSTEON_BUILD_TESTS=OFF\ncmake --build build-bench --target "
           "hausdorff_bench\n"
        << command << "\n```\n\n"
        << tables.str() << verdict.str();
    if (!osteon_bench::write_section(write_path, "## Hausdorff distance", body.str())) {
      std::fprintf(stderr, "hausdorff_bench: cannot write %s\n", write_path.c_str());
      return 1;
    }
  }
  return 0;
}
