// SPDX-License-Identifier: Apache-2.0
#include "osteon/codec.hpp"

#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>

#include "core/byte_io.hpp"
#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace codec_test {

// The triangles of `mesh` as sorted, rotation-normalised position triples after the codec has
// cleaned it (degenerate triangles and unreferenced vertices removed), quantized on `grid`.
std::vector<std::array<float, 9>> expected_triangles(const Mesh& input,
                                                     const QuantizationGrid& grid) {
  Mesh mesh = input;
  remove_degenerate_triangles(mesh);
  remove_unreferenced_vertices(mesh);
  for (Vec3& p : mesh.positions) {
    auto snap = [&](float v, float o) {
      return static_cast<float>(o + std::llround((double(v) - o) / grid.step) * grid.step);
    };
    p = {snap(p.x, grid.origin.x), snap(p.y, grid.origin.y), snap(p.z, grid.origin.z)};
  }
  return test::canonical_triangles(mesh);
}

// Encodes, decodes and checks: same triangles with the same orientation (compared through their
// quantized positions, so vertex order does not matter), every coordinate within half a step.
void expect_round_trip(const Mesh& mesh, const EncodeOptions& options = {}) {
  EncodeReport report;
  Result<std::vector<uint8_t>> bytes = encode(mesh, options, &report);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  EXPECT_EQ(report.bytes, bytes->size());
  Result<Mesh> decoded = decode(bytes->data(), bytes->size());
  ASSERT_TRUE(decoded.ok()) << decoded.status().message();
  EXPECT_EQ(decoded->triangle_count(), report.triangles);
  EXPECT_EQ(decoded->vertex_count(), report.vertices);
  EXPECT_EQ(test::canonical_triangles(*decoded), expected_triangles(mesh, report.grid));
  // Half a step, plus the float output's own rounding (half an ulp of the largest coordinate).
  Aabb box = bounding_box(mesh);
  double largest = std::max({std::fabs(box.min.x), std::fabs(box.min.y), std::fabs(box.min.z),
                             std::fabs(box.max.x), std::fabs(box.max.y), std::fabs(box.max.z)});
  EXPECT_LE(report.max_error, report.grid_step * 0.5 + largest * 0x1p-24 * 1.01);
  EXPECT_EQ(decoded->normals.size(), decoded->vertex_count());
}

TEST(Codec, RoundTripsEveryMeshCategory) {
  for (const auto& [category, mesh] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    expect_round_trip(mesh);
  }
}

TEST(Codec, RoundTripsThePhantomSkeleton) {
  Phantom phantom = make_phantom({.seed = 3, .detail = 2});
  for (const Mesh& part : phantom.scene.parts) {
    SCOPED_TRACE(part.name);
    expect_round_trip(part);
  }
}

// A raw marching-cubes-like surface: a sphere, off the lattice's symmetry, whose vertices each
// keep two coordinates on the planes of an isotropic voxel lattice (`spacing` apart) and move
// along the third axis, the one the normal points along most, back onto the sphere.
Mesh make_lattice_sphere(int subdivisions, float radius, float spacing) {
  Mesh mesh = make_icosphere(subdivisions, radius);
  const float centre[3] = {0.37f * spacing, 0.71f * spacing, 0.13f * spacing};
  for (Vec3& p : mesh.positions) {
    float c[3] = {p.x, p.y, p.z};
    int free = 0;
    for (int k = 1; k < 3; ++k) free = std::fabs(c[k]) > std::fabs(c[free]) ? k : free;
    float rest = 0;
    for (int k = 0; k < 3; ++k) {
      if (k == free) continue;
      c[k] = std::round((c[k] + centre[k]) / spacing) * spacing;
      rest += (c[k] - centre[k]) * (c[k] - centre[k]);
    }
    c[free] =
        centre[free] + std::copysign(std::sqrt(std::max(0.0f, radius * radius - rest)), c[free]);
    p = {c[0], c[1], c[2]};
  }
  return mesh;
}

// A regular surface whose triangles scatter around equilateral, as on a smoothed isosurface: an
// icosphere whose vertices move by up to `amount` / 2 per axis (a fixed linear congruential
// sequence, the same on every platform), then back onto the sphere.
Mesh make_jittered_sphere(int subdivisions, float radius, float amount) {
  Mesh mesh = make_icosphere(subdivisions, radius);
  uint32_t state = 12345;
  auto jitter = [&] {
    state = state * 1664525u + 1013904223u;
    return amount * (float(state >> 8) / float(1u << 24) - 0.5f);
  };
  for (Vec3& p : mesh.positions) {
    const Vec3 q{p.x + jitter(), p.y + jitter(), p.z + jitter()};
    const float scale = radius / std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    p = {q.x * scale, q.y * scale, q.z * scale};
  }
  return mesh;
}

TEST(Codec, LatticeSurfacesCodeOnTheLattice) {
  const Mesh sphere = make_lattice_sphere(4, 50.0f, 2.3f);
  EncodeReport report;
  Result<std::vector<uint8_t>> on_lattice = encode(sphere, {}, &report);
  ASSERT_TRUE(on_lattice.ok()) << on_lattice.status().message();
  EXPECT_GE(report.grid.lattice, 2u);
  EXPECT_NEAR(report.grid_step * report.grid.lattice, 2.3, 1e-4);
  EXPECT_LE(report.grid_step, 100.0 / 16383);  // never coarser than --bits asked for
  expect_round_trip(sphere);
  // The same grid without the hint: plain residuals, much larger.
  EncodeOptions plain;
  plain.grid = report.grid;
  plain.grid.lattice = 0;
  Result<std::vector<uint8_t>> off_lattice = encode(sphere, plain);
  ASSERT_TRUE(off_lattice.ok());
  EXPECT_LT(on_lattice->size() * 10, off_lattice->size() * 8);
  // A wrong hint costs bytes, never exactness; a smooth sphere has no lattice.
  EncodeOptions wrong = plain;
  wrong.grid.lattice = 7;
  expect_round_trip(sphere, wrong);
  EncodeReport smooth;
  ASSERT_TRUE(encode(make_icosphere(4, 50.0f), {}, &smooth).ok());
  EXPECT_EQ(smooth.grid.lattice, 0u);
  EncodeOptions precise;
  precise.precision = 0.01;
  ASSERT_TRUE(encode(sphere, precise, &report).ok());
  EXPECT_GE(report.grid.lattice, 2u);
  EXPECT_LE(report.max_error, 0.01 + 1e-5);
  expect_round_trip(sphere, precise);
}

// The report says what the encoder's search cost: a small mesh has each of its four plain
// codings (two parallelogram modes, with and without the tangent plane) measured on every vertex;
// a large one measures them on a prefix and codes the rest once.
TEST(Codec, ReportsTheSearchsWork) {
  EncodeReport small;
  ASSERT_TRUE(encode(make_icosphere(2, 50.0f), {}, &small).ok());  // 162 vertices
  EXPECT_GE(small.geometry_passes, 4.0);
  EXPECT_LE(small.geometry_passes, 5.0);  // at most one more coding, for the curvature step
  EXPECT_EQ(small.connectivity_models, 4);
  EncodeReport large;
  ASSERT_TRUE(encode(make_icosphere(6, 50.0f), {}, &large).ok());  // 40,962 vertices
  EXPECT_GE(large.geometry_passes, 1.0);
  EXPECT_LT(large.geometry_passes, 2.0);
  EXPECT_EQ(large.connectivity_models, 4);  // the two large models wait for 200,000 symbols
}

// Effort 0 codes without the search: one pass of geometry prediction, one connectivity model,
// exact all the same, and a little larger than the default.
TEST(Codec, EffortZeroCodesWithoutTheSearch) {
  EncodeOptions fast;
  fast.effort = 0;
  for (const auto& [category, mesh] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    expect_round_trip(mesh, fast);
  }
  Phantom phantom = make_phantom({.seed = 3, .detail = 2});
  size_t searched = 0, unsearched = 0;
  for (const Mesh& part : phantom.scene.parts) {
    SCOPED_TRACE(part.name);
    expect_round_trip(part, fast);
    EncodeReport report, fast_report;
    ASSERT_TRUE(encode(part, {}, &report).ok());
    ASSERT_TRUE(encode(part, fast, &fast_report).ok());
    EXPECT_EQ(fast_report.geometry_passes, 1.0);
    EXPECT_EQ(fast_report.connectivity_models, 1);
    EXPECT_EQ(fast_report.shape_scale, 16);  // the plain parallelogram
    EXPECT_EQ(fast_report.shape_apex, 0);
    EXPECT_EQ(fast_report.curvature, 0);
    searched += report.bytes;
    unsearched += fast_report.bytes;
  }
  EXPECT_GE(unsearched, searched) << "the search keeps the smallest of what it measures";
  EXPECT_LT(double(unsearched), 1.15 * double(searched));
  // On a voxel lattice (raw marching cubes, skull_mc.ply's kind) effort 0 codes on it too: much
  // smaller than plain residuals on the same grid.
  const Mesh sphere = make_lattice_sphere(4, 50.0f, 2.3f);
  expect_round_trip(sphere, fast);
  EncodeReport lattice;
  Result<std::vector<uint8_t>> on_lattice = encode(sphere, fast, &lattice);
  ASSERT_TRUE(on_lattice.ok());
  EXPECT_GE(lattice.grid.lattice, 2u);
  EncodeOptions plain = fast;
  plain.grid = lattice.grid;
  plain.grid.lattice = 0;
  Result<std::vector<uint8_t>> off_lattice = encode(sphere, plain);
  ASSERT_TRUE(off_lattice.ok());
  EXPECT_LT(on_lattice->size() * 10, off_lattice->size() * 8);
  for (int effort : {-1, 2}) {
    EncodeOptions bad;
    bad.effort = effort;
    Result<std::vector<uint8_t>> refused = encode(sphere, bad);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.status().code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(
        refused.status().message().find("effort must be 0 or 1, not " + std::to_string(effort)),
        std::string::npos)
        << refused.status().message();
  }
}

TEST(Codec, BitsAndPrecisionSetTheGridStep) {
  Mesh sphere = make_icosphere(3, 50.0f);
  for (int bits : {8, 12, 16, 20, 24}) {
    EncodeOptions options;
    options.bits = bits;
    EncodeReport report;
    ASSERT_TRUE(encode(sphere, options, &report).ok());
    // The step, rounded down to a float (which the header stores in 4 bytes).
    const double step = 100.0 / double((1u << bits) - 1);
    EXPECT_NEAR(report.grid_step, step, 1e-3 * report.grid_step);
    EXPECT_LE(report.grid_step, step);
    EXPECT_EQ(report.grid_step, double(float(report.grid_step)));
    EXPECT_LE(report.max_error, report.grid_step / 2 + 1e-5);
    expect_round_trip(sphere, options);
  }
  EncodeOptions precise;
  precise.precision = 0.05;
  EncodeReport report;
  ASSERT_TRUE(encode(sphere, precise, &report).ok());
  // 0.1 rounded down to a float: every coordinate still within 0.05.
  EXPECT_EQ(report.grid_step, double(std::nextafter(0.1f, 0.0f)));
  EXPECT_LE(report.max_error, 0.05 + 1e-5);
  Result<std::vector<uint8_t>> bytes = encode(sphere, precise);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ((*bytes)[5], 2) << "flags: the step stored as a float";
  Result<QuantizationGrid> grid = stream_grid(bytes->data(), bytes->size());
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->step, report.grid_step);
}

TEST(Codec, SharedGridMakesPartsMeetWithoutCracks) {
  // Two boxes sharing a face: on one grid, the shared corners decode to identical positions.
  Mesh a = make_box({0, 0, 0}, {1.01f, 1, 1});
  Mesh b = make_box({1.01f, 0, 0}, {3.3f, 1, 1});
  EncodeOptions options;
  options.grid.origin = {-1, -1, -1};
  options.grid.step = 0.007;
  auto ra = encode(a, options), rb = encode(b, options);
  ASSERT_TRUE(ra.ok() && rb.ok());
  auto da = decode(ra->data(), ra->size()), db = decode(rb->data(), rb->size());
  ASSERT_TRUE(da.ok() && db.ok());
  size_t shared = 0;
  for (const Vec3& p : da->positions)
    for (const Vec3& q : db->positions) shared += p == q;
  EXPECT_EQ(shared, 4u);
}

TEST(Codec, RejectsBadOptionsAndBadMeshes) {
  Mesh sphere = make_icosphere(1);
  EncodeOptions options;
  options.bits = 7;
  EXPECT_EQ(encode(sphere, options).status().code(), ErrorCode::kInvalidArgument);
  options.bits = 25;
  EXPECT_NE(encode(sphere, options).status().message().find("between 8 and 24"), std::string::npos);
  options = {};
  options.precision = 1e-12;
  EXPECT_NE(encode(sphere, options).status().message().find("too fine"), std::string::npos);
  Mesh bad = sphere;
  bad.positions[3].x = std::nanf("");
  EXPECT_NE(encode(bad).status().message().find("NaN"), std::string::npos);
  bad = sphere;
  bad.indices[5] = 999;
  EXPECT_NE(encode(bad).status().message().find("out of range"), std::string::npos);
}

TEST(Codec, EmptyMeshRoundTrips) {
  Result<std::vector<uint8_t>> bytes = encode(Mesh{});
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  Result<Mesh> decoded = decode(bytes->data(), bytes->size());
  ASSERT_TRUE(decoded.ok()) << decoded.status().message();
  EXPECT_EQ(decoded->triangle_count(), 0u);
}

// Where a stream's header puts things (docs/FORMAT.md): fixed fields up to version 6, varint
// counts and lengths from version 7.
struct Layout {
  size_t triangles_at = 0;     // the triangle count
  size_t grid_at = 0;          // the grid, right after the counts
  size_t connectivity_at = 0;  // the connectivity section's length
  size_t sections = 0;         // the connectivity section's first byte
  uint64_t connectivity = 0;   // its length
};

Layout layout(const std::vector<uint8_t>& bytes) {
  if (bytes[4] < 7) {
    uint32_t connectivity = 0;
    std::memcpy(&connectivity, bytes.data() + 48, 4);
    return {12, 16, 48, 60, connectivity};
  }
  Layout l;
  ByteReader in(bytes.data(), bytes.size());
  uint64_t count = 0;
  in.skip(6);
  in.read_varint(&count);  // vertices
  l.triangles_at = in.offset();
  in.read_varint(&count);
  l.grid_at = in.offset();
  in.skip(3 * 4 + ((bytes[5] & 2) != 0 ? 4 : 8));  // the origin, and the step (version 8: a float)
  l.connectivity_at = in.offset();
  in.read_varint(&l.connectivity);
  if ((bytes[5] & 1) != 0) in.read_varint(&count);  // the normals section's length
  l.sections = in.offset();
  return l;
}

std::vector<uint8_t> small_stream() {
  auto bytes = encode(make_torus(2, 0.5f, 8, 6));
  EXPECT_TRUE(bytes.ok());
  return bytes.ok() ? bytes.value() : std::vector<uint8_t>{};
}

// A small stream whose geometry is coded on a lattice (its lattice varint is the geometry
// section's second byte).
std::vector<uint8_t> small_lattice_stream() {
  auto bytes = encode(make_lattice_sphere(2, 10.0f, 1.3f));
  EXPECT_TRUE(bytes.ok());
  if (!bytes.ok()) return {};
  const Layout l = layout(bytes.value());
  EXPECT_NE((*bytes)[l.sections + l.connectivity + 1], 0) << "not coded on the lattice";
  return bytes.value();
}

TEST(Codec, TruncationAtEveryByteIsAnError) {
  for (const std::vector<uint8_t>& bytes : {small_stream(), small_lattice_stream()}) {
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
      Result<Mesh> r = decode(bytes.data(), cut, "cut.ostm");
      ASSERT_FALSE(r.ok()) << "cut at " << cut;
      EXPECT_EQ(r.status().message().rfind("cut.ostm: ", 0), 0u) << r.status().message();
    }
  }
}

TEST(Codec, FlippedBitsFailTheChecksum) {
  for (const std::vector<uint8_t>& bytes : {small_stream(), small_lattice_stream()}) {
    for (size_t i = 0; i < bytes.size(); ++i) {
      std::vector<uint8_t> copy = bytes;
      copy[i] ^= uint8_t(1u << (i % 8));
      Result<Mesh> r = decode(copy.data(), copy.size());
      EXPECT_FALSE(r.ok()) << "flip in byte " << i;
    }
  }
}

// Corrupts a stream past the checksum (the checksum is recomputed) to reach the inner decoders.
void set_crc(std::vector<uint8_t>& bytes) {
  uint32_t crc = 0xffffffffu;
  for (size_t i = 0; i + 4 < bytes.size(); ++i) {
    crc ^= bytes[i];
    for (int k = 0; k < 8; ++k) crc = (crc & 1) ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
  }
  crc ^= 0xffffffffu;
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
}

TEST(Codec, CorruptionBehindAValidChecksumNeverCrashes) {
  // Plain, lattice, tangent-plane and apex-weighted geometry (the last with both refinements).
  const std::string golden = std::string(OSTEON_SOURCE_DIR) + "/tests/data/golden/";
  const std::vector<uint8_t> streams[4] = {
      small_stream(), small_lattice_stream(), test::read_bytes(golden + "pelvis_half_b14_v6.ostm"),
      test::read_bytes(golden + "jittered_sphere_b14_v6.ostm")};
  std::mt19937 rng(7);
  for (int trial = 0; trial < 8000; ++trial) {
    std::vector<uint8_t> copy = streams[trial % 4];
    int flips = 1 + trial % 4;
    const size_t sections = layout(copy).sections;
    for (int f = 0; f < flips; ++f) {
      size_t i = sections + rng() % (copy.size() - sections - 4);  // inside the sections
      copy[i] ^= uint8_t(1u << (rng() % 8));
    }
    set_crc(copy);
    Result<Mesh> r = decode(copy.data(), copy.size());
    if (r.ok()) {
      for (uint32_t index : r->indices) ASSERT_LT(index, r->vertex_count());
    }
  }
}

TEST(Codec, HeaderErrorsAreNamed) {
  std::vector<uint8_t> bytes = small_stream();
  std::vector<uint8_t> magic = bytes;
  magic[0] = 'X';
  EXPECT_NE(decode(magic.data(), magic.size()).status().message().find("wrong magic"),
            std::string::npos);
  std::vector<uint8_t> version = bytes;
  version[4] = 9;
  EXPECT_NE(decode(version.data(), version.size()).status().message().find("stream version 9"),
            std::string::npos);
  // Edited headers, behind a recomputed checksum: the decoder's message.
  auto message_of = [](std::vector<uint8_t> edited) {
    set_crc(edited);
    return decode(edited.data(), edited.size()).status().message();
  };
  // The triangle count's varint made 2^28 - 1 (four bytes instead of its one or two).
  const Layout l = layout(bytes);
  std::vector<uint8_t> huge(bytes.begin(), bytes.begin() + l.triangles_at);
  ByteWriter(&huge).write_varint(0x0fffffff);
  huge.insert(huge.end(), bytes.begin() + l.grid_at, bytes.end());
  EXPECT_NE(message_of(huge).find("implausible counts"), std::string::npos);
  // Version 6's fixed fields: the count's four bytes.
  std::vector<uint8_t> fixed =
      test::read_bytes(std::string(OSTEON_SOURCE_DIR) + "/tests/data/golden/pelvis_b14_v6.ostm");
  ASSERT_GT(fixed.size(), 64u);
  const uint32_t count = 0x0fffffff;
  std::memcpy(fixed.data() + layout(fixed).triangles_at, &count, 4);
  EXPECT_NE(message_of(fixed).find("implausible counts"), std::string::npos);
  // A compact header's section lengths beyond the stream.
  std::vector<uint8_t> longer(bytes.begin(), bytes.begin() + l.connectivity_at);
  ByteWriter(&longer).write_varint(65535);
  longer.insert(longer.end(), bytes.begin() + l.sections, bytes.end());
  EXPECT_NE(message_of(longer).find("section lengths"), std::string::npos);
  EXPECT_NE(decode(bytes.data(), 10).status().message().find("too short"), std::string::npos);
}

// The geometry section's mode byte: tangent-plane prediction (bit 1) exists from version 3 on,
// and only with plain residuals, not lattice coding; the apex weight (bits 2 to 5) in version 4,
// up to 8 eighths; from version 5 on, bit 2 says that a triangle shape follows, each of its two
// weights up to 32 sixteenths, and bits 3 to 7 are 0; from version 6 on, bit 3 says that the two
// refinements' weights follow, each up to 32 sixteenths, the curvature's 0 with lattice coding,
// and bits 4 to 7 are 0.
TEST(Codec, PredictionModesAreCheckedAgainstVersionAndCoding) {
  auto geometry_mode = [](std::vector<uint8_t>& bytes) -> uint8_t& {
    const Layout l = layout(bytes);
    return bytes[l.sections + l.connectivity];
  };
  std::vector<uint8_t> plane = test::read_bytes(std::string(OSTEON_SOURCE_DIR) +
                                                "/tests/data/golden/pelvis_half_b14_v6.ostm");
  ASSERT_GT(plane.size(), 64u);
  ASSERT_EQ(geometry_mode(plane), 2);
  ASSERT_TRUE(decode(plane.data(), plane.size()).ok());
  std::vector<uint8_t> old = plane;
  old[4] = 2;  // version 2 has no tangent plane
  set_crc(old);
  EXPECT_NE(decode(old.data(), old.size()).status().message().find("unknown prediction mode"),
            std::string::npos);
  std::vector<uint8_t> unknown = plane;
  geometry_mode(unknown) = 0x40;
  set_crc(unknown);
  EXPECT_NE(
      decode(unknown.data(), unknown.size()).status().message().find("unknown prediction mode"),
      std::string::npos);
  auto rejected = [](std::vector<uint8_t>& bytes) {
    set_crc(bytes);
    return decode(bytes.data(), bytes.size()).status().message().find("unknown prediction mode") !=
           std::string::npos;
  };
  const std::string golden = std::string(OSTEON_SOURCE_DIR) + "/tests/data/golden/";
  std::vector<uint8_t> apex = test::read_bytes(golden + "jittered_sphere_b14_v4.ostm");
  ASSERT_GT(apex.size(), 64u);
  ASSERT_GE(geometry_mode(apex) >> 2, 1);
  ASSERT_TRUE(decode(apex.data(), apex.size()).ok());
  std::vector<uint8_t> apex_v3 = apex;
  apex_v3[4] = 3;  // version 3 has no apex weight
  EXPECT_TRUE(rejected(apex_v3));
  std::vector<uint8_t> heavy = apex;
  geometry_mode(heavy) = static_cast<uint8_t>((geometry_mode(heavy) & 3) | 9 << 2);  // 9 eighths
  EXPECT_TRUE(rejected(heavy));
  std::vector<uint8_t> shape = test::read_bytes(golden + "jittered_sphere_b14_v5.ostm");
  ASSERT_GT(shape.size(), 64u);
  ASSERT_EQ(geometry_mode(shape) & 4, 4);
  ASSERT_TRUE(decode(shape.data(), shape.size()).ok());
  // The mode bit after the version's last, and each of two weights (from byte `first` after the
  // mode byte) at 33 sixteenths, are rejected.
  auto checks_weights = [&](const std::vector<uint8_t>& stream, uint8_t next_bit, int first) {
    std::vector<uint8_t> unknown_bit = stream;
    geometry_mode(unknown_bit) |= next_bit;
    EXPECT_TRUE(rejected(unknown_bit));
    for (int weight = 0; weight < 2; ++weight) {
      std::vector<uint8_t> too_heavy = stream;
      (&geometry_mode(too_heavy))[first + weight] = 33;
      EXPECT_TRUE(rejected(too_heavy)) << weight;
    }
  };
  checks_weights(shape, 8, 1);
  // Version 6: the jittered sphere has the shape (bytes 1 and 2 after the mode byte) and both
  // refinements (bytes 3 and 4).
  std::vector<uint8_t> refined = test::read_bytes(golden + "jittered_sphere_b14_v6.ostm");
  ASSERT_GT(refined.size(), 64u);
  ASSERT_EQ(geometry_mode(refined) & 12, 12);
  ASSERT_TRUE(decode(refined.data(), refined.size()).ok());
  checks_weights(refined, 16, 3);
  std::vector<uint8_t> refined_v5 = refined;
  refined_v5[4] = 5;  // version 5 has no refinements
  EXPECT_TRUE(rejected(refined_v5));
  std::vector<uint8_t> lattice_refined = test::read_bytes(golden + "lattice_sphere_b14_v6.ostm");
  ASSERT_GT(lattice_refined.size(), 64u);
  ASSERT_EQ(geometry_mode(lattice_refined) & 12, 12);
  (&geometry_mode(lattice_refined))[4] = 4;  // a curvature step with lattice coding
  set_crc(lattice_refined);
  EXPECT_NE(decode(lattice_refined.data(), lattice_refined.size())
                .status()
                .message()
                .find("bad lattice period"),
            std::string::npos);
  std::vector<uint8_t> lattice = small_lattice_stream();
  ASSERT_EQ(geometry_mode(lattice) & 3, 0);
  geometry_mode(lattice) |= 2;  // the tangent plane with lattice coding
  set_crc(lattice);
  EXPECT_NE(decode(lattice.data(), lattice.size()).status().message().find("bad lattice period"),
            std::string::npos);
}

TEST(Codec, RealMeshesRoundTrip) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  for (const char* file :
       {"MyoHub__myo_sim/meshes/arm_r_humerus.stl",  // non-manifold edges
        "aHer-dev__3DAnatomy/models/bones/FJ101_BP62633_FMA23725_Right_trapezoid.glb",
        "stity__spl-abdominal-atlas/Data/Model_299_Pelvis.vtk",
        "cearto__zen__MeshsegBenchmark/data/off/101.off"}) {
    SCOPED_TRACE(file);
    Result<Scene> scene = read_path(data + "/" + file);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    expect_round_trip(scene->parts[0]);
  }
}

}  // namespace codec_test
}  // namespace
}  // namespace osteon

namespace osteon {
namespace {
namespace codec_test {

TEST(CodecNormals, TransmittedNormalsComeBackWithinTheirQuantization) {
  for (const auto& [category, input] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    Mesh mesh = input;
    remove_degenerate_triangles(mesh);
    remove_unreferenced_vertices(mesh);
    // Normals that are not the surface's own: tilted by a fixed rotation, so prediction alone
    // cannot produce them.
    mesh.normals = compute_vertex_normals(mesh);
    for (Vec3& n : mesh.normals) {
      float c = std::cos(0.3f), s = std::sin(0.3f);
      n = {c * n.x - s * n.y, s * n.x + c * n.y, n.z};
      if (n.x == 0 && n.y == 0 && n.z == 0) n = {0, 0, 1};
    }
    for (int bits : {8, 10, 16}) {
      EncodeOptions options;
      options.normals = true;
      options.normal_bits = bits;
      EncodeReport report;
      Result<std::vector<uint8_t>> bytes = encode(mesh, options, &report);
      ASSERT_TRUE(bytes.ok()) << bytes.status().message();
      EXPECT_GT(report.normal_bytes, 0u);
      Result<Mesh> decoded = decode(bytes->data(), bytes->size());
      ASSERT_TRUE(decoded.ok()) << decoded.status().message();
      // Match decoded vertices to input vertices by quantized position (unique in these meshes).
      ASSERT_EQ(decoded->vertex_count(), mesh.vertex_count());
      double worst = 0;  // the largest angle, from the cross product (acos is ill-conditioned)
      for (size_t d = 0; d < decoded->vertex_count(); ++d) {
        const Vec3& p = decoded->positions[d];
        size_t best = 0;
        double best_distance = 1e30;
        for (size_t i = 0; i < mesh.vertex_count(); ++i) {
          const Vec3& r = mesh.positions[i];
          double e = std::fabs(p.x - r.x) + std::fabs(p.y - r.y) + std::fabs(p.z - r.z);
          if (e < best_distance) {
            best_distance = e;
            best = i;
          }
        }
        const Vec3& n = mesh.normals[best];
        const Vec3& m = decoded->normals[d];
        double cx = double(n.y) * m.z - double(n.z) * m.y,
               cy = double(n.z) * m.x - double(n.x) * m.z,
               cz = double(n.x) * m.y - double(n.y) * m.x;
        double dot = double(n.x) * m.x + double(n.y) * m.y + double(n.z) * m.z;
        worst = std::max(worst, std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot));
      }
      // Octahedral codes of b bits are within a few 1 / 2^b radians of the vector (measured:
      // 3.2 / 2^8 at 8 bits, 3.8 / 2^10 at 10), plus float rounding.
      EXPECT_LE(worst, 5.0 / double(1u << bits) + 1e-6) << bits << " bits";
    }
  }
}

TEST(CodecNormals, BadNormalOptionsAreRejected) {
  EncodeOptions options;
  options.normals = true;
  options.normal_bits = 7;
  EXPECT_EQ(encode(make_icosphere(1), options).status().code(), ErrorCode::kInvalidArgument);
  Mesh mesh = make_icosphere(1);
  mesh.normals.assign(mesh.vertex_count(), Vec3{std::nanf(""), 0, 0});
  options.normal_bits = 10;
  EXPECT_NE(encode(mesh, options).status().message().find("NaN or infinite normal"),
            std::string::npos);
}

}  // namespace codec_test
}  // namespace
}  // namespace osteon

namespace osteon {
namespace {
namespace codec_test {

// Golden streams freeze the bitstream: the encoder must keep producing exactly these bytes for
// these meshes, and the decoder must keep reading them. A deliberate format change bumps the
// stream version and regenerates them with OSTEON_WRITE_GOLDEN=1; the previous version's files
// stay, as older goldens (kOlderVersions).
struct Golden {
  const char* name;  // the file's name without its version (golden_file)
  // A phantom part (detail 1, seed 1); nullptr: make_lattice_sphere(2, 10, 1.3); "jittered":
  // make_jittered_sphere(3, 10, 0.8).
  const char* part;
  int bits;
  bool normals;
  // Below 1: the part simplified to this share of its triangles (meshopt_simplify), whose
  // irregular triangles make the encoder choose tangent-plane prediction.
  float kept = 1;
  int detail = 1;  // the phantom's
};
constexpr Golden kGoldens[] = {
    {"vertebra_l1_b12", "vertebra_l1", 12, false},      // genus 1
    {"pelvis_b14", "pelvis", 14, false},                // 4 holes
    {"scapula_l_b10", "scapula_l", 10, false},          // non-manifold edges
    {"femur_r_b16_normals", "femur_r", 16, true},       // mirrored copy, normals sent
    {"lattice_sphere_b14", nullptr, 14, false},         // voxel lattice, the apex
    {"rib_l1_half_b14", "rib_l1", 14, false, 0.5f, 2},  // tangent plane, first only
    {"pelvis_half_b14", "pelvis", 14, false, 0.5f},     // tangent plane, mean
    {"jittered_sphere_b14", "jittered", 14, false},     // the apex
};
// Streams of earlier versions, frozen before the next, of the first `goldens` of kGoldens.
struct OlderVersion {
  uint8_t version;
  size_t goldens;
};
constexpr OlderVersion kOlderVersions[] = {{1, 4}, {2, 5}, {3, 7}, {4, 8}, {5, 8}, {6, 8}, {7, 8}};

// "pelvis_b14.ostm" for version 1, "pelvis_b14_v6.ostm" for version 6.
std::string golden_file(const Golden& g, int version) {
  return std::string(g.name) + (version == 1 ? "" : "_v" + std::to_string(version)) + ".ostm";
}

std::string golden_dir() {
  return std::string(OSTEON_SOURCE_DIR) + "/tests/data/golden";
}

const Mesh* golden_mesh(const Phantom& detail_1, const Golden& g) {
  static const Mesh lattice_sphere = make_lattice_sphere(2, 10.0f, 1.3f);
  static const Mesh jittered_sphere = make_jittered_sphere(3, 10.0f, 0.8f);
  static const Phantom detail_2 = make_phantom({.seed = 1, .detail = 2});
  static std::vector<std::unique_ptr<Mesh>> simplified;
  if (g.part == nullptr) return &lattice_sphere;
  if (std::string(g.part) == "jittered") return &jittered_sphere;
  for (const Mesh& m : (g.detail == 2 ? detail_2 : detail_1).scene.parts) {
    if (m.name != g.part) continue;
    if (g.kept >= 1) return &m;
    auto s = std::make_unique<Mesh>(m);
    s->normals.clear();
    const size_t target = static_cast<size_t>(double(m.indices.size()) * g.kept) / 3 * 3;
    s->indices.resize(meshopt_simplify(s->indices.data(), m.indices.data(), m.indices.size(),
                                       &m.positions[0].x, m.positions.size(), sizeof(Vec3), target,
                                       1.0f, 0, nullptr));
    simplified.push_back(std::move(s));
    return simplified.back().get();
  }
  return nullptr;
}

TEST(CodecGolden, EncoderReproducesAndDecoderReadsTheFrozenStreams) {
  Phantom phantom = make_phantom({.seed = 1, .detail = 1});
  const bool write = std::getenv("OSTEON_WRITE_GOLDEN") != nullptr;
  int extrapolated = 0, curved = 0;  // goldens with each refinement
  for (const Golden& g : kGoldens) {
    const std::string file = golden_file(g, kStreamVersion);
    SCOPED_TRACE(file);
    const Mesh* part = golden_mesh(phantom, g);
    ASSERT_NE(part, nullptr);
    EncodeOptions options;
    options.bits = g.bits;
    options.normals = g.normals;
    Result<std::vector<uint8_t>> bytes = encode(*part, options);
    ASSERT_TRUE(bytes.ok()) << bytes.status().message();
    std::string path = golden_dir() + "/" + file;
    if (write) {
      test::write_bytes(path, std::string(bytes->begin(), bytes->end()));
      continue;
    }
    std::vector<uint8_t> frozen = test::read_bytes(path);
    ASSERT_FALSE(frozen.empty()) << path << " is missing (OSTEON_WRITE_GOLDEN=1 writes it)";
    EXPECT_EQ(bytes.value(), frozen) << "the encoder's output changed: if the format changed on "
                                        "purpose, bump the version and regenerate";
    Result<Mesh> decoded = decode(frozen.data(), frozen.size(), path);
    ASSERT_TRUE(decoded.ok()) << decoded.status().message();
    EXPECT_EQ(decoded->triangle_count(), part->triangle_count());
    EncodeReport report;
    ASSERT_TRUE(encode(*part, options, &report).ok());
    if (g.kept < 1) {
      EXPECT_EQ(report.prediction_mode & 2, 2) << "tangent-plane prediction";
    }
    if (g.detail == 2) {
      EXPECT_EQ(report.prediction_mode & 3, 3) << "the first parallelogram only";
    }
    const bool plain = report.shape_scale == 16 && report.shape_apex == 0;
    EXPECT_EQ((report.prediction_mode & 4) != 0, !plain) << "mode bit 2: a triangle shape";
    const bool refined = report.extrapolation != 0 || report.curvature != 0;
    EXPECT_EQ((report.prediction_mode & 8) != 0, refined) << "mode bit 3: the refinements";
    extrapolated += report.extrapolation != 0 ? 1 : 0;
    curved += report.curvature != 0 ? 1 : 0;
    // The spheres' triangles are near-equilateral: mostly the apex (the lattice sphere's with
    // lattice coding), little of the parallelogram's offsets.
    if (g.part == nullptr || std::string(g.part) == "jittered") {
      EXPECT_GE(report.shape_apex, 8) << "the apex";
      EXPECT_LT(report.shape_scale, 8);
    }
  }
  if (!write) {
    EXPECT_GE(extrapolated, 1) << "a golden stream with the extrapolation";
    EXPECT_GE(curved, 1) << "a golden stream with the curvature step";
  }
}

// The decoder keeps reading versions 1 to 7, to the very mesh the version-7 golden of the same
// part decodes to (versions 1 to 7 share the grid; they differ in how they predict and code it).
// Version 8 rounds the codec's own step down to a float: the same triangles, every position
// within one step of version 7's.
TEST(CodecGolden, DecoderStillReadsOlderVersions) {
  Phantom phantom = make_phantom({.seed = 1, .detail = 1});
  auto decoded_golden = [](const Golden& g, int version) {
    const std::string path = golden_dir() + "/" + golden_file(g, version);
    std::vector<uint8_t> frozen = test::read_bytes(path);
    EXPECT_GT(frozen.size(), 4u) << path;
    if (frozen.size() > 4) {
      EXPECT_EQ(frozen[4], version) << path;
    }
    Result<Mesh> mesh = decode(frozen.data(), frozen.size(), path);
    EXPECT_TRUE(mesh.ok()) << path << ": " << mesh.status().message();
    return mesh.ok() ? mesh.value() : Mesh();
  };
  std::vector<Mesh> v7s;  // each golden's version-7 stream, decoded once
  for (const Golden& g : kGoldens) v7s.push_back(decoded_golden(g, 7));
  size_t files = 0;
  for (const OlderVersion& older : kOlderVersions) {
    for (size_t i = 0; i < older.goldens; ++i) {
      const Golden& g = kGoldens[i];
      SCOPED_TRACE(golden_file(g, older.version));
      const Mesh old_decoded = decoded_golden(g, older.version);
      EXPECT_EQ(old_decoded.indices, v7s[i].indices);
      EXPECT_EQ(old_decoded.positions, v7s[i].positions);
      EXPECT_EQ(old_decoded.normals, v7s[i].normals);
      ++files;
    }
  }
  EXPECT_EQ(files, 48u) << "every older golden file";
  for (size_t i = 0; i < std::size(kGoldens); ++i) {
    const Golden& g = kGoldens[i];
    SCOPED_TRACE(g.name);
    const Mesh& v7 = v7s[i];
    const Mesh v8 = decoded_golden(g, 8);
    const Mesh* part = golden_mesh(phantom, g);
    ASSERT_NE(part, nullptr);
    EncodeReport report;
    EncodeOptions options;
    options.bits = g.bits;
    ASSERT_TRUE(encode(*part, options, &report).ok());
    EXPECT_EQ(v8.indices, v7.indices);
    ASSERT_EQ(v8.positions.size(), v7.positions.size());
    double furthest = 0;
    for (size_t v = 0; v < v8.positions.size(); ++v) {
      furthest = std::max({furthest, std::fabs(double(v8.positions[v].x) - v7.positions[v].x),
                           std::fabs(double(v8.positions[v].y) - v7.positions[v].y),
                           std::fabs(double(v8.positions[v].z) - v7.positions[v].z)});
    }
    EXPECT_LE(furthest, report.grid_step * 1.001);
  }
}

// Version 7 changed the header alone: each golden stream's sections are version 6's byte for
// byte, behind a header half as long.
TEST(CodecGolden, CompactHeaderKeepsVersion6Sections) {
  for (const Golden& g : kGoldens) {
    SCOPED_TRACE(g.name);
    const std::vector<uint8_t> v6 = test::read_bytes(golden_dir() + "/" + golden_file(g, 6));
    const std::vector<uint8_t> v7 = test::read_bytes(golden_dir() + "/" + golden_file(g, 7));
    ASSERT_GT(v6.size(), 64u);
    ASSERT_GT(v7.size(), 33u);
    const size_t header_6 = layout(v6).sections, header_7 = layout(v7).sections;
    EXPECT_EQ(header_6, 60u);
    EXPECT_LE(header_7, 34u);
    EXPECT_EQ(std::vector<uint8_t>(v6.begin() + header_6, v6.end() - 4),
              std::vector<uint8_t>(v7.begin() + header_7, v7.end() - 4));
  }
}

TEST(CodecFuzzCorpus, EverySavedStreamDecodesOrFailsCleanly) {
  namespace fs = std::filesystem;
  std::string dir = std::string(OSTEON_SOURCE_DIR) + "/fuzz/corpus/ostm";
  size_t files = 0, decoded = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::vector<uint8_t> bytes = test::read_bytes(entry.path().string());
    Result<Mesh> mesh = decode(bytes.data(), bytes.size(), "corpus.ostm");
    ++files;
    if (mesh.ok()) {
      ++decoded;
      for (uint32_t index : mesh->indices) ASSERT_LT(index, mesh->vertex_count());
    } else {
      EXPECT_EQ(mesh.status().message().rfind("corpus.ostm: ", 0), 0u) << mesh.status().message();
    }
  }
  EXPECT_GT(files, 5u);
  EXPECT_GT(decoded, 0u);
}

}  // namespace codec_test
}  // namespace
}  // namespace osteon
