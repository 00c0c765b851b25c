// SPDX-License-Identifier: Apache-2.0
#include "repeats_internal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "eigen_interop.hpp"

// Based on: S. Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991 (rotation from the SVD of the cross-covariance, the sign of its
// smallest singular direction chosen for the determinant, scale from the singular values);
// P. Besl, N. McKay, "A method for registration of 3-D shapes", IEEE PAMI 14(2), 1992
// (iterate: closest points, refit). Closest points are exact point-to-triangle distances from
// DistanceQuery (src/distance_query.cpp).
//
// Two departures from textbook ICP, both for repeats: the fit keeps the determinant's sign of the
// starting transform (Umeyama forces +1; a mirrored bone needs -1), and correspondences run both
// ways (a's samples to b and b's samples back to a), so that a member larger than the prototype
// in places is not ignored.

namespace osteon::detail {

Vec3d apply(const Similarity& s, const Vec3d& x) {
  return multiply(s.linear, x) + s.translation;
}

Similarity inverse(const Similarity& s) {
  Similarity out;
  Eigen::Map<Matrix3>(out.linear.data()) = Eigen::Map<const Matrix3>(s.linear.data()).inverse();
  out.translation = -1.0 * multiply(out.linear, s.translation);
  return out;
}

double similarity_scale(const Similarity& s) {
  return std::cbrt(std::fabs(determinant(s.linear)));
}

bool fit_similarity(const std::vector<Vec3d>& from, const std::vector<Vec3d>& to, int det_sign,
                    bool allow_scale, Similarity* out) {
  const size_t n = std::min(from.size(), to.size());
  if (n < 3) return false;
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_from += eig(from[i]);
    mean_to += eig(to[i]);
  }
  mean_from /= double(n);
  mean_to /= double(n);
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  double variance = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d f = eig(from[i]) - mean_from;
    cross += (eig(to[i]) - mean_to) * f.transpose();
    variance += f.squaredNorm();
  }
  cross /= double(n);
  variance /= double(n);
  if (!(variance > 0) || !std::isfinite(variance)) return false;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
  Eigen::Vector3d s(1, 1, 1);
  // U V^T is the best orthogonal matrix; flipping the direction of the smallest singular value
  // gives the best one of the other determinant.
  const double natural = (u * v.transpose()).determinant() < 0 ? -1.0 : 1.0;
  if (det_sign != 0 && natural * det_sign < 0) s(2) = -1;
  const Eigen::Matrix3d rotation = u * s.asDiagonal() * v.transpose();
  double scale = 1;
  if (allow_scale) {
    scale = svd.singularValues().dot(s) / variance;
    if (!(scale > 0) || !std::isfinite(scale)) return false;
  }
  const Eigen::Matrix3d linear = scale * rotation;
  const Eigen::Vector3d translation = mean_to - linear * mean_from;
  Eigen::Map<Matrix3>(out->linear.data()) = linear;
  out->translation = {translation.x(), translation.y(), translation.z()};
  return true;
}

namespace {

// Iterations before an ICP may give up.
constexpr int kGiveUpAfter = 3;

// The corner of triangle t of `mesh` nearest to x.
Vec3d nearest_corner(const Mesh& mesh, uint32_t t, const Vec3d& x) {
  Vec3d best = to_double(mesh.positions[mesh.indices[3 * size_t(t)]]);
  for (int k = 1; k < 3; ++k) {
    const Vec3d c = to_double(mesh.positions[mesh.indices[3 * size_t(t) + k]]);
    if (squared_length(c - x) < squared_length(best - x)) best = c;
  }
  return best;
}

}  // namespace

double corner_residual(const IcpSide& a, const IcpSide& b, const Similarity& t) {
  const Similarity back = inverse(t);
  const double scale = similarity_scale(t);
  double sum2 = 0;
  for (const Vec3d& p : *a.samples) {
    const Vec3d x = apply(t, p);
    const ClosestPoint c = b.query->closest(x);
    sum2 += squared_length(nearest_corner(*b.mesh, c.triangle, x) - x);
  }
  for (const Vec3d& q : *b.samples) {
    const Vec3d y = apply(back, q);
    const ClosestPoint c = a.query->closest(y);
    sum2 += scale * scale * squared_length(nearest_corner(*a.mesh, c.triangle, y) - y);
  }
  const size_t n = a.samples->size() + b.samples->size();
  return n > 0 ? std::sqrt(sum2 / double(n)) : 0.0;
}

IcpResult icp(const IcpSide& a, const IcpSide& b, const Similarity& start, bool allow_scale,
              int iterations, double give_up) {
  const int det_sign = determinant(start.linear) < 0 ? -1 : 1;
  const std::vector<Vec3d>& a_samples = *a.samples;
  const std::vector<Vec3d>& b_samples = *b.samples;
  std::vector<uint32_t> a_hints(a_samples.size(), ClosestPoint::kNoTriangle);
  std::vector<uint32_t> b_hints(b_samples.size(), ClosestPoint::kNoTriangle);
  std::vector<Vec3d> from, to;
  from.reserve(a_samples.size() + b_samples.size());
  to.reserve(from.capacity());

  IcpResult best;
  best.transform = start;
  best.rms = std::numeric_limits<double>::infinity();
  best.max = std::numeric_limits<double>::infinity();
  Similarity current = start;
  double previous = std::numeric_limits<double>::infinity();
  // Phase 0 pairs each sample with its closest point on the other surface; once that stops
  // improving, phase 1 pairs it with the nearest corner of that closest triangle instead, which
  // for a copy with the same vertices (in any order) gives the exact correspondences and the
  // exact transform, where closest points only creep towards it (a cylinder turning about its
  // axis, say).
  int phase = 0, phase_iterations = 0;
  for (int it = 0; it <= iterations; ++it) {
    from.clear();
    to.clear();
    const bool corners = phase == 1;
    const Similarity back = inverse(current);
    const double scale = similarity_scale(current);
    double sum2 = 0, max = 0;
    for (size_t i = 0; i < a_samples.size(); ++i) {
      const Vec3d x = apply(current, a_samples[i]);
      const ClosestPoint c = b.query->closest(x, a_hints[i]);
      a_hints[i] = c.triangle;
      from.push_back(a_samples[i]);
      to.push_back(corners ? nearest_corner(*b.mesh, c.triangle, x) : c.point);
      sum2 += c.distance * c.distance;
      max = std::max(max, c.distance);
    }
    for (size_t i = 0; i < b_samples.size(); ++i) {
      const Vec3d y = apply(back, b_samples[i]);
      const ClosestPoint c = a.query->closest(y, b_hints[i]);
      b_hints[i] = c.triangle;
      from.push_back(corners ? nearest_corner(*a.mesh, c.triangle, y) : c.point);
      to.push_back(b_samples[i]);
      const double d = scale * c.distance;  // the same distance measured in b's space
      sum2 += d * d;
      max = std::max(max, d);
    }
    const double rms = from.empty() ? 0.0 : std::sqrt(sum2 / double(from.size()));
    if (rms < best.rms) {
      best.transform = current;
      best.rms = rms;
      best.max = max;
      best.iterations = it;
    }
    if (!(rms > 0) || it == iterations) break;
    // Converged: the RMS no longer falls. Slow: the RMS (a lower bound of the largest
    // distance) is above give_up and, falling at its present rate for twice the iterations
    // allowed, would still be.
    const bool converged = phase_iterations > 0 && previous - rms <= 1e-9 * previous;
    const bool slow =
        give_up > 0 && phase_iterations >= kGiveUpAfter && rms > give_up &&
        (rms >= previous || rms * std::pow(rms / previous, 2.0 * iterations) > give_up);
    if (converged || slow) {
      if (phase == 1) {
        best.gave_up = slow && best.rms > give_up;
        break;
      }
      phase = 1;  // on to the corners, from the best so far
      phase_iterations = 0;
      current = best.transform;
      previous = std::numeric_limits<double>::infinity();
      continue;
    }
    previous = rms;
    ++phase_iterations;
    Similarity next;
    if (!fit_similarity(from, to, det_sign, allow_scale, &next)) break;
    current = next;
  }
  return best;
}

}  // namespace osteon::detail
