// SPDX-License-Identifier: Apache-2.0
// PLACEHOLDER: being written.
#include "osteon/phantom.hpp"

namespace osteon {

Mesh make_icosphere(int, float) { return {}; }
Mesh make_torus(float, float, int, int) { return {}; }
Mesh make_open_cylinder(float, float, int, int) { return {}; }
Mesh make_box(Vec3, Vec3) { return {}; }
Mesh make_nonmanifold_book() { return {}; }
Mesh make_bowtie_tetrahedra() { return {}; }
Phantom make_phantom(const PhantomOptions&) { return {}; }

}  // namespace osteon
