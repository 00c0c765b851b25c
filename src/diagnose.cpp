// SPDX-License-Identifier: Apache-2.0
// PLACEHOLDER: being written.
#include "osteon/diagnose.hpp"

namespace osteon {

DiagnosisReport diagnose(const Mesh& mesh) {
  DiagnosisReport r;
  r.vertices = mesh.vertex_count();
  r.triangles = mesh.triangle_count();
  return r;
}

}  // namespace osteon
