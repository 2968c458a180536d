// Registration of point-cloud files (`recon register` on .ply / .pcd; docs/ARCHITECTURE.md §10.4):
// the ICP family of registration.h on clouds of outside tools, read by core's read_cloud_file.
//
// - Points: the file's, optionally averaged in a voxel grid (registration.voxel_m; the mean of a
//   voxel's points, with the covariance of a mean of independent measurements, sum C_i / n^2).
// - Measurement covariance: the file's per-point covariance (cov_xx..cov_zz, variance or sigma;
//   cloud_file.h). gicp-ours uses it; a cloud without one adds none (its surface covariance only),
//   and with neither cloud carrying one gicp-ours is plain GICP (reported as such). gicp-def
//   (the Handa model of a PrimeSense camera's depth) is refused: nothing says a file came from one.
// - Surface: prepare_surface (20 neighbours; normals towards the viewpoint: PCD's VIEWPOINT
//   translation, else the file's origin; the ICP metrics use n n^T and covariances, so the sign
//   does not change a result).
// - Initial pose: the given one, else the identity (no images, so no ORB guess or feature check).
// - After ICP the pair is refused, an Error naming both files, when fewer than min_fitness of the
//   source points lie within fitness_distance_m of the target's surface (surface_overlap).
#pragma once

#include <cstddef>
#include <string>

#include "panoscan/core/cloud_file.h"
#include "panoscan/core/config.h"
#include "panoscan/recon/registration.h"
#include "panoscan/recon/stage2.h"

namespace panoscan {

struct CloudRegistrationOptions {
  IcpOptions icp;           // registration.{method, max_correspondence_m, max_iterations}, threads
  SurfaceOptions surface;   // registration.surface_covariance
  double min_fitness = 0.5;  // registration.min_fitness (surface_overlap at the result)
  double voxel_m = 0.0;      // registration.voxel_m; 0 = every point
};

// Keys as pair_registration_options_from_config (the ones that apply to clouds) plus registration.voxel_m.
CloudRegistrationOptions cloud_registration_options_from_config(Config& config);

// The registration cloud of a file: points (voxel-averaged when voxel_m > 0), the file's
// covariances when `with_covariance` and it has them, then prepare_surface at the file's viewpoint.
// Throws Error naming the file when fewer than 10 points are left.
RegistrationCloud cloud_file_registration_cloud(const CloudFile& file, double voxel_m, bool with_covariance,
                                                const SurfaceOptions& surface);

// The viewpoint prepare_surface orients normals towards: PCD's VIEWPOINT translation, else the origin.
Eigen::Vector3d cloud_file_viewpoint(const CloudFile& file);

struct CloudPairRegistration {
  Rigid3d target_from_source = Rigid3d::Identity();
  IcpResult icp;
  IcpMethod method_used = IcpMethod::kGicpMeasured;  // what ran (gicp-ours without covariances: gicp)
  bool source_covariance = false, target_covariance = false;  // the file's covariance was used
  std::string covariance_note;  // how the measurement covariance was chosen, in words
  double overlap = 0.0;         // surface_overlap at the result
  std::size_t source_points = 0, target_points = 0;  // registered (after the voxel grid)
};

// Registers `source` onto `target` from `initial` (see the top of this file). Throws Error naming
// both files (and the field) for gicp-def, too few points, an ICP failure or too little overlap.
CloudPairRegistration register_cloud_files(const CloudFile& source, const CloudFile& target, const Rigid3d& initial,
                                           const CloudRegistrationOptions& options);

}  // namespace panoscan
