// Stage 2's poses: placing registered panoramas in one frame. The one rule, used by `recon scene`
// (register_scene_panoramas) and `recon integrate`:
//  1. chain: breadth first from panorama 0 (which stays at world_from_first), preferring the
//     registrations between panoramas adjacent in the given order (the consecutive scans of a
//     scene), then the others in the order given;
//  2. drop every registration outside that chain that contradicts it by more than
//     max_loop_rotation_deg or max_loop_translation_m: drift along a short chain is millimetres
//     and tenths of a degree, a wrong registration (a symmetric room registered 180 degrees off)
//     metres and tens of degrees, and the pose graph would spread its error over every pose;
//  3. refine with the pose graph (pose_graph.h) when the kept registrations are redundant.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "panoscan/recon/pose_graph.h"

namespace panoscan {

struct PlacementOptions {
  double max_loop_rotation_deg = 5.0;
  double max_loop_translation_m = 0.1;
  PoseGraphOptions pose_graph;  // fixed_node is always 0 here
};

struct Placement {
  std::vector<Rigid3d> world_from_panorama;          // the final poses
  std::vector<Rigid3d> world_from_panorama_chained;  // after step 1 (before the pose graph)
  std::vector<char> edge_kept;                       // per input edge: used (1) or dropped (0)
  std::vector<char> edge_in_chain;                   // per input edge: placed a panorama in step 1
  std::vector<std::string> dropped;                  // "B -> A: contradicts the chained registrations by ..."
  bool pose_graph_used = false;
  // The worst pairwise inconsistency (pose_graph.h) over the kept registrations, chained and final.
  EdgeDiscrepancy inconsistency_chained, inconsistency_final;
};

// `names` names the panoramas (one per panorama, for messages); an edge measures
// The panoramas (of `count`, in index order) that no chain of the edges links to panorama 0: those
// place_panoramas cannot place. Edge indices must lie in [0, count).
std::vector<int> unlinked_panoramas(int count, const std::vector<PoseGraphEdge>& edges);

// to_from_from between panorama indices. Throws Error naming a panorama that no chain of
// registrations links to names[0], or an edge with an index out of range.
Placement place_panoramas(const std::vector<std::string>& names, const Rigid3d& world_from_first,
                          const std::vector<PoseGraphEdge>& edges, const PlacementOptions& options);

// {"format": "panoscan-placement", "version": 1, "panoramas": [{"name", "world_from_panorama"}],
//  "registrations": [{"source", "target", "kept", "in_chain"}], "dropped": [...], "pose_graph_used",
//  "inconsistency": {"chained": {...}, "final": {...}}}
nlohmann::json placement_to_json(const std::vector<std::string>& names, const std::vector<PoseGraphEdge>& edges,
                                 const Placement& placement);

}  // namespace panoscan
