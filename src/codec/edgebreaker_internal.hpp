// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <bit>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "codec/connectivity.hpp"
#include "codec/corner_table.hpp"
#include "core/byte_io.hpp"
#include "core/huge_pages.hpp"
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

/// At most 2^28 triangles: the closed mesh then has at most 2^30 faces (a dummy face per border
/// edge) and at most 3 * 2^30 vertex ids, so every corner and vertex id fits in 32 bits.
inline constexpr uint32_t kMaxConnectivityTriangles = 1u << 28;

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

// ---- the decoder core ------------------------------------------------------------------------

/// A fixed-size array addressed by one index type, left uninitialized (T must be an
/// implicit-lifetime type: trivially copyable and destructible). The decoder core writes every
/// element before reading it, so tens of megabytes are not cleared for nothing.
template <class I, class T>
class ScratchArray {
 public:
  void allocate(size_t n) {
    data_.reset(static_cast<T*>(::operator new[](n * sizeof(T))));
    advise_huge_pages(data_.get(), n * sizeof(T));
    size_ = n;
  }
  T& operator[](I i) { return data_.get()[i.value]; }
  const T& operator[](I i) const { return data_.get()[i.value]; }
  const T* data() const { return data_.get(); }
  size_t size() const { return size_; }

 private:
  struct Free {
    void operator()(T* p) const { ::operator delete[](p); }
  };
  std::unique_ptr<T, Free> data_;
  size_t size_ = 0;
};

/// Spirale Reversi: rebuilds the closed manifold corner table from the CLERS symbols in decoding
/// order (the reverse of the encoder's traversal), one face per symbol, then one start face per
/// component. Face k's corners are 3k (the tip: opposite the edge the next-decoded face, the
/// previous one in traversal order, attaches to), 3k+1 (opposite the right edge) and 3k+2
/// (opposite the left edge). Vertex ids are handed out as faces need them and are never reused:
/// an S merges two ids into one and the other dies.
///
/// Per vertex the core keeps, in one 16-byte record: the "left-most" corner (Draco's name), the
/// corner of the vertex's open fan whose incoming edge V[p] -> V is a free (unglued) edge, so a C
/// or a start face finds the edge to close in O(1); the vertex at the other end of that edge
/// ("far"), so the context of the symbol after a C costs two loads, not three; the number of
/// corners on the vertex, for the context and so that an S relabels the smaller of the two fans
/// it merges (O(n log n) for any input, O(n) in practice); and the vertex's key.
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

  /// The partial valence (corners decoded so far) of the vertex a C would close once step(symbol)
  /// has run (V[c1] of the new face), computed from the state before it, without a branch on
  /// `symbol`: the decoder reads the next symbol, whose context this is, before stepping, so a
  /// mispredicted branch in step() does not hold up the entropy decoder. 0 when the step would
  /// fail for want of an active edge. For the symbol context.
  uint32_t next_valence(uint32_t symbol) const {
    uint32_t c_count = 0, r_count = 0, s_count = 0;  // stay 0 when the step would fail
    uint32_t l_count = 1;                            // L and E: a new vertex
    if (faces_ > 0) {
      // After every step the active corner (the stack's top) is the new face's c0, so V[n(a)]
      // is its c1: known without reading the stack.
      const VertexRecord& v = vertices_[vertex_[CornerIndex(3 * faces_ - 2)]];
      c_count = vertices_[v.far].count + 1;  // C: the vertex across v's free edge
      r_count = v.count + 1;                 // R: V[n(a)] stays active
      CornerIndex below = stack_.size() > 1 ? stack_[stack_.size() - 2] : kNoCorner;
      const SplitEvent& e = events_[next_event_];  // the sentinel when none is left
      if (e.split == faces_) below = CornerIndex(3 * e.source + 1 + e.edge);
      if (below.valid()) s_count = vertices_[vertex_[next(below)]].count + 1;
    }
    // A select by masks looked up by symbol, not by branches: the result is on the decoder's
    // critical path, and which symbol comes is a guess the branch predictor often loses (the
    // compiler turns comparisons with the symbol back into branches).
    static constexpr uint32_t kIsC[8] = {~0u, 0, 0, 0, 0, 0, 0, 0};
    static constexpr uint32_t kIsR[8] = {0, ~0u, 0, 0, 0, 0, 0, 0};
    static constexpr uint32_t kIsS[8] = {0, 0, 0, 0, ~0u, 0, 0, 0};
    static constexpr uint32_t kIsLE[8] = {0, 0, ~0u, ~0u, 0, ~0u, ~0u, ~0u};
    const uint32_t s = symbol & 7;
    return (c_count & kIsC[s]) | (r_count & kIsR[s]) | (s_count & kIsS[s]) | (l_count & kIsLE[s]);
  }
  /// Corners decoded so far on vertex v (0 once v has been merged into another id).
  uint32_t valence(VertexIndex v) const { return vertices_[v].count; }
  /// The smallest id merged into v: vertices numbered by key are numbered by the first face, in
  /// decoding order, that uses them.
  uint32_t key(VertexIndex v) const { return vertices_[v].key; }

  uint32_t faces() const { return faces_; }
  uint32_t vertex_ids() const { return vertex_ids_; }
  /// V and O of the corners of faces 0..faces()-1.
  VertexIndex vertex(CornerIndex c) const { return vertex_[c]; }
  CornerIndex opposite(CornerIndex c) const { return opposite_[c]; }
  const VertexIndex* corner_vertex() const { return vertex_.data(); }
  const CornerIndex* corner_opposite() const { return opposite_.data(); }
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
  /// A new vertex id whose single corner is c (its far vertex is set by set_left once the face's
  /// vertices are known).
  VertexIndex new_vertex() {
    VertexIndex v(vertex_ids_++);
    vertices_[v] = {kNoCorner, kNoVertex, 1, v.value};
    return v;
  }
  /// Makes c the left-most corner of V[c]; V[p(c)] must be set.
  void set_left(CornerIndex c) {
    VertexRecord& r = vertices_[vertex_[c]];
    r.left = c;
    r.far = vertex_[prev(c)];
  }
  bool merge(CornerIndex a, CornerIndex b, VertexIndex* merged);

  struct VertexRecord {
    CornerIndex left;  ///< left-most corner
    VertexIndex far;   ///< V[p(left)]
    uint32_t count;    ///< corners on the vertex; 0 once merged into another id
    uint32_t key;      ///< smallest id merged into it
  };
  ScratchArray<CornerIndex, VertexIndex> vertex_;
  ScratchArray<CornerIndex, CornerIndex> opposite_;
  ScratchArray<VertexIndex, VertexRecord> vertices_;  // one spare record past the last id
  std::vector<CornerIndex> stack_;
  std::vector<SplitEvent> events_;  // then a sentinel whose split is no face
  size_t next_event_ = 0;
  uint32_t components_ = 0;
  uint32_t faces_ = 0;
  uint32_t vertex_ids_ = 0;
  uint32_t max_vertex_ids_ = 0;
  const char* what_ = "";
};

/// Undoes the encoder's cutting on a rebuilt closed mesh: drops the faces on the dummy vertices,
/// maps each glued copy onto its original, and numbers the remaining vertices in the order of
/// their keys (the first face in decoding order that uses them). `glue` holds (copy, original)
/// pairs of vertex ids. Writes exactly `triangle_count` triangles over exactly `vertex_count`
/// vertices to out->indices (faces in decoding order, corners in face order) and their newest
/// triangles to out->newest (an edge shared with a dummy face has nothing across), and, when
/// `final_of_id` is not null, the final vertex of each vertex id (kNoVertex for dead ids and
/// dummies). False (with *what) when the counts disagree, an id is out of range or not a vertex,
/// a triangle would repeat a vertex or a vertex would be left unused. O(faces + vertex ids).
bool uncut(const SpiraleReversi& core, const std::vector<uint32_t>& dummies,
           const std::vector<std::pair<uint32_t, uint32_t>>& glue, uint32_t triangle_count,
           uint32_t vertex_count, DecodedConnectivity* out, std::vector<VertexIndex>* final_of_id,
           const char** what);

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
/// Version 8's head byte of the connectivity section: the context model in its low bits, then
/// which of the counts that are usually 0 (or 1) follow.
inline constexpr uint8_t kHeadModelMask = 7;
inline constexpr uint8_t kHeadEvents = 1u << 3;      // split events follow
inline constexpr uint8_t kHeadDummies = 1u << 4;     // dummy vertices follow
inline constexpr uint8_t kHeadGlue = 1u << 5;        // glued vertices follow
inline constexpr uint8_t kHeadComponents = 1u << 6;  // the component count follows (else 1)
inline constexpr uint32_t kContextModelCount =
    static_cast<uint32_t>(sizeof(kContextModels) / sizeof(kContextModels[0]));
/// The models the encoder tries: the first four always, and the large models 4 and 5 (1600 and
/// 4000 contexts) from kLargeModelSymbols symbols on, where they can win (2-3% of the section on
/// million-triangle bones; never on the small meshes, whose encoding their table merging would
/// slow down several times). The entropy decoder's tables for this 5-symbol alphabet are 16 bytes
/// a context, so the large models decode as fast as the small ones.
inline constexpr uint32_t kEncoderContextModels = 4;
/// The one model the encoder plans without its search (EncodeOptions::effort 0): the previous
/// symbol and the valence (40 contexts), which the search keeps on most small and mid-sized
/// meshes, within about 1% of the best model on the others measured.
inline constexpr uint32_t kFastContextModel = 2;
inline constexpr uint32_t kLargeModelSymbols = 200000;

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
    for (uint32_t len = 0; len <= 32; ++len) {
      // len bucket: 0, 1, 2, 3, 4-7, 8-15, 16-31, 32+ (len saturates at 32).
      const uint32_t len8 = len < 4 ? len : static_cast<uint32_t>(std::bit_width(len)) + 1;
      const uint32_t bucket = model.len_buckets == 8   ? kLen8[len8]
                              : model.len_buckets == 4 ? kLen4[len8]
                                                       : 0;
      len_term_[len] = w_len_ * bucket;
    }
  }
  uint32_t contexts() const { return contexts_; }

  /// The context that get() returns after the previous symbols p1, p2, p3 (< 5; 0 before the
  /// first), with va (clamped to 7) and len in its 8-bucket form len8 (0..7, as in the
  /// constructor). The encoder counts its symbols once by every feature and maps the counts onto
  /// each model with this.
  uint32_t compose(uint32_t p1, uint32_t p2, uint32_t p3, uint32_t va, uint32_t len8) const {
    static constexpr uint8_t kLenOfBucket[8] = {0, 1, 2, 3, 4, 8, 16, 32};  // a len in each
    return w_p1_ * p1 + w_p2_ * p2 + w_p3_ * p3 + w_va_ * (va < 7 ? va : 7) +
           len_term_[kLenOfBucket[len8 & 7]];
  }

  /// The context of the next symbol; `va` = SpiraleReversi::next_valence() of the one before it
  /// (0 for the first symbol). The history part is summed in update(), off the decoder's
  /// critical path, which runs through va.
  uint32_t get(uint32_t va) const { return history_ + w_va_ * (va < 7 ? va : 7); }
  void update(uint32_t symbol) {
    p3_ = p2_;
    p2_ = p1_;
    p1_ = symbol;
    // By tables, not branches (as in next_valence()): E and S reset len, which saturates at 32.
    static constexpr uint32_t kKeepsLen[8] = {~0u, ~0u, ~0u, 0, 0, ~0u, ~0u, ~0u};
    len_ = (len_ + (len_ < 32 ? 1 : 0)) & kKeepsLen[symbol & 7];
    history_ = w_p1_ * p1_ + w_p2_ * p2_ + w_p3_ * p3_ + len_term_[len_];
  }

 private:
  uint32_t w_p1_ = 0, w_p2_ = 0, w_p3_ = 0, w_va_ = 0, w_len_ = 0;
  uint32_t contexts_ = 1;
  uint32_t len_term_[33] = {};  // w_len * the bucket of len, for len 0..32
  uint32_t p1_ = 0, p2_ = 0, p3_ = 0, len_ = 0;
  uint32_t history_ = 0;  // the context without va (all features 0 before the first symbol)
};

}  // namespace osteon::detail
