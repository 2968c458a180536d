// The block-mean depth grid (depth_grid.h).
#include "panoscan/recon/depth_grid.h"

#include <algorithm>

#include "panoscan/core/error.h"

namespace panoscan {

DepthGrid make_depth_grid(const ImageF32& depth_m, const PinholeIntrinsics& pixel_intrinsics, int block,
                          double depth_noise_coefficient) {
  if (block < 1) throw make_error("<depth grid>", "block", "must be >= 1");
  if (depth_m.channels != 1) throw make_error("<depth grid>", "depth", "must have one channel");
  DepthGrid grid;
  grid.block = block;
  const int w = depth_m.width / block, h = depth_m.height / block;
  grid.depth = ImageF32(w, h, 1, 0.0f);
  // Block (i, j) covers pixels [b i, b i + b - 1]: its centre is pixel b i + (b - 1) / 2, so
  // u_grid = (u_pixel - (b - 1) / 2) / b.
  grid.intrinsics = pixel_intrinsics;
  grid.intrinsics.width = w;
  grid.intrinsics.height = h;
  grid.intrinsics.fx = pixel_intrinsics.fx / block;
  grid.intrinsics.fy = pixel_intrinsics.fy / block;
  grid.intrinsics.cx = (pixel_intrinsics.cx - 0.5 * (block - 1)) / block;
  grid.intrinsics.cy = (pixel_intrinsics.cy - 0.5 * (block - 1)) / block;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      double sum = 0.0;
      float lo = 1e30f, hi = 0.0f;
      bool valid = true;
      for (int y = j * block; y < (j + 1) * block && valid; ++y)
        for (int x = i * block; x < (i + 1) * block; ++x) {
          const float z = depth_m.at(x, y);
          if (!(z > 0.0f)) {
            valid = false;
            break;
          }
          sum += z;
          lo = std::min(lo, z);
          hi = std::max(hi, z);
        }
      if (!valid) continue;
      const double mean = sum / (block * block);
      const double span = std::max(0.1 * mean, 6.0 * depth_noise_coefficient * mean * mean);
      if (hi - lo <= span) grid.depth.at(i, j) = float(mean);
    }
  return grid;
}

}  // namespace panoscan
