// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <string>

#include "osteon/codec.hpp"
#include "osteon/mesh.hpp"

// The C ABI the WebAssembly decoder exports (web/decoder/build.sh lists every export): one call
// decodes a stream with osteon::decode (src/codec_decode.cpp, the native decoder's own source)
// into a handle, accessors hand JavaScript pointers into the decoded arrays, osteon_free releases
// it. JavaScript copies the arrays out of WebAssembly memory before freeing (osteon_decoder.mjs).
//
// Based on: meshoptimizer's js/meshopt_decoder.mjs (a few plain C exports, no embind, the wasm
// instantiated by a small hand-written wrapper).

static_assert(sizeof(osteon::Vec3) == 3 * sizeof(float),
              "positions are handed out as float[3 * n]");

/// What osteon_decode returns: the decoded mesh, or the decoder's error message.
struct OsteonDecoded {
  osteon::Mesh mesh;
  std::string error;
};

extern "C" {

/// Allocates `size` bytes in WebAssembly memory for the caller to fill (the stream to decode);
/// null when memory cannot grow. Release with osteon_free_bytes.
void* osteon_alloc(size_t size) {
  return std::malloc(size ? size : 1);
}
void osteon_free_bytes(void* bytes) {
  std::free(bytes);
}

/// Decodes `size` bytes at `data`. `source` (a NUL-terminated name, or null for "osteon stream")
/// opens every error message. Returns a handle that holds the mesh or the error (check
/// osteon_error); null only when memory for the handle itself cannot be found.
OsteonDecoded* osteon_decode(const uint8_t* data, size_t size, const char* source) {
  auto* out = new (std::nothrow) OsteonDecoded;
  if (!out) return nullptr;
  osteon::Result<osteon::Mesh> mesh =
      osteon::decode(data, size, source && *source ? source : "osteon stream");
  if (mesh.ok()) {
    out->mesh = std::move(mesh).value();
  } else {
    out->error = mesh.status().message();
  }
  return out;
}

/// The error message (NUL-terminated), or null when decoding succeeded.
const char* osteon_error(const OsteonDecoded* h) {
  return h->error.empty() ? nullptr : h->error.c_str();
}
uint32_t osteon_vertex_count(const OsteonDecoded* h) {
  return static_cast<uint32_t>(h->mesh.vertex_count());
}
uint32_t osteon_triangle_count(const OsteonDecoded* h) {
  return static_cast<uint32_t>(h->mesh.triangle_count());
}
/// x, y, z per vertex.
const float* osteon_positions(const OsteonDecoded* h) {
  return reinterpret_cast<const float*>(h->mesh.positions.data());
}
/// Three vertex indices per triangle.
const uint32_t* osteon_indices(const OsteonDecoded* h) {
  return h->mesh.indices.data();
}
/// Unit vertex normals, x, y, z per vertex (computed by the decoder unless the stream has them).
const float* osteon_normals(const OsteonDecoded* h) {
  return reinterpret_cast<const float*>(h->mesh.normals.data());
}
void osteon_free(OsteonDecoded* h) {
  delete h;
}

}  // extern "C"
