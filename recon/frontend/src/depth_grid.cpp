// The block-mean depth grid (depth_grid.h).
#include "panoscan/recon/depth_grid.h"

#include <algorithm>
#include <cstdint>
#include <vector>

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
  // Two passes per band of `block` rows, both over contiguous memory so that the compiler vectorises
  // them: each pixel column's sum, range and validity down the band, then each block's over its
  // columns. Sums in float: 16-64 depths of 0.3-10 m, a relative error of 1e-7 (0.1 um at 1 m).
  const std::size_t columns = static_cast<std::size_t>(w) * static_cast<std::size_t>(block);
  std::vector<float> column_sum(columns), column_lo(columns), column_hi(columns);
  std::vector<std::uint8_t> column_valid(columns);
  for (int j = 0; j < h; ++j) {
    std::fill(column_sum.begin(), column_sum.end(), 0.0f);
    std::fill(column_lo.begin(), column_lo.end(), 1e30f);
    std::fill(column_hi.begin(), column_hi.end(), 0.0f);
    std::fill(column_valid.begin(), column_valid.end(), std::uint8_t(1));
    for (int y = j * block; y < (j + 1) * block; ++y) {
      const float* row = &depth_m.at(0, y);
      for (std::size_t x = 0; x < columns; ++x) {
        const float z = row[x];
        column_valid[x] &= std::uint8_t(z > 0.0f);  // false for NaN too
        column_sum[x] += z;
        column_lo[x] = std::min(column_lo[x], z);
        column_hi[x] = std::max(column_hi[x], z);
      }
    }
    for (int i = 0; i < w; ++i) {
      const std::size_t first = static_cast<std::size_t>(i) * block;
      float sum = 0.0f, lo = 1e30f, hi = 0.0f;
      bool valid = true;
      for (std::size_t x = first; x < first + block; ++x) {
        valid = valid && column_valid[x];
        sum += column_sum[x];
        lo = std::min(lo, column_lo[x]);
        hi = std::max(hi, column_hi[x]);
      }
      if (!valid) continue;
      const double mean = double(sum) / (block * block);
      const double span = std::max(0.1 * mean, 6.0 * depth_noise_coefficient * mean * mean);
      if (hi - lo <= span) grid.depth.at(i, j) = float(mean);
    }
  }
  return grid;
}

}  // namespace panoscan
