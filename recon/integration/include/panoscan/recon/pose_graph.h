// Pose-graph refinement of panorama poses from redundant pairwise registrations (paper §5.2:
// "a pose graph approach [Grisetti et al. 2010] ... with the covariance of each edge set
// equally"). Nodes are panoramas (world_from_node), edges measured relative poses
// to_from_from; one node is held fixed (the gauge). Solved with Ceres on quaternion manifolds.
// Edge residual: r = [log(R_meas^-1 R_rel); t_rel - t_meas] in the `to` frame, with
// R_rel = R_to^-1 R_from; every edge has the same information, diag(1/sigma_r^2, 1/sigma_t^2).
#pragma once

#include <vector>

#include "panoscan/core/geometry.h"

namespace panoscan {

struct PoseGraphEdge {
  int from = 0;
  int to = 0;
  Rigid3d to_from_from = Rigid3d::Identity();
};

struct PoseGraphOptions {
  int fixed_node = 0;
  double rotation_sigma_rad = 0.0175;  // 1 degree
  double translation_sigma_m = 0.01;   // 1 cm: with the above, 1 deg weighs like 1 cm
  int max_iterations = 100;
};

struct PoseGraphResult {
  std::vector<Rigid3d> world_from_node;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool converged = false;
};

// How far an edge's measurement is from the relative pose of its two nodes: the angle of
// R_meas^-1 R_rel and |t_rel - t_meas| (the `to` frame). The worst over a graph's edges is its
// "pairwise inconsistency": chained poses put all of a loop's disagreement on the edges outside
// the chain; the pose graph spreads it.
struct EdgeDiscrepancy {
  double rotation_deg = 0.0;
  double translation_m = 0.0;
};
std::vector<EdgeDiscrepancy> edge_discrepancies(const std::vector<Rigid3d>& world_from_node,
                                                const std::vector<PoseGraphEdge>& edges);
// The largest rotation and the largest translation discrepancy (each over all edges).
EdgeDiscrepancy worst_edge_discrepancy(const std::vector<Rigid3d>& world_from_node,
                                       const std::vector<PoseGraphEdge>& edges);

// Throws Error if an edge names a missing node, the graph is not connected to the fixed node,
// or the initial poses are not finite.
PoseGraphResult optimize_pose_graph(const std::vector<Rigid3d>& initial_world_from_node,
                                    const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& options);

}  // namespace panoscan
