// One RGB-D frame as Open3D's RGBDImage, for the outside references built on Open3D (the TSDF
// baseline, the pre-stitched EX / GT odometry baselines). Open3D's headers stay out: the type is
// only declared here.
#pragma once

#include <memory>

#include "panoscan/core/scan.h"

namespace open3d::geometry {
class RGBDImage;
}

namespace panoscan {

// Depth in metres, invalid (NaN, non-positive) as 0 and beyond max_depth_m cut by Open3D.
// convert_rgb_to_intensity: a one-channel float intensity (what Open3D's photometric odometry needs)
// instead of the 8-bit colour (what the coloured TSDF integrates).
std::shared_ptr<open3d::geometry::RGBDImage> open3d_rgbd_from_frame(const RgbdFrame& frame, double max_depth_m,
                                                                    bool convert_rgb_to_intensity);

}  // namespace panoscan
