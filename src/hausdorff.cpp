// SPDX-License-Identifier: Apache-2.0
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "distance_internal.hpp"
#include "osteon/hausdorff.hpp"

// Based on: P. Cignoni, C. Rocchini, R. Scopigno, "Metro: measuring error on simplified surfaces",
// Computer Graphics Forum 17(2), 1998: samples on the vertices, the edges and the faces of one
// mesh, each measured exactly to the other mesh; max, mean and RMS of those distances. The split
// of the sample budget among the three kinds is MeshLab's Hausdorff filter's (vertices, then as
// many edge samples as face samples), so both tools can be run at the same sample count.
//
// Sampling. Edge samples follow Metro's rule (EdgeSampling::kEvenlySpaced): n samples shared out
// over the unique edges laid end to end, edge e getting floor(running length through e / (L / n))
// minus what the edges before it got, at evenly spaced interior points; so osteon and MeshLab
// place their edge samples at the very same points. kStratified puts sample k at arc length
// (k + u) L / n instead, u uniform in [0, 1). Face samples are stratified by area over the
// triangles in index order, at a uniform random point of the triangle the stratum falls in:
// stratified rather than Metro's plain Monte Carlo, so every A / n of area gets exactly one
// sample and no region is left unsampled by chance; the expected mean is the same. Consecutive
// samples lie on neighbouring triangles, whose closest triangle on the other mesh is a good start
// for the next query (DistanceQuery's hint).
//
// Determinism. Sample k's position is a pure function of (seed, kind, k): a counter-based hash,
// no generator state shared between threads. Samples are measured in fixed blocks of kBlock; each
// block sums its distances in order and the blocks are added in order, so the figures are the same
// bit for bit whatever the number of threads and however TBB schedules the blocks.

namespace osteon {

namespace {

constexpr uint64_t kBlock = 4096;         // samples per task; the unit of the ordered sums
constexpr uint64_t kBlocksPerSlice = 64;  // blocks between progress reports (262,144 samples)

enum SampleKind : uint64_t { kVertexSample = 1, kEdgeSample = 2, kFaceSample = 3 };

// SplitMix64's finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mix.
uint64_t mix64(uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ull;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Draw `j` (0..3) of sample `k` of a kind whose stream key is `key`: uniform in [0, 1).
double uniform(uint64_t key, uint64_t k, uint64_t j) {
  return double(mix64(key + (4 * k + j + 1) * 0x9e3779b97f4a7c15ull) >> 11) * 0x1p-53;
}

// Where the samples of one mesh go.
struct SamplePlan {
  const Mesh* mesh = nullptr;
  std::vector<uint32_t> vertices;  // referenced vertex ids, ascending
  std::vector<uint64_t> edges;     // unique undirected edges, (low id << 32) | high id, ascending
  std::vector<double> edge_end;    // running length at each edge's end
  std::vector<uint64_t> edge_count_end;  // kEvenlySpaced: running sample count at each edge's end
  EdgeSampling edge_sampling = EdgeSampling::kStratified;
  std::vector<double> face_end;  // running area at each triangle's end
  uint64_t vertex_samples = 0, edge_samples = 0, face_samples = 0;
  uint64_t vertex_key = 0, edge_key = 0, face_key = 0;
  double diagonal = 0;
  double largest_coordinate = 0;

  uint64_t total() const { return vertex_samples + edge_samples + face_samples; }
};

Vec3d position(const Mesh& mesh, uint32_t vertex) {
  return to_double(mesh.positions[vertex]);
}

double diagonal_of(const Aabb& box) {
  if (box.empty) return 0;
  Vec3d d = to_double(box.max) - to_double(box.min);
  return std::sqrt(dot(d, d));
}

double largest_coordinate_of(const Aabb& box) {
  if (box.empty) return 0;
  return std::max({std::fabs(double(box.min.x)), std::fabs(double(box.min.y)),
                   std::fabs(double(box.min.z)), std::fabs(double(box.max.x)),
                   std::fabs(double(box.max.y)), std::fabs(double(box.max.z))});
}

Status check_options(const HausdorffOptions& options) {
  if (options.samples == 0 && !(options.samples_per_face > 0 && options.samples_per_face < 1e9)) {
    return error(ErrorCode::kInvalidArgument, "",
                 "samples_per_face must be > 0 (and below 1e9) when samples is 0");
  }
  if (!(options.known_max >= 0 && options.known_max < 1e300)) {
    return error(ErrorCode::kInvalidArgument, "", "known_max must be a finite distance >= 0");
  }
  if (options.threads < 0) {
    return error(ErrorCode::kInvalidArgument, "", "threads must be >= 0 (0: every core)");
  }
  if (!options.sample_vertices && !options.sample_edges && !options.sample_faces) {
    return error(ErrorCode::kInvalidArgument, "",
                 "no sample kind chosen (vertices, edges and faces are all off)");
  }
  return Status::ok_status();
}

// Plans the samples on `mesh` (already checked by check_surface).
SamplePlan make_plan(const Mesh& mesh, const HausdorffOptions& options) {
  SamplePlan plan;
  plan.mesh = &mesh;
  size_t triangles = mesh.triangle_count();
  uint64_t budget = options.samples;
  if (budget == 0) {
    budget = std::max<uint64_t>(1, uint64_t(std::llround(options.samples_per_face * triangles)));
  }
  std::vector<bool> seen(mesh.positions.size(), false);
  for (uint32_t i : mesh.indices) seen[i] = true;
  for (uint32_t v = 0; v < seen.size(); ++v) {
    if (seen[v]) plan.vertices.push_back(v);
  }
  Aabb box;
  for (uint32_t v : plan.vertices) expand(box, mesh.positions[v]);
  plan.diagonal = diagonal_of(box);
  plan.largest_coordinate = largest_coordinate_of(box);

  double length = 0;
  if (options.sample_edges) {
    plan.edges.reserve(mesh.indices.size());
    for (size_t t = 0; t < triangles; ++t) {
      for (int k = 0; k < 3; ++k) {
        uint32_t a = mesh.indices[3 * t + k], b = mesh.indices[3 * t + (k + 1) % 3];
        if (a == b) continue;
        plan.edges.push_back(uint64_t(std::min(a, b)) << 32 | std::max(a, b));
      }
    }
    tbb::parallel_sort(plan.edges.begin(), plan.edges.end());
    plan.edges.erase(std::unique(plan.edges.begin(), plan.edges.end()), plan.edges.end());
    plan.edge_end.resize(plan.edges.size());
    for (size_t e = 0; e < plan.edges.size(); ++e) {
      Vec3d d =
          position(mesh, uint32_t(plan.edges[e] >> 32)) - position(mesh, uint32_t(plan.edges[e]));
      length += std::sqrt(dot(d, d));
      plan.edge_end[e] = length;
    }
  }
  double area = 0;
  if (options.sample_faces) {
    plan.face_end.resize(triangles);
    for (size_t t = 0; t < triangles; ++t) {
      Vec3d a = position(mesh, mesh.indices[3 * t]);
      Vec3d n = cross(position(mesh, mesh.indices[3 * t + 1]) - a,
                      position(mesh, mesh.indices[3 * t + 2]) - a);
      area += 0.5 * std::sqrt(dot(n, n));
      plan.face_end[t] = area;
    }
  }

  // The split: MeshLab's Hausdorff filter samples SampleNum vertices (all of them when there are
  // fewer), SampleNum edge points and SampleNum face points; so min(vertices, budget / kinds)
  // vertex samples, the rest shared by edges and faces. Kinds of zero size (all edges of zero
  // length, all triangles of zero area) get none; vertices are sampled when nothing else is left.
  bool edges = options.sample_edges && length > 0;
  bool faces = options.sample_faces && area > 0;
  bool vertices = options.sample_vertices || (!edges && !faces);
  uint64_t kinds = uint64_t(vertices) + uint64_t(edges) + uint64_t(faces);
  uint64_t vertex_count = plan.vertices.size();
  plan.vertex_samples = vertices ? std::min(vertex_count, budget / kinds) : 0;
  uint64_t rest = budget - plan.vertex_samples;
  if (edges && faces) {
    plan.edge_samples = rest / 2;
    plan.face_samples = rest - plan.edge_samples;
  } else if (edges) {
    plan.edge_samples = rest;
  } else if (faces) {
    plan.face_samples = rest;
  }
  plan.edge_sampling = options.edge_sampling;
  if (plan.edge_samples > 0 && plan.edge_sampling == EdgeSampling::kEvenlySpaced) {
    // Samples through edge e: floor(running length / (L / n)); the last edge closes at n.
    double step = length / double(plan.edge_samples);
    plan.edge_count_end.resize(plan.edges.size());
    for (size_t e = 0; e < plan.edges.size(); ++e) {
      plan.edge_count_end[e] =
          std::min(plan.edge_samples, uint64_t(std::floor(plan.edge_end[e] / step)));
    }
    plan.edge_count_end.back() = plan.edge_samples;
  }
  uint64_t seed_key = mix64(options.seed);
  plan.vertex_key = mix64(seed_key ^ kVertexSample);
  plan.edge_key = mix64(seed_key ^ kEdgeSample);
  plan.face_key = mix64(seed_key ^ kFaceSample);
  return plan;
}

// The position of sample g (vertex samples first, then edge, then face samples).
Vec3d sample_point(const SamplePlan& plan, uint64_t g) {
  const Mesh& mesh = *plan.mesh;
  if (g < plan.vertex_samples) {
    // Stratified over the vertex list: all of them in order when there are as many samples.
    double where = (double(g) + uniform(plan.vertex_key, g, 0)) * double(plan.vertices.size()) /
                   double(plan.vertex_samples);
    size_t i = std::min(plan.vertices.size() - 1, size_t(where));
    return position(mesh, plan.vertices[i]);
  }
  g -= plan.vertex_samples;
  if (g < plan.edge_samples && plan.edge_sampling == EdgeSampling::kEvenlySpaced) {
    size_t e = std::upper_bound(plan.edge_count_end.begin(), plan.edge_count_end.end(), g) -
               plan.edge_count_end.begin();
    uint64_t first = e > 0 ? plan.edge_count_end[e - 1] : 0;
    double t = double(g - first + 1) / double(plan.edge_count_end[e] - first + 1);
    Vec3d a = position(mesh, uint32_t(plan.edges[e] >> 32));
    Vec3d b = position(mesh, uint32_t(plan.edges[e]));
    return a + t * (b - a);
  }
  if (g < plan.edge_samples) {
    double total = plan.edge_end.back();
    double s = (double(g) + uniform(plan.edge_key, g, 0)) * total / double(plan.edge_samples);
    size_t e =
        std::upper_bound(plan.edge_end.begin(), plan.edge_end.end(), s) - plan.edge_end.begin();
    e = std::min(e, plan.edges.size() - 1);
    double start = e > 0 ? plan.edge_end[e - 1] : 0.0;
    double length = plan.edge_end[e] - start;
    double t = length > 0 ? std::clamp((s - start) / length, 0.0, 1.0) : 0.5;
    Vec3d a = position(mesh, uint32_t(plan.edges[e] >> 32));
    Vec3d b = position(mesh, uint32_t(plan.edges[e]));
    return a + t * (b - a);
  }
  g -= plan.edge_samples;
  double total = plan.face_end.back();
  double s = (double(g) + uniform(plan.face_key, g, 0)) * total / double(plan.face_samples);
  size_t t =
      std::upper_bound(plan.face_end.begin(), plan.face_end.end(), s) - plan.face_end.begin();
  t = std::min(t, plan.face_end.size() - 1);
  // A uniform point of the triangle: sqrt(u1) picks the distance from corner a's opposite side
  // with density proportional to the width there, u2 the position across.
  double r = std::sqrt(uniform(plan.face_key, g, 1));
  double w = uniform(plan.face_key, g, 2);
  Vec3d a = position(mesh, mesh.indices[3 * t]);
  Vec3d b = position(mesh, mesh.indices[3 * t + 1]);
  Vec3d c = position(mesh, mesh.indices[3 * t + 2]);
  return (1 - r) * a + (r * (1 - w)) * b + (r * w) * c;
}

struct BlockResult {
  double sum = 0;
  double sum2 = 0;
  double max = -1;
  Vec3d max_at, max_closest;
};

struct Progress {
  const std::function<void(uint64_t, uint64_t)>* callback = nullptr;
  uint64_t before = 0;  // samples done before this direction
  uint64_t total = 0;   // samples of every direction
};

// Measures one sample `g` of `plan` into `r`. With `max_only`, only as far as it could raise
// the larger of r.max and `floor` (a distance already reached): a sample nearer than that records
// some distance no larger than it, never more, so the largest recorded is still the exact largest
// wherever it exceeds `floor`.
void measure_sample(const SamplePlan& plan, const DistanceQuery& target, uint64_t g,
                    double zero_below, bool max_only, double floor, uint32_t* hint,
                    BlockResult* r) {
  Vec3d p = sample_point(plan, g);
  ClosestPoint c = max_only ? target.closest(p, *hint, std::max({r->max, floor, zero_below}))
                            : target.closest(p, *hint);
  *hint = c.triangle;
  double d = c.distance <= zero_below ? 0.0 : c.distance;
  r->sum += d;
  r->sum2 += d * d;
  if (d > r->max) {
    r->max = d;
    r->max_at = p;
    r->max_closest = c.point;
  }
}

// Measures every sample of `plan` against `target`. With `max_only`, a distance `known` from
// elsewhere and then every kSeedStride-th sample, measured first in order, set the floor below
// which the blocks need not measure exactly: without it each block would search the whole
// hierarchy for its first samples, until its own largest distance grew.
OneSidedDistance measure(const SamplePlan& plan, const DistanceQuery& target, double zero_below,
                         bool max_only, double known, const Progress& progress) {
  constexpr uint64_t kSeedStride = 61;
  uint64_t count = plan.total();
  uint64_t blocks = (count + kBlock - 1) / kBlock;
  BlockResult seed;
  if (max_only) {
    uint32_t hint = ClosestPoint::kNoTriangle;
    for (uint64_t g = 0; g < count; g += kSeedStride) {
      measure_sample(plan, target, g, zero_below, true, known, &hint, &seed);
    }
  }
  const double floor = max_only ? std::max(known, seed.max) : 0.0;
  std::vector<BlockResult> results(blocks);
  for (uint64_t slice = 0; slice < blocks; slice += kBlocksPerSlice) {
    uint64_t slice_end = std::min(blocks, slice + kBlocksPerSlice);
    tbb::parallel_for(tbb::blocked_range<uint64_t>(slice, slice_end, 1),
                      [&](const tbb::blocked_range<uint64_t>& range) {
                        for (uint64_t block = range.begin(); block < range.end(); ++block) {
                          BlockResult& r = results[block];
                          uint32_t hint = ClosestPoint::kNoTriangle;
                          uint64_t end = std::min(count, (block + 1) * kBlock);
                          for (uint64_t g = block * kBlock; g < end; ++g) {
                            measure_sample(plan, target, g, zero_below, max_only, floor, &hint, &r);
                          }
                        }
                      });
    if (progress.callback != nullptr && *progress.callback) {
      (*progress.callback)(progress.before + std::min(count, slice_end * kBlock), progress.total);
    }
  }
  OneSidedDistance out;
  double sum = 0, sum2 = 0;
  out.max = seed.max;  // -1 unless seeded; a block's sample wins only where it is larger
  out.max_at = seed.max_at;
  out.max_closest = seed.max_closest;
  for (const BlockResult& r : results) {
    sum += r.sum;
    sum2 += r.sum2;
    if (r.max > out.max) {
      out.max = r.max;
      out.max_at = r.max_at;
      out.max_closest = r.max_closest;
    }
  }
  out.max = std::max(out.max, 0.0);
  out.samples = count;
  out.vertex_samples = plan.vertex_samples;
  out.edge_samples = plan.edge_samples;
  out.face_samples = plan.face_samples;
  out.mean = count > 0 && !max_only ? sum / double(count) : 0.0;
  out.rms = count > 0 && !max_only ? std::sqrt(sum2 / double(count)) : 0.0;
  out.diagonal = plan.diagonal;
  return out;
}

// Distances at or below this are rounding, not geometry: 2^-32 of the largest coordinate
// magnitude, 1/256 of float's resolution at the meshes' scale and far above double's rounding in
// the distance computation.
double zero_below(double largest_coordinate) {
  return largest_coordinate * 0x1p-32;
}

// Runs f on `threads` threads (0: every core; more than the cores: every core).
template <class F>
auto in_arena(int threads, F&& f) {
  int cores = tbb::info::default_concurrency();
  tbb::task_arena arena(threads > 0 ? std::min(threads, cores) : cores);
  return arena.execute(std::forward<F>(f));
}

}  // namespace

Result<OneSidedDistance> one_sided_distance(const Mesh& sampled, const DistanceQuery& target,
                                            const HausdorffOptions& options) {
  OSTEON_RETURN_IF_ERROR(check_options(options));
  OSTEON_RETURN_IF_ERROR(detail::check_surface(sampled));
  return in_arena(options.threads, [&] {
    SamplePlan plan = make_plan(sampled, options);
    double largest = std::max(plan.largest_coordinate, largest_coordinate_of(target.bounds()));
    Progress progress{&options.progress, 0, plan.total()};
    return measure(plan, target, zero_below(largest), options.max_only, options.known_max,
                   progress);
  });
}

Result<HausdorffReport> hausdorff(const Mesh& a, const Mesh& b, const HausdorffOptions& options) {
  OSTEON_RETURN_IF_ERROR(check_options(options));
  OSTEON_RETURN_IF_ERROR(detail::check_surface(a));
  OSTEON_RETURN_IF_ERROR(detail::check_surface(b));
  return in_arena(options.threads, [&]() -> Result<HausdorffReport> {
    OSTEON_ASSIGN_OR_RETURN(DistanceQuery to_b, DistanceQuery::build(b));
    OSTEON_ASSIGN_OR_RETURN(DistanceQuery to_a, DistanceQuery::build(a));
    SamplePlan on_a = make_plan(a, options);
    SamplePlan on_b = make_plan(b, options);
    double floor = zero_below(std::max(on_a.largest_coordinate, on_b.largest_coordinate));
    uint64_t total = on_a.total() + on_b.total();
    HausdorffReport report;
    report.forward = measure(on_a, to_b, floor, options.max_only, options.known_max,
                             {&options.progress, 0, total});
    report.backward = measure(on_b, to_a, floor, options.max_only, options.known_max,
                              {&options.progress, on_a.total(), total});

    const OneSidedDistance& f = report.forward;
    const OneSidedDistance& r = report.backward;
    OneSidedDistance& s = report.symmetric;
    const OneSidedDistance& larger = r.max > f.max ? r : f;
    s.max = larger.max;
    s.max_at = larger.max_at;
    s.max_closest = larger.max_closest;
    s.mean = std::max(f.mean, r.mean);
    s.rms = std::max(f.rms, r.rms);
    s.samples = f.samples + r.samples;
    s.vertex_samples = f.vertex_samples + r.vertex_samples;
    s.edge_samples = f.edge_samples + r.edge_samples;
    s.face_samples = f.face_samples + r.face_samples;
    Aabb both = to_a.bounds();
    expand(both, to_b.bounds());
    s.diagonal = diagonal_of(both);
    return report;
  });
}

PaperRelativeErrors paper_relative_errors(const OneSidedDistance& x_to_y,
                                          const OneSidedDistance& x_to_x) {
  auto relative = [](double xy, double xx) -> std::optional<double> {
    if (!(xx > 0)) return std::nullopt;
    return std::fabs(xy - xx) / xx;
  };
  return {relative(x_to_y.max, x_to_x.max), relative(x_to_y.mean, x_to_x.mean),
          relative(x_to_y.rms, x_to_x.rms)};
}

}  // namespace osteon
