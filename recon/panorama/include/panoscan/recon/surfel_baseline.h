// The surfel baseline of Tables 1 and 3 ("Surfels-3m", "Surfels-4m", "Surfels-4m (RC)"): frames of
// one scanning position fused into surfels with ElasticFusion's update rule (Whelan et al. 2015):
//   new measurement: position p, normal n (from the neighbouring pixels), colour, radius
//     r = sqrt(2) z / (f |n_z|) (n_z in the camera frame), confidence alpha = exp(-g^2 / (2 * 0.6^2)),
//     g the pixel's distance from the image centre normalised by the half-diagonal;
//   association: an existing surfel in the same direction bin (seen from the panorama centre; for
//     an in-place scan this is ElasticFusion's projective association) within `merge_distance_m`
//     along the ray and with normals within `merge_angle_deg`;
//   merge: p, n, colour <- confidence-weighted averages; r <- min(r, r_new) when the new radius is
//     smaller (the finer observation wins); confidence <- confidence + alpha;
//   no association: a new surfel. Depths beyond `max_depth_m` (3 m or 4 m) are not used.
// Surfels with confidence below `min_confidence` are dropped at the end (ElasticFusion: unstable).
// The "(RC)" panorama ray-casts the surfels as disks into the equirectangular panorama.
#pragma once

#include <cstddef>
#include <string>

#include "panoscan/core/camera.h"
#include "panoscan/core/image.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"

namespace panoscan {

struct SurfelOptions {
  double max_depth_m = 4.0;          // surfels.max_depth_m: the paper's 3 m / 4 m cut-off
  double merge_distance_m = 0.05;    // surfels.merge_distance_m
  double merge_angle_deg = 20.0;     // surfels.merge_angle_deg (ElasticFusion)
  double min_confidence = 1.0;       // surfels.min_confidence (ElasticFusion's 10 assumes every frame)
  int direction_bins_height = 2048;  // rows of the equirectangular association grid
  int frame_stride = 1;
  void check(const std::string& origin = "<surfel options>") const;
};

struct SurfelResult {
  PointCloud surfels;              // centres, normals, colours (what Table 3's "Surfels" row evaluates)
  std::vector<float> radii;        // metres, one per surfel
  std::vector<float> confidences;  // one per surfel
  std::size_t memory_bytes = 0;
  double seconds = 0.0;
};

SurfelResult build_surfel_baseline(const ScanIndex& scan, const RigTrajectory& trajectory,
                                   const SurfelOptions& options);

// Ray-cast of the surfels as disks into the panorama centred at world_from_pano (radial depth,
// 0 = no hit): the "(RC)" row.
ImageF32 raycast_surfels(const SurfelResult& surfels, const Rigid3d& world_from_pano, const Equirectangular& pano);

}  // namespace panoscan
