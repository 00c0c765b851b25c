// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cmath>

// The geometry kernel every layer shares (core layer: no third-party code): 3-vectors in float
// (stored positions) and double (computation), and 4x4 affine matrices, column-major as glTF and
// the package manifest store them. Plain structs and free functions; each operation is written
// once here, in a fixed evaluation order, so results are bit-identical wherever it is used.

namespace osteon {

/// A position or normal as meshes store it.
struct Vec3 {
  float x = 0, y = 0, z = 0;
  friend bool operator==(const Vec3&, const Vec3&) = default;
};

/// A point or direction in double precision: sample points, closest points, transforms.
struct Vec3d {
  double x = 0, y = 0, z = 0;
  friend bool operator==(const Vec3d&, const Vec3d&) = default;
};

// ---- float vectors ---------------------------------------------------------------------------

inline Vec3 operator+(const Vec3& a, const Vec3& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec3 operator-(const Vec3& a, const Vec3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec3 operator*(float s, const Vec3& v) {
  return {s * v.x, s * v.y, s * v.z};
}
inline float dot(const Vec3& a, const Vec3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// ---- double vectors --------------------------------------------------------------------------

inline Vec3d to_double(const Vec3& v) {
  return {v.x, v.y, v.z};
}
/// Rounds each coordinate to the nearest float.
inline Vec3 to_float(const Vec3d& v) {
  return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}
inline Vec3d operator+(const Vec3d& a, const Vec3d& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec3d operator-(const Vec3d& a, const Vec3d& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec3d operator*(double s, const Vec3d& v) {
  return {s * v.x, s * v.y, s * v.z};
}
inline double dot(const Vec3d& a, const Vec3d& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double squared_length(const Vec3d& v) {
  return dot(v, v);
}
inline double length(const Vec3d& v) {
  return std::sqrt(dot(v, v));
}
/// `v` scaled to unit length; precondition: v is not zero.
inline Vec3d normalize(const Vec3d& v) {
  return (1.0 / std::sqrt(dot(v, v))) * v;
}

/// (b - a) x (c - a) in double: the normal of triangle (a, b, c) scaled by twice its area (zero for
/// a degenerate triangle).
inline Vec3d triangle_cross(const Vec3& a, const Vec3& b, const Vec3& c) {
  return cross(to_double(b) - to_double(a), to_double(c) - to_double(a));
}

// ---- 4x4 matrices ----------------------------------------------------------------------------

/// An affine transform, column-major: element (row r, column c) is m[4 * c + r]; the translation
/// is m[12..14].
using Mat4 = std::array<double, 16>;

inline constexpr Mat4 kIdentityMatrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

/// a * b (b applied first).
inline Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 out{};
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      double sum = 0;
      for (int k = 0; k < 4; ++k) sum += a[4 * k + r] * b[4 * c + k];
      out[4 * c + r] = sum;
    }
  }
  return out;
}

/// m applied to the point p (w = 1).
inline Vec3d transform_point(const Mat4& m, const Vec3d& p) {
  return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12],
          m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
          m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}
/// m applied to a float point, computed in double and rounded once to float.
inline Vec3 transform_point(const Mat4& m, const Vec3& p) {
  return to_float(transform_point(m, to_double(p)));
}

/// The determinant of the linear (upper-left 3x3) part: negative for a mirroring transform.
inline double determinant3(const Mat4& m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
         m[8] * (m[1] * m[6] - m[5] * m[2]);
}

}  // namespace osteon
