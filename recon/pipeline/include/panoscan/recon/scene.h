// The whole method on one scene (docs/ARCHITECTURE.md §2, §12): per scanning position, tracking
// (paper §4.1, or given poses) and panorama construction (§4.2); then registration between panoramas
// (§5.1), a pose graph when the registrations are redundant, and MAP integration (§5.2) into one cloud.
//
// Frames: the scene frame is the frame of the first scan's tracking (its reference camera's
// first frame), or, with given trajectories, whatever frame those are in. Panorama k sits at
// world_from_panorama[k] in it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "panoscan/recon/placement.h"
#include "panoscan/recon/stage2.h"
#include "panoscan/recon/tracking.h"

namespace panoscan {

struct SceneScan {
  std::string name;  // e.g. "SO-1"
  ScanIndex scan;
  std::optional<RigTrajectory> trajectory;  // given poses (e.g. ground truth); tracked if empty
};

struct SceneOptions {
  TrackingOptions tracking;
  PanoramaOptions panorama;
  PairRegistrationOptions registration;
  IntegrationOptions integration;
  // Pairs of scans registered: every pair is tried and used when it succeeds (redundancy for the
  // pose graph); every scan must be linked to the first by pairs that succeed. Off: consecutive
  // scans (in the order given) only, and each must register.
  bool register_all_pairs = true;
  // How the registrations place the panoramas (placement.h): a registration that contradicts the
  // chain of consecutive ones is dropped and listed in skipped_pairs.
  PlacementOptions placement;
};

struct PairEdge {
  int source = 0, target = 0;
  PairRegistration registration;
};

struct SceneResult {
  std::vector<RigTrajectory> trajectories;
  std::vector<Panorama> panoramas;
  std::vector<Rigid3d> world_from_panorama;
  std::vector<PairEdge> edges;  // the registrations kept by the placement
  // Every registration that succeeded (as pose-graph edges) and the placement made of them; the
  // fields around are its figures (world_from_panorama = placement.world_from_panorama).
  std::vector<PoseGraphEdge> registrations;
  Placement placement;
  std::vector<std::string> skipped_pairs;  // "SO-1 -> SO-4: <reason>"
  bool pose_graph_used = false;
  // The worst pairwise inconsistency (pose_graph.h) of the chained poses and of the final ones.
  EdgeDiscrepancy inconsistency_chained, inconsistency_final;
  IntegrationResult integration;
  // Wall-clock seconds per stage; seconds_registration includes the pose graph's seconds_pose_graph.
  double seconds_tracking = 0, seconds_panorama = 0, seconds_registration = 0, seconds_integration = 0;
  double seconds_pose_graph = 0;
};

// What registration made of each pair, as `recon scene` writes it (registrations.json): per kept
// registration its pose, overlap, feature evidence and runner-up (with the ambiguity verdict: taken,
// dismissed or kept below), and every skipped pair with its reason. `names` are the panoramas' names.
nlohmann::json scene_registrations_to_json(const std::vector<std::string>& names, const SceneResult& result);

// Stage 2's poses for built panoramas: pairwise registrations (every pair when
// options.register_all_pairs, else the consecutive ones), then place_panoramas (placement.h) from
// the first panorama (which stays at its world_from_pano). Fills edges (the kept ones),
// skipped_pairs (failed and dropped), world_from_panorama(_chained), pose_graph_used, the
// inconsistencies and seconds_registration of `result`. Throws Error naming a scan that the pairs
// that succeeded do not link to the first, with its pairs' reasons (without register_all_pairs:
// naming the consecutive pair that fails).
void register_scene_panoramas(const std::vector<Panorama>& panoramas, const std::vector<std::string>& names,
                              const SceneOptions& options, SceneResult& result);

// Throws Error when a scan cannot be placed (register_scene_panoramas) or a stage fails.
SceneResult reconstruct_scene(const std::vector<SceneScan>& scans, const SceneOptions& options);

// Keys: those of tracking_options_from_config (track.*, frontend.*), panorama_options_from_config
// (panorama.*), pair_registration_options_from_config and integration_options_from_config
// (registration.*, integration.*, seed, threads; see stage2.h), and registration.all_pairs (true).
SceneOptions scene_options_from_config(Config& config);

}  // namespace panoscan
