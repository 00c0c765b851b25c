// SPDX-License-Identifier: Apache-2.0
#include "dual_graph.hpp"

#include <algorithm>
#include <cmath>

#include "core/release.hpp"

// The dual graph of the paper's segmentation (section IV.B, after Zhou & Jia 2017 and Katz & Tal
// 2003). For two triangles across an edge:
//   CD  the geodesic distance between their centroids through the shared edge: the straight line
//       once the second triangle is unfolded into the first one's plane;
//   AD  eta (1 - cos theta), theta the angle between their normals, eta 1 where the edge is
//       concave (the neighbour's centroid lies above the triangle's plane) and small where convex;
//   GD  (CD + phi * AD * mean CD) / beta, beta the bounding-box diagonal.
// The paper writes GD = (CD + phi AD) / beta, which mixes a length with an angle, so the weight of
// the angular term would change with the mesh's unit; here AD is counted in mean centroid
// distances, which keeps GD free of unit and scale (docs/DESIGN.md, "Segmentation").

namespace osteon::detail {
namespace {

struct HalfEdge {
  uint64_t key;  // (min vertex << 32) | max vertex
  uint32_t corner;  // 3 * triangle + k: the edge from corner k to corner k + 1
};

}  // namespace

DualGraph build_dual_graph(const Mesh& mesh, const DualGraphOptions& options) {
  DualGraph g;
  const uint32_t triangles = static_cast<uint32_t>(mesh.triangle_count());
  const auto& P = mesh.positions;
  const auto& I = mesh.indices;
  g.centroid.resize(triangles);
  g.area.resize(triangles);
  std::vector<Vec3> normal(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    const Vec3 &a = P[I[3 * t]], &b = P[I[3 * t + 1]], &c = P[I[3 * t + 2]];
    g.centroid[t] = {(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3};
    const Vec3d n = cross(to_double(b) - to_double(a), to_double(c) - to_double(a));
    const double len = length(n);
    g.area[t] = len / 2;
    normal[t] = len > 0 ? Vec3{float(n.x / len), float(n.y / len), float(n.z / len)}
                        : Vec3{0, 0, 0};
  }
  const Aabb box = bounding_box(mesh);
  const double dx = double(box.max.x) - box.min.x, dy = double(box.max.y) - box.min.y,
               dz = double(box.max.z) - box.min.z;
  g.diagonal = triangles > 0 ? std::sqrt(dx * dx + dy * dy + dz * dz) : 0;

  // Pair the half-edges by their undirected key.
  std::vector<HalfEdge> half(3 * size_t{triangles});
  for (uint32_t c = 0; c < 3 * triangles; ++c) {
    const uint32_t a = I[c], b = I[c % 3 == 2 ? c - 2 : c + 1];
    half[c] = {(uint64_t{std::min(a, b)} << 32) | std::max(a, b), c};
  }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.corner < y.corner;
  });
  struct Arc {
    uint32_t from, to;
    float cd, ad, length;
  };
  std::vector<Arc> arcs;
  arcs.reserve(half.size());
  double cd_sum = 0;
  size_t cd_count = 0;
  for (size_t begin = 0; begin < half.size();) {
    size_t end = begin + 1;
    while (end < half.size() && half[end].key == half[begin].key) ++end;
    for (size_t i = begin; i < end; ++i) {
      for (size_t j = i + 1; j < end; ++j) {
        const uint32_t ti = half[i].corner / 3, tj = half[j].corner / 3;
        if (ti == tj) continue;  // a degenerate triangle repeating an edge
        const uint32_t c = half[i].corner;
        const Vec3& p = P[I[c]];
        const Vec3& q = P[I[c % 3 == 2 ? c - 2 : c + 1]];
        const Vec3d e = to_double(q) - to_double(p);
        const double elen = length(e);
        // Unfold: along-edge coordinate t and distance h from the edge line, per centroid.
        double t[2], h[2];
        const uint32_t tt[2] = {ti, tj};
        for (int k = 0; k < 2; ++k) {
          const Vec3& m = g.centroid[tt[k]];
          const Vec3d w = to_double(m) - to_double(p);
          t[k] = elen > 0 ? dot(w, e) / elen : 0;
          h[k] = std::sqrt(std::max(0.0, dot(w, w) - t[k] * t[k]));
        }
        const double cd = std::hypot(t[0] - t[1], h[0] + h[1]);
        const Vec3 &ni = normal[ti], &nj = normal[tj];
        float ad = 0;
        const bool flat = (ni.x == 0 && ni.y == 0 && ni.z == 0) ||
                          (nj.x == 0 && nj.y == 0 && nj.z == 0);
        if (!flat) {
          const double cos_theta =
              std::clamp(double(ni.x) * nj.x + double(ni.y) * nj.y + double(ni.z) * nj.z, -1.0, 1.0);
          const Vec3 &ci = g.centroid[ti], &cj = g.centroid[tj];
          const double up = (double(cj.x) - ci.x) * ni.x + (double(cj.y) - ci.y) * ni.y +
                            (double(cj.z) - ci.z) * ni.z;
          const double eta = up > 0 ? 1.0 : options.convex_eta;
          ad = static_cast<float>(eta * (1 - cos_theta));
        }
        arcs.push_back({ti, tj, float(cd), ad, float(elen)});
        cd_sum += cd;
        ++cd_count;
      }
    }
    begin = end;
  }
  release(half);
  g.mean_cd = cd_count > 0 ? cd_sum / double(cd_count) : 0;
  const double scale = g.diagonal > 0 ? 1 / g.diagonal : 1;
  const double angular = options.phi * g.mean_cd;

  // Compressed rows, both directions.
  g.first.assign(size_t{triangles} + 1, 0);
  for (const Arc& a : arcs) {
    ++g.first[a.from + 1];
    ++g.first[a.to + 1];
  }
  for (uint32_t t = 0; t < triangles; ++t) g.first[t + 1] += g.first[t];
  const size_t n = g.first[triangles];
  g.target.resize(n);
  g.weight.resize(n);
  g.concavity.resize(n);
  g.length.resize(n);
  std::vector<uint32_t> fill(g.first.begin(), g.first.end() - 1);
  for (const Arc& a : arcs) {
    const float w = static_cast<float>((a.cd + angular * a.ad) * scale);
    for (auto [from, to] : {std::pair{a.from, a.to}, std::pair{a.to, a.from}}) {
      const uint32_t k = fill[from]++;
      g.target[k] = to;
      g.weight[k] = w;
      g.concavity[k] = a.ad;
      g.length[k] = a.length;
    }
  }
  return g;
}

uint32_t label_dual_parts(const DualGraph& graph, std::vector<uint32_t>* part) {
  constexpr uint32_t kNone = 0xFFFFFFFFu;
  const uint32_t n = graph.triangles();
  part->assign(n, kNone);
  std::vector<uint32_t> stack;
  uint32_t parts = 0;
  for (uint32_t s = 0; s < n; ++s) {
    if ((*part)[s] != kNone) continue;
    (*part)[s] = parts;
    stack.push_back(s);
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      for (uint32_t k = graph.first[t]; k < graph.first[t + 1]; ++k) {
        const uint32_t u = graph.target[k];
        if ((*part)[u] == kNone) {
          (*part)[u] = parts;
          stack.push_back(u);
        }
      }
    }
    ++parts;
  }
  return parts;
}

}  // namespace osteon::detail
