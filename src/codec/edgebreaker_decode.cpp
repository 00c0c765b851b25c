// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "codec/connectivity.hpp"
#include "codec/edgebreaker_internal.hpp"
#include "codec/entropy.hpp"

// Edgebreaker decoding by Spirale Reversi: the CLERS symbols are read in the reverse of the
// encoder's traversal, so every face is attached to faces already built and no S offsets are
// needed. Handles cost one topology split event each; holes and non-manifold cuts are undone at
// the end (uncut()). The section layout is in docs/FORMAT.md ("Connectivity section").
//
// Speed (hip_mcs.ply, 1.06M triangles, native, one core: about 18 ns a symbol, then 12 ns a
// triangle to number the vertices and file the triangles for the geometry stage): one pass over
// the symbols on flat arrays (V and O per corner, one 16-byte record per vertex id), nothing
// hashed and nothing cleared up front; a C or a start face finds the edge it closes in O(1)
// through the left-most corner, and only an S walks a fan, the smaller of the two it merges. The
// symbol contexts depend on the mesh being built, so the loop is software-pipelined (the next
// symbol is read before the current face is built) and C and R, nine symbols in ten, share one
// branch-free path: what remains is the chain from one symbol through its context to the next,
// and the loads of the fans a C closes, a ring of the surface back.
//
// Based on: M. Isenburg, J. Snoeyink, "Spirale Reversi: reverse decoding of the Edgebreaker
// encoding", CGTA 20(1), 2001; J. Rossignac, "Edgebreaker", IEEE TVCG 5(1), 1999; Draco's
// MeshEdgebreakerDecoderImpl::DecodeConnectivity (left-most corners, topology split events,
// interior start faces).

namespace osteon::detail {

OSTEON_COLD_FUNCTION void SpiraleReversi::begin(uint32_t symbols, uint32_t components,
                                                uint32_t vertex_ids,
                                                std::vector<SplitEvent> events) {
  const size_t corners = 3 * (static_cast<size_t>(symbols) + components);
  // Not cleared: a face writes V and O of its three corners, a vertex id its record, before
  // anything reads them.
  vertex_.allocate(corners);
  opposite_.allocate(corners);
  vertices_.allocate(static_cast<size_t>(vertex_ids) + 1);
  stack_.clear();
  stack_.reserve(64);
  events_ = std::move(events);
  events_.push_back({0xFFFFFFFFu, 0, 0});  // the sentinel: no face is its split
  next_event_ = 0;
  components_ = components;
  faces_ = 0;
  vertex_ids_ = 0;
  max_vertex_ids_ = vertex_ids;
  what_ = "";
}

// Merges the two copies of the S face's tip: V[p(a)] (left branch) and V[n(b)] (right branch).
// The smaller fan is relabelled; the merged vertex keeps the right branch's left-most corner.
bool SpiraleReversi::merge(CornerIndex a, CornerIndex b, VertexIndex* merged) {
  const VertexIndex vp = vertex_[prev(a)];
  const VertexIndex vn = vertex_[next(b)];
  if (vp == vn) return fail("an S merges a vertex with itself");
  const VertexRecord right = vertices_[vn];
  const uint32_t total = vertices_[vp].count + right.count;
  const uint32_t key = std::min(vertices_[vp].key, right.key);
  VertexIndex keep = vp, drop = vn;
  if (vertices_[vp].count < right.count) std::swap(keep, drop);
  // Walk drop's open fan from its left-most corner across its paired edges to the other end,
  // relabelling it; a vertex whose far vertex was drop (its left-most corner follows one of
  // drop's corners) now has keep there.
  const uint32_t count = vertices_[drop].count;
  CornerIndex q = vertices_[drop].left;
  for (uint32_t steps = 1;; ++steps) {
    if (vertex_[q] != drop) return fail("a vertex fan is inconsistent");
    vertex_[q] = keep;
    VertexRecord& u = vertices_[vertex_[next(q)]];
    if (u.left == next(q)) u.far = keep;
    const CornerIndex r = opposite_[prev(q)];
    if (!r.valid()) {
      if (steps != count) return fail("a vertex fan is inconsistent");
      break;
    }
    if (steps == count) return fail("a vertex fan is closed where it must be open");
    q = prev(r);
  }
  vertices_[drop].count = 0;
  vertices_[keep] = {right.left, right.far, total, key};
  *merged = keep;
  return true;
}

bool SpiraleReversi::step(uint32_t symbol) {
  const CornerIndex c0(3 * faces_), c1(3 * faces_ + 1), c2(3 * faces_ + 2);
  if (symbol <= kSymbolR) [[likely]] {
    // C and R (nine symbols in ten) share one path without a branch on which it is: a
    // mispredicted branch here would stall the entropy decoder, which waits for this face.
    //
    // C: the new face closes the fan of v = V[n(a)]. Its right edge w-v is glued to the active
    //    edge (opposite a), its left edge v-x to v's other free edge, found through v's
    //    left-most corner q (opposite b = n(q)); x..w becomes the active edge.
    // R: the left edge is glued to the active edge; n is a new vertex; the right edge and v..n
    //    stay free.
    //
    //          C:    v                       R:    w
    //          b's / c0 \ a's             a's   / c0 \      (dotted: free edges;
    //         face/ new  \face            face / new  .      n: new)
    //            / c1  c2 \                   / c1  c2 .
    //           x ........ w                  v ........ n
    if (stack_.empty()) return fail("C or R with no active edge");
    const bool is_c = symbol == kSymbolC;
    const CornerIndex a = stack_.back();
    const VertexIndex v = vertex_[next(a)], w = vertex_[prev(a)];
    const VertexRecord& rv = vertices_[v];
    const CornerIndex q = rv.left;
    const CornerIndex b = next(q);
    // V[p(q)], from v's record rather than from q's face: that face is usually a ring of the
    // surface back, and the next step's context waits on x.
    const VertexIndex x = rv.far;
    const VertexIndex n(vertex_ids_);  // R's new vertex; a spare record when all ids are used
    // Bitwise, not short-circuit: every operand is at hand, and a branch per operand would be
    // a branch on the symbol.
    const unsigned c_bad =
        unsigned{opposite_[b].valid()} | unsigned{a == b} | unsigned{x == w} | unsigned{x == v};
    const unsigned r_bad = unsigned{vertex_ids_ == max_vertex_ids_};
    const bool bad = (unsigned{opposite_[a].valid()} | (unsigned{is_c} & c_bad) |
                      (unsigned{!is_c} & r_bad)) != 0;
    if (bad) [[unlikely]]
      return fail(is_c ? "C glues an edge that is not free, or closes too small a fan"
                       : "R glues an edge that is not free, or makes too many vertices");
    vertex_[c0] = is_c ? v : w;
    vertex_[c1] = is_c ? x : v;
    vertex_[c2] = is_c ? w : n;
    opposite_[c0] = kNoCorner;
    opposite_[a] = is_c ? c1 : c2;
    opposite_[c1] = is_c ? a : kNoCorner;
    opposite_[c2] = is_c ? b : a;
    const CornerIndex b_opposite = opposite_[b];
    opposite_[b] = is_c ? c2 : b_opposite;
    vertices_[n] = {c2, v, 1, n.value};  // R's new vertex (harmless scratch for a C)
    vertex_ids_ += is_c ? 0 : 1;
    VertexRecord& rw = vertices_[w];
    rw.left = is_c ? c2 : c0;
    rw.far = is_c ? x : n;
    ++rw.count;
    ++vertices_[v].count;
    vertices_[x].count += is_c ? 1 : 0;
    stack_.back() = c0;
    ++faces_;
    return true;
  }
  switch (symbol) {
    case kSymbolL: {
      // L: the right edge is glued to the active edge; x is a new vertex; the left edge and
      //    x..w stay free.
      //
      //              v
      //            / c0 \ a's
      //           . new  \face
      //          . c1  c2 \      (x: new)
      //         x ........ w
      if (stack_.empty()) return fail("L with no active edge");
      const CornerIndex a = stack_.back();
      if (opposite_[a].valid()) return fail("L glues an edge that is not free");
      if (vertex_ids_ == max_vertex_ids_) return fail("more vertices than declared");
      const VertexIndex v = vertex_[next(a)], w = vertex_[prev(a)];
      vertex_[c0] = v;
      vertex_[c1] = new_vertex();
      vertex_[c2] = w;
      opposite_[c0] = opposite_[c2] = kNoCorner;
      glue(c1, a);
      set_left(c1);
      set_left(c2);
      ++vertices_[v].count;
      ++vertices_[w].count;
      stack_.back() = c0;
      break;
    }
    case kSymbolE: {
      // E: three new vertices, nothing glued: the last face of a branch of the traversal,
      //    pushed as a new active edge.
      //
      //              v0
      //            . c0 .
      //           .  new .
      //          . c1  c2 .
      //        v1 ........ v2
      if (max_vertex_ids_ - vertex_ids_ < 3) return fail("more vertices than declared");
      vertex_[c0] = new_vertex();
      vertex_[c1] = new_vertex();
      vertex_[c2] = new_vertex();
      opposite_[c0] = opposite_[c1] = opposite_[c2] = kNoCorner;
      set_left(c0);
      set_left(c1);
      set_left(c2);
      stack_.push_back(c0);
      break;
    }
    case kSymbolS: {
      // S: the right edge is glued to the active edge b (popped), the left edge to a: the edge
      //    below it on the stack, or, where the encoder's left branch was already visited through
      //    a handle, a split event's edge. The tip's two copies V[p(a)] and V[n(b)] merge.
      //
      //              v
      //      a's   / c0 \  b's
      //      face / new  \ face
      //          / c1  c2 \      (v: V[p(a)] and V[n(b)] merged)
      //         y ........ w
      if (stack_.empty()) return fail("S with no active edge");
      const CornerIndex b = stack_.back();
      stack_.pop_back();
      CornerIndex a;
      if (events_[next_event_].split == faces_) {
        const SplitEvent& e = events_[next_event_++];
        a = CornerIndex(3 * e.source + 1 + e.edge);
        stack_.push_back(a);
      } else {
        if (stack_.empty()) return fail("S with one active edge");
        a = stack_.back();
      }
      if (opposite_[a].valid() || opposite_[b].valid() || a == b) {
        return fail("S glues an edge that is not free");
      }
      VertexIndex v;
      if (!merge(a, b, &v)) return false;
      const VertexIndex y = vertex_[next(a)], w = vertex_[prev(b)];
      vertex_[c0] = v;
      vertex_[c1] = y;
      vertex_[c2] = w;
      opposite_[c0] = kNoCorner;
      glue(c1, b);
      glue(c2, a);
      set_left(c2);
      ++vertices_[v].count;
      ++vertices_[y].count;
      ++vertices_[w].count;
      stack_.back() = c0;
      break;
    }
    default:
      return fail("unknown symbol");
  }
  ++faces_;
  return true;
}

OSTEON_COLD_FUNCTION bool SpiraleReversi::close_components() {
  if (next_event_ + 1 != events_.size()) {
    return fail("a split event names a face that is not an S");
  }
  if (stack_.size() != components_) return fail("the traversal does not end in its components");
  // Components were pushed last-encoded first: pop the first-encoded one first.
  while (!stack_.empty()) {
    // Start face: e0 opposite the component's last active edge a (e1 on V[p(a)], e2 on V[n(a)]);
    // its other two edges close the fans of V[n(a)] and of x through their left-most corners.
    //
    //              x
    //            / e0  \       (e1's edge closes x's fan, e2's
    //           / start \       edge closes V[n(a)]'s fan)
    //          / e1   e2 \      e1 on V[p(a)], e2 on V[n(a)]
    //         ------------
    //            a's face
    const CornerIndex a = stack_.back();
    stack_.pop_back();
    const CornerIndex e0(3 * faces_), e1(3 * faces_ + 1), e2(3 * faces_ + 2);
    const VertexIndex v1 = vertex_[prev(a)], v2 = vertex_[next(a)];
    const CornerIndex q2 = vertices_[v2].left;
    const VertexIndex x = vertex_[prev(q2)];
    const CornerIndex qx = vertices_[x].left;
    const CornerIndex b = next(q2), c = next(qx);
    if (opposite_[a].valid() || opposite_[b].valid() || opposite_[c].valid() || a == b || b == c ||
        a == c) {
      return fail("a start face glues an edge that is not free");
    }
    if (vertex_[prev(qx)] != v1 || x == v1 || x == v2) {
      return fail("a component does not close into a start face");
    }
    vertex_[e0] = x;
    vertex_[e1] = v1;
    vertex_[e2] = v2;
    glue(e0, a);
    glue(e1, b);
    glue(e2, c);
    ++vertices_[x].count;
    ++vertices_[v1].count;
    ++vertices_[v2].count;
    ++faces_;
  }
  return true;
}

OSTEON_NOINLINE bool uncut(const SpiraleReversi& core, const std::vector<uint32_t>& dummies,
                           const std::vector<std::pair<uint32_t, uint32_t>>& glue,
                           uint32_t triangle_count, uint32_t vertex_count, DecodedConnectivity* out,
                           std::vector<VertexIndex>* final_of_id, const char** what) {
  auto fail = [&](const char* message) {
    *what = message;
    return false;
  };
  // The final vertex of every vertex id, or a mark. Live ids are those with corners (an S
  // relabels every corner of the id it drops).
  constexpr uint32_t kFree = 0xFFFFFFFFu;   // a dead id, or not numbered yet
  constexpr uint32_t kDummy = 0xFFFFFFFEu;  // a dummy vertex: its faces are dropped
  constexpr uint32_t kCopy = 0xFFFFFFFDu;   // a glued copy: numbered as its original
  const uint32_t ids = core.vertex_ids();
  auto live = [&](uint32_t id) { return id < ids && core.valence(VertexIndex(id)) > 0; };
  std::vector<uint32_t> final_id(ids, kFree);
  for (uint32_t d : dummies) {
    if (!live(d) || final_id[d] != kFree) return fail("a dummy vertex is not a vertex or repeated");
    final_id[d] = kDummy;
  }
  for (const auto& [copy, original] : glue) {
    if (!live(copy) || !live(original) || copy == original || final_id[copy] != kFree) {
      return fail("a glued vertex pair is not a pair of vertices, or repeated");
    }
    final_id[copy] = kCopy;
  }
  for (const auto& [copy, original] : glue) {
    if (final_id[original] != kFree) return fail("a vertex is glued to a copy or a dummy");
  }
  // Number the other live ids by key: by_key[key] = the live id with that key (keys of live ids
  // are distinct: each is the smallest of the ids merged into one vertex).
  std::vector<uint32_t> by_key(ids, kFree);
  for (uint32_t id = 0; id < ids; ++id) {
    if (live(id)) by_key[core.key(VertexIndex(id))] = id;
  }
  uint32_t next_final = 0;
  for (uint32_t k = 0; k < ids; ++k) {
    const uint32_t id = by_key[k];
    if (id == kFree || final_id[id] != kFree) continue;
    if (next_final == vertex_count) return fail("more vertices than declared");
    final_id[id] = next_final++;
  }
  if (next_final != vertex_count) return fail("fewer vertices than declared");
  for (const auto& [copy, original] : glue) final_id[copy] = final_id[original];

  // Faces in decoding order, dummy faces dropped, with each face's newest vertex counted (shifted
  // by two for the filling below) and the neighbour of its middle one noted. Every numbered
  // vertex has corners, so only where dummy faces are dropped can one end up unused (in a
  // corrupt stream): check it there.
  const size_t wanted = 3 * static_cast<size_t>(triangle_count);
  reserve_huge(&out->indices, wanted);
  out->indices.resize(wanted);
  uint32_t* indices = out->indices.data();
  NewestTriangles& newest = out->newest;
  // clear() then resize() rather than assign(): the decoder's download holds one fewer function.
  newest.first.clear();
  newest.first.resize(size_t{vertex_count} + 2);
  newest.neighbour.resize(vertex_count);
  std::fill(newest.neighbour.begin(), newest.neighbour.end(), kNoVertexId);
  uint32_t* first = newest.first.data();
  uint32_t* neighbour = newest.neighbour.data();
  size_t written = 0;
  const bool has_dummies = !dummies.empty();
  std::vector<uint8_t> used(has_dummies ? vertex_count : 0, 0);
  // Where each decoded face went (kFree for a dummy face), when there are dummy faces.
  std::vector<uint32_t> final_face(has_dummies ? core.faces() : 0, kFree);
  const VertexIndex* corner_vertex = core.corner_vertex();
  const CornerIndex* opposite = core.corner_opposite();
  const uint32_t faces = core.faces();
  for (uint32_t f = 0; f < faces; ++f) {
    const uint32_t a = final_id[corner_vertex[3 * f].value];
    const uint32_t b = final_id[corner_vertex[3 * f + 1].value];
    const uint32_t c = final_id[corner_vertex[3 * f + 2].value];
    if (std::max({a, b, c}) >= vertex_count) [[unlikely]] {
      if (a == kDummy || b == kDummy || c == kDummy) continue;
      return fail("a face uses a vertex that was merged away");
    }
    if ((a == b) | (b == c) | (a == c)) return fail("a decoded triangle repeats a vertex");
    if (written == wanted) return fail("more triangles than declared");
    indices[written] = a;
    indices[written + 1] = b;
    indices[written + 2] = c;
    const uint32_t hi = std::max({a, b, c}), lo = std::min({a, b, c});
    ++first[size_t{hi} + 2];
    neighbour[a ^ b ^ c ^ hi ^ lo] = lo;  // the middle one
    if (has_dummies) {
      final_face[f] = static_cast<uint32_t>(written / 3);
      used[a] = used[b] = used[c] = 1;
    }
    written += 3;
  }
  if (written != wanted) return fail("fewer triangles than declared");
  if (std::find(used.begin(), used.end(), 0) != used.end()) {
    return fail("a vertex is used by dummy faces only");
  }

  // File every triangle under its newest vertex; first[v + 1] runs from v's start to its end
  // (and is then v + 1's start). Across the newest corner's edge: the vertex of the opposite
  // corner, read from the triangles just written. Every corner of a closed mesh is glued (a
  // corrupt stream may leave one free); across a dummy face's edge is nothing. Without dummy
  // faces, decoded faces are the output's.
  for (uint32_t v = 2; v < vertex_count + 2; ++v) first[v] += first[v - 1];
  reserve_huge(&newest.entries, triangle_count);
  newest.entries.resize(triangle_count);
  NewestTriangle* entries = newest.entries.data();
  const uint32_t corners = 3 * faces;
  constexpr uint32_t kAhead = 16;  // faces: the opposite face is often a ring back, a cache miss
  for (uint32_t f = 0; f < faces; ++f) {
#if defined(__GNUC__)
    if (f + kAhead < faces && !has_dummies) {
      OSTEON_UNROLL
      for (uint32_t k = 0; k < 3; ++k) {
        const uint32_t ahead = opposite[3 * (f + kAhead) + k].value;
        if (ahead < corners) __builtin_prefetch(indices + ahead);
      }
    }
#endif
    const uint32_t t = has_dummies ? final_face[f] : f;
    if (t == kFree) continue;
    const uint32_t* tri = indices + 3 * size_t{t};
    const uint32_t a = tri[0], b = tri[1], c = tri[2];
    // The newest corner k, and the two after it (without branches: k is random).
    const uint32_t k = (b > a && b > c) ? 1 : (c > a && c > b) ? 2 : 0;
    const uint32_t m = tri[k];
    const uint32_t n = tri[k == 2 ? 0 : k + 1], p = tri[k == 0 ? 2 : k - 1];
    const uint32_t across = opposite[3 * f + k].value;
    uint32_t o = kNoVertexId;
    if (across < corners) {
      // across / 3 as the multiply and shift a constant divisor compiles to (exact for every
      // 32-bit value): g++ 12 emits a division instruction here otherwise.
      const auto face = static_cast<uint32_t>(uint64_t{across} * 0xAAAAAAABu >> 33);
      const uint32_t corner = across - 3 * face;
      const uint32_t g = has_dummies ? final_face[face] : face;
      if (g != kFree) o = indices[3 * size_t{g} + corner];
    }
    entries[first[size_t{m} + 1]++] = NewestTriangle{n, p, o < m ? o : kNoVertexId};
  }
  newest.first.pop_back();
  if (final_of_id) {
    final_of_id->assign(ids, kNoVertex);
    for (uint32_t v = 0; v < ids; ++v) {
      if (final_id[v] < vertex_count) (*final_of_id)[v] = VertexIndex(final_id[v]);
    }
  }
  return true;
}

namespace {

#if defined(__GNUC__)
#define OSTEON_FLATTEN __attribute__((flatten))
#else
#define OSTEON_FLATTEN
#endif

// The hot loop, in a function of its own so that the compiler inlines everything into it.
// Software-pipelined: symbol i+1 is read before face i is built (see next_valence()), so the
// entropy decoder does not wait for step()'s memory traffic and mispredicted branches. Stops
// early, returning true, when the entropy decoder fails (its finish() reports that).
OSTEON_NOINLINE OSTEON_FLATTEN bool decode_symbols(SpiraleReversi& core, SymbolDecoder& decoder,
                                                   const SymbolContext& model, uint32_t symbols,
                                                   uint32_t* failed_at) {
  // The entropy decoder's moving parts and the context's history in locals (registers).
  SymbolDecoder::Cursor cursor = decoder.cursor();
  SymbolContext context = model;
  bool ok = true;
  uint32_t symbol = symbols > 0 ? decoder.get(cursor, context.get(0)) : 0;
  for (uint32_t i = 0; i < symbols && cursor.ok; ++i) {
    const uint32_t valence = core.next_valence(symbol);
    context.update(symbol);
    const uint32_t following = i + 1 < symbols ? decoder.get(cursor, context.get(valence)) : 0;
    if (!core.step(symbol)) [[unlikely]] {
      *failed_at = i;
      ok = false;
      break;
    }
    symbol = following;
  }
  decoder.resume(cursor);
  return ok;
}

}  // namespace

OSTEON_COLD_FUNCTION Result<DecodedConnectivity> decode_connectivity(ByteReader& in,
                                                                     uint32_t vertex_count,
                                                                     uint32_t triangle_count,
                                                                     uint8_t version,
                                                                     const std::string& source) {
  size_t at = in.offset();
  // "connectivity: " + first + second, by appends (fewer functions in the decoder's download).
  auto bad = [&](const std::string& first, const char* second = "") {
    std::string what = "connectivity: ";
    what += first;
    what += second;
    return error(ErrorCode::kInvalidData, source, what, at_byte(at));
  };
  auto read = [&](uint64_t* value, const char* what) -> Status {
    at = in.offset();
    if (!in.read_varint(value)) return bad("truncated ", what);
    return Status::ok_status();
  };

  // Counts, each bounded before anything is allocated. Faces of the closed mesh = the triangles
  // plus one dummy face per boundary edge (at most three per triangle) = symbols + components.
  if (triangle_count > kMaxConnectivityTriangles) {
    return bad(message("% triangles, more than 2^28", {triangle_count}));
  }
  // Version 8: a head byte first, the context model and which counts follow (the others are 0,
  // the component count 1); the vertex ids are counted beyond vertex_count.
  const bool compact = version >= kCompactSectionVersion;
  uint8_t head = kHeadEvents | kHeadDummies | kHeadGlue | kHeadComponents;
  if (compact &&
      (!in.read_le(&head) || (head & 0x80) != 0 || (head & kHeadModelMask) >= kContextModelCount)) {
    return bad(message("truncated or unknown head byte %", {head}));
  }
  uint64_t symbols = 0, components = 1, vertex_ids = 0;
  OSTEON_RETURN_IF_ERROR(read(&symbols, "symbol count"));
  if (symbols > 4 * static_cast<uint64_t>(triangle_count)) {
    return bad(
        message("% symbols for % triangles (at most 4 per triangle)", {symbols, triangle_count}));
  }
  if ((head & kHeadComponents) != 0) {
    OSTEON_RETURN_IF_ERROR(read(&components, "component count"));
  }
  if (components > symbols || symbols + components > 4 * static_cast<uint64_t>(triangle_count) ||
      (triangle_count > 0 && components == 0)) {
    return bad(message("% components for % symbols", {components, symbols}));
  }
  OSTEON_RETURN_IF_ERROR(read(&vertex_ids, "vertex id count"));
  if (compact) {  // beyond vertex_count (a count that large fails below, without overflowing)
    vertex_ids = vertex_ids > 3 * symbols ? 3 * symbols + 1 : vertex_ids + vertex_count;
  }
  if (vertex_ids > 3 * symbols || vertex_ids < vertex_count) {
    return bad(
        message("% vertex ids for % symbols and % vertices", {vertex_ids, symbols, vertex_count}));
  }

  uint64_t count = 0;
  if ((head & kHeadEvents) != 0) OSTEON_RETURN_IF_ERROR(read(&count, "split event count"));
  if (count > symbols || !in.fits(count, 2)) {
    return bad(
        message("% split events for % symbols and % bytes", {count, symbols, in.remaining()}));
  }
  std::vector<SplitEvent> events(count);
  uint64_t previous = 0;
  for (uint64_t i = 0; i < count; ++i) {
    uint64_t delta = 0, back = 0;
    OSTEON_RETURN_IF_ERROR(read(&delta, "split event"));
    OSTEON_RETURN_IF_ERROR(read(&back, "split event"));
    const uint64_t split = i == 0 ? delta : previous + 1 + delta;
    if (delta >= symbols || split >= symbols || (back >> 1) >= split) {
      return bad("split event out of range");
    }
    events[i] = {static_cast<uint32_t>(split), static_cast<uint32_t>(split - 1 - (back >> 1)),
                 static_cast<uint32_t>(back & 1)};
    previous = split;
  }

  auto read_ids = [&](std::vector<uint32_t>* ids, bool present, const char* what) -> Status {
    uint64_t n = 0;
    if (present) OSTEON_RETURN_IF_ERROR(read(&n, what));
    if (n > vertex_ids || !in.fits(n, 1)) return bad("too many ", what);
    ids->resize(n);
    uint64_t last = 0;
    for (uint64_t i = 0; i < n; ++i) {
      uint64_t delta = 0;
      OSTEON_RETURN_IF_ERROR(read(&delta, what));
      const uint64_t id = i == 0 ? delta : last + 1 + delta;
      if (delta >= vertex_ids || id >= vertex_ids) return bad(what, " out of range");
      (*ids)[i] = static_cast<uint32_t>(id);
      last = id;
    }
    return Status::ok_status();
  };
  std::vector<uint32_t> dummies, copies;
  OSTEON_RETURN_IF_ERROR(read_ids(&dummies, (head & kHeadDummies) != 0, "dummy vertices"));
  OSTEON_RETURN_IF_ERROR(read_ids(&copies, (head & kHeadGlue) != 0, "glued vertices"));
  std::vector<std::pair<uint32_t, uint32_t>> glue(copies.size());
  for (size_t i = 0; i < copies.size(); ++i) {
    uint64_t original = 0;
    OSTEON_RETURN_IF_ERROR(read(&original, "glued vertex"));
    if (original >= vertex_ids) return bad("glued vertex out of range");
    glue[i] = {copies[i], static_cast<uint32_t>(original)};
  }

  at = in.offset();
  uint8_t model = head & kHeadModelMask;
  if (!compact && !in.read_le(&model)) return bad("truncated context model");
  if (model >= kContextModelCount) return bad(message("unknown context model %", {model}));
  SymbolContext context(kContextModels[model]);
  at = in.offset();
  SymbolDecoder decoder;
  OSTEON_RETURN_IF_ERROR(decoder.init(in, kSymbolCount, context.contexts(),
                                      {version, symbols, 0, compact}, source, "connectivity"));
  if (decoder.symbols_left() != symbols) {
    return bad(
        message("the symbol section holds % symbols, not %", {decoder.symbols_left(), symbols}));
  }

  SpiraleReversi core;
  core.begin(static_cast<uint32_t>(symbols), static_cast<uint32_t>(components),
             static_cast<uint32_t>(vertex_ids), std::move(events));
  uint32_t failed_at = 0;
  if (!decode_symbols(core, decoder, context, static_cast<uint32_t>(symbols), &failed_at)) {
    return bad(core.what(), message(" at symbol %", {failed_at}).c_str());
  }
  OSTEON_RETURN_IF_ERROR(decoder.finish(source, "connectivity"));
  if (!core.close_components()) return bad(core.what());

  DecodedConnectivity out;
  out.last_state = decoder.last_state();
  const char* what = "";
  if (!uncut(core, dummies, glue, triangle_count, vertex_count, &out, nullptr, &what)) {
    return bad(what);
  }
  return out;
}

}  // namespace osteon::detail
