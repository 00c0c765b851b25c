// SPDX-License-Identifier: Apache-2.0
#include "support/phantom.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

// Based on: the subdivided icosahedron (Loop's 1-to-4 split projected to the sphere), swept
// generalized cylinders with rotation-minimizing-enough frames (a fixed reference vector), and
// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014).
//
// Everything is computed in double with + - * / and sqrt only (IEEE-exact operations), sine and
// cosine included (a short Taylor series after Cody-Waite reduction, below), so the bytes do not
// depend on the C library. They can still differ where a compiler contracts a * b + c into a fused
// multiply-add (-ffp-contract=fast on FMA hardware); the random stream itself is integer-exact.
//
// Orientation convention used by every builder: a grid vertex (i, j) has i running around (the
// angle) and j running along (the axis); the quad (i, j), (i+1, j), (i+1, j+1), (i, j+1) is split
// into (a, b, c) and (a, c, d). With the around-direction b and the along-direction t such that
// (outward n, b, t) is right-handed, these triangles are counter-clockwise seen from outside.

namespace osteon {

namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

/// sin(x) and cos(x) to about 1 ulp from + - * / only: x = k * pi/2 + r with |r| <= pi/4
/// (fdlibm's two-part pi/2, exact for |k| < 2^20), then Taylor series of sin r and cos r.
void sin_cos(double x, double* s, double* c) {
  constexpr double kPio2Hi = 1.57079632673412561417e+00;  // the first 33 bits of pi/2
  constexpr double kPio2Lo = 6.07710050650619224932e-11;  // pi/2 - kPio2Hi
  const double k = std::nearbyint(x * (2.0 / kPi));
  const double r = (x - k * kPio2Hi) - k * kPio2Lo;
  const double r2 = r * r;
  const double sr =
      r * (1 + r2 * (-1 / 6.0 +
                     r2 * (1 / 120.0 +
                           r2 * (-1 / 5040.0 + r2 * (1 / 362880.0 +
                                                     r2 * (-1 / 39916800.0 +
                                                           r2 * (1 / 6227020800.0 +
                                                                 r2 * (-1 / 1307674368000.0))))))));
  const double cr =
      1 + r2 * (-1 / 2.0 +
                r2 * (1 / 24.0 +
                      r2 * (-1 / 720.0 + r2 * (1 / 40320.0 +
                                               r2 * (-1 / 3628800.0 +
                                                     r2 * (1 / 479001600.0 +
                                                           r2 * (-1 / 87178291200.0 +
                                                                 r2 * (1 / 20922789888000.0))))))));
  switch (static_cast<int64_t>(k) & 3) {
    case 0:
      *s = sr, *c = cr;
      break;
    case 1:
      *s = cr, *c = -sr;
      break;
    case 2:
      *s = -sr, *c = -cr;
      break;
    default:
      *s = -cr, *c = sr;
      break;
  }
}
double sin_of(double x) {
  double s, c;
  sin_cos(x, &s, &c);
  return s;
}
double cos_of(double x) {
  double s, c;
  sin_cos(x, &s, &c);
  return c;
}

/// SplitMix64: a 64-bit state, integer-only, the same stream on every platform.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [-1, 1).
  double symmetric() { return double(next() >> 11) * 0x1.0p-52 - 1.0; }

 private:
  uint64_t state_;
};

/// A smooth bump: 1 at u = 0, 0 for |u| >= 1, C1 everywhere.
double bump(double u) {
  if (u <= -1 || u >= 1) return 0;
  const double w = 1 - u * u;
  return w * w;
}
double smoothstep(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * (3 - 2 * u);
}
/// A rounded end: 0 at s = 0 and s = 1, rising like a circle's quarter over a fraction `w` of the
/// length, 1 in between.
double end_cap(double s, double w) {
  const double m = std::min(s, 1 - s);
  if (m >= w) return 1;
  const double u = 1 - m / w;
  return std::sqrt(std::max(0.0, 1 - u * u));
}
/// The distance between two angles, in [0, pi].
double angle_between(double a, double b) {
  double d = std::fmod(std::fabs(a - b), 2 * kPi);
  return d > kPi ? 2 * kPi - d : d;
}

/// A mesh under construction, in double.
struct Builder {
  std::vector<Vec3d> points;
  std::vector<uint32_t> indices;

  uint32_t add(Vec3d p) {
    points.push_back(p);
    return static_cast<uint32_t>(points.size() - 1);
  }
  void triangle(uint32_t a, uint32_t b, uint32_t c) { indices.insert(indices.end(), {a, b, c}); }
  void quad(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    triangle(a, b, c);
    triangle(a, c, d);
  }
  /// Quads between consecutive rows of `grid` (rows of equal length), closing each row around.
  void rows_around(const std::vector<std::vector<uint32_t>>& grid) {
    for (size_t j = 0; j + 1 < grid.size(); ++j) {
      const size_t n = grid[j].size();
      for (size_t i = 0; i < n; ++i) {
        const size_t k = (i + 1) % n;
        quad(grid[j][i], grid[j][k], grid[j + 1][k], grid[j + 1][i]);
      }
    }
  }
  Mesh to_mesh() const {
    Mesh mesh;
    mesh.positions.reserve(points.size());
    for (const Vec3d& p : points) {
      mesh.positions.push_back(
          {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
    }
    mesh.indices = indices;
    mesh.stored_vertices = mesh.positions.size();
    return mesh;
  }
};

/// Drops the vertices no triangle uses, keeping the order of the others.
void drop_unreferenced(Builder& b) {
  std::vector<uint32_t> remap(b.points.size(), UINT32_MAX);
  for (uint32_t i : b.indices) remap[i] = 0;
  uint32_t next = 0;
  std::vector<Vec3d> kept;
  for (size_t v = 0; v < b.points.size(); ++v) {
    if (remap[v] == UINT32_MAX) continue;
    remap[v] = next++;
    kept.push_back(b.points[v]);
  }
  for (uint32_t& i : b.indices) i = remap[i];
  b.points = std::move(kept);
}

// ---- unit icosphere ------------------------------------------------------------------------

Builder unit_icosphere(int subdivisions) {
  // The icosahedron (+-1, +-phi, 0) and its cyclic permutations, faces counter-clockwise outside.
  const double t = (1 + std::sqrt(5.0)) / 2;
  Builder b;
  const Vec3d corners[12] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                             {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                             {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (const Vec3d& p : corners) b.add(normalize(p));
  b.indices = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
               4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
               6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
  for (int level = 0; level < subdivisions; ++level) {
    std::unordered_map<uint64_t, uint32_t> midpoints;
    midpoints.reserve(b.indices.size());
    auto midpoint = [&](uint32_t u, uint32_t v) {
      const uint64_t key = (uint64_t{std::min(u, v)} << 32) | std::max(u, v);
      auto [it, inserted] = midpoints.emplace(key, 0);
      if (inserted) it->second = b.add(normalize(0.5 * (b.points[u] + b.points[v])));
      return it->second;
    };
    std::vector<uint32_t> old;
    old.swap(b.indices);
    b.indices.reserve(4 * old.size());
    for (size_t f = 0; f < old.size(); f += 3) {
      const uint32_t p = old[f], q = old[f + 1], r = old[f + 2];
      const uint32_t pq = midpoint(p, q), qr = midpoint(q, r), rp = midpoint(r, p);
      b.triangle(p, pq, rp);
      b.triangle(q, qr, pq);
      b.triangle(r, rp, qr);
      b.triangle(pq, qr, rp);
    }
  }
  return b;
}

// ---- swept tubes closed by two poles (long bones, ribs, plates) ---------------------------------

struct TubeShape {
  std::function<Vec3d(double)> curve;  ///< the axis, s in [0, 1]; the poles are curve(0), curve(1)
  Vec3d reference;                     ///< never parallel to the axis: fixes the ring frames
  std::function<double(double)> rx;    ///< half-width along the frame's n, > 0 inside (0, 1)
  std::function<double(double)> ry;    ///< half-width along the frame's b
};

struct Frame {
  Vec3d center, n, b;
};

Frame tube_frame(const TubeShape& shape, double s) {
  const double h = 1e-5;
  const Vec3d t = normalize(shape.curve(std::min(1.0, s + h)) - shape.curve(std::max(0.0, s - h)));
  const Vec3d b = normalize(shape.reference - dot(shape.reference, t) * t);
  return {shape.curve(s), cross(b, t), b};  // (n, b, t) right-handed: n x b = t
}

/// Rings at s_j = (1 - cos(pi j / rings)) / 2, j = 1 .. rings-1 (denser near the poles, where
/// the rounded ends curve most), `segments` vertices each, closed by a pole at each end.
/// `ring_ids` receives the vertex ids of each ring, from s near 0 to s near 1.
Builder tube(const TubeShape& shape, int segments, int rings,
             std::vector<std::vector<uint32_t>>* ring_ids = nullptr,
             std::vector<Frame>* frames = nullptr) {
  Builder b;
  std::vector<std::vector<uint32_t>> grid;
  const uint32_t pole0 = b.add(shape.curve(0));
  for (int j = 1; j < rings; ++j) {
    const double s = 0.5 * (1 - cos_of(kPi * j / rings));
    const Frame f = tube_frame(shape, s);
    const double rx = shape.rx(s), ry = shape.ry(s);
    std::vector<uint32_t> ring;
    for (int i = 0; i < segments; ++i) {
      double sn, cs;
      sin_cos(2 * kPi * i / segments, &sn, &cs);
      ring.push_back(b.add(f.center + (rx * cs) * f.n + (ry * sn) * f.b));
    }
    grid.push_back(std::move(ring));
    if (frames) frames->push_back(f);
  }
  const uint32_t pole1 = b.add(shape.curve(1));
  b.rows_around(grid);
  for (int i = 0; i < segments; ++i) {
    const int k = (i + 1) % segments;
    b.triangle(pole0, grid.front()[k], grid.front()[i]);
    b.triangle(grid.back()[i], grid.back()[k], pole1);
  }
  if (ring_ids) *ring_ids = std::move(grid);
  return b;
}

// ---- ring bones (genus 1): a tube around an ellipse in the XY plane -----------------------------

struct RingShape {
  double radius_x = 20, radius_y = 20;        ///< the centre ellipse
  std::function<double(double)> half_width;   ///< in-plane tube half-width at angle u
  std::function<double(double)> half_height;  ///< vertical tube half-height at angle u
  std::function<double(double)> process;      ///< extra outward reach at u (outer side only)
};

Builder ring_bone(const RingShape& shape, int around, int tube_segments) {
  Builder b;
  std::vector<std::vector<uint32_t>> grid;  // rows by u, closed around in v
  for (int i = 0; i < around; ++i) {
    double su, cu;
    sin_cos(2 * kPi * i / around, &su, &cu);
    const double u = 2 * kPi * i / around;
    const Vec3d centre{shape.radius_x * cu, shape.radius_y * su, 0};
    const Vec3d n = normalize(Vec3d{shape.radius_y * cu, shape.radius_x * su, 0});
    const double a = shape.half_width(u), h = shape.half_height(u), p = shape.process(u);
    std::vector<uint32_t> row;
    for (int j = 0; j < tube_segments; ++j) {
      double sv, cv;
      sin_cos(2 * kPi * j / tube_segments, &sv, &cv);
      const double outward = a * cv + (cv > 0 ? p * cv * cv : 0.0);
      row.push_back(b.add(centre + outward * n + Vec3d{0, 0, h * sv}));
    }
    grid.push_back(std::move(row));
  }
  // Vertex (i, j) = grid[i][j]; quads (i,j), (i+1,j), (i+1,j+1), (i,j+1) with i around the
  // ellipse (counter-clockwise from +Z) and j around the tube (from outward towards +Z).
  for (int i = 0; i < around; ++i) {
    const int i1 = (i + 1) % around;
    for (int j = 0; j < tube_segments; ++j) {
      const int j1 = (j + 1) % tube_segments;
      b.quad(grid[i][j], grid[i1][j], grid[i1][j1], grid[i][j1]);
    }
  }
  return b;
}

// ---- transforms ----------------------------------------------------------------------------

Mat4 translation(Vec3d t) {
  Mat4 m = kIdentityMatrix;
  m[12] = t.x, m[13] = t.y, m[14] = t.z;
  return m;
}
Mat4 rotation_x(double angle) {
  double s, c;
  sin_cos(angle, &s, &c);
  Mat4 m = kIdentityMatrix;
  m[5] = c, m[6] = s, m[9] = -s, m[10] = c;
  return m;
}
Mat4 rotation_z(double angle) {
  double s, c;
  sin_cos(angle, &s, &c);
  Mat4 m = kIdentityMatrix;
  m[0] = c, m[1] = s, m[4] = -s, m[5] = c;
  return m;
}
Mat4 reflection_x() {
  Mat4 m = kIdentityMatrix;
  m[0] = -1;
  return m;
}
/// Rotates by `rotation` about `pivot`, then moves by `offset`.
Mat4 rotate_about(const Mat4& rotation, Vec3d pivot, Vec3d offset) {
  return multiply(multiply(translation(pivot + offset), rotation), translation(Vec3d{} - pivot));
}

Builder moved(Builder b, Vec3d offset) {
  for (Vec3d& p : b.points) p = p + offset;
  return b;
}

// ---- the bones -----------------------------------------------------------------------------

/// Segment counts for `detail`: tubes get 4 * 2^d around and 8 * 2^d rings (about 64 * 4^d
/// triangles), ring bones 8 * 2^d by 4 * 2^d, the skull an icosphere of d + 1 subdivisions.
struct Resolution {
  int around, along;
};
Resolution resolution(int detail) {
  return {4 << detail, 8 << detail};
}

/// A long bone along +Z from `base`: a shaft with a bulbous distal end (condyles, at s = 0) and a
/// proximal head (s = 1) that leans towards -X (medially, for a left bone).
Builder long_bone(Vec3d base, double length, double shaft, double distal, double proximal,
                  double head_offset, double flatten, int detail) {
  const double cap = 1.15 * std::max(distal + shaft, proximal + shaft) / length;
  TubeShape shape;
  shape.curve = [=](double s) {
    return base + Vec3d{-head_offset * smoothstep((s - 0.8) / 0.2), 0, length * s};
  };
  shape.reference = {0, 1, 0};
  shape.rx = [=](double s) {
    return end_cap(s, cap) *
           (shaft + distal * bump((s - 0.05) / 0.13) + proximal * bump((s - 0.95) / 0.11));
  };
  shape.ry = [=](double s) { return flatten * shape.rx(s); };
  const Resolution r = resolution(detail);
  return tube(shape, r.around, r.along);
}

Builder skull(Vec3d centre, int detail) {
  Builder b = unit_icosphere(detail + 1);
  const Vec3d jaw = normalize(Vec3d{0, 0.75, -0.66});
  const Vec3d brow = normalize(Vec3d{0, 0.9, 0.3});
  for (Vec3d& u : b.points) {
    const double ax = u.x / 72, ay = u.y / 92, az = u.z / 84;
    const double ellipsoid = 1 / std::sqrt(ax * ax + ay * ay + az * az);
    const double r = ellipsoid + 22 * bump(std::sqrt(dot(u - jaw, u - jaw)) / 0.75) +
                     5 * bump(std::sqrt(dot(u - brow, u - brow)) / 0.35) -
                     8 * bump((u.z + 1) / 0.45);  // a flatter base
    u = centre + r * u;
  }
  return b;
}

Builder vertebra(Vec3d centre, int detail) {
  RingShape shape;
  shape.radius_x = 20;
  shape.radius_y = 17;
  auto front = [](double u) { return 0.5 * (1 + sin_of(u)); };  // 1 at the body (+Y), 0 behind
  shape.half_width = [=](double u) { return 4.5 + 9 * front(u) * front(u); };
  shape.half_height = [=](double u) { return 6 + 9 * front(u) * front(u); };
  shape.process = [](double u) {
    return 26 * bump(angle_between(u, 1.5 * kPi) / 0.35) +  // spinous process, behind
           16 * bump(angle_between(u, 0) / 0.3) + 16 * bump(angle_between(u, kPi) / 0.3);
  };
  const Resolution r = resolution(detail);
  return moved(ring_bone(shape, r.along, r.around), centre);
}

Builder atlas(Vec3d centre, int detail) {
  RingShape shape;
  shape.radius_x = 23;
  shape.radius_y = 19;
  shape.half_width = [](double u) {
    return 3.5 + 3 * bump(angle_between(u, 0) / 0.8) + 3 * bump(angle_between(u, kPi) / 0.8);
  };
  shape.half_height = [](double u) {
    return 4 + 3 * bump(angle_between(u, 0) / 0.8) + 3 * bump(angle_between(u, kPi) / 0.8);
  };
  shape.process = [](double u) {
    return 12 * bump(angle_between(u, 0) / 0.3) + 12 * bump(angle_between(u, kPi) / 0.3);
  };
  const Resolution r = resolution(detail);
  return moved(ring_bone(shape, r.along, r.around), centre);
}

/// A left rib: a flat band from the spine (behind) around the side to the front, falling as it
/// goes.
Builder rib(Vec3d origin, int detail) {
  TubeShape shape;
  shape.curve = [=](double s) {
    double sn, cs;
    sin_cos((-80 + 150 * s) * kPi / 180, &sn, &cs);
    return origin + Vec3d{30 + 100 * cs, 90 * sn, -45 * s};
  };
  shape.reference = {0, 0, 1};
  shape.rx = [](double s) { return 3.5 * end_cap(s, 0.02); };
  shape.ry = [](double s) { return (6 + 2 * s) * end_cap(s, 0.02); };
  const Resolution r = resolution(detail);
  return tube(shape, r.around, r.along);
}

/// A left scapula: a thin triangular plate in the XZ plane behind the ribs, with a fin (the
/// scapular spine) standing out of its back and sharing a row of the plate's edges: those edges
/// have three triangles each, and `*nonmanifold_edges` receives their number. The fin's free
/// edges make one open boundary chain from one end of the shared row to the other: one loop.
Builder scapula(Vec3d base, int detail, int* nonmanifold_edges) {
  TubeShape shape;
  shape.curve = [=](double s) { return base + Vec3d{0, 0, 150 * s}; };
  shape.reference = {0, -1, 0};  // b points backwards: the plate's back is at angle pi/2
  shape.rx = [](double s) { return (12 + 45 * s) * end_cap(s, 0.05); };
  shape.ry = [](double s) { return 4 * end_cap(s, 0.05); };
  const Resolution r = resolution(detail);
  std::vector<std::vector<uint32_t>> rings;
  std::vector<Frame> frames;
  Builder b = tube(shape, r.around, r.along, &rings, &frames);

  // rings[k] is ring j = k + 1; its vertex around/4 sits at angle pi/2, on the back.
  const int back = r.around / 4;
  const int first = std::max(1, int(0.55 * r.along)) - 1;
  const int last = std::min(r.along - 1, int(0.85 * r.along)) - 1;
  const int rows = std::max(2, r.around / 8);
  std::vector<std::vector<uint32_t>> fin;  // fin[k][row]: row 0 is the plate's own vertex
  for (int k = first; k <= last; ++k) {
    const uint32_t foot = rings[k][back];
    const Frame& f = frames[k];
    const double height = 10 + 8 * sin_of(kPi * (k - first) / (last - first));
    std::vector<uint32_t> column{foot};
    for (int row = 1; row <= rows; ++row) {
      const double q = double(row) / rows;
      column.push_back(b.add(b.points[foot] + (height * q) * f.b + (3 * q * q) * f.n));
    }
    fin.push_back(std::move(column));
  }
  for (size_t k = 0; k + 1 < fin.size(); ++k) {
    for (int row = 0; row < rows; ++row) {
      b.quad(fin[k][row], fin[k + 1][row], fin[k + 1][row + 1], fin[k][row + 1]);
    }
  }
  *nonmanifold_edges = last - first;
  return b;
}

/// A pelvis-like open basin: a flared open tube (the inlet above, the outlet below) with two
/// obturator foramina cut out at the front. Four boundary loops, genus 0.
Builder pelvis(Vec3d base, int detail) {
  const int around = 8 << detail, rows = 4 << detail;
  Builder b;
  std::vector<std::vector<uint32_t>> grid;
  for (int j = 0; j <= rows; ++j) {
    const double t = double(j) / rows;
    const double rx = 55 + 75 * t * t, ry = 45 + 25 * t;
    std::vector<uint32_t> ring;
    for (int i = 0; i < around; ++i) {
      double sn, cs;
      sin_cos(2 * kPi * i / around, &sn, &cs);
      ring.push_back(b.add(base + Vec3d{rx * cs, ry * sn - 10 * t, 160 * t}));
    }
    grid.push_back(std::move(ring));
  }
  // Holes: quads in rows [rows/4, rows/2) and two column ranges either side of the front (+Y,
  // column around/4), two columns apart, so the holes touch neither each other nor the rims.
  const int front = around / 4, gap = around / 16;
  auto in_hole = [&](int i, int j) {
    const bool row_in = j >= rows / 4 && j < rows / 2;
    const bool left = i >= front - 3 * gap && i < front - gap;
    const bool right = i >= front + gap && i < front + 3 * gap;
    return row_in && (left || right);
  };
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < around; ++i) {
      if (in_hole(i, j)) continue;
      const int k = (i + 1) % around;
      b.quad(grid[j][i], grid[j][k], grid[j + 1][k], grid[j + 1][i]);
    }
  }
  drop_unreferenced(b);
  return b;
}

}  // namespace

// ---- primitives ----------------------------------------------------------------------------

Mesh make_icosphere(int subdivisions, float radius) {
  assert(subdivisions >= 0 && subdivisions <= 12);
  Builder b = unit_icosphere(std::clamp(subdivisions, 0, 12));
  for (Vec3d& p : b.points) p = double(radius) * p;
  return b.to_mesh();
}

Mesh make_torus(float major_radius, float minor_radius, int major_segments, int minor_segments) {
  assert(major_segments >= 3 && minor_segments >= 3);
  if (major_segments < 3 || minor_segments < 3) return {};
  RingShape shape;
  shape.radius_x = shape.radius_y = major_radius;
  shape.half_width = shape.half_height = [=](double) { return double(minor_radius); };
  shape.process = [](double) { return 0.0; };
  return ring_bone(shape, major_segments, minor_segments).to_mesh();
}

Mesh make_open_cylinder(float radius, float height, int segments, int rings) {
  assert(segments >= 3 && rings >= 1);
  if (segments < 3 || rings < 1) return {};
  Builder b;
  std::vector<std::vector<uint32_t>> grid;
  for (int j = 0; j <= rings; ++j) {
    const double z = double(height) * (double(j) / rings - 0.5);
    std::vector<uint32_t> ring;
    for (int i = 0; i < segments; ++i) {
      double sn, cs;
      sin_cos(2 * kPi * i / segments, &sn, &cs);
      ring.push_back(b.add({radius * cs, radius * sn, z}));
    }
    grid.push_back(std::move(ring));
  }
  b.rows_around(grid);
  return b.to_mesh();
}

Mesh make_box(Vec3 min, Vec3 max) {
  // Vertex i has x = max.x when bit 0 is set, y when bit 1, z when bit 2: vertex 0 is `min`,
  // vertex 1 is (max.x, min.y, min.z).
  Mesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.positions.push_back(
        {(i & 1) ? max.x : min.x, (i & 2) ? max.y : min.y, (i & 4) ? max.z : min.z});
  }
  mesh.indices = {0, 2, 3, 0, 3, 1,   // -Z
                  4, 5, 7, 4, 7, 6,   // +Z
                  0, 1, 5, 0, 5, 4,   // -Y
                  2, 6, 7, 2, 7, 3,   // +Y
                  0, 4, 6, 0, 6, 2,   // -X
                  1, 3, 7, 1, 7, 5};  // +X
  mesh.stored_vertices = 8;
  return mesh;
}

Mesh make_nonmanifold_book() {
  // The spine is the edge 0-1 on the Z axis; page k is the unit quad towards angle 120k degrees,
  // split so that only its second triangle holds the spine.
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {0, 0, 1}};
  const float h = 0.8660254037844386f;  // sin 60
  const Vec3 directions[3] = {{1, 0, 0}, {-0.5f, h, 0}, {-0.5f, -h, 0}};
  for (int k = 0; k < 3; ++k) {
    const uint32_t a = uint32_t(mesh.positions.size());
    mesh.positions.push_back(directions[k]);
    mesh.positions.push_back({directions[k].x, directions[k].y, 1});
    mesh.indices.insert(mesh.indices.end(), {0, a, a + 1, 0, a + 1, 1});
  }
  mesh.stored_vertices = mesh.positions.size();
  return mesh;
}

Mesh make_bowtie_tetrahedra() {
  // Corner tetrahedra (0, e_x, e_y, e_z) and its point reflection, sharing the origin (vertex 0).
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  mesh.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,   // the first, outward
                  0, 4, 5, 0, 6, 4, 0, 5, 6, 4, 6, 5};  // the reflection, winding reversed
  mesh.stored_vertices = mesh.positions.size();
  return mesh;
}

// ---- the phantom skeleton ------------------------------------------------------------------

Phantom make_phantom(const PhantomOptions& options) {
  // detail outside [1, 6] is clamped: 1 keeps every hole and fin representable, 6 is ~260k
  // triangles a bone.
  const int detail = std::clamp(options.detail, 1, 6);
  SplitMix64 rng(options.seed);
  Phantom out;
  std::vector<Builder> built;  // the double-precision geometry of each part, for copies

  auto add = [&](Builder b, PhantomPart part) {
    Mesh mesh = b.to_mesh();
    mesh.name = part.name;
    mesh.unit = Unit::kMillimetre;
    mesh.unit_source = UnitSource::kUser;
    out.scene.parts.push_back(std::move(mesh));
    out.truth.push_back(std::move(part));
    built.push_back(std::move(b));
  };
  auto original = [&](const std::string& name, Builder b, PhantomKind kind = PhantomKind::kOriginal,
                      int genus = 0, int loops = 0, int nonmanifold = 0) {
    PhantomPart part;
    part.name = name;
    part.kind = kind;
    part.genus = genus;
    part.boundary_loops = loops;
    part.nonmanifold_edges = nonmanifold;
    add(std::move(b), std::move(part));
  };
  // A copy is made from the original's float positions (what a reader of the scene sees), so
  // `transform` maps the scene's original onto the scene's copy up to float rounding.
  auto copy = [&](const std::string& name, const std::string& of, PhantomKind kind,
                  const Mat4& transform, float noise = 0.0f) {
    size_t source = 0;
    while (out.truth[source].name != of) ++source;
    const Mesh& from = out.scene.parts[source];
    PhantomPart part = out.truth[source];
    part.name = name;
    part.kind = kind;
    part.copy_of = of;
    part.transform = transform;
    part.noise = noise;
    Builder b;
    b.indices = built[source].indices;
    const double spread = double(noise) / std::sqrt(3.0);  // |offset| <= noise
    for (const Vec3& p : from.positions) {
      Vec3d q = transform_point(transform, Vec3d{p.x, p.y, p.z});
      if (noise > 0) {
        const double dx = rng.symmetric(), dy = rng.symmetric(), dz = rng.symmetric();
        q = q + spread * Vec3d{dx, dy, dz};
      }
      b.points.push_back(q);
    }
    if (determinant3(transform) < 0) {  // a reflection turns the surface inside out: re-wind
      for (size_t f = 0; f < b.indices.size(); f += 3)
        std::swap(b.indices[f + 1], b.indices[f + 2]);
    }
    add(std::move(b), std::move(part));
  };

  // Millimetres, standing: Z up from the soles, +X the body's left, +Y forwards.
  original("skull", skull({0, 10, 1600}, detail));
  original("atlas_c1", atlas({0, -15, 1470}, detail), PhantomKind::kGenusOne, 1);
  const Vec3d l1{0, -45, 1150};
  original("vertebra_l1", vertebra(l1, detail), PhantomKind::kOriginal, 1);
  copy("vertebra_l2", "vertebra_l1", PhantomKind::kRotatedCopy,
       rotate_about(rotation_x(4 * kPi / 180), l1, {0, 2, -38}));
  copy("vertebra_l3", "vertebra_l1", PhantomKind::kRotatedCopy,
       rotate_about(rotation_x(9 * kPi / 180), l1, {0, 5, -77}));
  const Vec3d rib_origin{0, -20, 1330};
  original("rib_l1", rib(rib_origin, detail));
  copy("rib_l2", "rib_l1", PhantomKind::kNoisyCopy,
       rotate_about(multiply(rotation_z(-3 * kPi / 180), rotation_x(2 * kPi / 180)), rib_origin,
                    {0, 0, -26}),
       0.05f);
  int scapula_edges = 0;
  Builder plate = scapula({95, -105, 1190}, detail, &scapula_edges);
  original("scapula_l", std::move(plate), PhantomKind::kNonManifold, -1, 1, scapula_edges);
  original("humerus_l", long_bone({195, -10, 1060}, 300, 9, 10, 14, 12, 0.9, detail));
  copy("humerus_r", "humerus_l", PhantomKind::kMirroredCopy,
       multiply(translation({0, 4, 0}), reflection_x()));
  original("pelvis", pelvis({0, 0, 880}, detail), PhantomKind::kWithHoles, 0, 4);
  original("femur_l", long_bone({95, 0, 470}, 440, 12, 16, 13, 22, 0.85, detail));
  copy("femur_r", "femur_l", PhantomKind::kMirroredCopy,
       multiply(translation({0, 5, 0}), reflection_x()));
  original("phalanx_2_l", long_bone({235, 40, 820}, 40, 4.5, 2.5, 2, 1, 0.8, detail));
  for (int finger = 3; finger <= 5; ++finger) {
    copy("phalanx_" + std::to_string(finger) + "_l", "phalanx_2_l", PhantomKind::kExactCopy,
         translation({0, -17.0 * (finger - 2), -4.0 * (finger - 2)}));
  }
  return out;
}

}  // namespace osteon
