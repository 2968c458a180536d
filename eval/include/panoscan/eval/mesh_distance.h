// Exact distance from points to a triangle mesh (docs/ARCHITECTURE.md §13: the distance to the closest
// point of the ground-truth triangles, point-to-triangle, never point-to-vertex or a sampled mesh).
//
// MeshDistance builds a BVH over the triangles once (Embree) and answers closest-point queries:
// the BVH only proposes candidate triangles, and each candidate's distance is computed exactly
// in double precision (point_triangle_distance), so the result is the exact minimum over all
// triangles, whatever the BVH's float rounding. Queries are thread-safe; distances() runs in
// parallel (oneTBB) and is deterministic (each point is independent).
//
// The same BVH answers visibility questions (is a segment blocked by the mesh?), used by the
// completeness metric to keep only the surface that the scanning positions can see.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/mesh.h"

namespace panoscan::eval {

struct ClosestPoint {
  double distance = 0.0;                            // metres, >= 0
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // closest point on the mesh
  int triangle = -1;                                // its triangle (lowest index on ties)
};

class MeshDistance {
 public:
  // Copies the mesh. Throws Error naming `origin` (e.g. the mesh file) if it has no triangles,
  // an index out of range or a non-finite vertex.
  explicit MeshDistance(const TriangleMesh& mesh, const std::string& origin = "ground-truth mesh");
  ~MeshDistance();
  MeshDistance(const MeshDistance&) = delete;
  MeshDistance& operator=(const MeshDistance&) = delete;

  ClosestPoint closest(const Eigen::Vector3d& point) const;
  double distance(const Eigen::Vector3d& point) const { return closest(point).distance; }

  // Distances of all points, in parallel. Throws Error naming `origin` and the point index if a
  // point is not finite.
  std::vector<double> distances(const std::vector<Eigen::Vector3d>& points, const std::string& origin = "points") const;

  // True if the open segment from `from` to `to`, shortened by `end_margin_m` at the `to` end, hits
  // a triangle (for "is this surface point visible from that viewpoint").
  bool segment_blocked(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double end_margin_m) const;

  const TriangleMesh& mesh() const;
  const std::string& origin() const;
  double surface_area() const;  // m^2, sum of triangle areas

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reference: the closest point by testing every triangle (O(triangles) per point). For tests and
// the benchmark only.
ClosestPoint closest_point_brute_force(const TriangleMesh& mesh, const Eigen::Vector3d& point);

}  // namespace panoscan::eval
