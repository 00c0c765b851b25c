// SPDX-License-Identifier: Apache-2.0
#include "codec/corner_table.hpp"

#include <algorithm>
#include <cassert>
#include <utility>

#include "core/huge_pages.hpp"

// Cutting any triangle list into a closed oriented manifold corner table, and the checks the tests
// use. See corner_table.hpp for the conventions.
//
// Based on: Rossignac, Safonova, Szymczak 2001 (corner table); Guéziec, Taubin, Lazarus, Horn 2001
// (cutting non-manifold meshes into manifold pieces); Rossignac 1999 (a dummy vertex per hole).

namespace osteon::detail {

CornerTable pair_half_edges(const std::vector<uint32_t>& indices, uint32_t vertex_count) {
  const uint32_t corners = static_cast<uint32_t>(indices.size());
  CornerTable table;
  table.vertex_count = vertex_count;
  reserve_huge(&table.vertex.raw(), corners);
  reserve_huge(&table.opposite.raw(), corners);
  table.vertex.resize(corners);
  for (uint32_t c = 0; c < corners; ++c) table.vertex[CornerIndex(c)] = VertexIndex(indices[c]);
  table.opposite.assign(corners, kNoCorner);

  // The edge opposite corner c runs from = V[n(c)] to = V[p(c)]. Bucket the edges by `from`
  // (counting sort), then sort each bucket by `to`, so both directions of {u, w} are found by a
  // binary search in a bucket of about a vertex's valence.
  std::vector<uint32_t> start(static_cast<size_t>(vertex_count) + 1, 0);
  for (uint32_t c = 0; c < corners; ++c) ++start[table.vertex[next(CornerIndex(c))].value + 1];
  for (uint32_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  struct Edge {
    uint32_t to;
    uint32_t corner;
    bool operator<(const Edge& e) const { return to < e.to || (to == e.to && corner < e.corner); }
  };
  // A vertex's bucket holds about its valence: sorted by insertion and scanned. A longer one (a
  // vertex of huge valence, rare) goes to std::sort and a binary search.
  constexpr ptrdiff_t kShortBucket = 16;
  std::vector<Edge> edges;
  reserve_huge(&edges, corners);
  edges.resize(corners);
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t c = 0; c < corners; ++c) {
      uint32_t from = table.vertex[next(CornerIndex(c))].value;
      edges[fill[from]++] = {table.vertex[prev(CornerIndex(c))].value, c};
    }
  }
  for (uint32_t v = 0; v < vertex_count; ++v) {
    Edge* const first = edges.data() + start[v];
    Edge* const last = edges.data() + start[v + 1];
    if (last - first > kShortBucket) {
      std::sort(first, last);
      continue;
    }
    for (Edge* e = first + 1; e < last; ++e) {  // a vertex's valence: inline insertion sort
      const Edge moved = *e;
      Edge* hole = e;
      for (; hole > first && moved < hole[-1]; --hole) *hole = hole[-1];
      *hole = moved;
    }
  }
  // The run of edges from -> to, as [first, last): in a vertex's bucket (a valence) by a scan,
  // whose one unpredictable branch is its end, in a longer one by a binary search.
  auto run = [&](uint32_t from, uint32_t to) {
    const Edge* first = edges.data() + start[from];
    const Edge* const hi = edges.data() + start[from + 1];
    if (hi - first > kShortBucket) {
      first = std::lower_bound(first, hi, Edge{to, 0});
    } else {
      while (first != hi && first->to < to) ++first;
    }
    const Edge* last = first;
    while (last != hi && last->to == to) ++last;
    return std::make_pair(first, last);
  };
  for (uint32_t v = 0; v < vertex_count; ++v) {
    // Each undirected edge once, from its smaller end: the bucket's edges to larger vertices.
    const uint32_t end = start[v + 1];
    uint32_t i = start[v];
    while (i < end && edges[i].to < v) ++i;
    for (; i < end; ++i) {
      const Edge& e = edges[i];
      if (i + 1 < end && edges[i + 1].to == e.to) continue;  // 2+ triangles u -> w
      if (i > start[v] && edges[i - 1].to == e.to) continue;
      auto [first, last] = run(e.to, v);
      if (last - first != 1) continue;  // no twin, or 2+ triangles w -> u
      CornerIndex a(e.corner), b(first->corner);
      table.opposite[a] = b;
      table.opposite[b] = a;
    }
  }
  return table;
}

ClosedManifold close_to_manifold(const std::vector<uint32_t>& indices, uint32_t vertex_count) {
  ClosedManifold out;
  out.input_triangles = static_cast<uint32_t>(indices.size() / 3);
  out.input_vertices = vertex_count;
  CornerTable table = pair_half_edges(indices, vertex_count);
  const uint32_t corners = table.corner_count();

  // 1. Fans: the corners of a vertex linked through paired edges. Each fan after a vertex's first
  //    becomes a new vertex. A fan is a cycle (an interior vertex) or a path from the corner whose
  //    incoming edge is unpaired to the corner whose outgoing edge is unpaired.
  IndexVector<CornerIndex, VertexIndex> split;
  reserve_huge(&split.raw(), corners);
  split.assign(corners, kNoVertex);
  std::vector<uint8_t> has_fan(vertex_count, 0);
  uint32_t next_id = vertex_count;
  for (uint32_t i = 0; i < corners; ++i) {
    CornerIndex c(i);
    if (split[c].valid()) continue;
    VertexIndex v = table.vertex[c];
    VertexIndex id = v;
    if (has_fan[v.value]) {
      id = VertexIndex(next_id++);
      out.copy_of.push_back(v);
    }
    has_fan[v.value] = 1;
    // Walk back from c, marking, once round a cycle or to a path's first corner; a path's
    // corners after c are then marked walking forward (swing_in and swing_out are inverses).
    split[c] = id;
    CornerIndex r = table.swing_in(c);
    for (; r.valid() && r != c; r = table.swing_in(r)) split[r] = id;
    if (!r.valid()) {
      for (CornerIndex q = table.swing_out(c); q.valid(); q = table.swing_out(q)) split[q] = id;
    }
  }
  table.vertex = std::move(split);
  out.first_dummy = next_id;

  // 2. Holes: after the split every vertex has at most one outgoing and one incoming unpaired edge,
  //    so the unpaired edges form simple loops. out_edge[u] = the corner opposite u's outgoing
  //    unpaired edge.
  IndexVector<VertexIndex, CornerIndex> out_edge(next_id, kNoCorner);
  uint32_t unpaired = 0;
  for (uint32_t i = 0; i < corners; ++i) {
    CornerIndex c(i);
    if (table.opposite[c].valid()) continue;
    VertexIndex from = table.vertex[next(c)];
    assert(!out_edge[from].valid());
    out_edge[from] = c;
    ++unpaired;
  }
  out.dummy_faces = unpaired;
  table.vertex.resize(corners + 3 * static_cast<size_t>(unpaired), kNoVertex);
  table.opposite.resize(corners + 3 * static_cast<size_t>(unpaired), kNoCorner);

  // 3. Close each loop a_0 -> a_1 -> ... -> a_{L-1} -> a_0 with a dummy vertex d and the faces
  //    f_i = (a_{i+1}, a_i, d). f_i's first edge a_{i+1} -> a_i (opposite its d corner) pairs with
  //    the loop edge; its edge d -> a_{i+1} (opposite its a_i corner) pairs with f_{i+1}'s edge
  //    a_{i+1} -> d (opposite f_{i+1}'s first corner):
  //
  //          a_i -------- a_{i+1} ------- a_{i+2}     (the mesh above, the loop edges unpaired)
  //            \   f_i    /    \  f_{i+1} /
  //             \        /      \        /
  //              \      /        \      /
  //               `----d----------'          one fan of L faces around the dummy vertex d
  uint32_t face = out.input_triangles;
  std::vector<CornerIndex> loop;
  for (uint32_t i = 0; i < corners; ++i) {
    CornerIndex c0(i);
    if (table.opposite[c0].valid()) continue;
    loop.clear();
    CornerIndex c = c0;
    do {
      loop.push_back(c);
      c = out_edge[table.vertex[prev(c)]];
      assert(c.valid());
    } while (c != c0);
    VertexIndex d(next_id++);
    const uint32_t first_face = face;
    const uint32_t length = static_cast<uint32_t>(loop.size());
    for (uint32_t k = 0; k < length; ++k, ++face) {
      CornerIndex e = loop[k];
      CornerIndex f0 = first_corner(FaceIndex(face));
      CornerIndex f1(f0.value + 1), f2(f0.value + 2);
      table.vertex[f0] = table.vertex[prev(e)];  // a_{i+1}
      table.vertex[f1] = table.vertex[next(e)];  // a_i
      table.vertex[f2] = d;
      table.opposite[f2] = e;
      table.opposite[e] = f2;
      CornerIndex g0 = first_corner(FaceIndex(first_face + (k + 1) % length));
      table.opposite[f1] = g0;
      table.opposite[g0] = f1;
    }
  }
  table.vertex_count = next_id;
  out.table = std::move(table);
  return out;
}

bool is_closed_manifold(const CornerTable& table) {
  const uint32_t corners = table.corner_count();
  if (corners % 3 != 0 || table.opposite.size() != corners) return false;
  std::vector<uint32_t> valence(table.vertex_count, 0);
  for (uint32_t i = 0; i < corners; ++i) {
    CornerIndex c(i);
    CornerIndex o = table.opposite[c];
    if (!o.valid() || o.value >= corners || table.opposite[o] != c) return false;
    if (face_of(o) == face_of(c)) return false;
    if (table.vertex[next(c)] != table.vertex[prev(o)]) return false;
    if (table.vertex[prev(c)] != table.vertex[next(o)]) return false;
    VertexIndex v = table.vertex[c];
    if (!v.valid() || v.value >= table.vertex_count) return false;
    if (v == table.vertex[next(c)] || v == table.vertex[prev(c)]) return false;
    ++valence[v.value];
  }
  // Every vertex: one cycle of swings through all of its corners.
  std::vector<uint8_t> done(table.vertex_count, 0);
  for (uint32_t i = 0; i < corners; ++i) {
    CornerIndex c(i);
    VertexIndex v = table.vertex[c];
    if (done[v.value]) continue;
    done[v.value] = 1;
    uint32_t steps = 0;
    CornerIndex q = c;
    do {
      if (table.vertex[q] != v || ++steps > valence[v.value]) return false;
      q = table.swing_out(q);
    } while (q != c);
    if (steps != valence[v.value]) return false;
  }
  for (uint32_t v = 0; v < table.vertex_count; ++v) {
    if (!done[v]) return false;
  }
  return true;
}

}  // namespace osteon::detail
