// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

// The corner table (Rossignac, Safonova, Szymczak 2001): corner c of face c / 3 sits on vertex
// V[c]; O[c] is the corner across the edge opposite c. Everything the connectivity coder knows
// about a mesh is these two arrays. Corner, vertex and face indices are distinct types (STYLE
// habit 6) so that a corner is never used where a vertex is meant.
//
// Orientation convention, used by every drawing in the Edgebreaker files:
//
//            p(c)                 face f = corners 3f, 3f+1, 3f+2, counter-clockwise seen from
//            / \                  outside. The edge opposite corner c runs from V[n(c)] to
//           /   \                 V[p(c)]; its twin (the same two vertices the other way round)
//          /  f  \                is the edge opposite O[c] in the neighbouring face.
//         c ----- n(c)
//
// close_to_manifold() turns any triangle list (several components, holes, handles, non-manifold
// edges and vertices, inconsistent orientation) into a closed oriented manifold corner table by
// cutting and closing, remembering what it did so the decoder can undo it exactly.
//
// Based on: J. Rossignac, A. Safonova, A. Szymczak, "3D compression made simple: Edgebreaker on a
// corner table", Shape Modeling International 2001; Draco's corner_table.h (naming of swings);
// A. Guéziec, G. Taubin, F. Lazarus, B. Horn, "Cutting and stitching: converting sets of polygons
// to manifold surfaces", IEEE TVCG 2001 (cut non-manifold vertices and edges, record the stitch).

namespace osteon::detail {

/// A typed 32-bit index. `kInvalid` (all ones) marks "none" (an unpaired corner, no vertex).
template <class Tag>
struct Index {
  static constexpr uint32_t kInvalid = 0xFFFFFFFFu;
  uint32_t value = kInvalid;

  constexpr Index() = default;
  constexpr explicit Index(uint32_t v) : value(v) {}
  constexpr bool valid() const { return value != kInvalid; }
  friend constexpr bool operator==(Index a, Index b) = default;
  friend constexpr auto operator<=>(Index a, Index b) = default;
};

using CornerIndex = Index<struct CornerTag>;
using VertexIndex = Index<struct VertexTag>;
using FaceIndex = Index<struct FaceTag>;

inline constexpr CornerIndex kNoCorner{};
inline constexpr VertexIndex kNoVertex{};

/// A std::vector addressed by one index type only.
template <class I, class T>
class IndexVector {
 public:
  IndexVector() = default;
  explicit IndexVector(size_t n, T fill = T()) : data_(n, fill) {}
  T& operator[](I i) { return data_[i.value]; }
  const T& operator[](I i) const { return data_[i.value]; }
  size_t size() const { return data_.size(); }
  void assign(size_t n, T fill) { data_.assign(n, fill); }
  /// Grows with `fill`; the default fill (T(): no index) as a memset, which g++ 12 does not
  /// make of resize(n, fill) (it stores each element through the stack).
  void resize(size_t n, T fill = T()) {
    if (fill == T()) {
      data_.resize(n);
    } else {
      data_.resize(n, fill);
    }
  }
  void push_back(T v) { data_.push_back(v); }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& raw() { return data_; }
  const std::vector<T>& raw() const { return data_; }

 private:
  std::vector<T> data_;
};

inline constexpr FaceIndex face_of(CornerIndex c) {
  return FaceIndex(c.value / 3);
}
inline constexpr CornerIndex first_corner(FaceIndex f) {
  return CornerIndex(f.value * 3);
}
/// The next corner of c's face (counter-clockwise).
inline constexpr CornerIndex next(CornerIndex c) {
  return CornerIndex(c.value % 3 == 2 ? c.value - 2 : c.value + 1);
}
/// The previous corner of c's face.
inline constexpr CornerIndex prev(CornerIndex c) {
  return CornerIndex(c.value % 3 == 0 ? c.value + 2 : c.value - 1);
}

struct CornerTable {
  IndexVector<CornerIndex, VertexIndex> vertex;    ///< V: 3 per face
  IndexVector<CornerIndex, CornerIndex> opposite;  ///< O: kNoCorner where the edge is unpaired
  uint32_t vertex_count = 0;

  uint32_t face_count() const { return static_cast<uint32_t>(vertex.size() / 3); }
  uint32_t corner_count() const { return static_cast<uint32_t>(vertex.size()); }
  VertexIndex v(CornerIndex c) const { return vertex[c]; }
  CornerIndex o(CornerIndex c) const { return opposite[c]; }

  /// The corner of V[c] in the face across c's outgoing edge V[c] -> V[n(c)] (kNoCorner on a
  /// boundary). Repeating it walks around V[c] one way; swing_in walks back.
  ///
  ///          p(c)          the edge c -> n(c) (opposite p(c)) is shared with face g, where
  ///          /  \          it runs n(r) -> p(r) (r = O[p(c)]), so swing_out(c) = p(r), which
  ///         / f  \         sits on V[c]
  ///        c ---- n(c)
  ///      p(r) ---- n(r)
  ///         \ g  /
  ///          \  /
  ///           r
  CornerIndex swing_out(CornerIndex c) const {
    CornerIndex r = opposite[prev(c)];
    return r.valid() ? prev(r) : kNoCorner;
  }
  /// The corner of V[c] in the face across c's incoming edge V[p(c)] -> V[c].
  CornerIndex swing_in(CornerIndex c) const {
    CornerIndex r = opposite[next(c)];
    return r.valid() ? next(r) : kNoCorner;
  }
};

/// Pairs the half-edges of a triangle list into a corner table without cutting anything: the
/// edge opposite corner c is paired with the edge opposite d when exactly one triangle runs
/// u -> v and exactly one runs v -> u; every other edge (a border, 3+ triangles on one edge, two
/// triangles in the same direction) is left unpaired. V[c] = indices[c].
/// Complexity: O(n) for n corners, plus O(k log k) for the k edges beyond the eighth of vertices
/// of higher degree.
CornerTable pair_half_edges(const std::vector<uint32_t>& indices, uint32_t vertex_count);

/// A closed oriented manifold made from any triangle list, and how to undo it.
///
/// Faces 0..T-1 are the input triangles with the input's corner order; faces T.. are the dummy
/// faces that close the holes. Vertices 0..V-1 are the input vertices (each keeps its first fan),
/// V..V+K-1 are copies made where a vertex had several fans (copy_of says of whom), and
/// V+K..vertex_count-1 are the dummy vertices, one per boundary loop.
struct ClosedManifold {
  CornerTable table;
  uint32_t input_triangles = 0;
  uint32_t input_vertices = 0;
  std::vector<VertexIndex> copy_of;  ///< copy_of[k] = input vertex that vertex V + k copies
  uint32_t first_dummy = 0;          ///< V + K
  uint32_t dummy_faces = 0;

  bool is_dummy(VertexIndex v) const { return v.value >= first_dummy; }
  bool is_copy(VertexIndex v) const { return v.value >= input_vertices && v.value < first_dummy; }
};

/// Cuts a triangle list into a closed oriented manifold (Guéziec et al.'s cutting, then a dummy
/// vertex per hole as in Rossignac's Edgebreaker paper):
/// 1. pair_half_edges(): only edges with exactly one triangle each way are kept;
/// 2. every vertex's corners are grouped into fans (corners linked through paired edges around
///    the vertex); each fan after the first becomes a new vertex (a copy);
/// 3. the unpaired edges now form simple loops (each vertex has at most one outgoing and one
///    incoming unpaired edge); each loop gets a dummy vertex and one dummy face per loop edge,
///    paired with that edge explicitly (a loop of length 2 gives two faces over the same vertices).
/// Preconditions: every index < vertex_count, no triangle repeats an index.
/// Complexity: O(n log d).
ClosedManifold close_to_manifold(const std::vector<uint32_t>& indices, uint32_t vertex_count);

/// True when `table` is a closed oriented manifold: every corner paired, O an involution between
/// different faces, twins running between the same two vertices the other way, and the corners of
/// each vertex forming a single cycle around it. For tests and debug checks; O(n).
bool is_closed_manifold(const CornerTable& table);

}  // namespace osteon::detail
