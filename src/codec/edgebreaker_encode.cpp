// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cassert>
#include <string>
#include <utility>
#include <vector>

#include "codec/connectivity.hpp"
#include "codec/corner_table.hpp"
#include "codec/edgebreaker_internal.hpp"
#include "codec/entropy.hpp"

// Edgebreaker encoding over a corner table. The input is first cut into a closed oriented
// manifold (corner_table.cpp: non-manifold edges and vertices cut, a dummy vertex per hole), then
// each component is traversed from a start face, one CLERS symbol per other face. The symbols are
// stored in reverse for the Spirale Reversi decoder, with one topology split event per handle.
//
// The encoder then runs the decoder's core on its own symbols and checks that each vertex of the
// rebuilt table is one vertex it encoded, so that every decoded face has its encoded face's
// vertices. The dummy vertex ids and the glue pairs are read off the rebuilt table, and the decoded
// triangles and vertex order returned to the caller are the decoder's own.
//
// Based on: J. Rossignac, "Edgebreaker: connectivity compression for triangle meshes", IEEE TVCG
// 5(1), 1999 (CLERS, dummy vertices for holes); J. Rossignac, A. Safonova, A. Szymczak, "3D
// compression made simple: Edgebreaker on a corner table", SMI 2001 (the traversal);
// Draco's MeshEdgebreakerEncoderImpl (iterative traversal, topology split events).

namespace osteon::detail {
namespace {

constexpr uint32_t kNone = 0xFFFFFFFFu;

struct Traversal {
  std::vector<uint8_t> symbols;     ///< encoding order
  std::vector<CornerIndex> tips;    ///< per symbol: the tip corner of its face
  std::vector<CornerIndex> starts;  ///< per component: the start face's corner opposite the
                                    ///< first traversed face
  std::vector<SplitEvent> events;   ///< encoding-order symbol ids
};

// The Edgebreaker traversal (Rossignac et al. 2001), iterative. c is the tip corner of the face
// being entered (the face was entered through the edge opposite c); r = O[n(c)] and l = O[p(c)]
// are the corners across its right and left edges:
//
//              c                 C: V[c] not visited yet   -> go right
//            /   \               L: left face visited      -> go right
//      l's  / face \  r's        R: right face visited     -> go left
//     face / n   p  \ face       E: both visited           -> end of branch
//         ------------           S: neither visited        -> right branch first, then left
//          entered here
//
// (n(c) sits on the left of the entry edge and p(c) on the right, since faces are
// counter-clockwise.) A popped left branch whose face was visited meanwhile (through a handle) is
// skipped; the face of that branch that saw the S face across its right or left edge records a
// split event, which tells the decoder where the S's left edge goes.
Traversal traverse(const ClosedManifold& m) {
  const CornerTable& t = m.table;
  const uint32_t faces = t.face_count();
  Traversal out;
  out.symbols.reserve(faces);
  out.tips.reserve(faces);
  std::vector<uint8_t> face_done(faces, 0);
  std::vector<uint8_t> vertex_done(t.vertex_count, 0);
  std::vector<uint32_t> split_symbol(faces, kNone);
  std::vector<CornerIndex> stack;

  auto done = [&](CornerIndex c) { return face_done[face_of(c).value] != 0; };
  auto check_split = [&](uint32_t symbol, CornerIndex neighbour, uint32_t edge) {
    const uint32_t s = split_symbol[face_of(neighbour).value];
    if (s != kNone) out.events.push_back({s, symbol, edge});
  };

  auto component = [&](FaceIndex start_face, CornerIndex s) {
    face_done[start_face.value] = 1;
    for (uint32_t k = 0; k < 3; ++k) vertex_done[t.v(CornerIndex(s.value / 3 * 3 + k)).value] = 1;
    out.starts.push_back(s);
    stack.assign(1, t.o(s));
    while (!stack.empty()) {
      CornerIndex c = stack.back();
      if (done(c)) {
        stack.pop_back();
        continue;
      }
      while (true) {
        const FaceIndex f = face_of(c);
        face_done[f.value] = 1;
        const uint32_t id = static_cast<uint32_t>(out.symbols.size());
        out.tips.push_back(c);
        const VertexIndex v = t.v(c);
        if (!vertex_done[v.value]) {
          vertex_done[v.value] = 1;
          out.symbols.push_back(kSymbolC);
          c = t.o(next(c));
          continue;
        }
        const CornerIndex r = t.o(next(c)), l = t.o(prev(c));
        const bool right_done = done(r), left_done = done(l);
        if (right_done) check_split(id, r, 0);
        if (left_done) check_split(id, l, 1);
        if (right_done && left_done) {
          out.symbols.push_back(kSymbolE);
          stack.pop_back();
          break;
        }
        if (right_done) {
          out.symbols.push_back(kSymbolR);
          c = l;
        } else if (left_done) {
          out.symbols.push_back(kSymbolL);
          c = r;
        } else {
          out.symbols.push_back(kSymbolS);
          split_symbol[f.value] = id;
          stack.back() = l;
          stack.push_back(r);
          break;
        }
      }
    }
  };

  // Components with holes start on a dummy face (its corner on the dummy vertex, so the traversal
  // begins on the hole's rim); the others on their first face.
  for (uint32_t f = m.input_triangles; f < faces; ++f) {
    if (!face_done[f]) component(FaceIndex(f), CornerIndex(3 * f + 2));
  }
  for (uint32_t f = 0; f < m.input_triangles; ++f) {
    if (!face_done[f]) component(FaceIndex(f), CornerIndex(3 * f));
  }
  return out;
}

Status internal(const std::string& what) {
  return error(ErrorCode::kInvalidArgument, "connectivity encoder", "internal error: " + what);
}

}  // namespace

Result<ConnectivityEncoding> encode_connectivity(const std::vector<uint32_t>& indices,
                                                 uint32_t vertex_count, bool search) {
  if (indices.size() % 3 != 0 || indices.size() / 3 > kMaxConnectivityTriangles) {
    return error(ErrorCode::kInvalidArgument, "connectivity encoder",
                 "the index count is not a multiple of 3 or exceeds 2^28 triangles");
  }
  {
    std::vector<uint8_t> used(vertex_count, 0);
    for (size_t i = 0; i < indices.size(); i += 3) {
      const uint32_t a = indices[i], b = indices[i + 1], c = indices[i + 2];
      if (a >= vertex_count || b >= vertex_count || c >= vertex_count) {
        return error(ErrorCode::kInvalidArgument, "connectivity encoder",
                     "index out of range in triangle " + std::to_string(i / 3));
      }
      if (a == b || b == c || a == c) {
        return error(ErrorCode::kInvalidArgument, "connectivity encoder",
                     "triangle " + std::to_string(i / 3) + " repeats a vertex");
      }
      used[a] = used[b] = used[c] = 1;
    }
    if (std::find(used.begin(), used.end(), 0) != used.end()) {
      return error(ErrorCode::kInvalidArgument, "connectivity encoder",
                   "a vertex is referenced by no triangle");
    }
  }
  const uint32_t triangle_count = static_cast<uint32_t>(indices.size() / 3);

  const ClosedManifold m = close_to_manifold(indices, vertex_count);
  const CornerTable& table = m.table;
  const Traversal tr = traverse(m);
  const uint32_t n = static_cast<uint32_t>(tr.symbols.size());
  const uint32_t components = static_cast<uint32_t>(tr.starts.size());
  if (n + components != table.face_count()) return internal("the traversal missed faces");

  // Decoding order is the reverse of the traversal: decoded face k is traversal symbol n-1-k.
  uint32_t vertex_ids = 0;
  for (uint8_t s : tr.symbols) {
    vertex_ids += s == kSymbolE ? 3 : (s == kSymbolR || s == kSymbolL) ? 1 : 0;
  }
  std::vector<SplitEvent> events;
  events.reserve(tr.events.size());
  for (const SplitEvent& e : tr.events) {
    events.push_back({n - 1 - e.split, n - 1 - e.source, e.edge});
  }
  std::sort(events.begin(), events.end(),
            [](const SplitEvent& a, const SplitEvent& b) { return a.split < b.split; });
  for (size_t i = 1; i < events.size(); ++i) {
    if (events[i].split == events[i - 1].split) return internal("two split events on one S");
  }

  // Run the decoder's core on the symbols, recording what the contexts need.
  SpiraleReversi core;
  core.begin(n, components, vertex_ids, events);
  std::vector<uint8_t> decoded_symbols(n), valences(n);
  uint32_t valence = 0;
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t symbol = tr.symbols[n - 1 - k];
    decoded_symbols[k] = static_cast<uint8_t>(symbol);
    valences[k] = static_cast<uint8_t>(std::min<uint32_t>(valence, 255));
    valence = core.next_valence(symbol);
    if (!core.step(symbol)) return internal(std::string("decoder rejects symbol: ") + core.what());
  }
  if (!core.close_components()) return internal(std::string("decoder: ") + core.what());
  if (core.vertex_ids() != vertex_ids) return internal("vertex id count");

  // The decoder id of each encoder vertex, read off the rebuilt table: decoded face k's corners are
  // the traversal's tip, next(tip) and prev(tip), start faces after the symbols, first-encoded
  // component first. Every id must stand for one encoder vertex, so that each decoded face has its
  // encoded face's vertices.
  std::vector<uint32_t> encoded_of_id(vertex_ids, kNone);  // decoder id -> encoder vertex
  const VertexIndex* decoded_vertex = core.corner_vertex();
  for (uint32_t f = 0; f < core.faces(); ++f) {
    const CornerIndex base = f < n ? tr.tips[n - 1 - f] : tr.starts[f - n];
    const CornerIndex corner[3] = {base, next(base), prev(base)};
    for (uint32_t j = 0; j < 3; ++j) {
      const uint32_t id = decoded_vertex[3 * f + j].value;
      const uint32_t ev = table.v(corner[j]).value;
      if (encoded_of_id[id] != ev && encoded_of_id[id] != kNone) {
        return internal("the rebuilt vertices differ from the encoded ones");
      }
      encoded_of_id[id] = ev;
    }
  }
  std::vector<uint32_t> id_of_encoded(table.vertex_count, kNone);  // encoder vertex -> decoder id
  for (uint32_t id = 0; id < vertex_ids; ++id) {
    if (encoded_of_id[id] == kNone) continue;
    if (id_of_encoded[encoded_of_id[id]] != kNone) return internal("two ids for one vertex");
    id_of_encoded[encoded_of_id[id]] = id;
  }

  // Dummy vertices and glue pairs, in decoder ids.
  std::vector<uint32_t> dummies;
  for (uint32_t v = m.first_dummy; v < table.vertex_count; ++v) dummies.push_back(id_of_encoded[v]);
  std::sort(dummies.begin(), dummies.end());
  std::vector<std::pair<uint32_t, uint32_t>> glue;
  for (size_t k = 0; k < m.copy_of.size(); ++k) {
    glue.push_back({id_of_encoded[m.input_vertices + k], id_of_encoded[m.copy_of[k].value]});
  }
  std::sort(glue.begin(), glue.end());

  ConnectivityEncoding out;
  std::vector<VertexIndex> final_of_id;
  const char* what = "";
  DecodedConnectivity decoded;
  if (!uncut(core, dummies, glue, triangle_count, vertex_count, &decoded, &final_of_id, &what)) {
    return internal(std::string("uncut: ") + what);
  }
  out.decoded_indices = std::move(decoded.indices);
  out.decoded_newest = std::move(decoded.newest);
  out.vertex_order.assign(vertex_count, kNone);
  for (uint32_t id = 0; id < vertex_ids; ++id) {
    if (!final_of_id[id].valid()) continue;
    uint32_t ev = encoded_of_id[id];
    if (ev >= m.input_vertices) ev = m.copy_of[ev - m.input_vertices].value;
    uint32_t& slot = out.vertex_order[final_of_id[id].value];
    if (slot != kNone && slot != ev) return internal("two input vertices decode as one");
    slot = ev;
  }

  // Each context model the encoder tries is sized from its symbols' counts alone, by the tables
  // the entropy coder would plan for them (plan_symbols); only the smallest is coded, with that
  // plan. The symbols are counted once, by every feature at once (the joint model: all three
  // previous symbols, va and 8 len buckets); each model's counts are sums of joint contexts, and
  // its contexts occur first where their first joint context does.
  constexpr ContextModel kJoint = {3, 1, 8};
  SymbolContext joint(kJoint);
  assert(joint.contexts() == 5 * 5 * 5 * 8 * 8);
  // The joint contexts that occur get slots by first symbol (8,000 of them would be 160 KB of
  // counts to clear for a mesh that uses a few hundred).
  constexpr uint16_t kNoSlot = 0xffff;
  std::vector<uint16_t> slot_of(joint.contexts(), kNoSlot);
  std::vector<uint32_t> joint_order;  // per slot: its joint context
  std::vector<uint32_t> slot_counts;  // per slot: kSymbolCount counts
  std::vector<uint16_t> slot_of_symbol(n);
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t j = joint.get(valences[k]);
    if (slot_of[j] == kNoSlot) {
      slot_of[j] = static_cast<uint16_t>(joint_order.size());
      joint_order.push_back(j);
      slot_counts.resize(slot_counts.size() + kSymbolCount, 0);
    }
    slot_of_symbol[k] = slot_of[j];
    ++slot_counts[size_t{slot_of[j]} * kSymbolCount + decoded_symbols[k]];
    joint.update(decoded_symbols[k]);
  }
  // A joint context's features: j = (((p1 * 5 + p2) * 5 + p3) * 8 + va) * 8 + len8.
  auto model_context = [](const SymbolContext& model, uint32_t j) {
    return model.compose(j / 1600, j / 320 % 5, j / 64 % 5, j / 8 % 8, j % 8);
  };
  uint32_t best_model = 0;
  SymbolPlan best_plan;
  // Without the search, one model: the one the search keeps most often.
  const uint32_t first_model = search ? 0 : kFastContextModel;
  const uint32_t models = !search                   ? kFastContextModel + 1
                          : n >= kLargeModelSymbols ? kContextModelCount
                                                    : kEncoderContextModels;
  out.models_planned = models - first_model;
  std::vector<uint32_t> counts;
  std::vector<uint32_t> order;  // the model's contexts that occur, by first symbol
  std::vector<uint8_t> seen;
  for (uint32_t model = first_model; model < models; ++model) {
    const SymbolContext context(kContextModels[model]);
    counts.assign(size_t{context.contexts()} * kSymbolCount, 0);
    seen.assign(context.contexts(), 0);
    order.clear();
    for (size_t slot = 0; slot < joint_order.size(); ++slot) {
      const uint32_t c = model_context(context, joint_order[slot]);
      if (!seen[c]) {
        seen[c] = 1;
        order.push_back(c);
      }
      for (uint32_t s = 0; s < kSymbolCount; ++s) {
        counts[size_t{c} * kSymbolCount + s] += slot_counts[slot * kSymbolCount + s];
      }
    }
    SymbolPlan plan = plan_symbols(counts, order, context.contexts(), kSymbolCount);
    if (model == first_model || plan.bits < best_plan.bits) {
      best_plan = std::move(plan);
      best_model = model;
    }
  }
  // The section (docs/FORMAT.md, "Connectivity section"): the head byte says which of the counts
  // that are usually 0 (events, dummies, glue) or 1 (components) follow.
  ByteWriter writer(&out.prefix);
  const uint8_t head = static_cast<uint8_t>(
      best_model | (events.empty() ? 0 : kHeadEvents) | (dummies.empty() ? 0 : kHeadDummies) |
      (glue.empty() ? 0 : kHeadGlue) | (components == 1 ? 0 : kHeadComponents));
  writer.write_le<uint8_t>(head);
  writer.write_varint(n);
  if (components != 1) writer.write_varint(components);
  writer.write_varint(vertex_ids - vertex_count);
  if (!events.empty()) writer.write_varint(events.size());
  for (size_t i = 0; i < events.size(); ++i) {
    writer.write_varint(i == 0 ? events[i].split : events[i].split - events[i - 1].split - 1);
    writer.write_varint((static_cast<uint64_t>(events[i].split - 1 - events[i].source) << 1) |
                        events[i].edge);
  }
  auto put_ids = [&](const std::vector<uint32_t>& ids) {
    if (!ids.empty()) writer.write_varint(ids.size());
    for (size_t i = 0; i < ids.size(); ++i) {
      writer.write_varint(i == 0 ? ids[i] : ids[i] - ids[i - 1] - 1);
    }
  };
  put_ids(dummies);
  std::vector<uint32_t> copies;
  for (const auto& g : glue) copies.push_back(g.first);
  put_ids(copies);
  for (const auto& g : glue) writer.write_varint(g.second);

  const SymbolContext context(kContextModels[best_model]);
  std::vector<uint32_t> context_of_slot(joint_order.size());
  for (size_t slot = 0; slot < joint_order.size(); ++slot) {
    context_of_slot[slot] = model_context(context, joint_order[slot]);
  }
  SymbolEncoder coder(kSymbolCount, context.contexts());
  coder.reserve(n);
  for (uint32_t k = 0; k < n; ++k) {
    coder.put(context_of_slot[slot_of_symbol[k]], decoded_symbols[k]);
  }
  coder.use_plan(std::move(best_plan));
  out.symbols.emplace(std::move(coder));
  return out;
}

}  // namespace osteon::detail
