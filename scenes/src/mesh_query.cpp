#include "mesh_query.h"

#include <algorithm>
#include <cmath>

#include "panoscan/core/geometry.h"

namespace panoscan::scenes {

namespace {

double box_distance2(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d d = (lo - p).cwiseMax(p - hi).cwiseMax(0.0);
  return d.squaredNorm();
}

// Slab test: does the ray enter the box before max_t?
bool ray_box(const Eigen::Vector3d& o, const Eigen::Vector3d& inv_d, const Eigen::Vector3d& lo,
             const Eigen::Vector3d& hi, double max_t) {
  double t0 = 0.0, t1 = max_t;
  for (int k = 0; k < 3; ++k) {
    double a = (lo[k] - o[k]) * inv_d[k], b = (hi[k] - o[k]) * inv_d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

MeshQuery::MeshQuery(const TriangleMesh& mesh, const std::function<bool(std::size_t)>& keep) : mesh_(mesh) {
  const std::size_t n = mesh.triangles.size();
  lo_.resize(n);
  hi_.resize(n);
  centre_.resize(n);
  for (std::size_t t = 0; t < n; ++t) {
    const Eigen::Vector3d a = mesh.vertices[mesh.triangles[t][0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[mesh.triangles[t][1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[mesh.triangles[t][2]].cast<double>();
    lo_[t] = a.cwiseMin(b).cwiseMin(c);
    hi_[t] = a.cwiseMax(b).cwiseMax(c);
    centre_[t] = 0.5 * (lo_[t] + hi_[t]);
    if (!keep || keep(t)) order_.push_back(static_cast<int>(t));
  }
  if (!order_.empty()) build(0, static_cast<int>(order_.size()));
}

int MeshQuery::build(int begin, int end) {
  Node node;
  node.lo = Eigen::Vector3d::Constant(1e30);
  node.hi = Eigen::Vector3d::Constant(-1e30);
  for (int i = begin; i < end; ++i) {
    node.lo = node.lo.cwiseMin(lo_[order_[i]]);
    node.hi = node.hi.cwiseMax(hi_[order_[i]]);
  }
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(node);
  if (end - begin <= 8) {
    nodes_[index].begin = begin;
    nodes_[index].end = end;
    return index;
  }
  int axis = 0;
  const Eigen::Vector3d extent = node.hi - node.lo;
  if (extent.y() > extent[axis]) axis = 1;
  if (extent.z() > extent[axis]) axis = 2;
  const int middle = begin + (end - begin) / 2;
  // Ties broken by index: the hierarchy does not depend on the standard library's nth_element.
  std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end, [&](int a, int b) {
    return centre_[a][axis] < centre_[b][axis] || (centre_[a][axis] == centre_[b][axis] && a < b);
  });
  const int left = build(begin, middle);
  const int right = build(middle, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

double MeshQuery::first_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_distance) const {
  if (nodes_.empty()) return -1.0;
  const Eigen::Vector3d inv_d(1.0 / (d.x() != 0 ? d.x() : 1e-300), 1.0 / (d.y() != 0 ? d.y() : 1e-300),
                              1.0 / (d.z() != 0 ? d.z() : 1e-300));
  double best = max_distance;
  bool hit = false;
  std::vector<int> stack = {0};
  while (!stack.empty()) {
    const Node& node = nodes_[static_cast<std::size_t>(stack.back())];
    stack.pop_back();
    if (!ray_box(o, inv_d, node.lo, node.hi, best)) continue;
    if (node.left >= 0) {
      stack.push_back(node.left);
      stack.push_back(node.right);
      continue;
    }
    for (int i = node.begin; i < node.end; ++i) {
      const Eigen::Vector3i& tri = mesh_.triangles[static_cast<std::size_t>(order_[i])];
      // Moeller-Trumbore, both sides.
      const Eigen::Vector3d a = mesh_.vertices[tri[0]].cast<double>();
      const Eigen::Vector3d e1 = mesh_.vertices[tri[1]].cast<double>() - a;
      const Eigen::Vector3d e2 = mesh_.vertices[tri[2]].cast<double>() - a;
      const Eigen::Vector3d p = d.cross(e2);
      const double det = e1.dot(p);
      if (std::abs(det) < 1e-14) continue;
      const Eigen::Vector3d s = o - a;
      const double u = s.dot(p) / det;
      if (u < 0.0 || u > 1.0) continue;
      const Eigen::Vector3d q = s.cross(e1);
      const double v = d.dot(q) / det;
      if (v < 0.0 || u + v > 1.0) continue;
      const double t = e2.dot(q) / det;
      if (t > 1e-9 && t < best) {
        best = t;
        hit = true;
      }
    }
  }
  return hit ? best : -1.0;
}

double MeshQuery::distance(const Eigen::Vector3d& point, double cap) const {
  double best2 = cap * cap;
  if (nodes_.empty()) return cap;
  std::vector<int> stack = {0};
  while (!stack.empty()) {
    const Node& node = nodes_[static_cast<std::size_t>(stack.back())];
    stack.pop_back();
    if (box_distance2(point, node.lo, node.hi) >= best2) continue;
    if (node.left >= 0) {
      stack.push_back(node.left);
      stack.push_back(node.right);
      continue;
    }
    for (int i = node.begin; i < node.end; ++i) {
      const std::size_t t = static_cast<std::size_t>(order_[i]);
      if (box_distance2(point, lo_[t], hi_[t]) >= best2) continue;
      const Eigen::Vector3i& tri = mesh_.triangles[t];
      const double dist =
          point_triangle_distance(point, mesh_.vertices[tri[0]].cast<double>(), mesh_.vertices[tri[1]].cast<double>(),
                                  mesh_.vertices[tri[2]].cast<double>());
      best2 = std::min(best2, dist * dist);
    }
  }
  return std::sqrt(best2);
}

}  // namespace panoscan::scenes
