// SPDX-License-Identifier: Apache-2.0
#include "osteon/repeats.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "osteon/hausdorff.hpp"
#include "repeats_internal.hpp"

// Based on: Zhou, Jia & Su (2018), section IV.C: candidates by AABB, then voxel similarity Phi,
// then a matrix per repeat. Added here, for medicine: every substitution is verified (ICP from the
// pose alignment, then a symmetric Hausdorff distance against a tolerance), and the all-pairs
// comparison is replaced by a grid over a pose-invariant descriptor. docs/DESIGN.md ("Repeated
// components") gives each step and why:
//
// clang-format off
//  components ──pose (src/pose.cpp)──▶ centroid, RMS scale, principal axes, signs, normalised AABB
//             ──voxelise (src/voxel_similarity.cpp)──▶ 16^3 occupancy in the normalised box
//  descriptor grid ──▶ pairs in neighbouring cells ──▶ descriptor test ──▶ AABB test
//  greedy, largest area first: prototype p, each unassigned partner m:
//      Phi over the pose alternatives (sign flips, turns about an ambiguous axis) ──▶ best 3
//      ──▶ ICP from each (src/icp.cpp) ──▶ Hausdorff(p transformed, m) <= tolerance ──▶ member
// clang-format on

namespace osteon {

namespace {

using Clock = std::chrono::steady_clock;
using detail::Mat3;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string component_label(const Mesh& mesh, size_t index) {
  if (!mesh.name.empty()) return mesh.name;
  if (!mesh.source.empty()) return mesh.source;
  return "component " + std::to_string(index);
}

Status check_component(const Mesh& mesh, size_t index) {
  const std::string label = component_label(mesh, index);
  const std::string where = "component " + std::to_string(index);
  if (mesh.indices.empty()) {
    return error(ErrorCode::kInvalidArgument, label, "has no triangles: nothing to compare", where);
  }
  if (mesh.indices.size() % 3 != 0) {
    return error(ErrorCode::kInvalidArgument, label,
                 "index count " + std::to_string(mesh.indices.size()) + " is not a multiple of 3",
                 where);
  }
  if (mesh.triangle_count() >= ClosestPoint::kNoTriangle) {
    return error(ErrorCode::kInvalidArgument, label, "has more than 2^32 - 2 triangles", where);
  }
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= mesh.positions.size()) {
      return error(ErrorCode::kInvalidArgument, label,
                   "index " + std::to_string(mesh.indices[i]) + " out of range (" +
                       std::to_string(mesh.positions.size()) + " vertices) in triangle " +
                       std::to_string(i / 3),
                   where);
    }
  }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return error(ErrorCode::kInvalidData, label,
                   "non-finite coordinate (" + std::to_string(p.x) + ", " + std::to_string(p.y) +
                       ", " + std::to_string(p.z) + ") at vertex " + std::to_string(v),
                   where);
    }
  }
  return Status::ok_status();
}

Status check_options(const RepeatOptions& o) {
  auto bad = [](const std::string& what) {
    return error(ErrorCode::kInvalidArgument, "repeat options", what);
  };
  auto finite_at_least = [](double x, double low) { return std::isfinite(x) && x >= low; };
  if (!finite_at_least(o.tolerance, 0)) return bad("tolerance must be a finite number >= 0");
  if (!finite_at_least(o.precision, 0)) return bad("precision must be a finite number >= 0");
  if (o.tolerance == 0 && o.precision == 0 && (o.bits < 8 || o.bits > 24)) {
    return bad("bits must be 8..24, got " + std::to_string(o.bits));
  }
  if (!finite_at_least(o.descriptor_tolerance, 0) || !finite_at_least(o.area_tolerance, 0) ||
      !finite_at_least(o.aabb_tolerance, 0)) {
    return bad("descriptor, area and AABB tolerances must be finite numbers >= 0");
  }
  if (!(o.phi_threshold >= 0 && o.phi_threshold <= 1) ||
      !(o.min_jaccard >= 0 && o.min_jaccard <= 1)) {
    return bad("phi_threshold and min_jaccard must be in [0, 1]");
  }
  if (o.icp_samples < 3) return bad("icp_samples must be >= 3");
  if (o.icp_iterations < 0 || o.icp_iterations > 1000) return bad("icp_iterations must be 0..1000");
  if (o.threads < 0) return bad("threads must be >= 0 (0: every core)");
  if (!finite_at_least(o.bytes_per_triangle, 0)) return bad("bytes_per_triangle must be >= 0");
  return Status::ok_status();
}

struct Component {
  bool usable = false;  // has a pose (area > 0)
  detail::Pose pose;
  detail::VoxelGrid grid;  // in the canonical frame, over the normalised AABB
  double shape_area = 0;   // area / scale^2: pose- and scale-invariant
  double resolution = 0;   // decimal_resolution of its coordinates
  double epsilon = 0;      // its tolerance as a member over its scale (normalised units)
};

// The decimal grid a mesh's coordinates were rounded to before they became floats (an exporter
// printing "%f" writes metres to 6 decimals: every MyoSim coordinate is a multiple of 1e-6), or 0
// when there is none to see. 10^-k for the smallest k (1..9) such that every coordinate is within
// float rounding of a multiple of 10^-k and at least half of those multiples do not end in 0 (so
// a box with integer corners is not "rounded to 0.1"); a grid finer than 16 float steps at the
// largest coordinate cannot be told from float rounding itself and is not looked for. O(V).
double decimal_resolution(const Mesh& mesh) {
  std::vector<char> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  std::vector<double> values;
  double largest = 0;
  for (size_t v = 0; v < used.size(); ++v) {
    if (!used[v]) continue;
    for (float c : {mesh.positions[v].x, mesh.positions[v].y, mesh.positions[v].z}) {
      values.push_back(c);
      largest = std::max(largest, std::fabs(double(c)));
    }
  }
  if (values.empty()) return 0;
  constexpr double kFloatStep = 0x1p-23;  // relative spacing of floats
  double resolution = 1;
  for (int k = 1; k <= 9; ++k) {
    resolution /= 10;
    if (resolution < 16 * largest * kFloatStep) break;
    const double scale = std::pow(10.0, k);
    bool on_grid = true;
    size_t nonzero = 0;
    for (double c : values) {
      const double t = c * scale, d = std::nearbyint(t);
      if (std::fabs(t - d) > scale * std::fabs(c) * kFloatStep + 1e-9) {
        on_grid = false;
        break;
      }
      if (std::fmod(std::fabs(d), 10.0) != 0) ++nonzero;
    }
    if (on_grid && 2 * nonzero >= values.size()) return resolution;
  }
  return 0;
}

// The vertices triangles use, evenly strided down to at most `count`.
std::vector<Vec3d> vertex_samples(const Mesh& mesh, size_t count) {
  std::vector<char> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  std::vector<uint32_t> list;
  for (uint32_t v = 0; v < used.size(); ++v) {
    if (used[v]) list.push_back(v);
  }
  std::vector<Vec3d> out;
  const size_t n = std::min(count, list.size());
  out.reserve(n);
  for (size_t k = 0; k < n; ++k)
    out.push_back(to_double(mesh.positions[list[k * list.size() / n]]));
  return out;
}

bool close_enough(double x, double y, double tolerance) {
  return std::fabs(x - y) <= tolerance * std::max(std::fabs(x), std::fabs(y)) + 1e-12;
}

// Two quantities of normalised poses agree: within `relative` of the larger and within
// `absolute`.
bool agree(double x, double y, double relative, double absolute) {
  return close_enough(x, y, relative) && std::fabs(x - y) <= absolute;
}

// The paper's step 1, on normalised boxes. Extents along an ambiguous axis depend on the turn
// about it, so there the distance from the distinct axis (or from the centroid) is compared.
bool boxes_agree(const detail::Pose& a, const detail::Pose& b, double relative, double absolute) {
  int u = 0;
  switch (detail::combined_ambiguity(a, b, &u)) {
    case detail::AxisAmbiguity::kNone:
      for (size_t k = 0; k < 3; ++k) {
        if (!agree(a.box_max[k] - a.box_min[k], b.box_max[k] - b.box_min[k], relative, absolute)) {
          return false;
        }
      }
      return true;
    case detail::AxisAmbiguity::kPlane: {
      const size_t k = size_t(u);
      return agree(a.box_max[k] - a.box_min[k], b.box_max[k] - b.box_min[k], relative, absolute) &&
             agree(a.radial[k], b.radial[k], relative, absolute);
    }
    case detail::AxisAmbiguity::kFull:
      return agree(a.radius, b.radius, relative, absolute);
  }
  return false;
}

// How far the normalised descriptor and box of a repeat within tolerance can move: every point
// moves at most epsilon (the tolerance over the scale, in normalised units), and the principal
// frame tilts with the moments, by up to about epsilon / (the 10% moment gap) radians, which
// moves a point at radius R by 10 epsilon R, twice over two components. So the candidate tests
// take at most (kTilt epsilon + kFloor) R on top of their options' relative tolerances: a look-
// alike stretched by a few percent is dropped there, before any ICP, once the tolerance is small.
constexpr double kTilt = 20;
constexpr double kFloor = 0.002;

double candidate_slack(const Component& a, const Component& b) {
  const double epsilon = std::max(a.epsilon, b.epsilon);
  return (kTilt * epsilon + kFloor) * std::max(a.pose.radius, b.pose.radius);
}

// True when `turn` only flips axes; sets the flipped axes as bits of *mask.
bool is_sign_flip(const Mat3& turn, unsigned* mask) {
  *mask = 0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const double x = turn[size_t(3 * r + c)];
      if (r != c && x != 0) return false;
      if (r == c && x != 1 && x != -1) return false;
      if (r == c && x < 0) *mask |= 1u << r;
    }
  }
  return true;
}

struct Candidate {
  Mat3 turn = detail::kIdentity3;
  detail::VoxelSimilarity similarity;
};

struct PairVoxels {
  std::vector<Candidate> passing;  // best first (by Jaccard, then Phi)
  uint64_t alternatives = 0;
};

constexpr size_t kTried = 3;  // pose alternatives refined by ICP per pair

// Phi and Jaccard between prototype a and component b under every pose alternative.
PairVoxels compare_voxels(const Mesh& b_mesh, const Component& a, const Component& b,
                          const RepeatOptions& options) {
  PairVoxels out;
  const double handedness = detail::determinant(a.pose.axes) * detail::determinant(b.pose.axes);
  for (const Mat3& turn : detail::pose_alternatives(a.pose, b.pose)) {
    if (!options.allow_mirror && handedness * detail::determinant(turn) < 0) continue;
    unsigned mask = 0;
    const detail::VoxelGrid grid = is_sign_flip(turn, &mask)
                                       ? detail::flip_axes(b.grid, mask)
                                       : detail::voxelize(b_mesh, b.pose, turn);
    const detail::VoxelSimilarity s = detail::voxel_similarity(a.grid, grid);
    ++out.alternatives;
    if (s.phi > options.phi_threshold && s.jaccard >= options.min_jaccard) {
      out.passing.push_back({turn, s});
    }
  }
  std::stable_sort(out.passing.begin(), out.passing.end(),
                   [](const Candidate& x, const Candidate& y) {
                     if (x.similarity.jaccard != y.similarity.jaccard) {
                       return x.similarity.jaccard > y.similarity.jaccard;
                     }
                     return x.similarity.phi > y.similarity.phi;
                   });
  return out;
}

// The similarity the pose alignment gives from a's vertices to b's: y_a = turn * y_b, so
// x_b = c_b + s_b axes_b^T turn^T axes_a (x_a - c_a) / s_a.
detail::Similarity pose_transform(const detail::Pose& a, const detail::Pose& b, const Mat3& turn,
                                  bool allow_scale) {
  Mat3 linear = detail::multiply(detail::transpose(b.axes),
                                 detail::multiply(detail::transpose(turn), a.axes));
  const double s = allow_scale ? b.scale / a.scale : 1.0;
  for (double& x : linear) x *= s;
  detail::Similarity out;
  out.linear = linear;
  out.translation = b.centroid - detail::multiply(linear, a.centroid);
  return out;
}

std::array<double, 16> column_major(const detail::Similarity& s) {
  std::array<double, 16> m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[size_t(4 * c + r)] = s.linear[size_t(3 * r + c)];
  }
  m[12] = s.translation.x;
  m[13] = s.translation.y;
  m[14] = s.translation.z;
  m[15] = 1;
  return m;
}

Mesh moved(const Mesh& mesh, const detail::Similarity& s) {
  Mesh out;
  out.name = mesh.name;
  out.source = mesh.source;
  out.indices = mesh.indices;
  out.positions.reserve(mesh.positions.size());
  for (const Vec3& p : mesh.positions) {
    const Vec3d q = detail::apply(s, to_double(p));
    out.positions.push_back({float(q.x), float(q.y), float(q.z)});
  }
  return out;
}

uint64_t hausdorff_samples(const Mesh& sampled, const RepeatOptions& options) {
  if (options.hausdorff_samples > 0) return options.hausdorff_samples;
  return std::clamp<uint64_t>(3 * uint64_t(sampled.vertex_count()), 600, 30000);
}

// Samples for the coarse ICP, a side, and how far beyond the tolerance its fit may be.
constexpr size_t kCoarseSamples = 64;
// Prototypes verified together at most (their work independent, see next_batch).
constexpr size_t kBatch = 256;
constexpr double kCoarseReject = 4.0;

// What every verification against one prototype shares.
struct Prototype {
  const Mesh* mesh = nullptr;
  const Component* component = nullptr;
  const DistanceQuery* query = nullptr;
  std::vector<Vec3d> samples;  // options.icp_samples of its vertices
  std::vector<Vec3d> coarse;   // kCoarseSamples of them
};

struct Verdict {
  bool verified = false;  // ICP (and, unless ICP already exceeded the tolerance, Hausdorff) ran
  bool accepted = false;
  RepeatMember member;
};

// The member's side of one verification.
struct Member {
  const Mesh* mesh = nullptr;
  const Component* component = nullptr;
  const DistanceQuery* query = nullptr;
};

// A fit of the prototype onto a member, and the pose alternative it came from.
struct Fit {
  detail::Similarity transform;
  Candidate used;
};

/// The tolerance member m is verified against: the codec's bound, but never below what the stored
/// coordinates' own rounding allows: two copies of one shape, each rounded to its decimal grid,
/// differ by up to sqrt(3) / 2 of the grid steps (the prototype's scaled) however exact the copy.
double member_tolerance(const Prototype& p, const Mesh& m_mesh, const Component& m,
                        const RepeatOptions& options) {
  double tolerance = repeat_tolerance(m_mesh, options);
  if (options.tolerance == 0) {
    const double s = options.allow_scale ? m.pose.scale / p.component->pose.scale : 1.0;
    tolerance =
        std::max(tolerance, 0.5 * std::sqrt(3.0) * (s * p.component->resolution + m.resolution));
  }
  return tolerance;
}

/// The fast path: a copy that kept its vertex order (what moving, rotating or mirroring a file's
/// vertices gives) fits vertex to vertex exactly, without closest points. True, with *out set,
/// when the fit of vertex i to vertex i takes every vertex within `tolerance` of its partner.
bool fit_vertex_order(const Mesh& p_mesh, const Mesh& m_mesh, double tolerance,
                      const RepeatOptions& options, detail::Similarity* out) {
  if (p_mesh.vertex_count() != m_mesh.vertex_count() ||
      p_mesh.triangle_count() != m_mesh.triangle_count()) {
    return false;
  }
  std::vector<Vec3d> from, to;
  from.reserve(p_mesh.vertex_count());
  to.reserve(p_mesh.vertex_count());
  for (size_t v = 0; v < p_mesh.vertex_count(); ++v) {
    from.push_back(to_double(p_mesh.positions[v]));
    to.push_back(to_double(m_mesh.positions[v]));
  }
  detail::Similarity fit;
  if (!detail::fit_similarity(from, to, options.allow_mirror ? 0 : 1, options.allow_scale, &fit)) {
    return false;
  }
  double worst = 0;
  for (size_t v = 0; v < from.size(); ++v) {
    worst = std::max(worst, std::sqrt(squared_length(detail::apply(fit, from[v]) - to[v])));
  }
  if (worst <= tolerance) {
    *out = fit;
    return true;
  }
  return false;
}

/// The pose alternatives ICP starts from, in the order it tries them. Where more pass than ICP
/// will try (turns about an ambiguous axis), the ones that line the vertices up best go first.
std::vector<Candidate> alternatives_to_try(const Prototype& p, const Member& m,
                                           const detail::IcpSide& p_coarse,
                                           const detail::IcpSide& m_coarse,
                                           const std::vector<Candidate>& passing,
                                           bool allow_scale) {
  if (passing.size() <= kTried) return passing;
  std::vector<std::pair<double, size_t>> ranked;
  for (size_t k = 0; k < passing.size(); ++k) {
    const detail::Similarity start =
        pose_transform(p.component->pose, m.component->pose, passing[k].turn, allow_scale);
    ranked.push_back({detail::corner_residual(p_coarse, m_coarse, start), k});
  }
  std::sort(ranked.begin(), ranked.end());
  std::vector<Candidate> best_ranked;
  for (size_t k = 0; k < kTried; ++k) best_ranked.push_back(passing[ranked[k].second]);
  return best_ranked;
}

/// ICP from the pose alignment, coarse to fine: ICP on a few samples first; a pose alternative
/// whose coarse fit leaves a sample farther than kCoarseReject tolerances from the other surface
/// is dropped (the distances are exact distances of samples, so the Hausdorff distance is at
/// least that), which spares the full ICP on look-alikes. True, with *fit set, when the best fine
/// fit leaves every sample within `tolerance`.
bool fit_icp(const Prototype& p, const Member& m, const PairVoxels& voxels, double tolerance,
             const RepeatOptions& options, Fit* fit) {
  const std::vector<Vec3d> m_coarse = vertex_samples(*m.mesh, kCoarseSamples);
  const std::vector<Vec3d> m_samples = vertex_samples(*m.mesh, options.icp_samples);
  const detail::IcpSide p_coarse_side{p.mesh, &p.coarse, p.query};
  const detail::IcpSide m_coarse_side{m.mesh, &m_coarse, m.query};
  const std::vector<Candidate> tried =
      alternatives_to_try(p, m, p_coarse_side, m_coarse_side, voxels.passing, options.allow_scale);
  detail::IcpResult best;
  bool have = false;
  for (const Candidate& c : tried) {
    const detail::IcpResult coarse = detail::icp(
        p_coarse_side, m_coarse_side,
        pose_transform(p.component->pose, m.component->pose, c.turn, options.allow_scale),
        options.allow_scale, options.icp_iterations, kCoarseReject * tolerance);
    if (coarse.gave_up || coarse.max > kCoarseReject * tolerance) continue;
    const detail::IcpResult r =
        detail::icp({p.mesh, &p.samples, p.query}, {m.mesh, &m_samples, m.query}, coarse.transform,
                    options.allow_scale, options.icp_iterations);
    if (!have || r.rms < best.rms) {
      best = r;
      fit->used = c;
      have = true;
    }
    if (best.max <= tolerance) break;
  }
  // The ICP's distances are exact distances of sample points to the other surface: when one
  // of them exceeds the tolerance, so does the Hausdorff distance.
  if (!have || best.max > tolerance) return false;
  fit->transform = best.transform;
  return true;
}

/// The symmetric Hausdorff distance between the prototype moved by `transform` and the member,
/// in the member's units; nothing when either side cannot be measured.
std::optional<double> moved_hausdorff(const Prototype& p, const Member& m,
                                      const detail::Similarity& transform,
                                      const RepeatOptions& options) {
  HausdorffOptions forward_options;
  forward_options.threads = 1;
  forward_options.max_only = true;  // only the largest distance decides
  forward_options.samples = hausdorff_samples(*p.mesh, options);
  HausdorffOptions backward_options = forward_options;
  backward_options.samples = hausdorff_samples(*m.mesh, options);
  const double scale = detail::similarity_scale(transform);
  // Forward: the moved prototype sampled against the member. Backward: the member sampled
  // against the prototype, after moving it back; distances scale by the similarity's scale.
  Result<OneSidedDistance> forward =
      one_sided_distance(moved(*p.mesh, transform), *m.query, forward_options);
  Result<OneSidedDistance> backward =
      one_sided_distance(moved(*m.mesh, detail::inverse(transform)), *p.query, backward_options);
  if (!forward.ok() || !backward.ok()) return std::nullopt;
  return std::max(forward->max, scale * backward->max);
}

// ICP from the pose alignment (or, for a copy with the same vertex list, the fit of vertex i to
// vertex i), then the symmetric Hausdorff distance between the moved prototype and the member.
Verdict verify(const Prototype& p, const Mesh& m_mesh, const Component& m, size_t m_index,
               const PairVoxels& voxels, const RepeatOptions& options) {
  Verdict verdict;
  verdict.verified = true;
  const double tolerance = member_tolerance(p, m_mesh, m, options);
  Result<DistanceQuery> built = DistanceQuery::build(m_mesh);
  if (!built.ok()) return verdict;
  const Member side{&m_mesh, &m, &built.value()};
  Fit fit{detail::Similarity{}, voxels.passing.front()};
  if (!fit_vertex_order(*p.mesh, m_mesh, tolerance, options, &fit.transform) &&
      !fit_icp(p, side, voxels, tolerance, options, &fit)) {
    return verdict;
  }
  const std::optional<double> distance = moved_hausdorff(p, side, fit.transform, options);
  if (!distance) return verdict;

  RepeatMember& member = verdict.member;
  member.part = m_index;
  member.matrix = column_major(fit.transform);
  member.mirror = detail::determinant(fit.transform.linear) < 0;
  member.scale = detail::similarity_scale(fit.transform);
  member.hausdorff = *distance;
  member.tolerance = tolerance;
  member.phi = fit.used.similarity.phi;
  member.jaccard = fit.used.similarity.jaccard;
  verdict.accepted = *distance <= tolerance;
  return verdict;
}

// What the steps of the search share: the input, the options, every component's pose and
// voxels, and the greedy order.
struct Search {
  const std::vector<Mesh>& meshes;
  const RepeatOptions& options;
  std::vector<Component> comps;
  std::vector<size_t> usable;  // the components with a pose
  std::vector<size_t> order;   // the greedy order of those: larger area first, ties by index
  std::vector<size_t> rank;    // each one's place in `order`
};

/// Step 1: the pose and voxels of every component, in parallel.
Search pose_components(const std::vector<Mesh>& components, const RepeatOptions& options) {
  const size_t n = components.size();
  Search s{components, options, std::vector<Component>(n), {}, {}, {}};
  const detail::PoseOptions pose_options;
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    Component& c = s.comps[i];
    c.usable = detail::compute_pose(components[i], pose_options, &c.pose);
    if (!c.usable) return;
    c.grid = detail::voxelize(components[i], c.pose, detail::kIdentity3);
    c.shape_area = c.pose.area / (c.pose.scale * c.pose.scale);
    c.resolution = options.tolerance == 0 ? decimal_resolution(components[i]) : 0.0;
    // The tolerance the component gets as a member (the rounding floor taken at scale 1).
    const double tolerance = std::max(repeat_tolerance(components[i], options),
                                      options.tolerance == 0 ? std::sqrt(3.0) * c.resolution : 0.0);
    c.epsilon = tolerance / c.pose.scale;
  });
  return s;
}

/// Sets the usable components, their greedy order and their ranks in it.
void order_components(Search* s) {
  const std::vector<Component>& comps = s->comps;
  for (size_t i = 0; i < comps.size(); ++i) {
    if (comps[i].usable) s->usable.push_back(i);
  }
  s->order = s->usable;
  std::sort(s->order.begin(), s->order.end(), [&](size_t a, size_t b) {
    if (comps[a].pose.area != comps[b].pose.area) return comps[a].pose.area > comps[b].pose.area;
    return a < b;
  });
  s->rank.assign(comps.size(), 0);
  for (size_t k = 0; k < s->order.size(); ++k) s->rank[s->order[k]] = k;
}

using Cell = std::array<int64_t, 3>;

// Step 2's grid over the pose descriptor: the two largest normalised moments, in cells of
// descriptor_tolerance, and log(area / scale^2), in cells wide enough for area_tolerance. A pair
// that can pass the descriptor test lies in neighbouring cells, so only those pairs are looked at.
struct DescriptorGrid {
  double moment_cell = 0;
  double area_cell = 0;                        // 0 (one layer) for an area_tolerance of 1 or more
  std::vector<std::pair<Cell, size_t>> cells;  // (cell, component), sorted

  Cell cell_of(const Component& c) const {
    return {int64_t(std::floor(c.pose.moments[0] / moment_cell)),
            int64_t(std::floor(c.pose.moments[1] / moment_cell)),
            area_cell > 0 ? int64_t(std::floor(std::log(c.shape_area) / area_cell)) : 0};
  }
};

/// The descriptor grid with every usable component filed in its cell.
DescriptorGrid descriptor_grid(const Search& s) {
  DescriptorGrid grid;
  grid.moment_cell = std::max(s.options.descriptor_tolerance, 1e-12);
  grid.area_cell =
      s.options.area_tolerance < 1 ? std::max(-std::log1p(-s.options.area_tolerance), 1e-12) : 0.0;
  grid.cells.reserve(s.usable.size());
  for (size_t i : s.usable) grid.cells.push_back({grid.cell_of(s.comps[i]), i});
  std::sort(grid.cells.begin(), grid.cells.end());
  return grid;
}

// How far a pair gets through the candidate tests.
enum class PairTest { kFailsDescriptor, kFailsBox, kPasses };

/// The descriptor test (moments, shape area, and the scale unless scaling is allowed), then the
/// normalised boxes (the paper's step 1).
PairTest test_pair(const Component& ca, const Component& cb, const RepeatOptions& options) {
  const double slack = candidate_slack(ca, cb);
  const double moment_bound = std::min(options.descriptor_tolerance, slack);
  if (std::fabs(cb.pose.moments[0] - ca.pose.moments[0]) > moment_bound ||
      std::fabs(cb.pose.moments[1] - ca.pose.moments[1]) > moment_bound ||
      !close_enough(ca.shape_area, cb.shape_area, options.area_tolerance)) {
    return PairTest::kFailsDescriptor;
  }
  if (!options.allow_scale && !close_enough(ca.pose.scale, cb.pose.scale, options.aabb_tolerance)) {
    return PairTest::kFailsDescriptor;
  }
  if (!boxes_agree(ca.pose, cb.pose, options.aabb_tolerance, slack)) return PairTest::kFailsBox;
  return PairTest::kPasses;
}

// One component's candidate partners j > i, with the pairs it looked at and those that passed
// the descriptor test.
struct Neighbours {
  std::vector<size_t> partners;
  uint64_t considered = 0;
  uint64_t descriptor = 0;
};

/// The candidates of component i among the 27 cells around its own.
Neighbours scan_neighbours(const Search& s, const DescriptorGrid& grid, size_t i) {
  Neighbours out;
  const Component& ca = s.comps[i];
  const Cell home = grid.cell_of(ca);
  for (int64_t d0 = -1; d0 <= 1; ++d0) {
    for (int64_t d1 = -1; d1 <= 1; ++d1) {
      for (int64_t d2 = -1; d2 <= 1; ++d2) {
        const Cell cell = {home[0] + d0, home[1] + d1, home[2] + d2};
        auto first =
            std::lower_bound(grid.cells.begin(), grid.cells.end(), std::make_pair(cell, size_t(0)));
        for (auto it = first; it != grid.cells.end() && it->first == cell; ++it) {
          const size_t j = it->second;
          if (j <= i) continue;
          ++out.considered;
          const PairTest test = test_pair(ca, s.comps[j], s.options);
          if (test != PairTest::kFailsDescriptor) ++out.descriptor;
          if (test == PairTest::kPasses) out.partners.push_back(j);
        }
      }
    }
  }
  return out;
}

using Partners = std::vector<std::vector<size_t>>;

/// Step 2: the candidate pairs, found in parallel. Each pair is filed under the one that comes
/// first in the greedy order (its possible prototype), partners in greedy order.
Partners candidate_partners(const Search& s, RepeatCounters* counters) {
  const DescriptorGrid grid = descriptor_grid(s);
  std::vector<Neighbours> found(s.usable.size());
  tbb::parallel_for(size_t(0), s.usable.size(),
                    [&](size_t a) { found[a] = scan_neighbours(s, grid, s.usable[a]); });
  Partners partners(s.comps.size());
  for (size_t a = 0; a < found.size(); ++a) {
    counters->pairs_considered += found[a].considered;
    counters->pairs_descriptor += found[a].descriptor;
    counters->pairs_aabb += found[a].partners.size();
    for (size_t j : found[a].partners) {
      const size_t i = s.usable[a];
      if (s.rank[i] < s.rank[j]) {
        partners[i].push_back(j);
      } else {
        partners[j].push_back(i);
      }
    }
  }
  for (std::vector<size_t>& list : partners) {
    std::sort(list.begin(), list.end(), [&](size_t a, size_t b) { return s.rank[a] < s.rank[b]; });
  }
  return partners;
}

// One prototype's work in a batch.
struct Job {
  size_t prototype;
  std::vector<size_t> open;  // unassigned partners
  std::vector<PairVoxels> voxels;
  std::vector<size_t> passing;  // indices into open
  std::optional<DistanceQuery> query;
  Prototype data;
  std::vector<Verdict> verdicts;
};

// Where the greedy grouping stands.
struct Grouping {
  std::vector<char> assigned;  // a prototype or member of a group already
  std::vector<char> touched;   // the prototype or an open partner of a job in the batch
  size_t next = 0;             // the next prototype to look at, in the greedy order
};

/// Step 3 takes prototypes in batches whose work is independent (no prototype among another's
/// open partners, no partner shared), so that the batch runs in parallel and gives exactly what
/// one at a time gives. The next such batch, from g->next on.
std::vector<Job> next_batch(const Search& s, const Partners& partners, Grouping* g) {
  std::vector<Job> batch;
  while (g->next < s.order.size() && batch.size() < kBatch) {
    const size_t p = s.order[g->next];
    std::vector<size_t> open;
    if (!g->assigned[p]) {
      for (size_t j : partners[p]) {
        if (!g->assigned[j]) open.push_back(j);
      }
    }
    if (open.empty()) {  // nothing to do, now or later
      ++g->next;
      continue;
    }
    bool conflict = g->touched[p] != 0;
    for (size_t j : open) conflict = conflict || g->touched[j] != 0;
    if (conflict) break;
    g->touched[p] = 1;
    for (size_t j : open) g->touched[j] = 1;
    batch.push_back({p, std::move(open), {}, {}, std::nullopt, {}, {}});
    ++g->next;
  }
  return batch;
}

/// Voxel similarity of every (prototype, partner) pair of the batch, in parallel; notes the
/// partners that pass.
void compare_batch(const Search& s, std::vector<Job>& batch, RepeatCounters* counters) {
  std::vector<std::pair<size_t, size_t>> pairs;  // (job, index in its open list)
  for (size_t b = 0; b < batch.size(); ++b) {
    batch[b].voxels.resize(batch[b].open.size());
    for (size_t k = 0; k < batch[b].open.size(); ++k) pairs.push_back({b, k});
  }
  tbb::parallel_for(size_t(0), pairs.size(), [&](size_t q) {
    Job& job = batch[pairs[q].first];
    const size_t j = job.open[pairs[q].second];
    job.voxels[pairs[q].second] =
        compare_voxels(s.meshes[j], s.comps[job.prototype], s.comps[j], s.options);
  });
  for (Job& job : batch) {
    for (size_t k = 0; k < job.open.size(); ++k) {
      counters->pose_alternatives += job.voxels[k].alternatives;
      if (!job.voxels[k].passing.empty()) job.passing.push_back(k);
    }
    counters->pairs_phi_evaluated += job.open.size();
    counters->pairs_phi += job.passing.size();
  }
}

/// The distance query and samples of every prototype with a passing partner, in parallel; the
/// first error in batch order.
Status build_prototypes(const Search& s, std::vector<Job>& batch) {
  std::vector<size_t> verifying;
  for (size_t b = 0; b < batch.size(); ++b) {
    if (!batch[b].passing.empty()) verifying.push_back(b);
  }
  std::vector<Status> built(verifying.size());
  tbb::parallel_for(size_t(0), verifying.size(), [&](size_t v) {
    Job& job = batch[verifying[v]];
    const Mesh& mesh = s.meshes[job.prototype];
    Result<DistanceQuery> query = DistanceQuery::build(mesh);
    if (!query.ok()) {
      built[v] = query.status();
      return;
    }
    job.query.emplace(std::move(query).value());
    job.data.mesh = &mesh;
    job.data.component = &s.comps[job.prototype];
    job.data.query = &*job.query;
    job.data.samples = vertex_samples(mesh, s.options.icp_samples);
    job.data.coarse = vertex_samples(mesh, kCoarseSamples);
    job.verdicts.resize(job.passing.size());
  });
  for (const Status& status : built) OSTEON_RETURN_IF_ERROR(status);
  return Status::ok_status();
}

/// Verifies every passing pair of the batch, in parallel.
void verify_batch(const Search& s, std::vector<Job>& batch) {
  std::vector<std::pair<size_t, size_t>> pairs;  // (job, index in its passing list)
  for (size_t b = 0; b < batch.size(); ++b) {
    for (size_t k = 0; k < batch[b].passing.size(); ++k) pairs.push_back({b, k});
  }
  tbb::parallel_for(size_t(0), pairs.size(), [&](size_t q) {
    Job& job = batch[pairs[q].first];
    const size_t k = job.passing[pairs[q].second];
    const size_t j = job.open[k];
    job.verdicts[pairs[q].second] =
        verify(job.data, s.meshes[j], s.comps[j], j, job.voxels[k], s.options);
  });
}

/// Makes a group of each prototype with accepted members, and frees the batch's components for
/// the next batch.
void collect_groups(std::vector<Job>& batch, Grouping* g, RepeatReport* report) {
  RepeatCounters& counters = report->counters;
  for (Job& job : batch) {
    RepeatGroup group;
    group.prototype = job.prototype;
    for (Verdict& v : job.verdicts) {
      counters.pairs_verified += v.verified ? 1 : 0;
      if (v.accepted) {
        ++counters.pairs_accepted;
        g->assigned[v.member.part] = 1;
        group.members.push_back(v.member);
      } else if (v.verified) {
        ++counters.rejected_hausdorff;
      }
    }
    g->touched[job.prototype] = 0;
    for (size_t j : job.open) g->touched[j] = 0;
    if (group.members.empty()) continue;
    g->assigned[job.prototype] = 1;
    report->groups.push_back(std::move(group));
  }
}

/// Step 3: greedy grouping, largest first, with lazy voxel comparison and verification.
Status group_repeats(const Search& s, const Partners& partners, RepeatReport* report) {
  const size_t n = s.comps.size();
  Grouping g{std::vector<char>(n, 0), std::vector<char>(n, 0), 0};
  while (g.next < s.order.size()) {
    std::vector<Job> batch = next_batch(s, partners, &g);
    auto stage = Clock::now();
    compare_batch(s, batch, &report->counters);
    report->timings.phi_ms += ms_since(stage);
    // Verification: the prototypes' distance queries, then every passing pair.
    stage = Clock::now();
    OSTEON_RETURN_IF_ERROR(build_prototypes(s, batch));
    verify_batch(s, batch);
    collect_groups(batch, &g, report);
    report->timings.verify_ms += ms_since(stage);
  }
  return Status::ok_status();
}

/// Groups by prototype, members by part, and what substituting the members saves.
void summarise(const Search& s, RepeatReport* report) {
  std::sort(report->groups.begin(), report->groups.end(),
            [](const RepeatGroup& a, const RepeatGroup& b) { return a.prototype < b.prototype; });
  for (RepeatGroup& g : report->groups) {
    std::sort(g.members.begin(), g.members.end(),
              [](const RepeatMember& a, const RepeatMember& b) { return a.part < b.part; });
    for (const RepeatMember& m : g.members) {
      const uint64_t triangles = s.meshes[m.part].triangle_count();
      ++report->members;
      report->triangles_saved += triangles;
      const double bytes =
          double(triangles) * s.options.bytes_per_triangle - double(s.options.bytes_per_instance);
      if (bytes > 0) report->bytes_saved += uint64_t(std::llround(bytes));
      report->largest_error = std::max(report->largest_error, m.hausdorff);
    }
  }
}

Result<RepeatReport> find_repeats_here(const std::vector<Mesh>& components,
                                       const RepeatOptions& options) {
  const auto start = Clock::now();
  RepeatReport report;
  const size_t n = components.size();
  report.counters.components = n;
  report.counters.pairs_total = n > 1 ? uint64_t(n) * (n - 1) / 2 : 0;

  auto stage = Clock::now();
  Search search = pose_components(components, options);
  order_components(&search);
  report.counters.skipped = n - search.usable.size();
  report.timings.pose_ms = ms_since(stage);

  stage = Clock::now();
  const Partners partners = candidate_partners(search, &report.counters);
  report.timings.candidates_ms = ms_since(stage);

  OSTEON_RETURN_IF_ERROR(group_repeats(search, partners, &report));
  summarise(search, &report);
  report.timings.total_ms = ms_since(start);
  return report;
}

}  // namespace

Result<RepeatReport> find_repeats(const std::vector<Mesh>& components,
                                  const RepeatOptions& options) {
  OSTEON_RETURN_IF_ERROR(check_options(options));
  for (size_t i = 0; i < components.size(); ++i) {
    OSTEON_RETURN_IF_ERROR(check_component(components[i], i));
  }
  const int cores = tbb::info::default_concurrency();
  tbb::task_arena arena(options.threads > 0 ? std::min(options.threads, cores) : cores);
  return arena.execute([&] { return find_repeats_here(components, options); });
}

double repeat_tolerance(const Mesh& member, const RepeatOptions& options) {
  if (options.tolerance > 0) return options.tolerance;
  double step = 2 * options.precision;
  if (!(options.precision > 0)) {
    const Aabb box = bounding_box(member);
    const double side =
        box.empty ? 0.0
                  : std::max({double(box.max.x) - box.min.x, double(box.max.y) - box.min.y,
                              double(box.max.z) - box.min.z});
    step = side / double((uint64_t{1} << options.bits) - 1);
  }
  return 0.5 * step * std::sqrt(3.0);
}

}  // namespace osteon
