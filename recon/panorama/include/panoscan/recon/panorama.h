// Panorama construction (paper §4.2): the RGB-D frames of one scanning position, with their poses,
// become one equirectangular panorama (H x 2H, centred on the rotation axis, z up) holding colour,
// radial depth, the depth variance sigma_z^2 and the observation count per pixel.
//
//   1. warp_frames: every frame is a mesh of adjacent valid depth pixels (no edge between pixels
//      whose depths differ by more than lambda_a), rasterised into the panorama with the model-view
//      T_u^-1 * T_ci. Each covered panorama pixel gets one measurement per covering triangle: the
//      radial distance where the panorama ray through the pixel centre meets the triangle's plane
//      (exact for planar surfaces), and the colour interpolated barycentrically in panorama pixels.
//      Triangles crossing the seam (azimuth 0 / 2 pi) are unwrapped and their pixels wrapped back;
//      triangles enclosing a pole are skipped (the paper's rig sees at most +-67.5 deg elevation).
//   2. Measurement sets: per pixel all its measurements in CSR layout (offsets + one flat array),
//      sorted by (sensor, frame, radial depth) so the layout does not depend on the thread count.
//   3. fuse: colour = mean of the measurements; radial depth minimises Eq. 5,
//        E(D) = sum_p sum_k |D_p - z_pk| + lambda_b * sum_p S_p(D),
//      with S one of: TV on the cylindrical radius rho = D sin(theta) (the paper's TV-L1), TV on the
//      radial depth, total surface area TSA (Eq. 6) or total planarity TP (Eq. 7); or the plain mean
//      ("ERP Ave."). See FusionOptions for units and the solver.
//   4. Uncertainty: sigma_z^2 = mean_k (z_pk - D_p)^2 about the solved depth, the count K_p, and a
//      flag where sigma_z > 0.15 m (§6.3 pre-processing drops those pixels).
//
// Everything is deterministic: the same input gives the same bytes with any thread count.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/allocator.h"
#include "panoscan/core/camera.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/rig_trajectory.h"

namespace panoscan {

class Config;

struct WarpOptions {
  int height = 1024;                    // panorama.height: H (width 2H)
  double max_edge_depth_jump_m = 0.15;  // panorama.lambda_a_m: the paper's lambda_a
  double min_depth_m = 0.0;             // panorama.min_depth_m: frame depths below are ignored
  double max_depth_m = 0.0;             // panorama.max_depth_m: frame depths above are ignored (0 = none)
  int frame_stride = 1;                 // panorama.frame_stride: use every n-th frame of each camera
  // panorama.min_valid_depth_share: warp_frames refuses (Error) a scan whose frames have depth on fewer
  // than this share of their pixels: a wrong depth scale, a covered sensor or a scan of nothing gives
  // a panorama of a few scattered pixels, not one a user should take for a result.
  double min_valid_depth_share = 0.2;
  void check(const std::string& origin = "<panorama options>") const;
};

// One raw measurement of a panorama pixel (12 bytes). A plain aggregate without member
// initialisers, so that sizing the measurement sets (17 million at H = 1024) does not fill them
// before warping writes every field: PanoramaMeasurement{} is all zeros, a bare declaration is not.
struct PanoramaMeasurement {
  float radial_m;  // distance from the panorama centre along the pixel's ray
  std::uint8_t rgb[3];
  std::uint8_t sensor;
  std::uint32_t frame;  // index in the scan's listing of that sensor
};

struct PanoramaMeasurements {
  Equirectangular pano;
  Rigid3d world_from_pano = Rigid3d::Identity();  // = T_u (RigTrajectory::world_from_axis)
  // CSR: the measurements of pixel p = v * W + u are samples[offsets[p] .. offsets[p + 1]).
  std::vector<std::uint64_t> offsets;                // size H * W + 1
  UninitialisedVector<PanoramaMeasurement> samples;  // resize() leaves them unwritten (core/allocator.h)
  std::size_t frames_used = 0;
  std::size_t triangles_skipped_at_poles = 0;
  std::size_t frame_pixels = 0;        // pixels of the frames used
  std::size_t valid_frame_pixels = 0;  // of those, with depth inside [min_depth_m, max_depth_m]
  std::size_t count(std::size_t pixel) const { return std::size_t(offsets[pixel + 1] - offsets[pixel]); }
  std::size_t memory_bytes() const {
    return offsets.capacity() * sizeof(std::uint64_t) + samples.capacity() * sizeof(PanoramaMeasurement);
  }
};

enum class DepthFusionMethod {
  kAverage,        // "ERP Ave.": mean of the measurements, no smoothness
  kTvCylindrical,  // "TV-L1": TV of rho = D sin(theta)
  kTvRadial,       // TV of the radial depth D itself (shows the spherical artefact)
  kTsa,            // "TSA-L1": total surface area, Eq. 6
  kTp,             // "TP-L1": total planarity, Eq. 7
};
const char* to_string(DepthFusionMethod method);
DepthFusionMethod depth_fusion_method_from_string(const std::string& name, const std::string& origin);

// Eq. 5 discretisation, units (metres; neighbours are the adjacent panorama pixels, azimuth
// periodic, no neighbour across the poles; a term needing a pixel without measurements is left out):
//   data:  sum_k |D_p - z_pk|                                             [m]
//   TV:    sqrt((q_p - q_left)^2 + (q_p - q_up)^2), q = D sin(theta) or D  [m]
//   TSA:   |(P_p - P_left) x (P_p - P_up)|, P = D * direction(pixel)      [m^2] (Eq. 6)
//   TP:    |(P_p - P_left) x (P_right - P_p)|^2 + |(P_p - P_up) x (P_down - P_p)|^2  [m^4] (Eq. 7)
// so lambda_b has units m^0, m^-1 and m^-3 respectively. The paper chose its lambdas (TV 50, TSA 5e3,
// TP 2e8) so that data ~ 4 x lambda x smoothness at the solution. Per pixel the data term grows with
// the number of measurements and does not depend on the resolution; the smoothness terms shrink with
// the pixel spacing: TV ~ 1/H, TSA and TP ~ 1/H^2 (TP on noisy planes: two lengths along the surface,
// two across). The default lambda is the paper's times (H / lambda_reference_height)^k times
// (mean measurements per measured pixel / lambda_reference_count), the reference being the paper's
// every-frame panoramas at H = 1024 (recon/panorama/README.md, "lambda_b", has the derivation and the
// measured balance). An explicit lambda is used as given. Neighbours whose median depths differ by more
// than max_coupled_depth_jump_m (lambda_a) are not coupled. Solver: L-BFGS on the smoothed energy
// (|x| -> sqrt(x^2 + eps^2) - eps), started from the per-pixel median, the data eps continued from
// data_epsilon_m down to data_epsilon_final_m, preconditioned with the diagonal curvature of both terms,
// Armijo backtracking so the smoothed energy never increases within a stage; the exact (unsmoothed)
// Eq. 5 energy is logged too. Parallel (oneTBB) with fixed-order reductions: deterministic for any
// thread count.
struct FusionOptions {
  DepthFusionMethod method = DepthFusionMethod::kTsa;  // panorama.method
  double lambda = -1.0;                // panorama.lambda: lambda_b; < 0 = the paper's default, scaled (above)
  int lambda_reference_height = 1024;  // panorama.lambda_reference_height: H at which the defaults hold
  // panorama.lambda_reference_count: measurements per pixel at which the defaults hold (the paper's
  // every-frame scan: 58.6 deg field of view / 0.375 deg per frame = 156 frames see a direction).
  double lambda_reference_count = 156.0;
  double lambda_scale = 1.0;      // panorama.lambda_scale: multiplies the default (sweeps; 1 = the paper's balance)
  int iterations = 100;           // panorama.iterations: L-BFGS iterations (max)
  int lbfgs_memory = 5;           // panorama.lbfgs_memory
  double data_epsilon_m = 0.002;  // panorama.data_epsilon_m: smoothing of |D - z| (first stage)
  double data_epsilon_final_m = 1e-4;  // panorama.data_epsilon_final_m: last stage (eps / 5 per stage)
  double tv_epsilon_m = 1e-4;          // smoothing of the TV norm
  double tsa_epsilon_m2 = 1e-7;        // smoothing of the TSA norm
  // panorama.tolerance: a stage stops after 3 steps in a row that lower its objective by less
  // than this (relative); see recon/panorama/README.md, "Speed and memory", for the choice.
  double relative_tolerance = 1e-5;
  double max_sigma_m = 0.15;  // panorama.max_sigma_m: flag pixels with sigma_z above
  // panorama.max_coupled_depth_jump_m: adjacent pixels whose median depths differ by more are not
  // coupled by the smoothness term (lambda_a, as in the warping; 0 = couple every neighbour).
  double max_coupled_depth_jump_m = 0.15;
  static double default_lambda(DepthFusionMethod method);  // TV 50, TSA 5e3, TP 2e8, average 0
  // lambda_b used at panorama height H with mean_count measurements per measured pixel (README).
  double effective_lambda(int height, double mean_count) const;
  void check(const std::string& origin = "<panorama options>") const;
};

struct EnergyRecord {
  int iteration = 0;
  double smoothed = 0.0;        // the objective the solver minimises (never increases within a stage)
  double data_epsilon_m = 0.0;  // the stage's data-term smoothing (smoothed jumps up when it shrinks)
  double data = 0.0;            // exact data term sum |D - z|
  double smoothness = 0.0;      // exact smoothness term (without lambda)
  double total() const { return data + smoothness_weighted; }
  double smoothness_weighted = 0.0;  // lambda * smoothness
};

struct Panorama {
  Equirectangular pano;
  Rigid3d world_from_pano = Rigid3d::Identity();
  ImageF32 colour;    // 3 channels, linear 0..1 (the mean of the 8-bit colours / 255)
  ImageF32 depth;     // radial distance in metres; 0 = no measurement
  ImageF32 variance;  // sigma_z^2 in m^2 (0 where no measurement)
  ImageF32 count;     // number of measurements
  ImageU8 flagged;    // 1 where sigma_z > max_sigma_m
  std::string method;
  double lambda = 0.0;
  double mean_count = 0.0;           // measurements per measured pixel (scales the default lambda)
  std::vector<EnergyRecord> energy;  // per iteration (empty for averaging)
  // The panorama's points in the world frame (pixels with depth; flagged ones included unless
  // skip_flagged), with colour and variance.
  PointCloud to_point_cloud(bool skip_flagged = false) const;
};

PanoramaMeasurements warp_frames(const ScanIndex& scan, const RigTrajectory& trajectory, const WarpOptions& options);
Panorama fuse(const PanoramaMeasurements& measurements, const FusionOptions& options);

// Folder: colour.exr (R,G,B), depth.exr (Z), variance.exr (V), count.exr (N), flags.png, colour.png,
// depth.png and variance.png (colour-mapped, legend bar at the bottom, range in panorama.json),
// cloud.ply (world frame, colour, variance), panorama.json (format, version, height, world_from_pano,
// method, lambda, energy log). Atomic (the folder appears complete or not at all).
void write_panorama(const std::filesystem::path& dir, const Panorama& panorama, bool overwrite);
// Reads what write_panorama wrote; throws Error naming the file and field.
Panorama read_panorama(const std::filesystem::path& dir);

struct PanoramaOptions {
  WarpOptions warp;
  FusionOptions fusion;
  int threads = 0;  // threads (0 = all cores)
  void check(const std::string& origin = "<panorama options>") const;
};
// Keys: panorama.{height, lambda_a_m, min_depth_m, max_depth_m, frame_stride, method, lambda,
// iterations, lbfgs_memory, data_epsilon_m, tolerance, max_sigma_m}, threads.
PanoramaOptions panorama_options_from_config(Config& config);

struct PanoramaResult {
  Panorama panorama;
  double warp_seconds = 0.0;
  double fusion_seconds = 0.0;
  std::size_t measurements = 0;
  std::size_t measurement_bytes = 0;
  std::size_t frames_used = 0;
};
// The one-call entry of `panoscan recon panorama`: checks the trajectory against the scan, warps
// and fuses with options.threads threads.
PanoramaResult build_panorama(const ScanIndex& scan, const RigTrajectory& trajectory, const PanoramaOptions& options);

}  // namespace panoscan
