#include "panoscan/recon/open3d_frame.h"

#include <algorithm>
#include <cmath>

#include <open3d/geometry/Image.h>
#include <open3d/geometry/RGBDImage.h>

namespace panoscan {

std::shared_ptr<open3d::geometry::RGBDImage> open3d_rgbd_from_frame(const RgbdFrame& frame, double max_depth_m,
                                                                    bool convert_rgb_to_intensity) {
  namespace o3d = open3d;
  o3d::geometry::Image colour, depth;
  colour.Prepare(frame.rgb.width, frame.rgb.height, 3, 1);
  std::copy(frame.rgb.data.begin(), frame.rgb.data.end(), colour.data_.begin());
  depth.Prepare(frame.depth.width, frame.depth.height, 1, 4);
  float* d = depth.PointerAs<float>();
  for (std::size_t i = 0; i < frame.depth.data.size(); ++i) {
    const float z = frame.depth.data[i];
    d[i] = (std::isfinite(z) && z > 0.f) ? z : 0.f;
  }
  // depth_scale 1: the depth is already in metres.
  return o3d::geometry::RGBDImage::CreateFromColorAndDepth(colour, depth, 1.0, max_depth_m, convert_rgb_to_intensity);
}

}  // namespace panoscan
