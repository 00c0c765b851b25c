// SPDX-License-Identifier: Apache-2.0
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "distance_internal.hpp"
#include "osteon/hausdorff.hpp"

// Based on: bounding-volume hierarchies for nearest-surface queries (a binary tree of axis-aligned
// boxes; the query descends nearer child first and skips every box farther than the best triangle
// found so far; see e.g. Ericson, "Real-Time Collision Detection", chapter 6). The split is the
// object median along the longest axis of the triangle centroids: on scanned or marching-cubes
// surfaces, whose triangles are all about the same size, it builds as good a tree for this query
// as a surface-area heuristic, and since each split depends only on the triangle count, the node
// layout is known in advance and the two halves build in parallel into one array.

namespace osteon {

namespace {

constexpr uint32_t kLeafSize = 4;
// Ranges at least this large build their two halves as parallel tasks.
constexpr uint32_t kParallelBuild = 1u << 14;

struct Node {
  float lo[3];
  uint32_t first;  ///< inner: the left child (the right is first + 1); leaf: first triangle slot
  float hi[3];
  uint32_t count;  ///< leaf: 1..kLeafSize triangles; inner: 0
};

struct StoredTriangle {
  Vec3 a, b, c;
};

// Squared distance from q to the box of `node` (0 inside), in float: within slack (see
// DistanceQuery::closest) of the exact value.
inline float box_distance2(const Node& node, const float q[3]) {
  float d2 = 0;
  for (int axis = 0; axis < 3; ++axis) {
    float d = std::max(std::max(node.lo[axis] - q[axis], q[axis] - node.hi[axis]), 0.0f);
    d2 += d * d;
  }
  return d2;
}

// Nodes in the subtree over n triangles: halves (n/2 and n - n/2) until a range fits a leaf. Only
// O(log n) distinct sizes occur, so every size the build asks for is computed once, up front.
class SubtreeSizes {
 public:
  explicit SubtreeSizes(uint32_t n) { count(n); }
  uint32_t operator()(uint32_t n) const { return memo_.at(n); }

 private:
  uint32_t count(uint32_t n) {
    auto found = memo_.find(n);
    if (found != memo_.end()) return found->second;
    uint32_t nodes = n <= kLeafSize ? 1 : 1 + count(n / 2) + count(n - n / 2);
    memo_.emplace(n, nodes);
    return nodes;
  }
  std::unordered_map<uint32_t, uint32_t> memo_;
};

// A triangle as the build sorts it: its centroid, its box and its id, side by side, so that each
// node's pass over its range reads memory in order.
struct BuildItem {
  float centroid[3];
  float lo[3];
  float hi[3];
  uint32_t id;
};

struct Builder {
  std::vector<BuildItem> items;  // leaf order once built
  std::vector<Node> nodes;
  SubtreeSizes sizes;

  // Fills nodes[node] over items[begin, end); its descendants go from nodes[next] on.
  void build(uint32_t node, uint32_t begin, uint32_t end, uint32_t next) {
    float lo[3] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                   std::numeric_limits<float>::max()};
    float hi[3] = {-lo[0], -lo[0], -lo[0]};
    float clo[3] = {lo[0], lo[1], lo[2]}, chi[3] = {hi[0], hi[1], hi[2]};
    for (uint32_t i = begin; i < end; ++i) {
      const BuildItem& item = items[i];
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = std::min(lo[axis], item.lo[axis]);
        hi[axis] = std::max(hi[axis], item.hi[axis]);
        clo[axis] = std::min(clo[axis], item.centroid[axis]);
        chi[axis] = std::max(chi[axis], item.centroid[axis]);
      }
    }
    Node& out = nodes[node];
    std::copy(lo, lo + 3, out.lo);
    std::copy(hi, hi + 3, out.hi);
    uint32_t n = end - begin;
    if (n <= kLeafSize) {
      out.first = begin;
      out.count = n;
      return;
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    }
    uint32_t mid = begin + n / 2;
    // Ties broken by id: the tree depends on the mesh alone, not on the sort's internals.
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                     [axis](const BuildItem& x, const BuildItem& y) {
                       float cx = x.centroid[axis], cy = y.centroid[axis];
                       return cx < cy || (cx == cy && x.id < y.id);
                     });
    out.first = next;
    out.count = 0;
    uint32_t left_next = next + 2;
    uint32_t right_next = left_next + sizes(n / 2) - 1;
    auto left = [&] { build(next, begin, mid, left_next); };
    auto right = [&] { build(next + 1, mid, end, right_next); };
    if (n >= kParallelBuild) {
      tbb::parallel_invoke(left, right);
    } else {
      left();
      right();
    }
  }
};

}  // namespace

namespace detail {

std::string mesh_label(const Mesh& mesh) {
  if (!mesh.source.empty()) return mesh.source;
  return mesh.name.empty() ? std::string("mesh") : mesh.name;
}

Status check_surface(const Mesh& mesh) {
  if (mesh.indices.size() < 3) {
    return error(ErrorCode::kInvalidArgument, mesh_label(mesh),
                 "has no triangles: a distance between surfaces needs triangles on both sides");
  }
  if (mesh.indices.size() % 3 != 0) {
    return error(ErrorCode::kInvalidArgument, mesh_label(mesh),
                 "index count " + std::to_string(mesh.indices.size()) + " is not a multiple of 3");
  }
  if (mesh.triangle_count() >= ClosestPoint::kNoTriangle) {
    return error(ErrorCode::kInvalidArgument, mesh_label(mesh), "has more than 2^32 - 2 triangles");
  }
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= mesh.positions.size()) {
      return error(ErrorCode::kInvalidArgument, mesh_label(mesh),
                   "index " + std::to_string(mesh.indices[i]) + " out of range (" +
                       std::to_string(mesh.positions.size()) + " vertices)",
                   "triangle " + std::to_string(i / 3));
    }
  }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return error(ErrorCode::kInvalidData, mesh_label(mesh),
                   "non-finite coordinate (" + std::to_string(p.x) + ", " + std::to_string(p.y) +
                       ", " + std::to_string(p.z) + ")",
                   "vertex " + std::to_string(v));
    }
  }
  return Status::ok_status();
}

}  // namespace detail

struct DistanceQuery::Impl {
  std::vector<Node> nodes;
  std::vector<StoredTriangle> triangles;  // in leaf order ("slots")
  std::vector<uint32_t> ids;              // triangle id of each slot
  std::vector<uint32_t> slots;            // slot of each triangle id
  Aabb bounds;
  double largest_coordinate = 0;  // of the box's corners, in magnitude
};

DistanceQuery::DistanceQuery(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DistanceQuery::DistanceQuery(DistanceQuery&&) noexcept = default;
DistanceQuery& DistanceQuery::operator=(DistanceQuery&&) noexcept = default;
DistanceQuery::~DistanceQuery() = default;

Result<DistanceQuery> DistanceQuery::build(const Mesh& mesh) {
  OSTEON_RETURN_IF_ERROR(detail::check_surface(mesh));
  uint32_t count = static_cast<uint32_t>(mesh.triangle_count());
  Builder builder{{}, {}, SubtreeSizes(count)};
  builder.items.resize(count);
  for (uint32_t t = 0; t < count; ++t) {
    const Vec3& a = mesh.positions[mesh.indices[3 * size_t(t)]];
    const Vec3& b = mesh.positions[mesh.indices[3 * size_t(t) + 1]];
    const Vec3& c = mesh.positions[mesh.indices[3 * size_t(t) + 2]];
    BuildItem& item = builder.items[t];
    item.centroid[0] = (a.x + b.x + c.x) / 3;
    item.centroid[1] = (a.y + b.y + c.y) / 3;
    item.centroid[2] = (a.z + b.z + c.z) / 3;
    item.lo[0] = std::min({a.x, b.x, c.x});
    item.lo[1] = std::min({a.y, b.y, c.y});
    item.lo[2] = std::min({a.z, b.z, c.z});
    item.hi[0] = std::max({a.x, b.x, c.x});
    item.hi[1] = std::max({a.y, b.y, c.y});
    item.hi[2] = std::max({a.z, b.z, c.z});
    item.id = t;
  }
  builder.nodes.resize(builder.sizes(count));
  builder.build(0, 0, count, 1);

  auto impl = std::make_unique<Impl>();
  impl->nodes = std::move(builder.nodes);
  impl->ids.resize(count);
  for (uint32_t slot = 0; slot < count; ++slot) impl->ids[slot] = builder.items[slot].id;
  builder.items = {};
  impl->triangles.resize(count);
  impl->slots.resize(count);
  for (uint32_t slot = 0; slot < count; ++slot) {
    uint32_t t = impl->ids[slot];
    impl->slots[t] = slot;
    impl->triangles[slot] = {mesh.positions[mesh.indices[3 * size_t(t)]],
                             mesh.positions[mesh.indices[3 * size_t(t) + 1]],
                             mesh.positions[mesh.indices[3 * size_t(t) + 2]]};
  }
  const Node& root = impl->nodes[0];
  impl->bounds.min = {root.lo[0], root.lo[1], root.lo[2]};
  impl->bounds.max = {root.hi[0], root.hi[1], root.hi[2]};
  impl->bounds.empty = false;
  for (int axis = 0; axis < 3; ++axis) {
    impl->largest_coordinate = std::max({impl->largest_coordinate, std::fabs(double(root.lo[axis])),
                                         std::fabs(double(root.hi[axis]))});
  }
  return DistanceQuery(std::move(impl));
}

size_t DistanceQuery::triangle_count() const {
  return impl_->ids.size();
}

Aabb DistanceQuery::bounds() const {
  return impl_->bounds;
}

ClosestPoint DistanceQuery::closest(const Vec3d& p) const {
  return closest(p, ClosestPoint::kNoTriangle);
}

ClosestPoint DistanceQuery::closest(const Vec3d& p, uint32_t hint) const {
  return closest(p, hint, -1.0);
}

ClosestPoint DistanceQuery::closest(const Vec3d& p, uint32_t hint, double enough) const {
  const Impl& tree = *impl_;
  const double enough2 = enough < 0 ? -1.0 : enough * enough;
  // Boxes are tested in float, for speed: the query point rounded to float and the float box
  // subtracted are each within 2^-24 of their magnitude, so a box distance is within
  // 2^-22 (|p| + the mesh's largest coordinate) of the exact one. A box is skipped only when it is
  // farther than the best distance plus 2^-20 times that, so no box that may hold a nearer
  // triangle is ever skipped: the answer is the exact nearest, only a few more boxes are opened.
  const float q[3] = {float(p.x), float(p.y), float(p.z)};
  double slack = 0x1p-20 * (tree.largest_coordinate +
                            std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}));
  double best2 = std::numeric_limits<double>::infinity();
  float prune2 = std::numeric_limits<float>::infinity();  // (sqrt(best2) + slack)^2, rounded up
  uint32_t best_slot = ClosestPoint::kNoTriangle;
  Vec3d best_point;
  auto visit = [&](uint32_t slot) {
    const StoredTriangle& t = tree.triangles[slot];
    // The triangle's own box first: a few float operations against the exact test's sixty.
    float d2_box = 0;
    const float lo[3] = {std::min({t.a.x, t.b.x, t.c.x}), std::min({t.a.y, t.b.y, t.c.y}),
                         std::min({t.a.z, t.b.z, t.c.z})};
    const float hi[3] = {std::max({t.a.x, t.b.x, t.c.x}), std::max({t.a.y, t.b.y, t.c.y}),
                         std::max({t.a.z, t.b.z, t.c.z})};
    for (int axis = 0; axis < 3; ++axis) {
      float d = std::max(std::max(lo[axis] - q[axis], q[axis] - hi[axis]), 0.0f);
      d2_box += d * d;
    }
    if (d2_box > prune2) return;
    Vec3d point;
    double d2 =
        detail::closest_on_triangle(p, to_double(t.a), to_double(t.b), to_double(t.c), &point);
    if (d2 < best2) {
      best2 = d2;
      best_slot = slot;
      best_point = point;
      double reach = std::sqrt(d2) + slack;
      prune2 = float(reach * reach * (1 + 0x1p-20));
    }
  };
  if (hint < tree.slots.size()) visit(tree.slots[hint]);
  // Near enough: a box is only ever opened below prune2, so an empty stack ends the search.
  auto near_enough = [&] { return best2 <= enough2; };

  // Depth-first, nearer child first; each entry keeps its box's squared distance so that a box
  // is dropped, when popped, if a nearer triangle was found since it was pushed. The tree is
  // balanced (median splits), so its depth is at most about log2(T), far below the stack size.
  struct Entry {
    float d2;
    uint32_t node;
  };
  Entry stack[128];
  int top = 0;
  if (!near_enough()) stack[top++] = {box_distance2(tree.nodes[0], q), 0};
  while (top > 0) {
    Entry e = stack[--top];
    if (e.d2 > prune2) continue;
    const Node& node = tree.nodes[e.node];
    if (node.count > 0) {
      for (uint32_t s = node.first; s < node.first + node.count; ++s) visit(s);
      if (near_enough()) break;
      continue;
    }
    uint32_t near = node.first, far = node.first + 1;
    float near2 = box_distance2(tree.nodes[near], q);
    float far2 = box_distance2(tree.nodes[far], q);
    if (far2 < near2) {
      std::swap(near, far);
      std::swap(near2, far2);
    }
    if (far2 <= prune2) stack[top++] = {far2, far};
    if (near2 <= prune2) stack[top++] = {near2, near};
  }
  ClosestPoint best;
  best.distance = std::sqrt(best2);
  best.point = best_point;
  best.triangle = tree.ids[best_slot];
  return best;
}

}  // namespace osteon
