// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <queue>
#include <utility>
#include <vector>

#include "segeval_internal.hpp"

// Based on: Chen, Golovinskiy, Funkhouser, "A Benchmark for 3D Mesh Segmentation" (SIGGRAPH 2009),
// section 4.1 "Cut Discrepancy", and its segEval program: the cut vertices of a segmentation are
// the endpoints of edges between two triangles of different segments; each cut vertex's distance
// to the other segmentation's cuts is a shortest path along mesh edges (Dijkstra from all of the
// other's cut vertices at once); CD is the mean of those distances over the cut vertices of both
// segmentations, divided by the mesh's average radius.
//
// Where segEval leaves a case to chance, the choices here (docs/DESIGN.md):
// - an edge with three or more triangles (non-manifold) is a cut when its triangles carry more
//   than one label; segEval's mesh splits such edges on reading;
// - a cut vertex with no path to the other segmentation's cuts (its connected component has none)
//   is left out of the mean; segEval would add FLT_MAX to it. CD is undefined when either side
//   has no cut vertex at all, or when no cut vertex reaches the other side's cuts.

namespace osteon::detail {

namespace {

double length(const Vec3& a, const Vec3& b) {
  double dx = double(a.x) - b.x, dy = double(a.y) - b.y, dz = double(a.z) - b.z;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

}  // namespace

void build_edge_graph(const Mesh& mesh, EvaluationMesh* out) {
  // Every (edge, triangle) incidence, keyed by the edge's vertex pair (smaller id first).
  struct Incidence {
    uint64_t key;
    uint32_t face;
  };
  size_t triangles = mesh.triangle_count();
  std::vector<Incidence> incidences;
  incidences.reserve(3 * triangles);
  for (size_t t = 0; t < triangles; ++t) {
    for (int k = 0; k < 3; ++k) {
      uint32_t a = mesh.indices[3 * t + k];
      uint32_t b = mesh.indices[3 * t + (k + 1) % 3];
      if (a == b) continue;
      if (a > b) std::swap(a, b);
      incidences.push_back({(uint64_t{a} << 32) | b, static_cast<uint32_t>(t)});
    }
  }
  std::sort(incidences.begin(), incidences.end(), [](const Incidence& x, const Incidence& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });

  out->edge_vertices.clear();
  out->edge_face_offset.assign(1, 0);
  out->edge_faces.clear();
  out->edge_faces.reserve(incidences.size());
  for (size_t i = 0; i < incidences.size(); ++i) {
    if (i == 0 || incidences[i].key != incidences[i - 1].key) {
      if (i > 0) out->edge_face_offset.push_back(static_cast<uint32_t>(out->edge_faces.size()));
      out->edge_vertices.push_back(static_cast<uint32_t>(incidences[i].key >> 32));
      out->edge_vertices.push_back(static_cast<uint32_t>(incidences[i].key & 0xffffffffu));
    }
    // A triangle that repeats a vertex can list the same edge twice: keep it once.
    if (i > 0 && incidences[i].key == incidences[i - 1].key &&
        incidences[i].face == incidences[i - 1].face) {
      continue;
    }
    out->edge_faces.push_back(incidences[i].face);
  }
  if (!incidences.empty()) {
    out->edge_face_offset.push_back(static_cast<uint32_t>(out->edge_faces.size()));
  }

  // The CSR graph: both directions of every edge.
  size_t vertices = mesh.positions.size();
  size_t edges = out->edge_vertices.size() / 2;
  out->adjacency_offset.assign(vertices + 1, 0);
  for (uint32_t v : out->edge_vertices) ++out->adjacency_offset[v + 1];
  for (size_t v = 0; v < vertices; ++v) out->adjacency_offset[v + 1] += out->adjacency_offset[v];
  out->adjacency.resize(2 * edges);
  out->adjacency_length.resize(2 * edges);
  std::vector<uint32_t> fill(out->adjacency_offset.begin(), out->adjacency_offset.end() - 1);
  for (size_t e = 0; e < edges; ++e) {
    uint32_t a = out->edge_vertices[2 * e], b = out->edge_vertices[2 * e + 1];
    double l = length(mesh.positions[a], mesh.positions[b]);
    out->adjacency[fill[a]] = b;
    out->adjacency_length[fill[a]++] = l;
    out->adjacency[fill[b]] = a;
    out->adjacency_length[fill[b]++] = l;
  }
}

double average_radius(const Mesh& mesh, const std::vector<double>& face_area) {
  size_t triangles = mesh.triangle_count();
  auto centroid_of = [&mesh](size_t t) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = mesh.positions[mesh.indices[3 * t + k]];
      c[0] += p.x;
      c[1] += p.y;
      c[2] += p.z;
    }
    return std::array<double, 3>{c[0] / 3, c[1] / 3, c[2] / 3};
  };
  double area = 0, center[3] = {0, 0, 0};
  for (size_t t = 0; t < triangles; ++t) {
    auto c = centroid_of(t);
    for (int k = 0; k < 3; ++k) center[k] += face_area[t] * c[k];
    area += face_area[t];
  }
  if (area <= 0) return 0;
  for (double& c : center) c /= area;
  double sum = 0;
  for (size_t t = 0; t < triangles; ++t) {
    auto c = centroid_of(t);
    double dx = c[0] - center[0], dy = c[1] - center[1], dz = c[2] - center[2];
    sum += face_area[t] * std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  return sum / area;
}

std::vector<uint32_t> find_cut_vertices(const EvaluationMesh& mesh,
                                        const std::vector<uint32_t>& labels) {
  std::vector<uint8_t> on_cut(mesh.vertex_count, 0);
  size_t edges = mesh.edge_vertices.size() / 2;
  for (size_t e = 0; e < edges; ++e) {
    uint32_t begin = mesh.edge_face_offset[e], end = mesh.edge_face_offset[e + 1];
    uint32_t first = labels[mesh.edge_faces[begin]];
    for (uint32_t i = begin + 1; i < end; ++i) {
      if (labels[mesh.edge_faces[i]] != first) {
        on_cut[mesh.edge_vertices[2 * e]] = 1;
        on_cut[mesh.edge_vertices[2 * e + 1]] = 1;
        break;
      }
    }
  }
  std::vector<uint32_t> cut;
  for (size_t v = 0; v < on_cut.size(); ++v) {
    if (on_cut[v]) cut.push_back(static_cast<uint32_t>(v));
  }
  return cut;
}

std::vector<double> distances_from(const EvaluationMesh& mesh,
                                   const std::vector<uint32_t>& sources) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  std::vector<double> distance(mesh.vertex_count, kInfinity);
  using Entry = std::pair<double, uint32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  for (uint32_t s : sources) {
    distance[s] = 0;
    heap.push({0.0, s});
  }
  while (!heap.empty()) {
    auto [d, v] = heap.top();
    heap.pop();
    if (d > distance[v]) continue;  // a stale entry: v was reached by a shorter path since
    for (uint32_t i = mesh.adjacency_offset[v]; i < mesh.adjacency_offset[v + 1]; ++i) {
      uint32_t w = mesh.adjacency[i];
      double through = d + mesh.adjacency_length[i];
      if (through < distance[w]) {
        distance[w] = through;
        heap.push({through, w});
      }
    }
  }
  return distance;
}

std::optional<double> cut_discrepancy(const EvaluationMesh& mesh, const PreparedSegmentation& a,
                                      const PreparedSegmentation& b) {
  if (a.cut_vertices.empty() || b.cut_vertices.empty() || mesh.average_radius <= 0) {
    return std::nullopt;
  }
  double sum = 0;
  size_t count = 0;
  auto add = [&sum, &count](const std::vector<uint32_t>& cut, const std::vector<double>& other) {
    for (uint32_t v : cut) {
      if (std::isfinite(other[v])) {
        sum += other[v];
        ++count;
      }
    }
  };
  add(a.cut_vertices, b.cut_distance);
  add(b.cut_vertices, a.cut_distance);
  if (count == 0) return std::nullopt;
  return sum / static_cast<double>(count) / mesh.average_radius;
}

}  // namespace osteon::detail
