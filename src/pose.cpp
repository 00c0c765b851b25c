// SPDX-License-Identifier: Apache-2.0
#include "repeats_internal.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

#include "eigen_interop.hpp"

// Based on: Zhou, Jia & Su (2018), eq. (5)-(9) (translation, scale and symmetry alignment);
// D. Vranic, D. Saupe, "3D shape descriptor based on 3D Fourier transform" / "continuous PCA"
// (2001): principal axes from the covariance of the surface, integrated exactly over each triangle
// rather than summed over vertices, so that the tessellation does not move the frame.
//
// Exact surface moments of a triangle (a, b, c) of area A: for a linear function f with values
// fa, fb, fc at the corners, the mean of f^n over the triangle is 2 n! / (n + 2)! times the sum of
// every monomial fa^i fb^j fc^k with i + j + k = n. n = 2: (fa^2 + fb^2 + fc^2 + fa fb + fb fc +
// fc fa) / 6, i.e. E[x x^T] = (a a^T + b b^T + c c^T + s s^T) / 12 with s = a + b + c; n = 3: the
// ten cubic monomials / 10.

namespace osteon::detail {

namespace {

Vec3d position(const Mesh& mesh, uint32_t i) {
  return to_double(mesh.positions[i]);
}

Mat3 from_eigen(const Matrix3& m) {
  Mat3 out;
  Eigen::Map<Matrix3>(out.data()) = m;
  return out;
}

// Third moments: E[y_i y_j y_k] over the surface (27 entries, symmetric).
struct Third {
  std::array<double, 27> t{};
  double& at(int i, int j, int k) { return t[size_t(9 * i + 3 * j + k)]; }
  double at(int i, int j, int k) const { return t[size_t(9 * i + 3 * j + k)]; }
};

// Adds weight * the mean of y_i y_j y_k over the triangle with corners y[0..2]: for linear
// functions f, g, h with corner values f_p, ..., 60 E[fgh] = Sf Sg Sh + Sh sum(f_p g_p) +
// Sf sum(g_p h_p) + Sg sum(f_p h_p) + 2 sum(f_p g_p h_p), S the sums over the corners (from the
// mean of a barycentric monomial, 2 i! j! k! / (i + j + k + 2)!).
void add_triangle(Third& third, const Eigen::Vector3d (&y)[3], double weight) {
  const Eigen::Vector3d s = y[0] + y[1] + y[2];
  for (int i = 0; i < 3; ++i) {
    for (int j = i; j < 3; ++j) {
      for (int k = j; k < 3; ++k) {
        double fg = 0, gh = 0, fh = 0, fgh = 0;
        for (int p = 0; p < 3; ++p) {
          fg += y[p](i) * y[p](j);
          gh += y[p](j) * y[p](k);
          fh += y[p](i) * y[p](k);
          fgh += y[p](i) * y[p](j) * y[p](k);
        }
        const double mean =
            (s(i) * s(j) * s(k) + s(k) * fg + s(i) * gh + s(j) * fh + 2 * fgh) / 60.0;
        const int perm[6][3] = {{i, j, k}, {i, k, j}, {j, i, k}, {j, k, i}, {k, i, j}, {k, j, i}};
        std::array<bool, 27> done{};
        for (const auto& q : perm) {
          const size_t at = size_t(9 * q[0] + 3 * q[1] + q[2]);
          if (done[at]) continue;
          done[at] = true;
          third.t[at] += weight * mean;
        }
      }
    }
  }
}

// sum_ijk T_ijk d_i d_j d_k: the third moment along d.
double cubic(const Third& third, const Eigen::Vector3d& d) {
  double sum = 0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) sum += third.at(i, j, k) * d(i) * d(j) * d(k);
    }
  }
  return sum;
}

// The skewness a direction needs to fix a free axis (beyond the paper's sign alignment).
constexpr double kResolveSkew = 0.1;

// Rotation by `angle` in the plane of axes (v, w), leaving the third axis alone.
Mat3 plane_rotation(int v, int w, double angle) {
  Mat3 m = kIdentity3;
  const double c = std::cos(angle), s = std::sin(angle);
  m[3 * v + v] = c;
  m[3 * v + w] = -s;
  m[3 * w + v] = s;
  m[3 * w + w] = c;
  return m;
}

Mat3 diagonal(double x, double y, double z) {
  return {x, 0, 0, 0, y, 0, 0, 0, z};
}

// 40 directions spread over the sphere (a Fibonacci lattice) for the image of the first axis,
// each with 8 turns about it: 320 rotations whose worst gap to any rotation is about 25 degrees,
// which ICP closes.
std::vector<Mat3> rotation_set() {
  constexpr int kDirections = 40, kTurns = 8;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<Mat3> out;
  out.reserve(kDirections * kTurns);
  for (int i = 0; i < kDirections; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / kDirections;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    // Any unit vector p orthogonal to d, then q = d x p: (d, p, q) is right-handed.
    Eigen::Vector3d p =
        std::fabs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    p = (p - p.dot(d) * d).normalized();
    const Eigen::Vector3d q = d.cross(p);
    for (int k = 0; k < kTurns; ++k) {
      const double angle = 2.0 * std::numbers::pi * k / kTurns;
      Matrix3 m;
      m.col(0) = d;
      m.col(1) = std::cos(angle) * p + std::sin(angle) * q;
      m.col(2) = -std::sin(angle) * p + std::cos(angle) * q;
      out.push_back(from_eigen(m));
    }
  }
  return out;
}

}  // namespace

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 out;
  Eigen::Map<Matrix3>(out.data()) =
      Eigen::Map<const Matrix3>(a.data()) * Eigen::Map<const Matrix3>(b.data());
  return out;
}

Mat3 transpose(const Mat3& a) {
  return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]};
}

double determinant(const Mat3& a) {
  return Eigen::Map<const Matrix3>(a.data()).determinant();
}

Vec3d multiply(const Mat3& a, const Vec3d& v) {
  return {a[0] * v.x + a[1] * v.y + a[2] * v.z, a[3] * v.x + a[4] * v.y + a[5] * v.z,
          a[6] * v.x + a[7] * v.y + a[8] * v.z};
}

bool compute_pose(const Mesh& mesh, const PoseOptions& options, Pose* pose) {
  const size_t triangles = mesh.triangle_count();
  // Eq. (5), area-weighted over triangles (not vertices): the centroid of the surface.
  double area = 0;
  Vec3d weighted;
  std::vector<double> areas(triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const Vec3d a = position(mesh, mesh.indices[3 * t]);
    const Vec3d b = position(mesh, mesh.indices[3 * t + 1]);
    const Vec3d c = position(mesh, mesh.indices[3 * t + 2]);
    areas[t] = 0.5 * std::sqrt(squared_length(cross(b - a, c - a)));
    area += areas[t];
    weighted = weighted + (areas[t] / 3.0) * (a + b + c);
  }
  if (!(area > 0) || !std::isfinite(area)) return false;
  const Vec3d centroid = (1.0 / area) * weighted;

  // The covariance of the surface about its centroid (exact second moments of the triangles).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (size_t t = 0; t < triangles; ++t) {
    const Eigen::Vector3d a = eig(position(mesh, mesh.indices[3 * t]) - centroid);
    const Eigen::Vector3d b = eig(position(mesh, mesh.indices[3 * t + 1]) - centroid);
    const Eigen::Vector3d c = eig(position(mesh, mesh.indices[3 * t + 2]) - centroid);
    const Eigen::Vector3d s = a + b + c;
    covariance += (areas[t] / 12.0) *
                  (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  covariance /= area;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  if (solver.info() != Eigen::Success) return false;
  Eigen::Vector3d values = solver.eigenvalues().cwiseMax(0.0);  // ascending
  const double trace = values.sum();
  // Scale: the RMS distance of the surface from its centroid (sqrt of the covariance's trace).
  const double scale = std::sqrt(trace);
  if (!(scale > 0) || !std::isfinite(scale)) return false;

  Pose out;
  out.centroid = centroid;
  out.area = area;
  out.scale = scale;
  Matrix3 axes;
  for (int k = 0; k < 3; ++k) {
    axes.row(k) = solver.eigenvectors().col(2 - k).transpose();  // largest moment first
    out.moments[size_t(k)] = values(2 - k) / trace;
  }

  // The surface's third moments in the principal frame, normalised by the scale.
  Third third;
  for (size_t t = 0; t < triangles; ++t) {
    const double w = areas[t] / area;
    const Eigen::Vector3d y[3] = {
        axes * eig(position(mesh, mesh.indices[3 * t]) - centroid) / scale,
        axes * eig(position(mesh, mesh.indices[3 * t + 1]) - centroid) / scale,
        axes * eig(position(mesh, mesh.indices[3 * t + 2]) - centroid) / scale};
    add_triangle(third, y, w);
  }
  // The variance along a (unit, principal-frame) direction.
  const Eigen::Vector3d moments(out.moments[0], out.moments[1], out.moments[2]);
  auto variance = [&](const Eigen::Vector3d& d) { return d.dot(moments.asDiagonal() * d); };
  auto skewness = [&](const Eigen::Vector3d& d) {
    const double v = variance(d);
    return v > 1e-24 ? cubic(third, d) / (v * std::sqrt(v)) : 0.0;
  };
  // `frame`: rows are the canonical axes in the principal frame; it ends up in out.axes.
  Matrix3 frame = Matrix3::Identity();

  // Eq. (8)-(9): the sign of each axis from the surface's asymmetry along it. The paper sums
  // sign(x) x^2 over vertices; here the skewness of the surface (its third moment over the
  // axis's standard deviation cubed), exact per triangle, so that it is an odd function with a
  // closed form and independent of the tessellation.
  for (int k = 0; k < 3; ++k) {
    if (skewness(frame.row(k).transpose()) < 0) frame.row(k) = -frame.row(k);
  }

  const auto& m = out.moments;
  const bool equal01 = m[0] - m[1] <= options.equal_moments * m[0];
  const bool equal12 = m[1] - m[2] <= options.equal_moments * m[1];
  if (equal01 && equal12) {
    out.ambiguity = AxisAmbiguity::kFull;
  } else if (equal01) {
    out.ambiguity = AxisAmbiguity::kPlane;
    out.distinct_axis = 2;
  } else if (equal12) {
    out.ambiguity = AxisAmbiguity::kPlane;
    out.distinct_axis = 0;
  }

  // Beyond the paper: where the second moments leave the axes free, the third moments usually do
  // not. Three equal moments: the direction of E[|y|^2 y] becomes the first axis (leaving a free
  // turn about it). Two equal moments: the direction in their plane along which the surface is
  // most skewed becomes the second axis, when it stands out (its skewness at least
  // kResolveSkew, and no other local maximum of the skewness around the plane within 80% of it:
  // a cross-section with three-fold symmetry keeps its turns free).
  if (out.ambiguity == AxisAmbiguity::kFull) {
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) g(i) += third.at(i, j, j);
    }
    if (g.norm() >= kResolveSkew) {
      const Eigen::Vector3d d0 = g.normalized();
      Eigen::Vector3d d1 =
          std::fabs(d0.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      d1 = (d1 - d1.dot(d0) * d0).normalized();
      frame.row(0) = d0.transpose();
      frame.row(1) = d1.transpose();
      frame.row(2) = d0.cross(d1).transpose();
      out.ambiguity = AxisAmbiguity::kPlane;
      out.distinct_axis = 0;
    }
  }
  if (out.ambiguity == AxisAmbiguity::kPlane) {
    const int u = out.distinct_axis, v = (u + 1) % 3, w = (u + 2) % 3;
    const Eigen::Vector3d ev = frame.row(v).transpose(), ew = frame.row(w).transpose();
    constexpr int kSteps = 360;
    std::array<double, kSteps> f;
    for (int i = 0; i < kSteps; ++i) {
      const double a = 2 * std::numbers::pi * i / kSteps;
      f[size_t(i)] = skewness(std::cos(a) * ev + std::sin(a) * ew);
    }
    const int best = int(std::max_element(f.begin(), f.end()) - f.begin());
    double second = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < kSteps; ++i) {
      const double here = f[size_t(i)];
      const bool local =
          here >= f[size_t((i + kSteps - 1) % kSteps)] && here >= f[size_t((i + 1) % kSteps)];
      const int apart = std::abs(i - best);
      if (local && std::min(apart, kSteps - apart) > 5) second = std::max(second, here);
    }
    if (f[size_t(best)] >= kResolveSkew && second < 0.8 * f[size_t(best)]) {
      const double a = 2 * std::numbers::pi * best / kSteps;
      frame.row(v) = (std::cos(a) * ev + std::sin(a) * ew).transpose();
      frame.row(w) = (-std::sin(a) * ev + std::cos(a) * ew).transpose();
      if (skewness(frame.row(w).transpose()) < 0) frame.row(w) = -frame.row(w);
      out.ambiguity = AxisAmbiguity::kNone;
    }
  }
  for (int k = 0; k < 3; ++k) {
    const double skew = skewness(frame.row(k).transpose());
    out.skew[size_t(k)] = std::fabs(skew);
    out.sign_free[size_t(k)] = std::fabs(skew) < options.free_sign_skew;
  }
  out.axes = from_eigen(frame * axes);

  // The normalised AABB and radii, over the vertices triangles use.
  std::vector<char> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  bool first = true;
  for (size_t v = 0; v < used.size(); ++v) {
    if (!used[v]) continue;
    const Vec3d y = to_canonical(out, position(mesh, uint32_t(v)));
    const double c[3] = {y.x, y.y, y.z};
    const double r2 = squared_length(y);
    for (size_t k = 0; k < 3; ++k) {
      out.box_min[k] = first ? c[k] : std::min(out.box_min[k], c[k]);
      out.box_max[k] = first ? c[k] : std::max(out.box_max[k], c[k]);
      out.radial[k] = std::max(out.radial[k], std::sqrt(std::max(0.0, r2 - c[k] * c[k])));
    }
    out.radius = std::max(out.radius, std::sqrt(r2));
    first = false;
  }
  *pose = out;
  return true;
}

Vec3d to_canonical(const Pose& pose, const Vec3d& x) {
  return (1.0 / pose.scale) * multiply(pose.axes, x - pose.centroid);
}

AxisAmbiguity combined_ambiguity(const Pose& a, const Pose& b, int* distinct_axis) {
  *distinct_axis = 0;
  if (a.ambiguity == AxisAmbiguity::kFull || b.ambiguity == AxisAmbiguity::kFull) {
    return AxisAmbiguity::kFull;
  }
  const bool plane_a = a.ambiguity == AxisAmbiguity::kPlane;
  const bool plane_b = b.ambiguity == AxisAmbiguity::kPlane;
  if (plane_a && plane_b && a.distinct_axis != b.distinct_axis) return AxisAmbiguity::kFull;
  if (plane_a || plane_b) {
    *distinct_axis = plane_a ? a.distinct_axis : b.distinct_axis;
    return AxisAmbiguity::kPlane;
  }
  return AxisAmbiguity::kNone;
}

std::vector<Mat3> pose_alternatives(const Pose& a, const Pose& b) {
  int u = 0;
  const AxisAmbiguity ambiguity = combined_ambiguity(a, b, &u);
  std::vector<Mat3> out;
  if (ambiguity == AxisAmbiguity::kNone) {
    // Only signs are in doubt: flip every subset of the free axes (identity first).
    unsigned free = 0;
    for (int k = 0; k < 3; ++k) {
      if (a.sign_free[size_t(k)] || b.sign_free[size_t(k)]) free |= 1u << k;
    }
    for (unsigned mask = 0; mask < 8; ++mask) {
      if ((mask & ~free) != 0) continue;
      out.push_back(diagonal(mask & 1 ? -1 : 1, mask & 2 ? -1 : 1, mask & 4 ? -1 : 1));
    }
    return out;
  }
  if (ambiguity == AxisAmbiguity::kPlane) {
    // Free rotation about axis u: 24 turns (15 degrees apart), each also mirrored in the plane
    // (flipping axis w); and both signs of u when its skew is too small to tell.
    constexpr int kTurns = 24;
    const int v = (u + 1) % 3, w = (u + 2) % 3;
    const bool free_u = a.sign_free[size_t(u)] || b.sign_free[size_t(u)];
    for (int flip_u = 0; flip_u <= (free_u ? 1 : 0); ++flip_u) {
      for (int mirror = 0; mirror <= 1; ++mirror) {
        Mat3 flips = kIdentity3;
        if (flip_u) flips[3 * u + u] = -1;
        if (mirror) flips[3 * w + w] = -1;
        for (int k = 0; k < kTurns; ++k) {
          out.push_back(multiply(plane_rotation(v, w, 2.0 * std::numbers::pi * k / kTurns), flips));
        }
      }
    }
    return out;
  }
  static const std::vector<Mat3> rotations = rotation_set();
  out.reserve(2 * rotations.size() + 1);
  out.push_back(kIdentity3);
  for (const Mat3& r : rotations) {
    out.push_back(r);
    out.push_back(multiply(r, diagonal(1, 1, -1)));
  }
  return out;
}

}  // namespace osteon::detail
