// Internal to panoscan_scenes: geometric queries on a triangle mesh for the room generator, with a
// bounding-volume hierarchy (median splits): first hits of rays and the distance from a point to
// the nearest triangle, both exact on the mesh's triangles.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "panoscan/core/mesh.h"

namespace panoscan::scenes {

class MeshQuery {
 public:
  // `keep`: which triangles take part (all if empty).
  explicit MeshQuery(const TriangleMesh& mesh, const std::function<bool(std::size_t)>& keep = {});

  // Distance along the unit direction to the first triangle hit within (0, max_distance), or a
  // negative value if none.
  double first_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& unit_direction,
                   double max_distance = 1e30) const;
  // Exact distance from `point` to the nearest triangle, or `cap` if none is nearer than cap.
  double distance(const Eigen::Vector3d& point, double cap) const;

 private:
  struct Node {
    Eigen::Vector3d lo, hi;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int begin = 0, end = 0;     // leaf: range in order_
  };
  int build(int begin, int end);
  const TriangleMesh& mesh_;
  std::vector<int> order_;
  std::vector<Eigen::Vector3d> lo_, hi_, centre_;  // per triangle
  std::vector<Node> nodes_;
};

}  // namespace panoscan::scenes
