// SPDX-License-Identifier: Apache-2.0
#include "osteon/segment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <queue>
#include <unordered_map>

#include "dual_graph.hpp"

// Segmentation by Dijkstra region diffusion (paper section IV.B and Algorithm 1, after Zhou & Jia
// 2017), in four stages on the dual graph (src/dual_graph.cpp):
//   1. parts: the edge-connected parts of the mesh; every later stage stays inside one part;
//   2. seeds: the paper's first seed, the triangle nearest the part's barycentre, then farthest
//      points in GD, the triangle the regions diffused so far reach last (a crease makes what lies
//      behind it far, so every part behind a crease gets a seed); more seeds than components;
//   3. diffusion and re-centring: all seeds diffuse at once by Dijkstra, each triangle joining the
//      region that reaches it first; each region's centre moves to its deepest triangle (the
//      farthest from the region's border) and the regions diffuse again (paper steps 4-6);
//   4. merging: neighbouring regions merge, the pair whose shared border is least concave first,
//      until the target count (or, without one, while borders are flatter than merge_concavity);
//      a merge that would pass max_triangles is not made, and a region still larger than that is
//      split by diffusion inside it.
// docs/DESIGN.md ("Segmentation") says why each reading of the paper was chosen.

namespace osteon {
namespace {

using detail::DualGraph;
constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr float kFar = std::numeric_limits<float>::infinity();
/// Without a target count, a component is expected to cover about this share of its part.
constexpr double kAutomaticComponents = 8;
/// A region covering less than this share of the area expected of a component is a sliver.
constexpr double kSliverShare = 0.05;

/// Multi-source Dijkstra. Each source s enters with distance 0 and owner[s] already set; a
/// triangle whose distance improves takes the owner of the triangle it was reached from. With
/// `within`, arcs are followed only between triangles with equal within[] (a region). Distances
/// of the triangles to be reached must be kFar (or larger than what diffusion will give) on entry.
/// The queue is a binary heap with lazy deletion, ordered by distance alone.
template <bool kWithin>
void diffuse_impl(const DualGraph& g, const std::vector<uint32_t>& sources, const uint32_t* within,
                  std::vector<float>& dist, std::vector<uint32_t>& owner) {
  struct Entry {
    float d;
    uint32_t t;
  };
  auto later = [](const Entry& x, const Entry& y) { return x.d > y.d; };
  std::vector<Entry> heap;
  heap.reserve(sources.size() * 4 + 64);
  for (uint32_t s : sources) {
    dist[s] = 0;
    heap.push_back({0.f, s});
  }
  float* const distance = dist.data();
  uint32_t* const owners = owner.data();
  const uint32_t* const first = g.first.data();
  const uint32_t* const target = g.target.data();
  const float* const weight = g.weight.data();
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), later);
    const Entry e = heap.back();
    heap.pop_back();
    const uint32_t t = e.t;
    if (e.d > distance[t]) continue;  // a stale entry
    for (uint32_t k = first[t], end = first[t + 1]; k < end; ++k) {
      const uint32_t u = target[k];
      if constexpr (kWithin) {
        if (within[u] != within[t]) continue;
      }
      const float nd = e.d + weight[k];
      if (nd < distance[u]) {
        distance[u] = nd;
        owners[u] = owners[t];
        heap.push_back({nd, u});
        std::push_heap(heap.begin(), heap.end(), later);
      }
    }
  }
}

void diffuse(const DualGraph& g, const std::vector<uint32_t>& sources,
             const std::vector<uint32_t>* within, std::vector<float>& dist,
             std::vector<uint32_t>& owner) {
  if (within) {
    diffuse_impl<true>(g, sources, within->data(), dist, owner);
  } else {
    diffuse_impl<false>(g, sources, nullptr, dist, owner);
  }
}

/// Up to `count` seeds among `members` (one connected piece of the graph, or of a region when
/// `within` is given): the member nearest their area-weighted barycentre, then farthest points.
/// Uses dist and owner as scratch on the members.
std::vector<uint32_t> farthest_seeds(const DualGraph& g, const std::vector<uint32_t>& members,
                                     uint32_t count, const std::vector<uint32_t>* within,
                                     std::vector<float>& dist, std::vector<uint32_t>& owner) {
  std::vector<uint32_t> seeds;
  if (members.empty() || count == 0) return seeds;
  double cx = 0, cy = 0, cz = 0, area = 0;
  for (uint32_t t : members) {
    const double a = g.area[t] > 0 ? g.area[t] : 1e-30;
    cx += a * g.centroid[t].x;
    cy += a * g.centroid[t].y;
    cz += a * g.centroid[t].z;
    area += a;
  }
  cx /= area;
  cy /= area;
  cz /= area;
  uint32_t first = members[0];
  double best = std::numeric_limits<double>::infinity();
  for (uint32_t t : members) {
    const double dx = g.centroid[t].x - cx, dy = g.centroid[t].y - cy, dz = g.centroid[t].z - cz;
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 < best) {
      best = d2;
      first = t;
    }
  }
  for (uint32_t t : members) dist[t] = kFar;
  seeds.push_back(first);
  owner[first] = 0;
  diffuse(g, {first}, within, dist, owner);
  while (seeds.size() < count) {
    uint32_t far = kNone;
    float far_dist = 0;
    for (uint32_t t : members) {
      if (dist[t] > far_dist) {
        far_dist = dist[t];
        far = t;
      }
    }
    if (far == kNone) break;  // every member is a seed, or at distance 0 from one
    owner[far] = static_cast<uint32_t>(seeds.size());
    seeds.push_back(far);
    diffuse(g, {far}, within, dist, owner);
  }
  return seeds;
}

/// The deepest triangle of every region (label 0 .. seeds.size() - 1): the farthest, in GD, from
/// the region's border. A region without a border (a whole part) keeps seeds[r]. Returns false
/// when no region has a border.
bool deepest_triangles(const DualGraph& g, const std::vector<uint32_t>& label,
                       std::vector<uint32_t>& seeds, std::vector<float>& depth,
                       std::vector<uint32_t>& scratch) {
  const uint32_t triangles = g.triangles();
  std::vector<uint32_t> border;
  for (uint32_t t = 0; t < triangles; ++t) {
    for (uint32_t k = g.first[t]; k < g.first[t + 1]; ++k) {
      if (label[g.target[k]] != label[t]) {
        border.push_back(t);
        break;
      }
    }
  }
  if (border.empty()) return false;
  std::fill(depth.begin(), depth.end(), kFar);
  diffuse(g, border, &label, depth, scratch);
  std::vector<float> deepest(seeds.size(), -1);
  for (uint32_t t = 0; t < triangles; ++t) {
    const uint32_t r = label[t];
    if (depth[t] != kFar && depth[t] > deepest[r]) {
      deepest[r] = depth[t];
      seeds[r] = t;
    }
  }
  return true;
}

/// The regions' union-find-free merge state: border length and concavity per pair of regions.
struct Border {
  double length = 0;
  double concave = 0;  // sum of length * AD
};

class Merger {
 public:
  Merger(const DualGraph& g, const std::vector<uint32_t>& region, uint32_t regions,
         const std::vector<uint32_t>& part_of_region, std::vector<uint32_t> wanted,
         const std::vector<double>& part_area, uint32_t max_triangles, double threshold)
      : adjacent_(regions),
        size_(regions, 0),
        area_(regions, 0),
        merged_into_(regions, kNone),
        stamp_(regions, 0),
        part_of_region_(part_of_region),
        wanted_(std::move(wanted)),
        max_triangles_(max_triangles),
        threshold_(threshold) {
    left_.assign(wanted_.size(), 0);
    for (uint32_t r = 0; r < regions; ++r) ++left_[part_of_region[r]];
    // A component is expected to cover about this much of its part; smaller regions merge
    // sooner (their borders cost less), so that no sliver behind a crease keeps a component.
    for (size_t p = 0; p < wanted_.size(); ++p) {
      expected_.push_back(part_area[p] / (wanted_[p] > 0 ? wanted_[p] : kAutomaticComponents));
    }
    for (uint32_t t = 0; t < g.triangles(); ++t) {
      ++size_[region[t]];
      area_[region[t]] += g.area[t];
      for (uint32_t k = g.first[t]; k < g.first[t + 1]; ++k) {
        const uint32_t u = g.target[k];
        if (u <= t || region[u] == region[t]) continue;
        for (auto [a, b] : {std::pair{region[t], region[u]}, std::pair{region[u], region[t]}}) {
          Border& border = adjacent_[a][b];
          border.length += g.length[k];
          border.concave += double(g.length[k]) * g.concavity[k];
        }
      }
    }
    for (uint32_t a = 0; a < regions; ++a) {
      for (const auto& [b, border] : adjacent_[a]) {
        if (a < b) push(a, b, border);
      }
    }
  }

  /// Merges until every part has its wanted count (0: until the threshold); returns, per region,
  /// the region it ended in.
  std::vector<uint32_t> run() {
    while (!heap_.empty()) {
      const Candidate c = heap_.top();
      heap_.pop();
      if (merged_into_[c.a] != kNone || merged_into_[c.b] != kNone) continue;
      if (c.stamp_a != stamp_[c.a] || c.stamp_b != stamp_[c.b]) continue;
      const uint32_t part = part_of_region_[c.a];
      const uint32_t wanted = wanted_[part];
      if (wanted > 0 ? left_[part] <= wanted : c.cost > threshold_) continue;
      if (max_triangles_ > 0 && size_[c.a] + size_[c.b] > max_triangles_) continue;
      merge(c.a, c.b);
      --left_[part];
    }
    std::vector<uint32_t> final_region(size_.size());
    for (uint32_t r = 0; r < size_.size(); ++r) {
      uint32_t f = r;
      while (merged_into_[f] != kNone) f = merged_into_[f];
      final_region[r] = f;
    }
    return final_region;
  }

 private:
  struct Candidate {
    double cost;
    uint32_t a, b, stamp_a, stamp_b;
    bool operator<(const Candidate& o) const {  // the smallest cost on top
      return cost != o.cost ? cost > o.cost : std::pair{a, b} > std::pair{o.a, o.b};
    }
  };

  void push(uint32_t a, uint32_t b, const Border& border) {
    const double concavity = border.length > 0 ? border.concave / border.length : 0;
    const double expected = expected_[part_of_region_[a]];
    const double smaller = std::min(area_[a], area_[b]);
    const double share = expected > 0 ? std::min(1.0, smaller / expected) : 1.0;
    // A sliver (under kSliverShare of a component) merges before any border is weighed.
    const double cost = share < kSliverShare ? share - 1 : concavity * std::sqrt(share);
    heap_.push({cost, a, b, stamp_[a], stamp_[b]});
  }

  void merge(uint32_t a, uint32_t b) {
    if (adjacent_[a].size() < adjacent_[b].size()) std::swap(a, b);
    adjacent_[a].erase(b);
    for (const auto& [c, border] : adjacent_[b]) {
      if (c == a) continue;
      Border& ac = adjacent_[a][c];
      ac.length += border.length;
      ac.concave += border.concave;
      adjacent_[c].erase(b);
      adjacent_[c][a] = ac;
    }
    adjacent_[b].clear();
    merged_into_[b] = a;
    size_[a] += size_[b];
    area_[a] += area_[b];
    ++stamp_[a];
    for (const auto& [c, border] : adjacent_[a]) push(std::min(a, c), std::max(a, c), border);
  }

  std::vector<std::unordered_map<uint32_t, Border>> adjacent_;
  std::vector<uint32_t> size_;
  std::vector<double> area_;
  std::vector<uint32_t> merged_into_, stamp_;
  const std::vector<uint32_t>& part_of_region_;
  std::vector<double> expected_;
  std::vector<uint32_t> wanted_, left_;
  uint32_t max_triangles_;
  double threshold_;
  std::priority_queue<Candidate> heap_;
};

/// How many components each part should end with: one each when there are at least as many
/// parts as wanted, else the extra ones shared by area (largest remainder). 0 = automatic.
std::vector<uint32_t> components_per_part(const std::vector<double>& part_area, uint32_t segments) {
  const size_t parts = part_area.size();
  std::vector<uint32_t> wanted(parts, segments == 0 ? 0 : 1);
  if (segments == 0 || segments <= parts) return wanted;
  const double total = std::accumulate(part_area.begin(), part_area.end(), 0.0);
  const uint32_t extra = segments - static_cast<uint32_t>(parts);
  std::vector<std::pair<double, size_t>> remainder;
  uint32_t given = 0;
  for (size_t p = 0; p < parts; ++p) {
    const double share = total > 0 ? extra * part_area[p] / total : double(extra) / parts;
    const auto whole = static_cast<uint32_t>(std::floor(share));
    wanted[p] += whole;
    given += whole;
    remainder.push_back({share - whole, p});
  }
  std::stable_sort(remainder.begin(), remainder.end(),
                   [](const auto& x, const auto& y) { return x.first > y.first; });
  for (size_t i = 0; given < extra; ++i, ++given) ++wanted[remainder[i % parts].second];
  return wanted;
}

}  // namespace

Result<Segmentation> segment(const Mesh& mesh, const SegmentOptions& options) {
  const std::string& source = mesh.source.empty() ? mesh.name : mesh.source;
  if (!(options.phi >= 0) || !std::isfinite(options.phi) || !(options.convex_eta >= 0) ||
      !std::isfinite(options.convex_eta) || !std::isfinite(options.merge_concavity)) {
    return error(ErrorCode::kInvalidArgument, source,
                 "segmentation: phi, convex_eta and merge_concavity must be finite and >= 0", "");
  }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return error(ErrorCode::kInvalidArgument, source,
                   "segmentation: a position is not finite", "vertex " + std::to_string(v));
    }
  }
  Segmentation out;
  const uint32_t triangles = static_cast<uint32_t>(mesh.triangle_count());
  if (triangles == 0) return out;

  const DualGraph g = detail::build_dual_graph(mesh, {options.phi, options.convex_eta});
  std::vector<uint32_t> part;
  out.parts = detail::label_dual_parts(g, &part);
  std::vector<std::vector<uint32_t>> members(out.parts);
  std::vector<double> part_area(out.parts, 0);
  for (uint32_t t = 0; t < triangles; ++t) {
    members[part[t]].push_back(t);
    part_area[part[t]] += g.area[t];
  }
  const std::vector<uint32_t> wanted = components_per_part(part_area, options.segments);
  const uint32_t max_triangles = options.max_triangles;

  // 2. Seeds, more than the components wanted, so that merging can pick the borders.
  std::vector<float> dist(triangles, kFar);
  std::vector<uint32_t> owner(triangles, kNone);
  std::vector<uint32_t> seeds, part_of_region;
  for (uint32_t p = 0; p < out.parts; ++p) {
    const uint32_t n = static_cast<uint32_t>(members[p].size());
    uint32_t count = wanted[p] > 0 ? std::max(4 * wanted[p], wanted[p] + 6)
                                   : (n < 64 ? 1u : 24u);
    if (wanted[p] == 1 && max_triangles == 0) count = 1;
    if (max_triangles > 0) count = std::max(count, 2 * ((n + max_triangles - 1) / max_triangles));
    count = std::min(count, n);
    for (uint32_t s : farthest_seeds(g, members[p], count, nullptr, dist, owner)) {
      seeds.push_back(s);
      part_of_region.push_back(p);
    }
  }

  // 3. Diffusion and re-centring: every region's centre moves to its deepest triangle.
  auto diffuse_all = [&] {
    std::fill(dist.begin(), dist.end(), kFar);
    for (uint32_t r = 0; r < seeds.size(); ++r) owner[seeds[r]] = r;
    diffuse(g, seeds, nullptr, dist, owner);
  };
  diffuse_all();
  std::vector<float> depth(triangles);
  std::vector<uint32_t> scratch(triangles);
  for (uint32_t round = 0; round < options.iterations; ++round) {
    std::vector<uint32_t> moved(seeds);
    if (!deepest_triangles(g, owner, moved, depth, scratch)) break;  // one region per part
    if (moved == seeds) break;
    seeds = std::move(moved);
    diffuse_all();
  }

  // 4. Merging, then splitting what is still too large.
  std::vector<uint32_t> region = owner;
  const uint32_t regions = static_cast<uint32_t>(seeds.size());
  {
    Merger merger(g, region, regions, part_of_region, wanted, part_area, max_triangles,
                  options.merge_concavity);
    const std::vector<uint32_t> final_region = merger.run();
    for (uint32_t& r : region) r = final_region[r];
  }
  if (max_triangles > 0) {
    std::unordered_map<uint32_t, std::vector<uint32_t>> by_region;
    for (uint32_t t = 0; t < triangles; ++t) by_region[region[t]].push_back(t);
    std::vector<std::vector<uint32_t>> work;
    for (auto& [r, list] : by_region) {
      if (list.size() > max_triangles) work.push_back(std::move(list));
    }
    std::sort(work.begin(), work.end());  // a fixed order, whatever the hash map's
    uint32_t next_region = regions;
    while (!work.empty()) {
      std::vector<uint32_t> list = std::move(work.back());
      work.pop_back();
      const uint32_t n = static_cast<uint32_t>(list.size());
      const uint32_t count = std::max(2u, (n + max_triangles - 1) / max_triangles);
      const std::vector<uint32_t> sub = farthest_seeds(g, list, count, &region, dist, owner);
      if (sub.size() < 2) {
        // Every triangle at distance 0 from the first (zero-area slivers): cut in input order.
        for (uint32_t i = max_triangles; i < n; ++i) {
          if (i % max_triangles == 0) ++next_region;
          region[list[i]] = next_region - 1;
        }
        continue;
      }
      for (uint32_t t : list) dist[t] = kFar;
      for (uint32_t i = 0; i < sub.size(); ++i) owner[sub[i]] = i;
      diffuse(g, sub, &region, dist, owner);
      std::vector<std::vector<uint32_t>> pieces(sub.size());
      for (uint32_t t : list) pieces[owner[t]].push_back(t);
      for (auto& piece : pieces) {
        const uint32_t id = next_region++;
        for (uint32_t t : piece) region[t] = id;
        if (piece.size() > max_triangles) work.push_back(std::move(piece));
      }
    }
  }

  // Number the components in order of their first triangle.
  std::unordered_map<uint32_t, uint32_t> number;
  out.labels.resize(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    auto [it, added] = number.try_emplace(region[t], static_cast<uint32_t>(number.size()));
    out.labels[t] = it->second;
  }
  out.count = static_cast<uint32_t>(number.size());
  return out;
}

}  // namespace osteon
