// SPDX-License-Identifier: Apache-2.0
#include "osteon/repeats.hpp"

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

// Based on: union-find (disjoint sets; R. Tarjan, "Efficiency of a good but not linear set union
// algorithm", JACM 22(2), 1975), here with path halving and union by smaller index: the
// vertex-connected pieces of a mesh, as diagnose() counts its components.

namespace osteon {

namespace {

/// No piece (yet): a root not numbered, a vertex no triangle uses.
constexpr uint32_t kNoPiece = UINT32_MAX;

uint32_t find_root(std::vector<uint32_t>& parent, uint32_t v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];
    v = parent[v];
  }
  return v;
}

}  // namespace

std::vector<uint32_t> connected_pieces(const Mesh& mesh, uint32_t* pieces) {
  const size_t triangles = mesh.triangle_count();
  std::vector<uint32_t> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t* f = &mesh.indices[3 * t];
    assert(f[0] < parent.size() && f[1] < parent.size() && f[2] < parent.size());
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = find_root(parent, f[0]), b = find_root(parent, f[k]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  // Pieces numbered in order of their first triangle.
  std::vector<uint32_t> piece_of_root(mesh.positions.size(), kNoPiece);
  std::vector<uint32_t> triangle_piece(triangles);
  uint32_t count = 0;
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t root = find_root(parent, mesh.indices[3 * t]);
    if (piece_of_root[root] == kNoPiece) piece_of_root[root] = count++;
    triangle_piece[t] = piece_of_root[root];
  }
  *pieces = count;
  return triangle_piece;
}

std::vector<Mesh> split_connected(const Mesh& mesh) {
  const size_t triangles = mesh.triangle_count();
  for (size_t i = 0; i < 3 * triangles; ++i) {
    if (mesh.indices[i] >= mesh.positions.size()) {
      return {mesh};  // not a valid mesh: left for the caller's checks to report
    }
  }
  uint32_t pieces = 0;
  const std::vector<uint32_t> triangle_piece = connected_pieces(mesh, &pieces);
  if (pieces <= 1) return {mesh};

  std::vector<Mesh> out(pieces);
  for (uint32_t k = 0; k < pieces; ++k) {
    out[k].name = mesh.name + "#" + std::to_string(k);
    out[k].source = mesh.source;
    out[k].unit = mesh.unit;
    out[k].unit_source = mesh.unit_source;
    out[k].has_color = mesh.has_color;
    out[k].color = mesh.color;
    out[k].label = mesh.label;
  }
  // Each piece keeps its vertices in their original order.
  std::vector<uint32_t> new_index(mesh.positions.size(), kNoPiece);
  std::vector<uint32_t> vertex_piece(mesh.positions.size(), kNoPiece);
  for (size_t t = 0; t < triangles; ++t) {
    for (int k = 0; k < 3; ++k) vertex_piece[mesh.indices[3 * t + k]] = triangle_piece[t];
  }
  const bool normals = mesh.normals.size() == mesh.positions.size();
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (vertex_piece[v] == kNoPiece) continue;  // unreferenced: dropped
    Mesh& piece = out[vertex_piece[v]];
    new_index[v] = uint32_t(piece.positions.size());
    piece.positions.push_back(mesh.positions[v]);
    if (normals) piece.normals.push_back(mesh.normals[v]);
  }
  for (size_t t = 0; t < triangles; ++t) {
    Mesh& piece = out[triangle_piece[t]];
    for (int k = 0; k < 3; ++k) piece.indices.push_back(new_index[mesh.indices[3 * t + k]]);
  }
  for (Mesh& piece : out) piece.stored_vertices = piece.positions.size();
  return out;
}

}  // namespace osteon
