// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// The osteon mesh codec (paper section IV.A): Edgebreaker connectivity decoded by Spirale
// Reversi, positions quantized on a grid and predicted by (multi-)parallelograms, rANS entropy
// coding with context models. The bitstream is specified byte by byte in docs/FORMAT.md.

namespace osteon {

/// The .ostm stream version encode() writes; decode() reads versions 1 to this one
/// (docs/FORMAT.md). A package's manifest records it, so a reader can refuse newer streams up
/// front.
inline constexpr int kStreamVersion = 8;

/// A quantization grid: position p is stored as round((p - origin) / step) per axis. Several
/// parts encoded with the same grid meet without cracks where their vertices coincide.
struct QuantizationGrid {
  Vec3 origin{0, 0, 0};
  double step = 0;  ///< > 0
  /// Grid steps between the planes of a voxel lattice the positions sit on (raw marching-cubes
  /// surfaces: two of each vertex's three coordinates on the lattice), with the origin on a
  /// lattice plane; 0 when there is none. A hint for the geometry coder: any value decodes
  /// exactly, a wrong one only costs bytes.
  uint32_t lattice = 0;
};

struct EncodeOptions {
  /// Grid step = largest bounding-box side / (2^bits - 1); 8..24. Ignored when precision > 0 or
  /// a grid is given. (Off a voxel lattice, a step the codec chooses is rounded down to a float,
  /// which the stream stores in 4 bytes: a step no larger, so every bound still holds.)
  int bits = 14;
  /// > 0: the largest position error allowed, in mesh units (step = 2 * precision, rounded down
  /// to a float, so every coordinate is within precision of the input).
  double precision = 0;
  /// When set (step > 0), use this grid instead of one derived from the mesh (shared grids).
  QuantizationGrid grid;
  /// Transmit per-vertex normals (octahedral, predicted from the decoded surface): the mesh's own
  /// normals when it has them, else its smooth normals before quantization. Otherwise the decoder
  /// computes smooth normals from the decoded positions.
  bool normals = false;
  /// Bits per octahedral component of transmitted normals, 8..16 (10: within about 0.1 degree).
  int normal_bits = 10;
  /// How hard the encoder searches for the smallest stream, 0 or 1. 1 (the default): it measures
  /// its candidate codings (prediction modes, triangle shapes, refinements, connectivity context
  /// models) and keeps the cheapest. 0: no search, one coding chosen up front, several times
  /// faster on small meshes for a few percent more bytes (docs/DESIGN.md, "Encode speed"). Both
  /// decode with the same decoder, to positions within the same bound.
  int effort = 1;
};

/// What encode measured; every field is filled on success.
struct EncodeReport {
  size_t bytes = 0;
  size_t connectivity_bytes = 0;
  size_t geometry_bytes = 0;
  size_t normal_bytes = 0;
  size_t vertices = 0;   ///< vertices coded (after removing unreferenced ones)
  size_t triangles = 0;  ///< triangles coded
  size_t degenerate_removed = 0;
  size_t unreferenced_removed = 0;
  double connectivity_bits_per_vertex = 0;
  double geometry_bits_per_vertex = 0;
  double max_error = 0;  ///< largest per-coordinate |decoded - input| over all vertices
  /// The geometry section's prediction mode (docs/FORMAT.md): bit 0 set for the first
  /// parallelogram only (else the mean of all), bit 1 for tangent-plane prediction, bit 2 when
  /// the triangle shape below is not the plain parallelogram, bit 3 when a refinement below is on.
  uint8_t prediction_mode = 0;
  /// The triangle shape each parallelogram places its vertex with, in sixteenths (docs/FORMAT.md,
  /// "value(n, p, o)"): the share of the parallelogram's offset from its edge's midpoint, and the
  /// equilateral apex's share. {16, 0} is the plain parallelogram.
  int shape_scale = 16;
  int shape_apex = 0;
  /// The prediction's refinements, in sixteenths (docs/FORMAT.md, "step_out" and
  /// "curvature_step"; 0 when off): how far a vertex without parallelograms steps out from its
  /// decoded neighbour, and the share of the neighbours' residuals along the normal that a
  /// parallelogram's prediction adds.
  int extrapolation = 0;
  int curvature = 0;
  /// The encoder's search, as work done: the vertices predicted by every geometry coding it
  /// measured and by the one it kept, over the vertex count (1 would be a single pass; a small
  /// mesh has its candidate codings measured on every vertex), and the connectivity context
  /// models whose tables it planned to keep the smallest.
  double geometry_passes = 0;
  int connectivity_models = 0;
  double grid_step = 0;
  QuantizationGrid grid;
};

/// The quantization grid encode() uses for `options` on `positions` (see EncodeOptions): the
/// given grid, or one with its origin at the box's minimum and a step from precision or bits.
/// When the positions sit on an isotropic voxel lattice (two coordinates of nine vertices in ten
/// on its planes), the step shrinks to the lattice spacing / k for the smallest integer k that
/// keeps it no larger, and the origin moves onto a lattice plane below the box (QuantizationGrid::
/// lattice = k): the error bound only tightens. Known approximation: the lattice is found from a
/// sample of at most 65,536 vertices. Callers that encode several pieces of one part on one grid
/// (so they meet without cracks) ask for it once and pass it in EncodeOptions::grid. Errors:
/// kInvalidArgument for options out of range or a grid with more than 2^30 cells a side.
/// O(V + S log S) for a sample of S vertices.
Result<QuantizationGrid> choose_grid(const std::vector<Vec3>& positions,
                                     const EncodeOptions& options);

/// Encodes a mesh. Degenerate triangles (repeated index or zero area) and unreferenced vertices
/// are removed first and counted in the report; everything else (several components, boundaries,
/// handles, non-manifold edges and vertices, inconsistent orientation) is coded exactly: decode()
/// returns the same triangles with the same orientation, up to a permutation of the vertices, and
/// every coordinate within half a grid step of the input.
/// Errors: kInvalidArgument for bits out of 8..24, a negative precision, a grid too fine for the
/// mesh (more than 2^30 cells a side), or a mesh with non-finite positions or indices out of range.
Result<std::vector<uint8_t>> encode(const Mesh& mesh, const EncodeOptions& options = {},
                                    EncodeReport* report = nullptr);

/// Decodes a stream written by encode(). Safe for untrusted bytes: every count is checked against
/// the bytes that remain before allocation; truncation, bad magic or version, a checksum mismatch
/// and inconsistent connectivity are errors naming the section and byte offset. Normals are
/// computed (area-weighted) unless the stream carries them. `source` names the stream in messages.
Result<Mesh> decode(const uint8_t* data, size_t size, const std::string& source = "osteon stream");

/// The grid a stream was encoded on, from its header: decode() places every vertex at
/// float(double(float(origin)) + q * step) for its integer coordinates q, so a caller that keeps
/// the decoded positions on their grid (osteon export's quantised glTF) recovers q exactly as
/// round((position - origin) / step). Checks the magic, version and size (not the checksum:
/// decode() does that). Errors: kInvalidData / kUnsupported as decode()'s header checks. O(1).
Result<QuantizationGrid> stream_grid(const uint8_t* data, size_t size,
                                     const std::string& source = "osteon stream");

/// Area-weighted smooth vertex normals (unit length; zero for vertices of zero-area fans).
std::vector<Vec3> compute_vertex_normals(const Mesh& mesh);

}  // namespace osteon
