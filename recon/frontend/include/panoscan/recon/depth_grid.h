// A depth image reduced to one surface sample per block of pixels: what the depth odometry of the
// tracking (track.depth_odometry, recon/tracking/src/depth_odometry.h) aligns between consecutive
// frames. The front end builds it while it has the frame decoded (FrontendOptions::depth_grid_block),
// so the depth PNGs are read once.
//
// Why blocks: the simulated (and the PrimeSense's) depth is quantised in disparity, a staircase of
// 3-25 mm steps at 1-3 m; one pixel's normal from its neighbours is noise. The mean of a block of
// b x b pixels (b = 4: 16 pixels) dithers the staircase by the sub-pixel shifts of the noise, and
// normals from neighbouring blocks span 2b pixels. A block is kept only when all its pixels are
// valid and it holds one surface (no depth edge inside it).
#pragma once

#include "panoscan/core/camera.h"
#include "panoscan/core/image.h"

namespace panoscan {

struct DepthGrid {
  int block = 0;                 // pixels per block side; 0 = no grid
  ImageF32 depth;                // per block: the mean z-depth in metres, 0 = not one valid surface
  PinholeIntrinsics intrinsics;  // of the grid: block (i, j) is the pixel (i, j), its centre the block's

  bool empty() const { return block == 0 || depth.empty(); }
  // The block's surface point in the camera frame (z-depth along the optical axis).
  Eigen::Vector3d point(int i, int j) const { return intrinsics.backproject(i, j, depth.at(i, j)); }
};

// One sample per block x block pixels of a z-depth image in metres (0 = invalid) seen through
// `pixel_intrinsics`. A block is a surface when every pixel is valid and its depths span at most
// max(0.1 z, 6 sigma_z) (sigma_z = depth_noise_coefficient z^2): a depth edge inside it would
// average two surfaces into a point on neither. Pixels beyond the last whole block are dropped.
DepthGrid make_depth_grid(const ImageF32& depth_m, const PinholeIntrinsics& pixel_intrinsics, int block,
                          double depth_noise_coefficient);

}  // namespace panoscan
