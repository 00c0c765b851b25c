// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "bench_markdown.hpp"
#include "osteon/codec.hpp"
#include "osteon/mesh.hpp"

// The native peers bench/codec_bench measures osteon against, behind a few calls so that the driver
// does not see their headers: Draco (libdraco-dev, in-process) and meshoptimizer's codecs under
// gzip (libmeshoptimizer-dev, zlib). Also the timing loop every measurement shares.

#include "bench_gzip.hpp"

namespace osteon_bench {

/// How a time is taken: the best of at least `repeat` runs and of at least `min_seconds` of
/// running (at most `max_runs` runs), thread CPU time or wall clock.
struct Timing {
  bool wall = false;
  int repeat = 5;
  double min_seconds = 0.3;
  int max_runs = 100;
};

/// CLOCK_THREAD_CPUTIME_ID (the machine is shared: a preempted run does not count the other
/// process's time) or, with `wall`, CLOCK_MONOTONIC. Every codec measured here is single-threaded.
inline double now_seconds(bool wall) {
  if (!wall) return thread_seconds();
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Runs `fn` as Timing says; returns the best time in milliseconds, or -1 as soon as `fn` returns
/// false (a failure, which `fn` records itself).
template <class Fn>
double best_ms(const Timing& timing, Fn&& fn) {
  double best = std::numeric_limits<double>::infinity(), total = 0;
  for (int runs = 0; runs < timing.repeat || (total < timing.min_seconds && runs < timing.max_runs);
       ++runs) {
    double start = now_seconds(timing.wall);
    bool ok = fn();
    double seconds = now_seconds(timing.wall) - start;
    if (!ok) return -1;
    best = std::min(best, seconds);
    total += seconds;
  }
  return best * 1e3;
}


/// Draco's compression levels measured, mapped to speeds as draco_encoder maps -cl.
constexpr int kDracoLevels[2] = {7, 10};

struct DracoResult {
  std::string error;
  size_t bytes = 0;
  double encode_ms = 0, decode_ms = 0;
  size_t decoded_triangles = 0;
  std::string stream;  ///< where the stream was written (empty: not written)
  double wasm_ms = -1;
  std::string wasm_error;
};

struct MeshoptResult {
  std::string error;
  size_t bytes = 0;
  double encode_ms = 0, decode_ms = 0;
  double max_error = 0;
  /// The buffers both meshoptimizer columns code: u32 vertex count, u32 index count, u32 stride,
  /// the quantized vertices, the u32 indices (after vertex cache and fetch optimisation).
  std::vector<uint8_t> buffers;
  /// meshoptimizer 1.x (npm, through bench/codec_wasm.mjs): where `buffers` was written, the
  /// gzipped size of its vertex codec v1 + index codec stream, its WebAssembly decode time.
  std::string buffers_file;
  size_t v1_bytes = 0;
  double v1_wasm_ms = -1;
  std::string v1_error;
};

/// Draco at both levels, and its position error.
struct DracoRun {
  DracoResult level[2];        ///< kDracoLevels[0], kDracoLevels[1]
  double max_error = -1;       ///< largest per-coordinate |decoded - input|; -1 when not measured
  std::string max_error_note;  ///< why it was not measured
};

/// Encodes `mesh` with Draco at both levels, positions only (no normals), quantized to `bits`;
/// times encode (EncodeMeshToBuffer on a draco::Mesh built beforehand) and decode
/// (DecodeMeshFromBuffer); writes each stream to `stream_stem` + "_cl7.drc" / "_cl10.drc".
/// The error is measured on a companion stream (cl7 settings) that also carries each vertex's input
/// index as an unquantized attribute, so every decoded point names its input vertex; quantization
/// does not depend on the connectivity coder, so the positions-only streams have the same error.
DracoRun run_draco(const osteon::Mesh& mesh, int bits, const Timing& timing,
                   const std::string& stream_stem);

/// Draco cl10's bytes for `mesh` with every position but two made one point: its connectivity and
/// headers, with next to no geometry (every residual 0 but a few), so that its stream's bytes less
/// these are its geometry's. 0 when Draco fails.
size_t draco_connectivity_bytes(const osteon::Mesh& mesh, int bits);

/// The benchmark's grid: origin at the bounding box's minimum, step = largest side / (2^bits - 1).
osteon::QuantizationGrid grid_for(const osteon::Mesh& mesh, int bits);

/// meshoptimizer 0.18 on positions quantized to grid_for(mesh, bits): uint16 x 3 plus 2 bytes of
/// padding (uint32 x 3 above 16 bits), meshopt_optimizeVertexCache, the vertex fetch remap
/// (meshopt_optimizeVertexFetchRemap + remap, what meshopt_optimizeVertexFetch does, keeping the
/// remap to match decoded vertices to input ones), meshopt_encodeVertexBuffer +
/// meshopt_encodeIndexBuffer, and both buffers behind a 12-byte header in one gzip -9 stream.
/// Encode time covers all of that; decode time gunzip and both decoders (positions stay uint16).
MeshoptResult run_meshopt(const osteon::Mesh& mesh, int bits, const Timing& timing);

}  // namespace osteon_bench
