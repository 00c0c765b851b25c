// SPDX-License-Identifier: Apache-2.0
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "osteon/diagnose.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract and Draco's per-decoder fuzz targets
// (draco/src/draco/tools/fuzz): one binary per reader, the reader picked by the file extension.
// Beyond sanitizer findings, a reader that returns a mesh breaking the Mesh contract (an index out
// of range, a NaN) or an error whose message does not start with the file name aborts the run.

#ifndef OSTEON_FUZZ_FORMAT
#error "build with -DOSTEON_FUZZ_FORMAT=\"stl\" (or obj, ply, off, vtk, gltf, glb)"
#endif

namespace {

[[noreturn]] void contract_broken(const char* what, const std::string& detail) {
  std::fprintf(stderr, "osteon fuzz: %s: %s\n", what, detail.c_str());
  std::abort();
}

bool finite(const osteon::Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

void check_contract(const osteon::Mesh& mesh) {
  if (mesh.indices.size() % 3 != 0) contract_broken("indices not a multiple of 3", mesh.name);
  for (uint32_t index : mesh.indices) {
    if (index >= mesh.positions.size()) contract_broken("index out of range", mesh.name);
  }
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
    contract_broken("normals do not match positions", mesh.name);
  for (const osteon::Vec3& p : mesh.positions) {
    if (!finite(p)) contract_broken("non-finite position", mesh.name);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string source = "fuzz." OSTEON_FUZZ_FORMAT;
  auto scene = osteon::read_memory(data, size, source, osteon::Format::kUnknown);
  if (!scene.ok()) {
    const std::string& message = scene.status().message();
    if (message.rfind(source + ": ", 0) != 0) contract_broken("message without source", message);
    return 0;
  }
  for (osteon::Mesh& part : scene->parts) {
    check_contract(part);
    osteon::DiagnosisReport report = osteon::diagnose(part);
    if (report.triangles != part.triangle_count())
      contract_broken("diagnose miscounted triangles", part.name);
    // read_memory already welded exactly; the tolerance weld takes the other path.
    osteon::weld(part, osteon::WeldOptions{1e-3f});
    check_contract(part);
    (void)osteon::count_degenerate_triangles(part);
  }
  return 0;
}
