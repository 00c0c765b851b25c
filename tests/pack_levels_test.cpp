// SPDX-License-Identifier: Apache-2.0
// Levels of detail in a package (docs/FORMAT.md "Levels of detail"): the chain of quarters, the
// stream layout (every coarsest level in the first chunks), what the level share keeps, errors
// that match what is measured,
// exact borders between the pieces of a segmented part at every level, and a corrupt level that
// fails alone.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/codec.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/package.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace pack_levels_test {

using test::read_bytes;
using test::scratch_dir;
using test::write_phantom;

Manifest read_manifest(const std::string& dir) {
  const std::vector<uint8_t> text = read_bytes(dir + "/manifest.json");
  Result<Manifest> manifest = parse_manifest(text.data(), text.size(), "manifest.json");
  EXPECT_TRUE(manifest.ok()) << manifest.status().message();
  return manifest.ok() ? manifest.value() : Manifest{};
}

/// The bytes of stream `level` of `c` (coarsest 0; c.levels.size() is the full one).
std::vector<uint8_t> level_stream(const std::string& dir, const Manifest& m,
                                  const ManifestComponent& c, size_t level) {
  uint64_t chunk = c.chunk, offset = c.offset, bytes = c.bytes;
  if (level < c.levels.size()) {
    chunk = c.levels[level].chunk;
    offset = c.levels[level].offset;
    bytes = c.levels[level].bytes;
  }
  const std::vector<uint8_t> data = read_bytes(dir + "/" + m.chunks[chunk].file);
  EXPECT_LE(offset + bytes, data.size()) << m.chunks[chunk].file;
  if (offset + bytes > data.size()) return {};
  return std::vector<uint8_t>(data.begin() + offset, data.begin() + offset + bytes);
}

/// Stream `level` of `c`, decoded.
Mesh decode_level(const std::string& dir, const Manifest& m, const ManifestComponent& c,
                  size_t level) {
  const std::vector<uint8_t> stream = level_stream(dir, m, c, level);
  Result<Mesh> mesh = decode(stream.data(), stream.size(), c.id);
  EXPECT_TRUE(mesh.ok()) << mesh.status().message();
  return mesh.ok() ? mesh.value() : Mesh{};
}

/// Options that keep every level of the chain (no level share).
PackOptions whole_chain() {
  PackOptions options;
  options.level_share = std::numeric_limits<double>::infinity();
  return options;
}

Result<PackReport> pack_phantom(const std::string& out, PackOptions options, int detail = 3) {
  options.output = out;
  options.threads = 2;
  return pack({write_phantom(detail)}, options);
}

TEST(PackLevels, ChainOfQuartersCoarsestFirstInTheStream) {
  const std::string out = scratch_dir() + "/levels";
  Result<PackReport> report = pack_phantom(out, whole_chain());
  ASSERT_TRUE(report.ok()) << report.status().message();
  const Manifest m = read_manifest(out);
  ASSERT_GT(report->level_streams, 0u);
  size_t with_levels = 0;
  uint64_t last_first_chunk = 0, first_finer_chunk = UINT64_MAX;
  for (const ManifestComponent& c : m.components) {
    EXPECT_EQ(!c.levels.empty(), c.triangles > 1024) << c.id << ": " << c.triangles;
    if (c.levels.empty()) {
      last_first_chunk = std::max(last_first_chunk, c.chunk);
      continue;
    }
    ++with_levels;
    EXPECT_GE(c.levels.front().triangles, 256u) << c.id;
    EXPECT_LT(c.levels.front().triangles, 1024u) << c.id << ": the chain goes on to a few hundred";
    for (size_t k = 0; k < c.levels.size(); ++k) {
      const uint64_t finer = k + 1 < c.levels.size() ? c.levels[k + 1].triangles : c.triangles;
      EXPECT_GE(4 * c.levels[k].triangles, finer * 3 / 4) << c.id << " level " << k;
      EXPECT_LE(c.levels[k].triangles, finer * 3 / 4) << c.id << " level " << k;
      EXPECT_GE(c.levels[k].error, c.error_bound);
      if (k + 1 < c.levels.size()) {
        EXPECT_GT(c.levels[k].error, c.levels[k + 1].error * 0.9);
      }
      const Mesh decoded = decode_level(out, m, c, k);
      EXPECT_EQ(decoded.triangle_count(), c.levels[k].triangles);
      EXPECT_EQ(decoded.positions.size(), c.levels[k].vertices);
      if (k > 0) {
        first_finer_chunk = std::min(first_finer_chunk, c.levels[k].chunk);
      }
    }
    last_first_chunk = std::max(last_first_chunk, c.levels.front().chunk);
    first_finer_chunk = std::min(first_finer_chunk, c.chunk);
  }
  EXPECT_GT(with_levels, 0u);
  EXPECT_LT(last_first_chunk, first_finer_chunk)
      << "the first chunks hold the coarsest levels and nothing else";
  EXPECT_LT(report->first_bytes, report->output_bytes / 2);

  // --no-lod: the same package without levels; --levels 2: one coarser level at most.
  PackOptions no_lod = whole_chain();
  no_lod.levels = 1;
  const std::string flat_dir = scratch_dir() + "/flat", two_dir = scratch_dir() + "/two";
  Result<PackReport> flat = pack_phantom(flat_dir, no_lod);
  ASSERT_TRUE(flat.ok());
  EXPECT_EQ(flat->level_streams, 0u);
  for (const ManifestComponent& c : read_manifest(flat_dir).components) {
    EXPECT_TRUE(c.levels.empty());
  }
  EXPECT_EQ(flat->triangles_out, report->triangles_out);
  PackOptions two = whole_chain();
  two.levels = 2;
  ASSERT_TRUE(pack_phantom(two_dir, two).ok());
  for (const ManifestComponent& c : read_manifest(two_dir).components) {
    EXPECT_LE(c.levels.size(), 1u);
  }
}

// Which levels a component keeps: its coarsest, then finer ones, coarse to fine, while all it
// keeps cost at most the share of its full level's bytes, or while the finest kept is more than
// a pixel off in the whole view; what it keeps is the whole chain's coarse end, stream for
// stream, and the first level left out was needed by neither.
/// The dense phantom packed into `dir` with the level share and the whole view's pixels given.
Manifest pack_kept(const std::string& dir, double share, double pixels) {
  PackOptions options;
  options.level_share = share;
  options.lod_view_pixels = pixels;
  Result<PackReport> report = pack_phantom(dir, options, 4);
  EXPECT_TRUE(report.ok()) << report.status().message();
  return read_manifest(dir);
}

TEST(PackLevels, LevelShareKeepsTheCoarsestAndWhatFits) {
  const std::string whole_dir = scratch_dir() + "/share_whole";
  ASSERT_TRUE(pack_phantom(whole_dir, whole_chain(), 4).ok());
  const Manifest whole = read_manifest(whole_dir);
  for (const double share : {0.0, 0.15, 0.5}) {
    SCOPED_TRACE("share " + std::to_string(share));
    const std::string dir = scratch_dir() + "/share_" + std::to_string(int(share * 100));
    const Manifest m = pack_kept(dir, share, 0);  // the share alone
    ASSERT_EQ(m.components.size(), whole.components.size());
    size_t shortened = 0;
    for (size_t i = 0; i < m.components.size(); ++i) {
      const ManifestComponent& c = m.components[i];
      const ManifestComponent& w = whole.components[i];
      ASSERT_EQ(c.id, w.id);
      EXPECT_EQ(c.bytes, w.bytes) << c.id;
      EXPECT_EQ(c.levels.empty(), w.levels.empty()) << c.id << ": the coarsest is always kept";
      ASSERT_LE(c.levels.size(), w.levels.size()) << c.id;
      uint64_t kept = 0;
      for (size_t k = 0; k < c.levels.size(); ++k) {
        EXPECT_EQ(c.levels[k].triangles, w.levels[k].triangles) << c.id << " level " << k;
        EXPECT_EQ(level_stream(dir, m, c, k), level_stream(whole_dir, whole, w, k))
            << c.id << " level " << k;
        kept += c.levels[k].bytes;
      }
      if (c.levels.size() > 1) {
        EXPECT_LE(double(kept), share * double(c.bytes)) << c.id;
      }
      if (share == 0.0) {
        EXPECT_LE(c.levels.size(), 1u) << c.id;
      }
      if (c.levels.size() < w.levels.size()) {
        ++shortened;
        EXPECT_GT(double(kept + w.levels[c.levels.size()].bytes), share * double(c.bytes))
            << c.id << ": level " << c.levels.size() << " would have fit";
      }
      EXPECT_EQ(decode_level(dir, m, c, c.levels.size()).triangle_count(), c.triangles);
    }
    if (share < 0.5) {
      EXPECT_GT(shortened, 0u) << "the phantom's chains are all within the share";
    }
  }
  // The whole view: with no share, a component keeps its coarsest level and, when that is more
  // than a pixel off in a view `pixels` high that shows the whole phantom, the whole chain's first
  // level within that pixel (none when no level is: the full one is), and nothing between.
  const Aabb& box = whole.bounds;  // of every part (rounded outward: a hair larger than pack's)
  const double extent = std::max({double(box.max.x) - box.min.x, double(box.max.y) - box.min.y,
                                  double(box.max.z) - box.min.z});
  size_t jumped = 0;  // over levels between the coarsest and the view's
  for (const double pixels : {256.0, 4096.0}) {
    SCOPED_TRACE("view " + std::to_string(pixels));
    const std::string dir = scratch_dir() + "/view_" + std::to_string(int(pixels));
    const Manifest m = pack_kept(dir, 0, pixels);
    ASSERT_EQ(m.components.size(), whole.components.size());
    const double pixel = extent / pixels;
    size_t deeper = 0;
    for (size_t i = 0; i < m.components.size(); ++i) {
      const ManifestComponent& c = m.components[i];
      const ManifestComponent& w = whole.components[i];
      ASSERT_EQ(c.levels.empty(), w.levels.empty()) << c.id;
      if (c.levels.empty()) continue;
      ASSERT_LE(c.levels.size(), 2u) << c.id;
      EXPECT_EQ(level_stream(dir, m, c, 0), level_stream(whole_dir, whole, w, 0)) << c.id;
      size_t first = 0;  // the whole chain's first level within the pixel
      while (first < w.levels.size() && w.levels[first].error > pixel) ++first;
      if (first == 0 || first == w.levels.size()) {
        EXPECT_EQ(c.levels.size(), 1u) << c.id << ": the coarsest is within the pixel, or none is";
        continue;
      }
      ASSERT_EQ(c.levels.size(), 2u) << c.id << ": the view needs level " << first;
      EXPECT_EQ(level_stream(dir, m, c, 1), level_stream(whole_dir, whole, w, first)) << c.id;
      EXPECT_EQ(c.levels[1].error, w.levels[first].error) << c.id;
      ++deeper;
      jumped += first > 1;
    }
    if (pixels > 1000) {
      EXPECT_GT(deeper, 0u) << "a close view keeps finer levels";
    }
  }
  EXPECT_GT(jumped, 0u) << "no view skipped a level";
  // The CLI's --level-share; a negative one is refused, naming the option.
  const std::string input = write_phantom(4);
  const std::string cli_dir = scratch_dir() + "/share_cli";
  test::CliRun packed = test::run_cli("pack " + input +
                                      " --no-viewer --level-share 0 --lod-view-pixels 0 -o " +
                                      cli_dir);
  ASSERT_EQ(packed.status, 0) << packed.err;
  for (const ManifestComponent& c : read_manifest(cli_dir).components) {
    EXPECT_LE(c.levels.size(), 1u) << c.id;
  }
  test::CliRun refused =
      test::run_cli("pack " + input + " --no-viewer --level-share -1 -o " + cli_dir + "_bad");
  EXPECT_NE(refused.status, 0);
  EXPECT_NE(refused.err.find("--level-share"), std::string::npos) << refused.err;
  Result<PackReport> negative = [&] {
    PackOptions options;
    options.level_share = -1;
    return pack_phantom(scratch_dir() + "/share_negative", options);
  }();
  ASSERT_FALSE(negative.ok());
  EXPECT_NE(negative.status().message().find("level share"), std::string::npos)
      << negative.status().message();
}

// What the manifest says of a level is what `osteon compare ORIGINAL PACKAGE --level K` measures.
/// Packs the phantom with `options` and checks, level by level, that what each part's manifest
/// entries record is what hausdorff() measures between the part read back and its input.
void expect_level_errors_measured(PackOptions options, const std::string& out) {
  const std::string input = write_phantom(3);
  options.output = out;
  ASSERT_TRUE(pack({input}, options).ok());
  const Manifest m = read_manifest(out);
  std::map<std::string, const ManifestComponent*> by_id;
  size_t depth = 0;
  for (const ManifestComponent& c : m.components) {
    by_id[c.id] = &c;
    depth = std::max(depth, c.levels.size());
  }
  Result<Scene> original = read_path(input);
  ASSERT_TRUE(original.ok());
  for (size_t level = 0; level < depth; ++level) {
    Result<Scene> drawn = read_package(out, static_cast<int>(level));
    ASSERT_TRUE(drawn.ok()) << drawn.status().message();
    ASSERT_EQ(drawn->parts.size(), m.parts.size());
    for (size_t p = 0; p < m.parts.size(); ++p) {
      double recorded = 0;
      bool coarser = false;
      for (const ManifestInstance& instance : m.instances) {
        if (instance.part != p) continue;
        const ManifestComponent& c = *by_id.at(instance.component);
        const double e = level < c.levels.size() ? c.levels[level].error : c.error_bound;
        coarser = coarser || level < c.levels.size();
        recorded = std::max(recorded, e + instance.error_bound - c.error_bound);
      }
      if (!coarser) continue;
      const Mesh* source = nullptr;
      for (const Mesh& part : original->parts) {
        if (part.name == m.parts[p].name) source = &part;
      }
      ASSERT_NE(source, nullptr) << m.parts[p].name;
      Result<HausdorffReport> measured = hausdorff(drawn->parts[p], *source);
      ASSERT_TRUE(measured.ok());
      const double d = measured->symmetric.max;
      // Both are sampled lower bounds, at different densities and seeds: a few percent apart.
      EXPECT_LE(d, 1.05 * recorded) << m.parts[p].name << " level " << level;
      EXPECT_GE(d, 0.25 * recorded) << m.parts[p].name << " level " << level;
    }
  }
}

TEST(PackLevels, LevelErrorsMatchWhatIsMeasured) {
  expect_level_errors_measured(whole_chain(), scratch_dir() + "/measured");
}

// The same for segmented parts, whose coarser levels keep the part's grid on their border and
// move the rest of their vertices onto a coarser lattice.
TEST(PackLevels, SegmentedLevelErrorsMatchWhatIsMeasured) {
  PackOptions options = whole_chain();
  options.max_triangles = 1500;  // the phantom's 4k-triangle bones in three or four pieces
  expect_level_errors_measured(options, scratch_dir() + "/measured_segmented");
}

// A bone with islands (a label's stray fragments): a small closed island collapses to nothing
// in one meshopt call, and a fragment far from the bone, dropped, is a level that far off. Each
// island is simplified on its own and the smallest are kept, so every level still has each of
// them, and what is recorded is what is measured.
TEST(PackLevels, IslandsSurviveEveryLevel) {
  Mesh bone = make_icosphere(5, 20.0f);  // 20,480 triangles
  const Mesh fragment = make_icosphere(1, 1.0f);  // 80: simplified with its share
  const Mesh speck = make_icosphere(0, 0.5f);     // 20: kept whole
  const Vec3 far_away[] = {{200, 0, 0}, {0, -150, 40}};
  for (int k = 0; k < 2; ++k) {
    const Mesh& island = k == 0 ? fragment : speck;
    const uint32_t base = static_cast<uint32_t>(bone.positions.size());
    for (const Vec3& p : island.positions) {
      bone.positions.push_back({p.x + far_away[k].x, p.y + far_away[k].y, p.z + far_away[k].z});
    }
    for (uint32_t i : island.indices) bone.indices.push_back(base + i);
  }
  bone.name = "islands";
  const std::string dir = scratch_dir() + "/islands";
  std::filesystem::create_directories(dir + "/in");
  ASSERT_TRUE(write_mesh(dir + "/in/islands.ply", bone).ok());
  PackOptions options = whole_chain();
  options.output = dir + "/out";
  ASSERT_TRUE(pack({dir + "/in"}, options).ok());
  const Manifest m = read_manifest(options.output);
  ASSERT_EQ(m.components.size(), 1u);
  const ManifestComponent& c = m.components[0];
  ASSERT_GE(c.levels.size(), 3u);
  for (size_t level = 0; level < c.levels.size(); ++level) {
    SCOPED_TRACE("level " + std::to_string(level));
    const Mesh drawn = decode_level(options.output, m, c, level);
    for (const Vec3& centre : far_away) {
      size_t near = 0;
      for (const Vec3& p : drawn.positions) {
        const float dx = p.x - centre.x, dy = p.y - centre.y, dz = p.z - centre.z;
        if (dx * dx + dy * dy + dz * dz < 4.0f) ++near;
      }
      EXPECT_GE(near, 4u) << "an island vanished";
    }
    EXPECT_LT(c.levels[level].error, 5.0) << "a level far off";
    Result<HausdorffReport> measured = hausdorff(drawn, bone);
    ASSERT_TRUE(measured.ok());
    EXPECT_LE(measured->symmetric.max, 1.05 * c.levels[level].error);
  }
}

// The CLI says what the manifest says: `pack --json` counts the levels and their bytes as the
// files hold them, and `compare --level 0` measures the coarsest level within what is recorded.
TEST(PackLevels, CliReportsLevelsAndCompareMeasuresThem) {
  const std::string input = write_phantom(3);
  const std::string out = scratch_dir() + "/cli";
  test::CliRun packed = test::run_cli("pack " + input + " --no-viewer -o " + out + " --json");
  ASSERT_EQ(packed.status, 0) << packed.err;
  const nlohmann::json report = nlohmann::json::parse(packed.out);
  const Manifest m = read_manifest(out);
  uint64_t level_bytes = 0, levels = 0, chunk_bytes = 0;
  double coarsest = 0, full = 0;
  std::map<std::string, const ManifestComponent*> by_id;
  for (const ManifestComponent& c : m.components) {
    by_id[c.id] = &c;
    levels += c.levels.size();
    for (const ManifestLevel& level : c.levels) level_bytes += level.bytes;
  }
  // A repeat's instance adds the tolerance it was accepted under.
  for (const ManifestInstance& instance : m.instances) {
    const ManifestComponent& c = *by_id.at(instance.component);
    const double tolerance = instance.error_bound - c.error_bound;
    coarsest = std::max(coarsest, (c.levels.empty() ? c.error_bound : c.levels.front().error) +
                                      tolerance);
    full = std::max(full, instance.error_bound);
  }
  for (const ManifestChunk& chunk : m.chunks) {
    EXPECT_EQ(std::filesystem::file_size(out + "/" + chunk.file), chunk.bytes) << chunk.file;
    chunk_bytes += chunk.bytes;
  }
  EXPECT_EQ(report["level_streams"].get<uint64_t>(), levels);
  EXPECT_EQ(report["level_bytes"].get<uint64_t>(), level_bytes);
  EXPECT_EQ(report["output_bytes"].get<uint64_t>(),
            chunk_bytes + std::filesystem::file_size(out + "/manifest.json"));
  test::CliRun coarse = test::run_cli("compare " + input + " " + out + " --level 0 --json");
  ASSERT_EQ(coarse.status, 0) << coarse.err;
  const double measured = nlohmann::json::parse(coarse.out)["symmetric"]["max"].get<double>();
  EXPECT_LE(measured, 1.05 * coarsest);
  EXPECT_GT(measured, 4 * full) << "level 0 is the coarse one, not the full level";
  test::CliRun fine = test::run_cli("compare " + input + " " + out + " --json");
  ASSERT_EQ(fine.status, 0) << fine.err;
  EXPECT_LE(nlohmann::json::parse(fine.out)["symmetric"]["max"].get<double>(), 1.0001 * full);
}

/// The positions of the vertices on `mesh`'s border edges (edges of one triangle), as floats.
std::set<std::array<float, 3>> border_positions(const Mesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = mesh.indices[3 * t + k], b = mesh.indices[3 * t + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::set<std::array<float, 3>> out;
  for (const auto& [edge, count] : uses) {
    if (count != 1) continue;
    for (uint32_t v : {edge.first, edge.second}) {
      out.insert({mesh.positions[v].x, mesh.positions[v].y, mesh.positions[v].z});
    }
  }
  return out;
}

// The pieces of a segmented bone meet without cracks whatever level each is drawn at: every level
// of a piece has the full level's border, vertex for vertex, after quantization.
TEST(PackLevels, SegmentedPartsKeepTheirBordersAtEveryLevel) {
  const std::string out = scratch_dir() + "/segmented";
  PackOptions options;
  options.max_triangles = 1500;  // the phantom's 4k-triangle bones in three or four pieces
  ASSERT_TRUE(pack_phantom(out, options).ok());
  const Manifest m = read_manifest(out);
  size_t checked = 0;
  for (const ManifestComponent& c : m.components) {
    if (c.levels.empty()) continue;
    const std::set<std::array<float, 3>> full = border_positions(decode_level(out, m, c, c.levels.size()));
    if (full.empty()) continue;
    for (size_t k = 0; k < c.levels.size(); ++k) {
      EXPECT_EQ(border_positions(decode_level(out, m, c, k)), full) << c.id << " level " << k;
      ++checked;
    }
  }
  EXPECT_GT(checked, 4u);
}

// A segmented part's coarser level keeps the part's grid, so that its border meets the other
// pieces, but stores the vertices off its border on a coarser lattice (a power of two of grid
// steps) that its recorded error allows: they cost fewer bits.
TEST(PackLevels, SegmentedLevelsStoreTheirInsideOnACoarserLattice) {
  const std::string out = scratch_dir() + "/segmented_lattice";
  PackOptions options;
  options.max_triangles = 1500;
  ASSERT_TRUE(pack_phantom(out, options).ok());
  const Manifest m = read_manifest(out);
  size_t coarser = 0, levels = 0;
  for (const ManifestComponent& c : m.components) {
    const Mesh finest = decode_level(out, m, c, c.levels.size());
    if (border_positions(finest).empty()) continue;  // not a piece of a segmented part
    const std::vector<uint8_t> full = level_stream(out, m, c, c.levels.size());
    Result<QuantizationGrid> part_grid = stream_grid(full.data(), full.size(), c.id);
    ASSERT_TRUE(part_grid.ok());
    for (size_t k = 0; k < c.levels.size(); ++k) {
      const std::vector<uint8_t> stream = level_stream(out, m, c, k);
      Result<Mesh> level = decode(stream.data(), stream.size(), c.id);
      Result<QuantizationGrid> grid = stream_grid(stream.data(), stream.size(), c.id);
      ASSERT_TRUE(level.ok() && grid.ok()) << c.id << " level " << k;
      const std::set<std::array<float, 3>> border = border_positions(level.value());
      EXPECT_EQ(grid->step, part_grid->step) << c.id << " level " << k;
      // The largest period every coordinate off the border is a multiple of.
      uint64_t period = 0;
      for (const Vec3& p : level->positions) {
        if (border.count({p.x, p.y, p.z})) continue;
        for (int axis = 0; axis < 3; ++axis) {
          const double at = axis == 0 ? p.x - double(grid->origin.x)
                          : axis == 1 ? p.y - double(grid->origin.y)
                                      : p.z - double(grid->origin.z);
          period = std::gcd(period, uint64_t(std::llabs(std::llround(at / grid->step))));
        }
      }
      ASSERT_GT(period, 0u) << c.id << " level " << k;
      ++levels;
      if (period == 1) continue;
      ++coarser;
      // A lattice of a power of two that moves a vertex by at most twice the level's distance
      // before quantization, which the error measured after it is seldom below.
      const uint64_t lattice = uint64_t{1} << std::countr_zero(period);
      EXPECT_LE(std::sqrt(3.0) / 2 * double(lattice) * grid->step, 2 * c.levels[k].error)
          << c.id << " level " << k << " lattice " << lattice;
    }
  }
  EXPECT_GT(levels, 4u);
  EXPECT_GT(coarser, levels / 2) << "most coarser levels store their inside on a coarser lattice";
}

// A level whose bytes are corrupt fails alone: reading it names its chunk and byte; the full
// level, in another chunk, still reads.
TEST(PackLevels, CorruptLevelFailsAlone) {
  const std::string out = scratch_dir() + "/corrupt";
  ASSERT_TRUE(pack_phantom(out, PackOptions{}).ok());
  const Manifest m = read_manifest(out);
  const ManifestComponent* target = nullptr;
  for (const ManifestComponent& c : m.components) {
    if (!c.levels.empty()) target = &c;
  }
  ASSERT_NE(target, nullptr);
  const ManifestLevel& level = target->levels.front();
  const std::string chunk = out + "/" + m.chunks[level.chunk].file;
  std::vector<uint8_t> bytes = read_bytes(chunk);
  for (uint64_t i = level.offset + 4; i < level.offset + level.bytes; i += 3) bytes[i] ^= 0x5a;
  std::ofstream(chunk, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  Result<Scene> coarse = read_package(out, 0);
  ASSERT_FALSE(coarse.ok());
  EXPECT_NE(coarse.status().message().find(m.chunks[level.chunk].file), std::string::npos)
      << coarse.status().message();
  EXPECT_NE(coarse.status().message().find("at byte " + std::to_string(level.offset)),
            std::string::npos)
      << coarse.status().message();
  EXPECT_TRUE(read_package(out).ok()) << "the full levels live in other chunks";
}

}  // namespace pack_levels_test
}  // namespace
}  // namespace osteon
