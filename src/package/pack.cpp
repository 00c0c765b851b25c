// SPDX-License-Identifier: Apache-2.0
#include "osteon/pack.hpp"

#include <openssl/evp.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/package.hpp"
#include "osteon/repeats.hpp"
#include "osteon/segment.hpp"
#include "package/package_internal.hpp"
#include "package/publish.hpp"

// Based on: FIPS 180-4 SHA-256 (through OpenSSL's EVP interface) for content-addressed file
// names, as static hosts and CDNs cache immutable hashed assets.
//
// pack() runs one function per stage (docs/DESIGN.md "The pipeline"); each takes what the stages
// before it produced and fills its own part of the report.

namespace osteon {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using ViewerFiles = std::vector<std::pair<std::string, std::vector<uint8_t>>>;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// options.progress, when set.
struct Progress {
  const PackOptions& options;
  void operator()(PackStage stage, uint64_t done, uint64_t total) const {
    if (options.progress) options.progress(stage, done, total);
  }
};

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

uint64_t file_size_or_zero(const std::string& path) {
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  return ec ? 0 : size;
}

/// The triangles of `mesh` labelled `label`, with only their vertices (in first-use order).
Mesh extract(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t label) {
  std::vector<uint32_t> corners;
  for (size_t t = 0; t < labels.size(); ++t) {
    if (labels[t] != label) continue;
    corners.insert(corners.end(), mesh.indices.begin() + 3 * t, mesh.indices.begin() + 3 * t + 3);
  }
  return detail::submesh(mesh, corners);
}

/// The world box of `box` under `m` (its eight corners transformed).
Aabb transform_box(const Aabb& box, const Mat4& m) {
  Aabb out;
  for (int c = 0; c < 8; ++c) {
    const Vec3 p{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                 (c & 4) ? box.max.z : box.min.z};
    expand(out, transform_point(m, p));
  }
  return out;
}

/// The largest face area of a box: its projected area seen along the best axis.
double projected_area(const Aabb& box) {
  const double dx = box.max.x - box.min.x, dy = box.max.y - box.min.y, dz = box.max.z - box.min.z;
  return std::max({dx * dy, dy * dz, dx * dz});
}

/// The viewer's files: (path relative to `root`, bytes), sorted by path, so packages are
/// byte-identical whatever order the file system lists them in.
Result<ViewerFiles> read_viewer(const std::string& root) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    return error(ErrorCode::kIoError, root,
                 "the viewer folder does not exist (build it: cd web && npm ci && npm run "
                 "build:viewer)");
  }
  ViewerFiles files;
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

/// The codec's bits or precision for a part in `unit`, as PackOptions says.
EncodeOptions quantization(const PackOptions& options, Unit unit) {
  EncodeOptions q;
  if (options.precision > 0) {
    q.precision = options.precision;
  } else if (options.bits > 0) {
    q.bits = options.bits;
  } else {
    q.precision = options.precision_mm / unit_in_millimetres(unit);
  }
  return q;
}

Status check_options(const std::vector<std::string>& inputs, const PackOptions& options) {
  if (inputs.empty()) return error(ErrorCode::kInvalidArgument, "pack", "no input given");
  if (options.output.empty()) {
    return error(ErrorCode::kInvalidArgument, "pack", "no output folder given");
  }
  if (options.bits != 0 && (options.bits < 8 || options.bits > 24)) {
    return error(ErrorCode::kInvalidArgument, "pack", "bits must be in 8..24");
  }
  if (!(options.precision_mm > 0) || !std::isfinite(options.precision_mm)) {
    return error(ErrorCode::kInvalidArgument, "pack", "the default precision must be > 0 mm");
  }
  if (options.levels < 0) {
    return error(ErrorCode::kInvalidArgument, "pack", "levels must be >= 0 (0: no limit)");
  }
  if (!(options.level_share >= 0)) {
    return error(ErrorCode::kInvalidArgument, "pack", "the level share must be >= 0");
  }
  if (!(options.lod_view_pixels >= 0) || !std::isfinite(options.lod_view_pixels)) {
    return error(ErrorCode::kInvalidArgument, "pack",
                 "the view's pixels for levels must be finite and >= 0");
  }
  if (options.chunk_bytes == 0) {
    return error(ErrorCode::kInvalidArgument, "pack", "chunk bytes must be at least 1");
  }
  if (!(options.precision >= 0) || !std::isfinite(options.precision) ||
      !(options.repeat_tolerance >= 0) || !std::isfinite(options.repeat_tolerance)) {
    return error(ErrorCode::kInvalidArgument, "pack",
                 "precision and repeat tolerance must be finite and >= 0");
  }
  return {};
}

// ---- the stages -------------------------------------------------------------------------------

/// What the read stage gives: the parts, and the files to write and name them with.
struct Inputs {
  std::vector<Mesh> parts;
  ViewerFiles viewer_files;
  detail::Names names;
};

/// Read: every input, plus the viewer's files and the names file first, so that a missing one
/// fails before any work.
Result<Inputs> read_stage(const std::vector<std::string>& inputs, const PackOptions& options,
                          const Progress& progress, PackReport* report) {
  Inputs in;
  if (!options.viewer.empty()) {
    OSTEON_ASSIGN_OR_RETURN(in.viewer_files, read_viewer(options.viewer));
  }
  if (!options.names.empty()) {
    OSTEON_ASSIGN_OR_RETURN(in.names, detail::read_names(options.names));
  }
  ReadOptions read = options.read;
  if (!(read.surface_precision > 0)) read.surface_precision = options.precision;
  for (size_t i = 0; i < inputs.size(); ++i) {
    progress(PackStage::kRead, i, inputs.size());
    OSTEON_ASSIGN_OR_RETURN(Scene scene, read_path(inputs[i], read));
    for (Mesh& part : scene.parts) {
      if (part.source.empty()) part.source = inputs[i];
      in.parts.push_back(std::move(part));
    }
  }
  progress(PackStage::kRead, inputs.size(), inputs.size());
  OSTEON_RETURN_IF_ERROR(detail::derive_regions(options.regions, in.parts, &in.names));
  std::set<std::string> sources;
  for (const Mesh& part : in.parts) sources.insert(part.source);
  for (const std::string& source : sources) report->input_bytes += file_size_or_zero(source);
  return in;
}

/// Clean: degenerate triangles and unreferenced vertices go; parts left empty are dropped.
Status clean_stage(const std::string& first_input, const Progress& progress,
                   std::vector<Mesh>* parts, PackReport* report) {
  std::vector<Mesh> kept;
  for (size_t i = 0; i < parts->size(); ++i) {
    progress(PackStage::kClean, i, parts->size());
    Mesh& part = (*parts)[i];
    remove_degenerate_triangles(part);
    remove_unreferenced_vertices(part);
    if (part.triangle_count() > 0) kept.push_back(std::move(part));
  }
  progress(PackStage::kClean, parts->size(), parts->size());
  *parts = std::move(kept);
  if (parts->empty()) return error(ErrorCode::kInvalidData, first_input, "no part has triangles");
  report->parts = parts->size();
  for (const Mesh& part : *parts) report->triangles_in += part.triangle_count();
  return {};
}

/// Per part: which part's components it draws, under which matrix, and the substitution's error.
struct Repeats {
  std::vector<size_t> prototype_of;
  std::vector<Mat4> matrix_of;
  std::vector<bool> mirror_of;
  std::vector<double> error_of;
  std::vector<size_t> prototypes;  ///< parts that are their own prototype, in order
};

/// Repeats, bone by bone: each member part is drawn as its prototype's components.
Result<Repeats> repeats_stage(const std::vector<Mesh>& parts, const PackOptions& options,
                              const Progress& progress) {
  Repeats r;
  r.prototype_of.resize(parts.size());
  r.matrix_of.assign(parts.size(), kIdentityMatrix);
  r.mirror_of.assign(parts.size(), false);
  r.error_of.assign(parts.size(), 0.0);
  for (size_t i = 0; i < parts.size(); ++i) r.prototype_of[i] = i;
  if (options.repeats) {
    progress(PackStage::kRepeats, 0, parts.size());
    RepeatOptions repeat_options;
    repeat_options.tolerance = options.repeat_tolerance;
    // A package has one unit, the first part's (the manifest's).
    const EncodeOptions q = quantization(options, parts.empty() ? Unit::kUnknown : parts[0].unit);
    repeat_options.bits = q.bits;
    repeat_options.precision = q.precision;
    repeat_options.threads = options.threads;
    OSTEON_ASSIGN_OR_RETURN(RepeatReport repeats, find_repeats(parts, repeat_options));
    for (const RepeatGroup& group : repeats.groups) {
      for (const RepeatMember& member : group.members) {
        r.prototype_of[member.part] = group.prototype;
        r.matrix_of[member.part] = member.matrix;
        r.mirror_of[member.part] = member.mirror;
        r.error_of[member.part] = member.tolerance;
      }
    }
  }
  progress(PackStage::kRepeats, parts.size(), parts.size());
  for (size_t p = 0; p < parts.size(); ++p) {
    if (r.prototype_of[p] == p) r.prototypes.push_back(p);
  }
  return r;
}

/// The largest piece: options.max_triangles, or when that is automatic, larger pieces when
/// components get levels. A piece's border is kept vertex for vertex at every level (its
/// neighbours must meet it), so its coarsest level holds at least its border: four times larger
/// pieces have half the border a triangle, and the whole skeleton's first view shrinks with it
/// (the dense skeleton: 1.93 -> 0.68 MB of first chunks, 1,984 -> 602 components).
uint32_t piece_triangles(const PackOptions& options) {
  if (options.max_triangles != PackOptions::kAutomaticPieces) return options.max_triangles;
  const bool levels = options.levels != 1 && options.lod_min_triangles > 0;
  return levels ? PackOptions::kPieceTrianglesWithLevels : PackOptions::kPieceTriangles;
}

/// Segment each prototype part larger than max_triangles into pieces (in parallel over parts;
/// each part's result lands in its own slot, so the output does not depend on timing). Returns
/// the pieces of every part (empty for repeats).
Result<std::vector<std::vector<Mesh>>> segment_stage(const std::vector<Mesh>& parts,
                                                     const std::vector<size_t>& prototypes,
                                                     const PackOptions& options,
                                                     const Progress& progress,
                                                     tbb::task_arena& arena) {
  std::vector<std::vector<Mesh>> pieces_of(parts.size());
  std::vector<Status> status(parts.size());
  std::vector<size_t> to_segment;
  const uint32_t max_triangles = piece_triangles(options);
  for (size_t p : prototypes) {
    if (max_triangles == 0 || parts[p].triangle_count() <= max_triangles) {
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
      segment_options.max_triangles = max_triangles;
      Result<Segmentation> seg = segment(parts[p], segment_options);
      if (!seg.ok()) {
        status[p] = seg.status();
        return;
      }
      for (uint32_t label = 0; label < seg.value().count; ++label) {
        Mesh piece = extract(parts[p], seg.value().labels, label);
        if (piece.triangle_count() > 0) pieces_of[p].push_back(std::move(piece));
      }
    });
  });
  for (size_t p : to_segment) OSTEON_RETURN_IF_ERROR(status[p]);
  progress(PackStage::kSegment, to_segment.size(), to_segment.size());
  return pieces_of;
}

/// Levels: the coarser levels of every piece larger than options.lod_min_triangles (in parallel
/// over pieces, each result in its own slot). Returns them per part, per piece, coarsest first.
/// Their distances are measured when they are encoded, only for the levels the package keeps.
std::vector<std::vector<std::vector<Mesh>>> levels_stage(
    const std::vector<size_t>& prototypes, const std::vector<std::vector<Mesh>>& pieces_of,
    const PackOptions& options, const Progress& progress, tbb::task_arena& arena) {
  std::vector<std::vector<std::vector<Mesh>>> levels_of(pieces_of.size());
  std::vector<std::pair<size_t, size_t>> jobs;  // (part, piece)
  for (size_t p : prototypes) {
    levels_of[p].resize(pieces_of[p].size());
    for (size_t k = 0; k < pieces_of[p].size(); ++k) {
      if (options.levels != 1 && options.lod_min_triangles > 0 &&
          pieces_of[p][k].triangle_count() > options.lod_min_triangles) {
        jobs.emplace_back(p, k);
      }
    }
  }
  // Largest first, so the long ones start early.
  std::stable_sort(jobs.begin(), jobs.end(), [&](const auto& a, const auto& b) {
    return pieces_of[a.first][a.second].triangle_count() >
           pieces_of[b.first][b.second].triangle_count();
  });
  progress(PackStage::kLevels, 0, jobs.size());
  arena.execute([&] {
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      const auto [p, k] = jobs[j];
      levels_of[p][k] = detail::detail_levels(pieces_of[p][k], options.levels);
    });
  });
  progress(PackStage::kLevels, jobs.size(), jobs.size());
  return levels_of;
}

/// An encoded stream, before it has a place in a chunk.
struct Stream {
  std::string hash;  ///< SHA-256 of the stream (hex): equal streams are stored once
  std::vector<uint8_t> bytes;
};

/// An encoded piece: its streams, coarsest level first, the full level last.
struct Encoded {
  ManifestComponent entry;  ///< chunks and offsets are set by chunk_streams
  std::vector<Stream> streams;
};

struct EncodedParts {
  std::vector<Encoded> components;
  std::vector<std::vector<size_t>> components_of;  ///< per prototype part
};

/// Encode every piece and each of its levels on its part's own grid (so the components of one
/// part, at any levels, meet without cracks), in parallel over pieces.
Result<EncodedParts> encode_stage(
    const std::vector<Mesh>& parts, const std::vector<size_t>& prototypes,
    const std::vector<std::vector<Mesh>>& pieces_of,
    const std::vector<std::vector<std::vector<Mesh>>>& levels_of, const Aabb& bounds,
    const PackOptions& options, const Progress& progress, tbb::task_arena& arena) {
  EncodedParts out;
  out.components_of.resize(parts.size());
  std::vector<std::pair<size_t, size_t>> jobs;  // (part, piece)
  for (size_t p : prototypes) {
    for (size_t k = 0; k < pieces_of[p].size(); ++k) {
      out.components_of[p].push_back(jobs.size());
      jobs.emplace_back(p, k);
    }
  }
  out.components.resize(jobs.size());
  // Each part's grid, chosen once as the codec would for the whole part (--bits over its largest
  // side, or 2 * --precision), then shared by its pieces.
  std::vector<QuantizationGrid> grid_of(parts.size());
  for (size_t p : prototypes) {
    const EncodeOptions part_options = quantization(options, parts[p].unit);
    Result<QuantizationGrid> grid = choose_grid(parts[p].positions, part_options);
    if (!grid.ok()) return error(grid.status().code(), parts[p].source, grid.status().message());
    grid_of[p] = grid.value();
  }
  // One pixel of a view lod_view_pixels high that shows the whole package (`bounds`, of every
  // part) (options.level_share).
  const double extent =
      bounds.empty ? 0.0
                   : std::max({double(bounds.max.x) - bounds.min.x,
                               double(bounds.max.y) - bounds.min.y,
                               double(bounds.max.z) - bounds.min.z});
  const double view_pixel = options.lod_view_pixels > 0 ? extent / options.lod_view_pixels
                                                        : std::numeric_limits<double>::infinity();
  std::vector<Status> status(jobs.size());
  progress(PackStage::kEncode, 0, jobs.size());
  arena.execute([&] {
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      // Plain variables, not a structured binding: encode_level below captures them (C++20
      // lets a lambda capture a binding; clang 14 does not).
      const size_t p = jobs[j].first, k = jobs[j].second;
      const std::vector<Mesh>& levels = levels_of[p][k];
      const Mesh& piece = pieces_of[p][k];
      Encoded& c = out.components[j];
      // Level `level` (levels.size(): the full one, on the part's grid), `distance` from the
      // full one, encoded.
      auto encode_level = [&](size_t level, double distance, EncodeReport* encoded) {
        const Mesh* mesh = level < levels.size() ? &levels[level] : &piece;
        EncodeOptions encode_options;
        encode_options.grid = grid_of[p];
        // A coarser level on a coarser step (src/package/level_grid.cpp): a whole part on a
        // coarser grid; a segmented part's piece on the part's grid, with the vertices off its
        // border on a lattice of that step.
        Mesh snapped;
        if (level < levels.size()) {
          const double step = detail::level_step(grid_of[p].step, distance);
          if (pieces_of[p].size() == 1) {
            encode_options.grid.step = step;
            encode_options.grid.lattice = 0;  // a coarser grid is off the voxel lattice
          } else if (step > grid_of[p].step) {
            const auto period = static_cast<uint32_t>(std::lround(step / grid_of[p].step));
            snapped = detail::snap_inside_border(*mesh, grid_of[p], period);
            mesh = &snapped;
            encode_options.grid.lattice = period;
          }
        }
        return encode(*mesh, encode_options, encoded);
      };
      // The full level first: its bytes bound what the coarser ones may cost (level_share).
      EncodeReport encoded;
      Result<std::vector<uint8_t>> full = encode_level(levels.size(), 0, &encoded);
      if (!full.ok()) {
        status[j] = full.status();
        return;
      }
      c.entry.bytes = full.value().size();
      c.entry.triangles = encoded.triangles;
      c.entry.vertices = encoded.vertices;
      c.entry.bounds = bounding_box(piece);
      // Every coordinate within half a step: the position within sqrt(3) / 2 steps.
      c.entry.error_bound = std::sqrt(3.0) / 2 * grid_of[p].step;
      const double share = options.level_share * double(c.entry.bytes);
      uint64_t spent = 0;
      std::optional<DistanceQuery> to_full;  // the full level's hierarchy, for every distance
      if (!levels.empty()) {
        Result<DistanceQuery> query = DistanceQuery::build(piece);
        if (!query.ok()) {
          status[j] = query.status();
          return;
        }
        to_full.emplace(std::move(query.value()));
      }
      // Coarse to fine: the coarsest always; then each level while the kept ones stay within the
      // share (each finer level costs more than the one before); then, if the finest kept is more
      // than a pixel off in the whole view, the first level within that pixel, and none after.
      for (size_t level = 0; level < levels.size(); ++level) {
        Result<double> distance = detail::level_distance(piece, *to_full, levels[level],
                                                         detail::LevelSampling::kEstimate);
        if (!distance.ok()) {
          status[j] = distance.status();
          return;
        }
        Result<std::vector<uint8_t>> bytes = encode_level(level, *distance, &encoded);
        if (!bytes.ok()) {
          status[j] = bytes.status();
          return;
        }
        const bool fits = level == 0 || double(spent + bytes.value().size()) <= share;
        if (!fits && c.entry.levels.back().error <= view_pixel) break;  // the view is served
        // Over the share, only a level within the view's pixel is kept. One whose estimated
        // distance is already over it is not measured (quantized, it is further still, but for
        // sampling noise).
        if (!fits && *distance > view_pixel) continue;
        // Measured as the viewer draws it: quantized. A level is never recorded as nearer than
        // the full level's own bound.
        Result<Mesh> drawn = decode(bytes.value().data(), bytes.value().size(), piece.source);
        Result<double> measured = drawn.ok()
                                      ? detail::level_distance(piece, *to_full, drawn.value(),
                                                                detail::LevelSampling::kMeasure)
                                      : Result<double>(drawn.status());
        if (!measured.ok()) {
          status[j] = measured.status();
          return;
        }
        const double error = std::max(measured.value(), c.entry.error_bound);
        if (!fits && error > view_pixel) continue;
        spent += bytes.value().size();
        ManifestLevel entry;
        entry.bytes = bytes.value().size();
        entry.triangles = encoded.triangles;
        entry.vertices = encoded.vertices;
        entry.error = error;
        c.entry.levels.push_back(entry);
        c.streams.push_back({sha256_hex(bytes.value()), std::move(bytes.value())});
        if (!fits) break;  // the level the whole view needs
      }
      c.streams.push_back({sha256_hex(full.value()), std::move(full.value())});
      // Formatted, not concatenated: g++ 12 warns (-Wrestrict, a false positive) on string
      // appends here.
      char id[32];
      std::snprintf(id, sizeof(id), "c%zu", j);
      c.entry.id = id;
    });
  });
  for (const Status& s : status) OSTEON_RETURN_IF_ERROR(s);
  progress(PackStage::kEncode, jobs.size(), jobs.size());
  return out;
}

/// Instances: every part draws each of its prototype's components with its matrix. Also sums
/// each component's projected world area, for the stream order.
std::vector<ManifestInstance> place_instances(const std::vector<Mesh>& parts, const Repeats& r,
                                              const EncodedParts& encoded,
                                              std::vector<double>* area_of) {
  std::vector<ManifestInstance> instances;
  area_of->assign(encoded.components.size(), 0.0);
  for (size_t p = 0; p < parts.size(); ++p) {
    for (size_t c : encoded.components_of[r.prototype_of[p]]) {
      ManifestInstance instance;
      instance.part = p;
      instance.component = encoded.components[c].entry.id;
      instance.matrix = r.matrix_of[p];
      instance.mirror = r.mirror_of[p];
      instance.error_bound = encoded.components[c].entry.error_bound + r.error_of[p];
      (*area_of)[c] +=
          projected_area(transform_box(encoded.components[c].entry.bounds, instance.matrix));
      instances.push_back(std::move(instance));
    }
  }
  return instances;
}

/// Where stream `level` of component `c` lies (its full level is the last stream).
void place_stream(Encoded& c, size_t level, uint64_t chunk, uint64_t offset) {
  if (level + 1 == c.streams.size()) {
    c.entry.chunk = chunk;
    c.entry.offset = offset;
  } else {
    c.entry.levels[level].chunk = chunk;
    c.entry.levels[level].offset = offset;
  }
}

/// The chunk files (docs/FORMAT.md "Levels of detail"): every component's first stream (its
/// coarsest level) in stream order, then, from a new chunk on, every second-coarsest level in
/// stream order, then every third, and so on, each chunk at most chunk_bytes (a larger stream
/// gets one of its own). So the viewer reads the first chunks whole, as streams, decoding each
/// component the moment its last byte arrives, and has the whole skeleton; the finer levels it
/// fetches by byte range as the view asks. Equal streams are stored once. Sets every stream's
/// chunk and offset.
std::vector<std::vector<uint8_t>> chunk_streams(const std::vector<size_t>& stream,
                                                uint64_t chunk_bytes,
                                                std::vector<Encoded>* components,
                                                std::vector<ManifestChunk>* chunks) {
  std::vector<std::vector<uint8_t>> bytes;
  // stream hash -> (chunk, offset) of the bytes already stored
  std::map<std::string, std::pair<uint64_t, uint64_t>> stored;
  bool new_chunk = true;
  auto add = [&](Encoded& c, size_t level) {
    const Stream& s = c.streams[level];
    auto first = stored.find(s.hash);
    if (first != stored.end()) {
      place_stream(c, level, first->second.first, first->second.second);
      return;
    }
    if (new_chunk || (!bytes.back().empty() && bytes.back().size() + s.bytes.size() > chunk_bytes)) {
      bytes.emplace_back();
      new_chunk = false;
    }
    const std::pair<uint64_t, uint64_t> at{bytes.size() - 1, bytes.back().size()};
    stored.emplace(s.hash, at);
    place_stream(c, level, at.first, at.second);
    bytes.back().insert(bytes.back().end(), s.bytes.begin(), s.bytes.end());
  };
  size_t depth = 0;
  for (size_t c : stream) {
    add((*components)[c], 0);
    depth = std::max(depth, (*components)[c].streams.size());
  }
  new_chunk = true;  // the first chunks hold first streams only
  for (size_t level = 1; level < depth; ++level) {
    for (size_t c : stream) {
      if (level < (*components)[c].streams.size()) add((*components)[c], level);
    }
  }
  for (const std::vector<uint8_t>& chunk : bytes) {
    ManifestChunk file;
    file.file = "c/";
    file.file += sha256_hex(chunk).substr(0, 24);
    file.file += ".ostc";
    file.bytes = chunk.size();
    chunks->push_back(std::move(file));
  }
  return bytes;
}

/// The manifest and the chunks' bytes: instances, stream order (components by decreasing summed
/// projected area of their instances), chunks, parts with their display names.
Manifest build_manifest(const std::vector<Mesh>& parts, const Aabb& bounds, const Repeats& r,
                        const detail::Names& names_file, uint64_t chunk_bytes,
                        EncodedParts* encoded, std::vector<std::vector<uint8_t>>* chunk_data) {
  Manifest manifest;
  manifest.unit = parts.front().unit;
  // Label volumes are read into the patient's frame (LPS: +z superior, -y anterior), so a package
  // made only of them says which way is up and where the front is.
  manifest.has_view = std::all_of(parts.begin(), parts.end(),
                                  [](const Mesh& part) { return part.label > 0; });
  manifest.bounds = bounds;
  std::vector<double> area_of;
  manifest.instances = place_instances(parts, r, *encoded, &area_of);
  std::vector<size_t> stream(encoded->components.size());
  for (size_t i = 0; i < stream.size(); ++i) stream[i] = i;
  std::stable_sort(stream.begin(), stream.end(),
                   [&](size_t a, size_t b) { return area_of[a] > area_of[b]; });
  *chunk_data = chunk_streams(stream, chunk_bytes, &encoded->components, &manifest.chunks);
  manifest.languages = names_file.languages;
  // The region tree: one group per distinct path prefix, in the order the parts first reach it,
  // each after its parent; a group's names in other languages are the first ones given.
  std::map<std::pair<int64_t, std::string>, int64_t> group_of;
  const auto add_path = [&](const std::vector<detail::GroupName>& path) {
    int64_t parent = -1;
    for (const detail::GroupName& g : path) {
      const auto [it, added] =
          group_of.emplace(std::make_pair(parent, g.name), int64_t(manifest.groups.size()));
      if (added) manifest.groups.push_back({g.name, parent, {}});
      ManifestGroup& group = manifest.groups[size_t(it->second)];
      for (const auto& [tag, text] : g.names) group.names.emplace(tag, text);
      parent = it->second;
    }
    return parent;
  };
  std::vector<const detail::DisplayName*> named_of(parts.size());
  for (size_t p = 0; p < parts.size(); ++p) {
    named_of[p] = detail::find_display_name(names_file, parts[p]);
  }
  // Derived paths first, in their rank order, so that the tree reads head to toe; the names
  // file's own paths follow in the file's order.
  std::vector<const detail::DisplayName*> ranked;
  for (const detail::DisplayName* named : named_of) {
    if (named != nullptr && !named->path.empty()) ranked.push_back(named);
  }
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const detail::DisplayName* a, const detail::DisplayName* b) {
                     return a->rank < b->rank;
                   });
  for (const detail::DisplayName* name : ranked) add_path(name->path);
  for (size_t p = 0; p < parts.size(); ++p) {
    ManifestPart part;
    part.name = parts[p].name;
    part.display_name = parts[p].name;
    const detail::DisplayName* named = named_of[p];
    if (named != nullptr) {
      if (!named->name.empty()) part.display_name = named->name;
      part.group = named->group;
      part.names = named->names;
      part.system = named->system;
      if (!named->path.empty()) {
        part.path = add_path(named->path);
        part.group.clear();
        for (const detail::GroupName& g : named->path) {
          part.group += (part.group.empty() ? "" : " / ") + g.name;
        }
      }
    }
    part.source = fs::path(parts[p].source).filename().string();
    part.triangles = parts[p].triangle_count();
    part.prototype = r.prototype_of[p];
    part.has_color = parts[p].has_color;
    part.color = parts[p].color;
    if (named != nullptr && named->has_color) {
      part.has_color = true;
      part.color = named->color;
    }
    manifest.parts.push_back(std::move(part));
  }
  for (const Encoded& c : encoded->components) manifest.components.push_back(c.entry);
  for (size_t c : stream) manifest.stream_order.push_back(encoded->components[c].entry.id);
  return manifest;
}

/// Write: the viewer's files, the chunk files, manifest.json.gz, then manifest.json last, each
/// through a temporary file and a rename.
Status write_stage(const PackOptions& options, const ViewerFiles& viewer_files,
                   const std::vector<std::vector<uint8_t>>& chunk_data, const Manifest& manifest,
                   const Progress& progress, PackReport* report) {
  const fs::path root(options.output);
  std::error_code ec;
  fs::create_directories(root / "c", ec);
  if (ec) {
    return error(ErrorCode::kIoError, options.output, "cannot create the folder: " + ec.message());
  }
  const uint64_t file_count = viewer_files.size() + chunk_data.size() + 1;
  uint64_t files_done = 0;
  progress(PackStage::kWrite, 0, file_count);
  for (const auto& [relative, bytes] : viewer_files) {
    const fs::path path = root / relative;
    fs::create_directories(path.parent_path(), ec);
    if (ec) {
      return error(ErrorCode::kIoError, path.parent_path().string(),
                   "cannot create the folder: " + ec.message());
    }
    OSTEON_RETURN_IF_ERROR(write_file_atomic(path.string(), bytes.data(), bytes.size()));
    report->viewer_bytes += bytes.size();
    progress(PackStage::kWrite, ++files_done, file_count);
  }
  report->viewer_files = viewer_files.size();
  for (size_t k = 0; k < chunk_data.size(); ++k) {
    progress(PackStage::kWrite, ++files_done, file_count);
    report->output_bytes += chunk_data[k].size();
    const std::string path = (root / manifest.chunks[k].file).string();
    OSTEON_RETURN_IF_ERROR(write_file_atomic(path, chunk_data[k].data(), chunk_data[k].size()));
  }
  const std::string text = write_manifest(manifest);
  report->manifest = (root / "manifest.json").string();
  // The manifest precompressed beside it (6x smaller): osteon serve, nginx's gzip_static and
  // most CDNs send it to browsers that accept gzip. Written before the manifest, which stays last.
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> gz,
                          gzip_deterministic(text, report->manifest + ".gz"));
  OSTEON_RETURN_IF_ERROR(write_file_atomic(report->manifest + ".gz", gz.data(), gz.size()));
  report->manifest_gzip_bytes = gz.size();
  OSTEON_RETURN_IF_ERROR(write_file_atomic(report->manifest, text.data(), text.size()));
  report->output_bytes += text.size();
  progress(PackStage::kWrite, file_count, file_count);
  return {};
}

}  // namespace

const char* stage_name(PackStage stage) {
  switch (stage) {
    case PackStage::kRead:
      return "read";
    case PackStage::kClean:
      return "clean";
    case PackStage::kRepeats:
      return "repeats";
    case PackStage::kSegment:
      return "segment";
    case PackStage::kLevels:
      return "levels";
    case PackStage::kEncode:
      return "encode";
    case PackStage::kWrite:
      return "write";
  }
  return "?";
}

const char* stage_unit(PackStage stage) {
  switch (stage) {
    case PackStage::kRead:
      return "inputs";
    case PackStage::kClean:
    case PackStage::kRepeats:
    case PackStage::kSegment:
      return "parts";
    case PackStage::kLevels:
    case PackStage::kEncode:
      return "components";
    case PackStage::kWrite:
      return "files";
  }
  return "?";
}

namespace {

/// Every stage but the write: the package in memory, the viewer's files to copy in, and the
/// report's counts and timings so far.
struct Built {
  PackageData package;
  ViewerFiles viewer_files;
};

Result<Built> build(const std::vector<std::string>& inputs, const PackOptions& options,
                    const Progress& progress, PackReport* report) {
  PackTimings& ms = report->timings;
  // More threads than cores only makes TBB warn; the output does not depend on the count.
  tbb::task_arena arena(options.threads > 0
                            ? std::min(options.threads, tbb::info::default_concurrency())
                            : tbb::task_arena::automatic);

  auto stage = Clock::now();
  OSTEON_ASSIGN_OR_RETURN(Inputs in, read_stage(inputs, options, progress, report));
  ms.read_ms = ms_since(stage);
  stage = Clock::now();
  OSTEON_RETURN_IF_ERROR(clean_stage(inputs.front(), progress, &in.parts, report));
  ms.clean_ms = ms_since(stage);
  stage = Clock::now();
  OSTEON_ASSIGN_OR_RETURN(Repeats repeats, repeats_stage(in.parts, options, progress));
  report->prototypes = repeats.prototypes.size();
  ms.repeats_ms = ms_since(stage);
  stage = Clock::now();
  OSTEON_ASSIGN_OR_RETURN(std::vector<std::vector<Mesh>> pieces,
                          segment_stage(in.parts, repeats.prototypes, options, progress, arena));
  ms.segment_ms = ms_since(stage);
  stage = Clock::now();
  const auto levels = levels_stage(repeats.prototypes, pieces, options, progress, arena);
  ms.levels_ms = ms_since(stage);
  stage = Clock::now();
  Aabb bounds;  // of every part: the manifest's, and the view levels are kept for
  for (const Mesh& part : in.parts) expand(bounds, bounding_box(part));
  OSTEON_ASSIGN_OR_RETURN(EncodedParts encoded,
                          encode_stage(in.parts, repeats.prototypes, pieces, levels, bounds,
                                       options, progress, arena));
  for (const Encoded& c : encoded.components) {
    report->triangles_out += c.entry.triangles;
    report->level_streams += c.entry.levels.size();
    for (const ManifestLevel& level : c.entry.levels) report->level_triangles += level.triangles;
  }
  ms.encode_ms = ms_since(stage);

  Built built;
  built.package.manifest = build_manifest(in.parts, bounds, repeats, in.names,
                                          options.chunk_bytes, &encoded, &built.package.chunks);
  built.package.source = "pack";
  built.viewer_files = std::move(in.viewer_files);
  const Manifest& manifest = built.package.manifest;
  // The first chunks hold every component's first stream (FORMAT: "Levels of detail").
  std::set<uint64_t> first_chunks;
  for (const ManifestComponent& c : manifest.components) {
    first_chunks.insert(c.levels.empty() ? c.chunk : c.levels.front().chunk);
    for (const ManifestLevel& level : c.levels) report->level_bytes += level.bytes;
  }
  for (uint64_t k : first_chunks) report->first_bytes += manifest.chunks[k].bytes;
  report->components = manifest.components.size();
  report->files = manifest.chunks.size();
  report->instances = manifest.instances.size();
  return built;
}

}  // namespace

Result<PackReport> pack(const std::vector<std::string>& inputs, const PackOptions& options) {
  OSTEON_RETURN_IF_ERROR(check_options(inputs, options));
  // Fails before any work when options.output is neither absent, empty nor a package.
  OSTEON_RETURN_IF_ERROR(detail::prepare_package_folder(options.output));
  const auto start = Clock::now();
  PackOptions staged = options;  // output: the fresh folder the write stage fills
  staged.progress = detail::with_pause_hook(options.progress);
  const Progress progress{staged};
  PackReport report;
  OSTEON_ASSIGN_OR_RETURN(Built built, build(inputs, options, progress, &report));
  const auto stage = Clock::now();
  // Written beside options.output, then swapped in whole (docs/DESIGN.md "Publishing a package").
  OSTEON_ASSIGN_OR_RETURN(detail::StagedPackage folder,
                          detail::stage_package_folder(options.output));
  staged.output = folder.folder;
  OSTEON_RETURN_IF_ERROR(write_stage(staged, built.viewer_files, built.package.chunks,
                                     built.package.manifest, progress, &report));
  OSTEON_RETURN_IF_ERROR(detail::publish_package_folder(&folder));
  report.manifest = (fs::path(options.output) / "manifest.json").string();
  report.timings.write_ms = ms_since(stage);
  report.timings.total_ms = ms_since(start);
  return report;
}

Result<PackageData> pack_in_memory(const std::vector<std::string>& inputs,
                                   const PackOptions& options, PackReport* report) {
  PackOptions memory = options;
  memory.output = "(memory)";  // check_options wants one; nothing is written
  memory.viewer.clear();
  OSTEON_RETURN_IF_ERROR(check_options(inputs, memory));
  const auto start = Clock::now();
  const Progress progress{memory};
  PackReport local;
  PackReport* r = report != nullptr ? report : &local;
  *r = PackReport();
  OSTEON_ASSIGN_OR_RETURN(Built built, build(inputs, memory, progress, r));
  for (const std::vector<uint8_t>& chunk : built.package.chunks) r->output_bytes += chunk.size();
  // The manifest as a reader of the written package sees it (numbers rounded as written), so
  // that what is made of it does not depend on whether the package went through a folder.
  const std::string text = write_manifest(built.package.manifest);
  r->output_bytes += text.size();
  OSTEON_ASSIGN_OR_RETURN(
      built.package.manifest,
      parse_manifest(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "pack"));
  r->timings.total_ms = ms_since(start);
  return std::move(built.package);
}

}  // namespace osteon
