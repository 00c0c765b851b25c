// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "byte_io.hpp"
#include "corner_table.hpp"
#include "osteon/status.hpp"

// What edgebreaker_encode.cpp and edgebreaker_decode.cpp share: the CLERS alphabet, the symbol
// context model, and the decoder's core (Spirale Reversi), which the encoder runs too, on its own
// symbols, to check its output and to learn the decoder's vertex numbering.
//
// Based on: J. Rossignac, "Edgebreaker: connectivity compression for triangle meshes", IEEE TVCG
// 1999; M. Isenburg, J. Snoeyink, "Spirale Reversi: reverse decoding of the Edgebreaker encoding",
// CCCG 2000 / CGTA 2001; Draco's MeshEdgebreakerDecoderImpl (left-most corners, topology split
// events, interior start faces).

namespace osteon::detail {

/// CLERS symbols, numbered by how often they occur on bone meshes.
enum Symbol : uint8_t { kSymbolC = 0, kSymbolR = 1, kSymbolL = 2, kSymbolE = 3, kSymbolS = 4 };
inline constexpr uint32_t kSymbolCount = 5;

/// A topology split event (Draco's term): S face `split` glues its left edge to the right
/// (edge 0) or left (edge 1) free edge of the earlier-decoded face `source`, instead of to the
/// active edge under the top of the stack. Ids are decoding-order face ids: source < split.
struct SplitEvent {
  uint32_t split = 0;
  uint32_t source = 0;
  uint32_t edge = 0;
};

// ---- varints (LEB128) ------------------------------------------------------------------------

inline void put_varint(std::vector<uint8_t>* out, uint64_t value) {
  while (value >= 0x80) {
    out->push_back(static_cast<uint8_t>(value | 0x80));
    value >>= 7;
  }
  out->push_back(static_cast<uint8_t>(value));
}

/// False at the end of the bytes or for a varint of more than 64 bits.
inline bool read_varint(ByteReader& in, uint64_t* out) {
  uint64_t value = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    uint8_t byte = 0;
    if (!in.read_le(&byte)) return false;
    if (shift == 63 && byte > 1) return false;
    value |= static_cast<uint64_t>(byte & 0x7f) << shift;
    if ((byte & 0x80) == 0) {
      *out = value;
      return true;
    }
  }
  return false;
}

// ---- the decoder core ------------------------------------------------------------------------

/// Spirale Reversi: rebuilds the closed manifold corner table from the CLERS symbols in decoding
/// order (the reverse of the encoder's traversal), one face per symbol, then one start face per
/// component. Face k's corners are 3k (the tip: opposite the edge the next-decoded face, the
/// previous one in traversal order, attaches to), 3k+1 (opposite the right edge) and 3k+2
/// (opposite the left edge). Vertex ids are handed out as faces need them and are never reused:
/// an S merges two ids into one and the other dies.
///
/// Per vertex the core keeps the "left-most" corner (Draco's name): the corner of the vertex's
/// open fan whose incoming edge V[p] -> V is a free (unglued) edge, so a C or a start face finds
/// the edge to close in O(1), and the number of corners on the vertex, so an S relabels the
/// smaller of the two fans it merges (O(n log n) for any input, O(n) in practice).
///
/// Hostile input: every step checks what it relies on (an active edge to attach to, free edges,
/// distinct vertices, vertex ids within the declared count) and fails instead; arrays are sized
/// once from the declared counts.
class SpiraleReversi {
 public:
  /// Sizes the tables for `symbols` symbols, `components` start faces and at most `vertex_ids`
  /// vertex ids. `events` must be sorted by split id, each source < its split (checked by the
  /// caller). The caller has bounded the counts.
  void begin(uint32_t symbols, uint32_t components, uint32_t vertex_ids,
             std::vector<SplitEvent> events);

  /// Decodes one symbol into face `faces()`. False (with what()) when the symbol does not fit.
  bool step(uint32_t symbol);
  /// After all symbols: one start face per component left on the stack. False (with what())
  /// when the stack does not hold exactly the declared number of components or a start face does
  /// not close.
  bool close_components();

  /// The partial valence (corners decoded so far) of the vertex the next face's C would close;
  /// 0 when no active edge is open. For the symbol context.
  uint32_t active_valence() const {
    return stack_.empty() ? 0 : count_[vertex_[next(stack_.back())]];
  }
  bool stack_empty() const { return stack_.empty(); }
  size_t stack_size() const { return stack_.size(); }
  /// The corner opposite the edge the next face attaches to (kNoCorner when none is open).
  CornerIndex active_corner() const { return stack_.empty() ? kNoCorner : stack_.back(); }
  /// Corners decoded so far on vertex v (0 once v has been merged into another id).
  uint32_t valence(VertexIndex v) const { return count_[v]; }
  /// The smallest id merged into v: vertices numbered by key are numbered by the first face, in
  /// decoding order, that uses them.
  uint32_t key(VertexIndex v) const { return key_[v]; }

  uint32_t faces() const { return faces_; }
  uint32_t vertex_ids() const { return vertex_ids_; }
  const IndexVector<CornerIndex, VertexIndex>& corner_vertex() const { return vertex_; }
  const IndexVector<CornerIndex, CornerIndex>& opposite() const { return opposite_; }
  const char* what() const { return what_; }

 private:
  bool fail(const char* what) {
    what_ = what;
    return false;
  }
  void glue(CornerIndex a, CornerIndex b) {
    opposite_[a] = b;
    opposite_[b] = a;
  }
  VertexIndex new_vertex(CornerIndex c) {
    VertexIndex v(vertex_ids_++);
    left_[v] = c;
    count_[v] = 1;
    key_[v] = v.value;
    return v;
  }
  bool merge(CornerIndex a, CornerIndex b, VertexIndex* merged);

  IndexVector<CornerIndex, VertexIndex> vertex_;
  IndexVector<CornerIndex, CornerIndex> opposite_;
  IndexVector<VertexIndex, CornerIndex> left_;
  IndexVector<VertexIndex, uint32_t> count_;
  IndexVector<VertexIndex, uint32_t> key_;
  std::vector<CornerIndex> stack_;
  std::vector<SplitEvent> events_;
  size_t next_event_ = 0;
  uint32_t symbols_ = 0;
  uint32_t components_ = 0;
  uint32_t faces_ = 0;
  uint32_t vertex_ids_ = 0;
  uint32_t max_vertex_ids_ = 0;
  const char* what_ = "";
};

/// Undoes the encoder's cutting on a rebuilt closed mesh: drops the faces on the dummy vertices,
/// maps each glued copy onto its original, and numbers the remaining vertices in the order of
/// their keys (the first face in decoding order that uses them). `glue` holds (copy, original)
/// pairs of vertex ids. Writes exactly `triangle_count`
/// triangles over exactly `vertex_count` vertices to `indices`, and, when `final_of_id` is not
/// null, the final vertex of each vertex id (kNoVertex for unused ids). False (with *what) when
/// the counts disagree, an id is out of range or a triangle would repeat a vertex.
bool uncut(const SpiraleReversi& core, const std::vector<uint32_t>& dummies,
           const std::vector<std::pair<uint32_t, uint32_t>>& glue, uint32_t triangle_count,
           uint32_t vertex_count, std::vector<uint32_t>* indices,
           std::vector<VertexIndex>* final_of_id, const char** what);

// ---- the symbol context model ------------------------------------------------------------------

/// The context of each symbol is built from what the decoder already knows when it reads it:
///   p1, p2, p3  the previous three symbols in decoding order (5 values each);
///   va          the corners decoded so far on the vertex a C would close (V[n(a)] of the active
///               corner a), clamped to 7: a C ends that vertex's fan, so a vertex with many
///               corners already is likely to be closed next (the valence idea of Touma-Gotsman
///               and of Draco's valence coder, here as a context);
///   len         the symbols since the last E or S (in 8 or 4 buckets): E and S cluster.
/// A model picks some of these; the encoder tries every model and keeps the smallest section,
/// so small meshes use few contexts (their tables are sent) and large ones many.
struct ContextModel {
  uint8_t history;      ///< previous symbols used: 0..3
  uint8_t valence;      ///< 1: va used
  uint8_t len_buckets;  ///< 1 (unused), 4 or 8
};
inline constexpr ContextModel kContextModels[] = {
    {0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {2, 1, 1}, {2, 1, 8}, {3, 1, 4},
};
inline constexpr uint32_t kContextModelCount =
    static_cast<uint32_t>(sizeof(kContextModels) / sizeof(kContextModels[0]));

/// Tracks the features and turns them into a context id for one model.
class SymbolContext {
 public:
  explicit SymbolContext(const ContextModel& model) {
    // ctx = (((p1 * 5 + p2) * 5 + p3) * 8 + va) * len_buckets + len, unused features dropped.
    uint32_t weight = model.len_buckets;
    w_len_ = 1;
    w_va_ = model.valence ? weight : 0;
    weight *= model.valence ? 8 : 1;
    w_p3_ = model.history >= 3 ? weight : 0;
    weight *= model.history >= 3 ? 5 : 1;
    w_p2_ = model.history >= 2 ? weight : 0;
    weight *= model.history >= 2 ? 5 : 1;
    w_p1_ = model.history >= 1 ? weight : 0;
    weight *= model.history >= 1 ? 5 : 1;
    contexts_ = weight;
    static constexpr uint8_t kLen8[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    static constexpr uint8_t kLen4[8] = {0, 0, 1, 1, 2, 3, 3, 3};
    for (int i = 0; i < 8; ++i) {
      len_map_[i] = model.len_buckets == 8 ? kLen8[i] : model.len_buckets == 4 ? kLen4[i] : 0;
    }
  }
  uint32_t contexts() const { return contexts_; }

  /// The context of the next symbol; `va` = SpiraleReversi::active_valence() before it.
  uint32_t get(uint32_t va) const {
    // len bucket: 0, 1, 2, 3, 4-7, 8-15, 16-31, 32+ (len saturates at 32).
    const uint32_t len8 = len_ < 4 ? len_ : static_cast<uint32_t>(std::bit_width(len_)) + 1;
    return w_p1_ * p1_ + w_p2_ * p2_ + w_p3_ * p3_ + w_va_ * (va < 7 ? va : 7) +
           w_len_ * len_map_[len8];
  }
  void update(uint32_t symbol) {
    p3_ = p2_;
    p2_ = p1_;
    p1_ = symbol;
    len_ = (symbol == kSymbolE || symbol == kSymbolS) ? 0 : (len_ < 32 ? len_ + 1 : 32);
  }

 private:
  uint32_t w_p1_ = 0, w_p2_ = 0, w_p3_ = 0, w_va_ = 0, w_len_ = 0;
  uint32_t contexts_ = 1;
  uint8_t len_map_[8] = {};
  uint32_t p1_ = 0, p2_ = 0, p3_ = 0, len_ = 0;
};

}  // namespace osteon::detail
