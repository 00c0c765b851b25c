// SPDX-License-Identifier: Apache-2.0
#include "codec/corner_table.hpp"

#include <algorithm>
#include <cassert>
#include <cstring>
#include <memory>
#include <utility>

#include "core/huge_pages.hpp"

// Cutting any triangle list into a closed oriented manifold corner table, and the checks the tests
// use. See corner_table.hpp for the conventions.
//
// Based on: Rossignac, Safonova, Szymczak 2001 (corner table); Guéziec, Taubin, Lazarus, Horn 2001
// (cutting non-manifold meshes into manifold pieces); Rossignac 1999 (a dummy vertex per hole).

namespace osteon::detail {

namespace {

/// Calls f(c, from, to) for every corner c, whose opposite edge runs from = V[n(c)] to = V[p(c)],
/// face by face, so that n and p are constants rather than a remainder per corner.
template <class F>
void for_each_edge(const CornerTable& table, F&& f) {
  const uint32_t faces = table.face_count();
  for (uint32_t face = 0; face < faces; ++face) {
    const uint32_t c = 3 * face;
    const uint32_t v0 = table.vertex[CornerIndex(c)].value;
    const uint32_t v1 = table.vertex[CornerIndex(c + 1)].value;
    const uint32_t v2 = table.vertex[CornerIndex(c + 2)].value;
    f(c, v1, v2);
    f(c + 1, v2, v0);
    f(c + 2, v0, v1);
  }
}

/// Every vertex's outgoing half-edges, for counting the edges from -> to in a fixed number of
/// compares with no branch on the data: a vertex keeps its first kSlots edges in a row of one
/// cache line, the vertices they run to and then their corners (unused slots run to kEmpty, which
/// is no vertex); a vertex of higher degree (a pole, a fan, rare) keeps the rest in an overflow
/// list sorted by vertex, searched only for it.
class OutgoingEdges {
 public:
  static constexpr uint32_t kSlots = 8;

  explicit OutgoingEdges(const CornerTable& table) : degree_(table.vertex_count, 0) {
    // Rows start on a cache line: room for one more row to align the first. Each row is
    // written once here (a value-initialised vector would clear it first).
    const size_t words = size_t{table.vertex_count} * kRow + kRow;
    storage_.reset(new uint32_t[words]);
    advise_huge_pages(storage_.get(), words * sizeof(uint32_t));
    const size_t misalignment = reinterpret_cast<uintptr_t>(storage_.get()) % (kRow * 4) / 4;
    rows_ = storage_.get() + (misalignment == 0 ? 0 : kRow - misalignment);
    for (uint32_t v = 0; v < table.vertex_count; ++v) {
      std::fill(rows_ + size_t{v} * kRow, rows_ + size_t{v} * kRow + kSlots, kEmpty);
      std::fill(rows_ + size_t{v} * kRow + kSlots, rows_ + size_t{v} * kRow + kRow, 0u);
    }
    for_each_edge(table, [&](uint32_t c, uint32_t from, uint32_t to) {
      const uint32_t k = degree_[from]++;
      if (k < kSlots) [[likely]] {
        rows_[size_t{from} * kRow + k] = to;
        rows_[size_t{from} * kRow + kSlots + k] = c;
      } else {
        overflow_.push_back({from, to, c});
      }
    });
    std::sort(overflow_.begin(), overflow_.end(),
              [](const Edge& a, const Edge& b) { return a.from < b.from; });
  }

  /// How many half-edges run from -> to, and the corner opposite one of them (the only one when
  /// the count is 1). The slots are compared four at a time (SSE2 or WebAssembly SIMD lanes, or
  /// scalar code where there are none).
  std::pair<uint32_t, uint32_t> find(uint32_t from, uint32_t to) const {
    static_assert(kSlots == 8);
    typedef uint32_t Lanes __attribute__((vector_size(16)));
    const uint32_t* row = rows_ + size_t{from} * kRow;
    Lanes to0, to1, corner0, corner1;
    std::memcpy(&to0, row, sizeof(Lanes));
    std::memcpy(&to1, row + 4, sizeof(Lanes));
    std::memcpy(&corner0, row + 8, sizeof(Lanes));
    std::memcpy(&corner1, row + 12, sizeof(Lanes));
    const Lanes want = {to, to, to, to};
    const Lanes match0 = (Lanes)(to0 == want);  // all ones where it matches
    const Lanes match1 = (Lanes)(to1 == want);
    // Lane sums: the negated count, and the matching corners ORed (no two lanes share a bit
    // unless two match, when the corner is not used).
    Lanes count = match0 + match1;
    Lanes corner = (corner0 & match0) | (corner1 & match1);
    count += __builtin_shufflevector(count, count, 2, 3, 0, 1);
    corner |= __builtin_shufflevector(corner, corner, 2, 3, 0, 1);
    count += __builtin_shufflevector(count, count, 1, 0, 3, 2);
    corner |= __builtin_shufflevector(corner, corner, 1, 0, 3, 2);
    const uint32_t lane_count = count[0], lane_corner = corner[0];
    std::pair<uint32_t, uint32_t> found{0u - lane_count, lane_corner};
    if (degree_[from] > kSlots) [[unlikely]] {
      auto edge = std::lower_bound(overflow_.begin(), overflow_.end(), from,
                                   [](const Edge& e, uint32_t v) { return e.from < v; });
      for (; edge != overflow_.end() && edge->from == from; ++edge) {
        if (edge->to != to) continue;
        ++found.first;
        found.second = edge->corner;
      }
    }
    return found;
  }

 private:
  static constexpr uint32_t kEmpty = 0xffffffffu;
  static constexpr uint32_t kRow = 2 * kSlots;  // 64 bytes
  struct Edge {
    uint32_t from;
    uint32_t to;
    uint32_t corner;
  };
  std::unique_ptr<uint32_t[]> storage_;
  uint32_t* rows_;  // in storage_, 64-byte aligned
  std::vector<uint32_t> degree_;
  std::vector<Edge> overflow_;
};

}  // namespace

CornerTable pair_half_edges(const std::vector<uint32_t>& indices, uint32_t vertex_count) {
  const uint32_t corners = static_cast<uint32_t>(indices.size());
  CornerTable table;
  table.vertex_count = vertex_count;
  reserve_huge(&table.vertex.raw(), corners);
  reserve_huge(&table.opposite.raw(), corners);
  table.vertex.resize(corners);
  for (uint32_t c = 0; c < corners; ++c) table.vertex[CornerIndex(c)] = VertexIndex(indices[c]);
  table.opposite.resize(corners);

  // Each corner c, whose edge runs u -> w, takes the corner d of the one edge w -> u if there
  // is exactly one. Then c and d are paired when d took c back, which happens exactly when
  // u -> w occurs once too. Every corner writes only its own opposite, with selects rather than
  // branches; the second pass may clear a corner before a later corner reads it, which changes
  // nothing, since a cleared corner never took the later one.
  const OutgoingEdges edges(table);
  for_each_edge(table, [&](uint32_t c, uint32_t from, uint32_t to) {
    const auto [reverse, twin] = edges.find(to, from);
    table.opposite[CornerIndex(c)] = reverse == 1 ? CornerIndex(twin) : kNoCorner;
  });
  for (uint32_t c = 0; c < corners; ++c) {
    const CornerIndex d = table.opposite[CornerIndex(c)];
    const CornerIndex probe = d.valid() ? d : CornerIndex(c);  // O[c] = d is not c
    table.opposite[CornerIndex(c)] = table.opposite[probe] == CornerIndex(c) ? d : kNoCorner;
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
