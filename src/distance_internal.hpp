// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>

#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// What the distance code shares (src/point_triangle.cpp, src/distance_query.cpp,
// src/hausdorff.cpp): the closest-point kernel and the checks every input mesh passes.

namespace osteon::detail {

/// closest_point_on_triangle without the square root: sets *q to the closest point of triangle
/// (a, b, c) to p and returns the squared distance.
double closest_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c,
                           Vec3d* q);

/// The name a mesh goes by in messages: its source file, else its part name, else "mesh".
std::string mesh_label(const Mesh& mesh);

/// Ok when `mesh` is a surface the distance code can use: at least one triangle, every index in
/// range, every position finite. Errors name mesh_label(mesh): kInvalidArgument for no triangles
/// or an index out of range, kInvalidData for a non-finite coordinate (with the vertex). O(V + T).
Status check_surface(const Mesh& mesh);

}  // namespace osteon::detail
