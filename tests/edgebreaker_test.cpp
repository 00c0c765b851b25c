// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "codec/codec_internal.hpp"
#include "codec/connectivity.hpp"
#include "core/byte_io.hpp"
#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "support/phantom.hpp"

// Edgebreaker connectivity coding: exact round trips on every mesh category, on generated
// torture meshes (Möbius strip, high genus, duplicate faces, random soups) and on every real mesh
// in ../shared/data; hostile streams (every truncation, random bit flips) fail cleanly.

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define OSTEON_TEST_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define OSTEON_TEST_ASAN 1
#endif

namespace osteon::detail {
namespace {
namespace edgebreaker_test {

using Triangles = std::vector<std::array<uint32_t, 3>>;

// Triangles as a sorted multiset, each rotated to start at its smallest id (orientation kept).
Triangles canonical(const std::vector<uint32_t>& indices, const std::vector<uint32_t>* map) {
  Triangles out;
  for (size_t i = 0; i + 2 < indices.size(); i += 3) {
    std::array<uint32_t, 3> t{indices[i], indices[i + 1], indices[i + 2]};
    if (map) {
      for (uint32_t& v : t) v = (*map)[v];
    }
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    out.push_back(t);
  }
  // Lexicographic, spelled out: std::array's synthesized <=> stays an out-of-line call under the
  // sanitizers, and this sort is most of the every-shared-file test's time there.
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a[0] != b[0] ? a[0] < b[0] : a[1] != b[1] ? a[1] < b[1] : a[2] < b[2];
  });
  return out;
}

// The newest triangles are what connectivity.hpp promises, rebuilt the slow way: every triangle
// under its largest vertex m, with the next two vertices and the vertex across their edge where
// that edge is manifold (one triangle each way) and the vertex is < m; the neighbour of each
// vertex from the last triangle in which it is the middle vertex.
::testing::AssertionResult newest_is_right(const std::vector<uint32_t>& indices,
                                           const NewestTriangles& newest, uint32_t vertex_count) {
  std::map<std::pair<uint32_t, uint32_t>, std::pair<uint32_t, uint32_t>> half_edges;
  for (size_t t = 0; t < indices.size(); t += 3) {
    for (size_t k = 0; k < 3; ++k) {
      auto& h = half_edges[{indices[t + (k + 1) % 3], indices[t + (k + 2) % 3]}];
      ++h.first;
      h.second = indices[t + k];  // the vertex opposite the half-edge
    }
  }
  std::vector<std::vector<NewestTriangle>> runs(vertex_count);
  std::vector<uint32_t> neighbour(vertex_count, kNoVertexId);
  for (size_t t = 0; t < indices.size(); t += 3) {
    const uint32_t* v = &indices[t];
    const size_t k = std::max_element(v, v + 3) - v;
    const uint32_t m = v[k], n = v[(k + 1) % 3], p = v[(k + 2) % 3];
    const auto twin = half_edges.find({p, n});
    const bool manifold =
        half_edges[{n, p}].first == 1 && twin != half_edges.end() && twin->second.first == 1;
    const uint32_t o = manifold && twin->second.second < m ? twin->second.second : kNoVertexId;
    runs[m].push_back({n, p, o});
    neighbour[std::max(n, p)] = std::min(n, p);  // the middle vertex gets the smallest
  }
  if (newest.first.size() != size_t{vertex_count} + 1 || newest.neighbour != neighbour) {
    return ::testing::AssertionFailure() << "offsets or neighbours differ";
  }
  for (uint32_t m = 0; m < vertex_count; ++m) {
    if (newest.first[m + 1] - newest.first[m] != runs[m].size()) {
      return ::testing::AssertionFailure() << "vertex " << m << ": run length differs";
    }
    for (size_t i = 0; i < runs[m].size(); ++i) {
      const NewestTriangle& got = newest.entries[newest.first[m] + i];
      const NewestTriangle& want = runs[m][i];
      if (got.n != want.n || got.p != want.p || got.o != want.o) {
        return ::testing::AssertionFailure()
               << "vertex " << m << " entry " << i << ": (" << got.n << ", " << got.p << ", "
               << got.o << "), want (" << want.n << ", " << want.p << ", " << want.o << ")";
      }
    }
  }
  return ::testing::AssertionSuccess();
}

struct RoundTrip {
  bool ok = false;
  size_t bytes = 0;
  double decode_seconds = 0;
};

// The whole connectivity section of `enc`, as a stream without later sections holds it.
std::vector<uint8_t> section(const ConnectivityEncoding& enc) {
  std::vector<uint8_t> out = enc.prefix;
  enc.symbols->append_to(&out);
  return out;
}

// Encodes, decodes and checks the decoded triangles against the input exactly.
RoundTrip round_trip(const std::vector<uint32_t>& indices, uint32_t vertex_count,
                     const std::string& name) {
  SCOPED_TRACE(name);
  RoundTrip result;
  Result<ConnectivityEncoding> enc = encode_connectivity(indices, vertex_count);
  if (!enc.ok()) {
    ADD_FAILURE() << enc.status().message();
    return result;
  }
  const uint32_t triangles = static_cast<uint32_t>(indices.size() / 3);
  const std::vector<uint8_t> bytes = section(*enc);
  ByteReader reader(bytes.data(), bytes.size());
  auto start = std::chrono::steady_clock::now();
  Result<DecodedConnectivity> decoded =
      decode_connectivity(reader, vertex_count, triangles, kStreamVersion, name);
  result.decode_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!decoded.ok()) {
    ADD_FAILURE() << decoded.status().message();
    return result;
  }
  const std::vector<uint32_t>* dec = &decoded->indices;
  EXPECT_EQ(reader.remaining(), 0u);
  EXPECT_EQ(*dec, enc->decoded_indices);
  EXPECT_EQ(decoded->newest.first, enc->decoded_newest.first);
  EXPECT_EQ(decoded->newest.neighbour, enc->decoded_newest.neighbour);
  EXPECT_TRUE(newest_is_right(*dec, decoded->newest, vertex_count));
  EXPECT_EQ(enc->vertex_order.size(), vertex_count);
  std::vector<uint8_t> seen(vertex_count, 0);
  for (uint32_t v : enc->vertex_order) {
    if (v >= vertex_count || seen[v]) {
      ADD_FAILURE() << "vertex_order is not a permutation";
      return result;
    }
    seen[v] = 1;
  }
  const bool same = canonical(indices, nullptr) == canonical(*dec, &enc->vertex_order);
  EXPECT_TRUE(same) << "decoded triangles differ from the input";
  result.ok = same && *dec == enc->decoded_indices;
  result.bytes = bytes.size();
  return result;
}

// What the codec's caller does first: degenerate triangles and unreferenced vertices removed.
Mesh cleaned(Mesh mesh) {
  remove_degenerate_triangles(mesh);
  remove_unreferenced_vertices(mesh);
  return mesh;
}

RoundTrip round_trip(const Mesh& mesh, const std::string& name) {
  return round_trip(mesh.indices, static_cast<uint32_t>(mesh.vertex_count()), name);
}

// ---- generated meshes --------------------------------------------------------------------------

// A strip of `n` quads whose ends are glued with a half twist (non-orientable).
std::vector<uint32_t> mobius_strip(uint32_t n) {
  std::vector<uint32_t> idx;
  for (uint32_t i = 0; i < n; ++i) {
    uint32_t a = 2 * i, b = 2 * i + 1, c = 2 * (i + 1), d = 2 * (i + 1) + 1;
    if (i + 1 == n) {  // the twist: the last rung joins the first one reversed
      c = 1;
      d = 0;
    }
    idx.insert(idx.end(), {a, c, b, b, c, d});
  }
  return idx;
}

// The boundary of a set of unit voxels (a quad per face between a voxel and empty space, split
// into two triangles, outward-facing), vertices welded by grid position. Voxels that touch along
// an edge or a vertex only give non-manifold edges and vertices.
std::vector<uint32_t> voxel_surface(const std::vector<uint8_t>& solid, int nx, int ny, int nz,
                                    uint32_t* vertex_count) {
  auto at = [&](int x, int y, int z) {
    return x >= 0 && y >= 0 && z >= 0 && x < nx && y < ny && z < nz &&
           solid[(static_cast<size_t>(z) * ny + y) * nx + x];
  };
  std::map<std::array<int, 3>, uint32_t> ids;
  auto vid = [&](int x, int y, int z) {
    auto [it, inserted] = ids.try_emplace({x, y, z}, static_cast<uint32_t>(ids.size()));
    return it->second;
  };
  std::vector<uint32_t> idx;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) {
        if (!at(x, y, z)) continue;
        for (int axis = 0; axis < 3; ++axis)
          for (int side = 0; side < 2; ++side) {
            int d[3] = {0, 0, 0};
            d[axis] = side ? 1 : -1;
            if (at(x + d[0], y + d[1], z + d[2])) continue;
            // The face's four corners, counter-clockwise seen from outside.
            int u = (axis + 1) % 3, w = (axis + 2) % 3;
            std::array<int, 3> p[4];
            for (int k = 0; k < 4; ++k) {
              int o[3] = {x, y, z};
              o[axis] += side;
              int du = (k == 1 || k == 2) ? 1 : 0, dw = (k >= 2) ? 1 : 0;
              o[u] += du;
              o[w] += dw;
              p[k] = {o[0], o[1], o[2]};
            }
            uint32_t q[4];
            for (int k = 0; k < 4; ++k) q[k] = vid(p[k][0], p[k][1], p[k][2]);
            if (side) {
              idx.insert(idx.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
            } else {
              idx.insert(idx.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
            }
          }
      }
  *vertex_count = static_cast<uint32_t>(ids.size());
  return idx;
}

// A plate of (2k+1) x (2k+1) voxels with k x k square holes: a closed surface of genus k^2.
std::vector<uint32_t> holey_plate(int k, uint32_t* vertex_count) {
  const int n = 2 * k + 1;
  std::vector<uint8_t> solid(static_cast<size_t>(n) * n, 1);
  for (int y = 1; y < n; y += 2)
    for (int x = 1; x < n; x += 2) solid[static_cast<size_t>(y) * n + x] = 0;
  return voxel_surface(solid, n, n, 1, vertex_count);
}

// Random distinct-index triangles over few vertices (non-manifold nearly everywhere), with the
// unreferenced vertices compacted away.
std::vector<uint32_t> random_soup(std::mt19937& rng, uint32_t vertices, uint32_t triangles,
                                  uint32_t* vertex_count) {
  std::vector<uint32_t> idx;
  while (idx.size() < 3 * static_cast<size_t>(triangles)) {
    uint32_t a = rng() % vertices, b = rng() % vertices, c = rng() % vertices;
    if (a != b && b != c && a != c) idx.insert(idx.end(), {a, b, c});
  }
  std::vector<uint32_t> remap(vertices, UINT32_MAX);
  uint32_t next_id = 0;
  for (uint32_t& v : idx) {
    if (remap[v] == UINT32_MAX) remap[v] = next_id++;
    v = remap[v];
  }
  *vertex_count = next_id;
  return idx;
}

// ---- round trips -------------------------------------------------------------------------------

TEST(Edgebreaker, EmptyMesh) {
  Result<ConnectivityEncoding> enc = encode_connectivity({}, 0);
  ASSERT_TRUE(enc.ok()) << enc.status().message();
  const std::vector<uint8_t> bytes = section(*enc);
  ByteReader reader(bytes.data(), bytes.size());
  Result<DecodedConnectivity> dec = decode_connectivity(reader, 0, 0, kStreamVersion, "empty");
  ASSERT_TRUE(dec.ok()) << dec.status().message();
  EXPECT_TRUE(dec->indices.empty());
  EXPECT_TRUE(dec->newest.entries.empty());
}

TEST(Edgebreaker, DeterministicAndSelfConsistent) {
  Mesh mesh = make_torus(2.0f, 0.5f, 24, 12);
  Result<ConnectivityEncoding> a = encode_connectivity(mesh.indices, 288);
  Result<ConnectivityEncoding> b = encode_connectivity(mesh.indices, 288);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(section(*a), section(*b));
  EXPECT_EQ(a->decoded_indices, b->decoded_indices);
  EXPECT_EQ(a->vertex_order, b->vertex_order);
  // Decoded vertices are numbered by first use in the decoded triangles.
  uint32_t next_new = 0;
  for (uint32_t v : a->decoded_indices) {
    ASSERT_LE(v, next_new);
    if (v == next_new) ++next_new;
  }
}

TEST(Edgebreaker, RejectsBadInput) {
  EXPECT_FALSE(encode_connectivity({0, 1}, 2).ok());
  EXPECT_FALSE(encode_connectivity({0, 1, 3}, 3).ok());
  EXPECT_FALSE(encode_connectivity({0, 1, 1}, 2).ok());
  EXPECT_FALSE(encode_connectivity({0, 1, 2}, 4).ok());  // vertex 3 unreferenced
}

TEST(Edgebreaker, EveryMeshCategory) {
  for (const test::NamedMesh& named : test::mesh_categories()) {
    Mesh mesh = cleaned(named.mesh);
    EXPECT_TRUE(round_trip(mesh, named.category).ok) << named.category;
  }
}

TEST(Edgebreaker, PhantomParts) {
  PhantomOptions options;
  options.detail = 2;
  Phantom phantom = make_phantom(options);
  for (const Mesh& part : phantom.scene.parts) {
    EXPECT_TRUE(round_trip(cleaned(part), part.name).ok) << part.name;
  }
}

TEST(Edgebreaker, SmallCases) {
  EXPECT_TRUE(round_trip({0, 1, 2}, 3, "one triangle").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 2, 1, 3}, 4, "two triangles").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 0, 1, 3}, 4, "two triangles, inconsistent").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 0, 2, 1}, 3, "a double-sided triangle").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 0, 1, 2}, 3, "a duplicate triangle").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 3, 4, 5}, 6, "two separate triangles").ok);
  EXPECT_TRUE(round_trip({0, 1, 2, 0, 3, 4}, 5, "two triangles on one vertex").ok);
  std::vector<uint32_t> loop2 = {0, 1, 2, 0, 2, 3, 1, 0, 3, 1, 3, 2, 0, 1, 4};
  EXPECT_TRUE(round_trip(loop2, 5, "a boundary loop of two edges").ok);
}

TEST(Edgebreaker, MobiusStrip) {
  for (uint32_t n : {3u, 4u, 5u, 12u}) {
    std::vector<uint32_t> idx = mobius_strip(n);
    EXPECT_TRUE(round_trip(idx, 2 * n, "mobius " + std::to_string(n)).ok);
  }
}

TEST(Edgebreaker, DuplicateFace) {
  Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  for (int k = 0; k < 3; ++k) {
    box.indices.insert(box.indices.end(), box.indices.begin() + 3 * k,
                       box.indices.begin() + 3 * k + 3);
  }
  EXPECT_TRUE(round_trip(box, "box with duplicate faces").ok);
}

TEST(Edgebreaker, HighGenus) {
  for (int k : {1, 2, 4, 7}) {
    uint32_t v = 0;
    std::vector<uint32_t> idx = holey_plate(k, &v);
    EXPECT_TRUE(round_trip(idx, v, "plate genus " + std::to_string(k * k)).ok);
  }
  // Several tori side by side, and a torus with the icosphere: components of different genus.
  Mesh a = make_torus(2.0f, 0.5f, 24, 12);
  Mesh b = make_torus(2.0f, 0.5f, 9, 5);
  std::vector<uint32_t> idx = a.indices;
  for (uint32_t i : b.indices) idx.push_back(i + static_cast<uint32_t>(a.vertex_count()));
  EXPECT_TRUE(
      round_trip(idx, static_cast<uint32_t>(a.vertex_count() + b.vertex_count()), "tori").ok);
}

TEST(Edgebreaker, RandomVoxelSets) {
  // Random voxel sets: handles, cavities, components, non-manifold edges and vertices.
  std::mt19937 rng(11);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 3 + trial % 5;
    std::vector<uint8_t> solid(static_cast<size_t>(n) * n * n);
    for (uint8_t& s : solid) s = (rng() % 100) < 45;
    uint32_t v = 0;
    std::vector<uint32_t> idx = voxel_surface(solid, n, n, n, &v);
    if (idx.empty()) continue;
    EXPECT_TRUE(round_trip(idx, v, "voxels " + std::to_string(trial)).ok);
  }
}

TEST(Edgebreaker, RandomSoups) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    uint32_t v = 0;
    std::vector<uint32_t> idx = random_soup(rng, 3 + rng() % 30, 1 + rng() % 80, &v);
    EXPECT_TRUE(round_trip(idx, v, "soup " + std::to_string(trial)).ok);
  }
}

// ---- hostile streams
// -----------------------------------------------------------------------------

// A decoded result is either an error or a valid mesh of the declared size: every index in range,
// every vertex referenced, no triangle repeating a vertex.
void expect_valid_or_error(const std::vector<uint8_t>& bytes, uint32_t vertex_count,
                           uint32_t triangle_count) {
  ByteReader reader(bytes.data(), bytes.size());
  Result<DecodedConnectivity> decoded =
      decode_connectivity(reader, vertex_count, triangle_count, kStreamVersion, "flip");
  if (!decoded.ok()) {
    EXPECT_NE(decoded.status().message().find("flip"), std::string::npos)
        << decoded.status().message();
    return;
  }
  const std::vector<uint32_t>* dec = &decoded->indices;
  ASSERT_EQ(dec->size(), 3 * static_cast<size_t>(triangle_count));
  // What the geometry decoder relies on: every vertex named before the one it is filed under.
  const NewestTriangles& newest = decoded->newest;
  ASSERT_EQ(newest.entries.size(), triangle_count);
  ASSERT_EQ(newest.first.size(), size_t{vertex_count} + 1);
  ASSERT_EQ(newest.neighbour.size(), vertex_count);
  EXPECT_EQ(newest.first[0], 0u);
  for (uint32_t m = 0; m < vertex_count; ++m) {
    ASSERT_LE(newest.first[m], newest.first[m + 1]);
    for (uint32_t i = newest.first[m]; i < newest.first[m + 1]; ++i) {
      const NewestTriangle& e = newest.entries[i];
      EXPECT_TRUE(e.n < m && e.p < m && (e.o == kNoVertexId || e.o < m));
    }
    EXPECT_TRUE(newest.neighbour[m] == kNoVertexId || newest.neighbour[m] < m);
  }
  EXPECT_EQ(newest.first[vertex_count], triangle_count);
  std::vector<uint8_t> used(vertex_count, 0);
  for (size_t i = 0; i < dec->size(); i += 3) {
    const uint32_t a = (*dec)[i], b = (*dec)[i + 1], c = (*dec)[i + 2];
    ASSERT_LT(a, vertex_count);
    ASSERT_LT(b, vertex_count);
    ASSERT_LT(c, vertex_count);
    EXPECT_TRUE(a != b && b != c && a != c);
    used[a] = used[b] = used[c] = 1;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
}

// A small mesh with everything: a hole, a handle, a non-manifold vertex, two components.
std::vector<uint32_t> small_mixed_mesh(uint32_t* vertex_count) {
  Mesh torus = make_torus(2.0f, 0.5f, 8, 5);
  Mesh tube = make_open_cylinder(1.0f, 1.0f, 6, 2);
  Mesh bowtie = make_bowtie_tetrahedra();
  std::vector<uint32_t> idx;
  uint32_t base = 0;
  for (const Mesh* m : {&torus, &tube, &bowtie}) {
    for (uint32_t i : m->indices) idx.push_back(i + base);
    base += static_cast<uint32_t>(m->vertex_count());
  }
  *vertex_count = base;
  return idx;
}

TEST(Edgebreaker, EveryTruncationIsAnError) {
  uint32_t v = 0;
  std::vector<uint32_t> idx = small_mixed_mesh(&v);
  Result<ConnectivityEncoding> enc = encode_connectivity(idx, v);
  ASSERT_TRUE(enc.ok()) << enc.status().message();
  const uint32_t t = static_cast<uint32_t>(idx.size() / 3);
  const std::vector<uint8_t> bytes = section(*enc);
  for (size_t size = 0; size < bytes.size(); ++size) {
    std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + size);
    ByteReader reader(cut.data(), cut.size());
    Result<DecodedConnectivity> dec =
        decode_connectivity(reader, v, t, kStreamVersion, "cut.osteon");
    ASSERT_FALSE(dec.ok()) << "a stream cut to " << size << " bytes decoded";
    EXPECT_NE(dec.status().message().find("cut.osteon"), std::string::npos);
  }
}

TEST(Edgebreaker, RandomBitFlipsNeverCrash) {
  uint32_t v = 0;
  std::vector<uint32_t> idx = small_mixed_mesh(&v);
  Result<ConnectivityEncoding> enc = encode_connectivity(idx, v);
  ASSERT_TRUE(enc.ok()) << enc.status().message();
  const uint32_t t = static_cast<uint32_t>(idx.size() / 3);
  const std::vector<uint8_t> whole = section(*enc);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 1000; ++trial) {
    std::vector<uint8_t> bytes = whole;
    const int flips = 1 + trial % 3;
    for (int f = 0; f < flips; ++f)
      bytes[rng() % bytes.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
    expect_valid_or_error(bytes, v, t);
  }
}

TEST(Edgebreaker, RandomBytesNeverCrash) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<uint8_t> bytes(rng() % 64);
    for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng() % 4 == 0 ? rng() : rng() % 8);
    expect_valid_or_error(bytes, 1 + rng() % 12, 1 + rng() % 20);
  }
}

TEST(Edgebreaker, HugeDeclaredCountsAreRejected) {
  // 4,000,000 symbols declared for 1,000 triangles; then counts that pass the first bounds but not
  // the bytes that remain. Version 7's layout, then version 8's (a head byte saying that the
  // component count and the split events follow; the vertex ids beyond the 500 vertices).
  for (const uint8_t version : {uint8_t{7}, uint8_t{8}}) {
    SCOPED_TRACE(int(version));
    const std::vector<uint8_t> head =
        version == 7 ? std::vector<uint8_t>{} : std::vector<uint8_t>{0x48};
    std::vector<uint8_t> bytes = head;
    bytes.insert(bytes.end(), {0x80, 0x92, 0xf4, 0x01, 1, 3});
    ByteReader r1(bytes.data(), bytes.size());
    Result<DecodedConnectivity> dec = decode_connectivity(r1, 500, 1000, version, "huge");
    ASSERT_FALSE(dec.ok());
    EXPECT_NE(dec.status().message().find("symbols"), std::string::npos) << dec.status().message();
    // 3999 symbols, 1 component, 11000 ids (version 8: 10500 beyond the vertices)
    bytes = head;
    bytes.insert(bytes.end(), {0x9f, 0x1f, 1});
    if (version == 7) {
      bytes.insert(bytes.end(), {0xf8, 0x55});
    } else {
      bytes.insert(bytes.end(), {0x84, 0x52});
    }
    bytes.insert(bytes.end(), {0xff, 0xff, 0x03});
    ByteReader r2(bytes.data(), bytes.size());
    dec = decode_connectivity(r2, 500, 1000, version, "huge");
    ASSERT_FALSE(dec.ok());
    EXPECT_NE(dec.status().message().find("split events"), std::string::npos)
        << dec.status().message();
  }
  // Version 8: an unknown head byte (bit 7, or context model 6).
  for (const uint8_t head : {uint8_t{0x80}, uint8_t{6}}) {
    const std::vector<uint8_t> bytes = {head, 10, 0};
    ByteReader in(bytes.data(), bytes.size());
    Result<DecodedConnectivity> dec = decode_connectivity(in, 5, 10, 8, "head");
    ASSERT_FALSE(dec.ok());
    EXPECT_NE(dec.status().message().find("unknown head byte"), std::string::npos)
        << dec.status().message();
  }
}

// ---- real meshes -------------------------------------------------------------------------------

struct Measured {
  std::string name;
  size_t triangles = 0, vertices = 0, bytes = 0;
  double decode_seconds = 0;
  double bpv() const { return vertices ? 8.0 * bytes / vertices : 0; }
};

// Round-trips every part of every mesh file under `folder`; returns one row per part.
std::vector<Measured> round_trip_folder(const std::string& folder) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    if (format_from_extension(entry.path().string()) == Format::kUnknown) continue;
    files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  std::vector<Measured> rows;
  for (const std::string& file : files) {
    Result<Scene> scene = read_path(file);
    if (!scene.ok()) {
      ADD_FAILURE() << scene.status().message();
      continue;
    }
    for (const Mesh& part : scene->parts) {
      Mesh mesh = cleaned(part);
      const std::string name =
          file.substr(folder.size() + 1) + (scene->parts.size() > 1 ? "/" + part.name : "");
      RoundTrip r = round_trip(mesh, name);
      EXPECT_TRUE(r.ok) << name;
      rows.push_back({name, mesh.triangle_count(), mesh.vertex_count(), r.bytes, r.decode_seconds});
    }
  }
  return rows;
}

void print_summary(const std::string& title, std::vector<Measured> rows) {
  if (rows.empty()) return;
  size_t v = 0, b = 0, t = 0;
  double seconds = 0;
  for (const Measured& m : rows) {
    v += m.vertices;
    b += m.bytes;
    t += m.triangles;
    seconds += m.decode_seconds;
  }
  std::sort(rows.begin(), rows.end(),
            [](const Measured& a, const Measured& c) { return a.triangles < c.triangles; });
  const Measured& median = rows[rows.size() / 2];
  std::printf(
      "[ bpv      ] %s: %zu parts, %zu triangles, connectivity %.3f bits/vertex overall; "
      "median part %s (%zu triangles) %.3f bpv; cold decodes %.1f M triangles/s\n",
      title.c_str(), rows.size(), t, 8.0 * b / v, median.name.c_str(), median.triangles,
      median.bpv(), seconds > 0 ? t / seconds / 1e6 : 0.0);
}

TEST(EdgebreakerRealData, EverySharedFile) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  for (const char* folder :
       {"aHer-dev__3DAnatomy", "MyoHub__myo_sim", "ingvilddevold__muscle-growth",
        "stity__spl-abdominal-atlas", "cearto__zen__MeshsegBenchmark"}) {
    const std::string path = data + "/" + folder;
    if (!std::filesystem::is_directory(path)) continue;
    print_summary(folder, round_trip_folder(path));
  }
}

TEST(EdgebreakerRealData, CtLikeScaleMeshes) {
  OSTEON_REQUIRE_SHARED_DATA(data);
#if defined(OSTEON_TEST_ASAN)
  GTEST_SKIP() << "ct-like meshes (1-1.5M triangles) skipped under AddressSanitizer; the Release "
                  "run covers them";
#endif
  for (const char* name : {"hip_mcs.ply", "skull_mc.ply"}) {
    const std::string path = data + "/ct-like/" + name;
    if (!std::filesystem::exists(path)) {
      std::printf("[ skipped  ] %s is absent\n", path.c_str());
      continue;
    }
    Result<Scene> scene = read_path(path);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    ASSERT_EQ(scene->parts.size(), 1u);
    Mesh mesh = cleaned(scene->parts[0]);
    RoundTrip r = round_trip(mesh, name);
    EXPECT_TRUE(r.ok);
    const double bpv = 8.0 * r.bytes / mesh.vertex_count();
    std::printf(
        "[ bpv      ] ct-like/%s: %zu triangles, %zu vertices, %zu bytes, %.3f bits/vertex; "
        "one cold decode %.1f ms (%.1f M triangles/s)\n",
        name, mesh.triangle_count(), mesh.vertex_count(), r.bytes, bpv, r.decode_seconds * 1e3,
        mesh.triangle_count() / r.decode_seconds / 1e6);
    EXPECT_LT(bpv, 1.8) << "closed bone meshes must code below 1.8 bits per vertex";
  }
}

}  // namespace edgebreaker_test
}  // namespace
}  // namespace osteon::detail
