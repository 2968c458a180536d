#include "panoscan/sim/noise.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"

namespace panoscan {

namespace {

// 35130 / Z_cm = 351.3 / Z_m.
constexpr double kDisparityTimesMetres = kHandaDisparityConstant / 100.0;

// kDisparityTimesMetres / q for the whole disparities q the sensor's range produces (351 / 0.5 m
// = 703; 4096 leaves room for any range): the same quotients as the division, computed once,
// because the per-pixel division was the slowest step of the noise model.
constexpr int kDepthTableSize = 4096;
const std::vector<double>& depth_of_disparity_table() {
  static const std::vector<double> table = [] {
    std::vector<double> t(kDepthTableSize, 0.0);
    for (int q = 1; q < kDepthTableSize; ++q) t[q] = kDisparityTimesMetres / double(q);
    return t;
  }();
  return table;
}

}  // namespace

double disparity_model_depth_std(double z_m, double disparity_std) {
  // dZ/dd = Z^2 / 351.3; rounding adds a uniform 1/12 units^2 averaged over the phase.
  return z_m * z_m / kDisparityTimesMetres * std::sqrt(disparity_std * disparity_std + 1.0 / 12.0);
}

double handa_depth_std(double z_m) { return disparity_model_depth_std(z_m, 1.0 / 6.0); }

bool depth_valid(double z_m, double incidence_cos, const NoiseOptions& options) {
  return z_m >= options.min_depth_m && z_m <= options.max_depth_m &&
         incidence_cos >= std::cos(deg2rad(options.max_incidence_deg));
}

ImageF32 apply_depth_noise(const DepthNoiseInput& input, const NoiseOptions& options, std::uint64_t seed) {
  const ImageF32& clean = *input.clean_depth;
  const ImageF32& incidence = *input.incidence_cos;
  const PinholeIntrinsics& k = *input.intrinsics;
  const int width = clean.width, height = clean.height;
  ImageF32 noisy(width, height, 1, 0.0f);
  const double disparity_std = options.effective_disparity_std();
  const bool noisy_preset = options.preset != NoisePreset::kNone;
  const bool lateral = options.preset == NoisePreset::kHandaIcl;
  const int band_rows = static_cast<int>(std::lround(options.ir_band_fraction * height));
  const double min_cos = std::cos(deg2rad(options.max_incidence_deg));
  const std::vector<double>& depth_of_disparity = depth_of_disparity_table();

  // Inverse depth per pixel, 0 where the sensor has no measurement (no hit, or outside its
  // range): such a pixel invalidates every lookup that touches it. Computed once per frame so
  // that the per-pixel lookup needs no division. The float quotient is the double one rounded to
  // float (double carries more than twice float's precision), and unlike it vectorises.
  ImageF32 inverse_depth(width, height, 1, 0.0f);
  const double min_depth = options.min_depth_m, max_depth = options.max_depth_m;
  for (std::size_t i = 0; i < clean.data.size(); ++i) {
    const float z = clean.data[i];
    const bool in_range = double(z) >= min_depth && double(z) <= max_depth;
    inverse_depth.data[i] = in_range ? 1.0f / z : 0.0f;
  }

  if (!noisy_preset) {
    for (std::size_t i = 0; i < clean.data.size(); ++i) {
      const double z_clean = clean.data[i];
      if (z_clean > 0 && depth_valid(z_clean, incidence.data[i], options)) noisy.data[i] = float(z_clean);
    }
    return noisy;
  }

  const double shift_std = options.shift_std_px;
  const double ir_dropout = options.ir_dropout, ir_disparity_std = options.ir_disparity_std;
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    // A row's variates are drawn first, one stream at a time, then the model runs over the row.
    // Each stream gives the same draws in the same order as when the pixel loop drew them (the
    // streams are independent of each other), so the noise is the same; the separate loops keep
    // one generator's state in registers and leave the model's loop free of the generators.
    std::vector<double> shift_x(width), shift_y(width), disparity_noise(width), lateral_noise(width, 0.0),
        speckle_noise(width, 0.0);
    std::vector<std::uint8_t> speckle_hole(width, 0);
    for (int y = rows.begin(); y != rows.end(); ++y) {
      // One stream per (purpose, row): the result does not depend on how rows are scheduled.
      RandomStream shift_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthShift, y);
      RandomStream disparity_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthDisparity, y);
      // Every variate is drawn for every pixel so that validity never shifts the streams.
      for (int x = 0; x < width; ++x) {
        shift_x[x] = shift_rng.normal() * shift_std;
        shift_y[x] = shift_rng.normal() * shift_std;
      }
      for (int x = 0; x < width; ++x) disparity_noise[x] = disparity_rng.normal() * disparity_std;
      if (lateral) {
        RandomStream lateral_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthLateral, y);
        for (int x = 0; x < width; ++x) lateral_noise[x] = lateral_rng.normal();
      }
      const bool in_band = options.ir_speckle && band_rows > 0 &&
                           ((input.speckle_top && y < band_rows) || (input.speckle_bottom && y >= height - band_rows));
      if (in_band) {
        RandomStream speckle_rng(seed, input.sensor, input.frame, RandomPurpose::kSpeckle, y);
        for (int x = 0; x < width; ++x) {
          speckle_hole[x] = speckle_rng.uniform() < ir_dropout;
          speckle_noise[x] = speckle_rng.normal() * ir_disparity_std;
        }
      } else {
        std::fill(speckle_hole.begin(), speckle_hole.end(), std::uint8_t(0));
        std::fill(speckle_noise.begin(), speckle_noise.end(), 0.0);
      }

      const float* clean_row = clean.row(y);
      const float* incidence_row = incidence.row(y);
      float* noisy_row = noisy.row(y);
      for (int x = 0; x < width; ++x) {
        const double z_clean = clean_row[x];
        const double cos_incidence = incidence_row[x];
        if (z_clean <= 0 || cos_incidence < min_cos || speckle_hole[x]) continue;

        // Step 1: sub-pixel shift, bilinear interpolation of inverse depth (clamped at the border);
        // a lookup touching an invalid neighbour is invalid.
        const double sx = std::clamp(x + shift_x[x], 0.0, double(width - 1));
        const double sy = std::clamp(y + shift_y[x], 0.0, double(height - 1));
        const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
        const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
        const double fx = sx - x0, fy = sy - y0;
        const float* upper = inverse_depth.row(y0);
        const float* lower = inverse_depth.row(y1);
        const double i00 = upper[x0], i10 = upper[x1];
        const double i01 = lower[x0], i11 = lower[x1];
        // The four tests combined without short-circuit branches: each is rarely true, and one
        // branch predicts better than four.
        if ((i00 == 0) | (i10 == 0) | (i01 == 0) | (i11 == 0)) continue;
        double inv = (1 - fy) * ((1 - fx) * i00 + fx * i10) + fy * ((1 - fx) * i01 + fx * i11);

        if (lateral) {
          // handa-icl: displacement along the surface normal with Nguyen et al.'s lateral std
          // sigma_L = (0.8 + 0.035 theta / (pi/2 - theta)) * Z / f; along the ray this moves the
          // range by delta / cos(theta), i.e. z by delta / (cos(theta) * |ray|) for a z-unit ray.
          double z = 1.0 / inv;
          const double c = std::max(cos_incidence, 0.1);
          const double theta = std::acos(std::min(c, 1.0));
          const double sigma_px = 0.8 + 0.035 * theta / std::max(M_PI / 2 - theta, 1e-3);
          const double delta = lateral_noise[x] * sigma_px * z / k.fx;
          const double ray_x = (x - k.cx) / k.fx, ray_y = (y - k.cy) / k.fy;
          z += delta / (c * std::sqrt(1.0 + ray_x * ray_x + ray_y * ray_y));
          if (z <= 0) continue;
          inv = 1.0 / z;
        }

        // Step 2: disparity noise and unbiased rounding to whole disparity units.
        const double disparity = kDisparityTimesMetres * inv + disparity_noise[x] + speckle_noise[x];
        // floor(disparity + 0.5) > 0 exactly when disparity + 0.5 >= 1; below 2^31 the integer
        // conversion truncates, which for positive values is the floor (std::floor is a libm
        // sequence on the baseline x86-64 target).
        const double rounded = disparity + 0.5;
        if (!(rounded >= 1.0)) continue;
        double z_noisy;
        if (rounded < double(kDepthTableSize)) {
          z_noisy = depth_of_disparity[static_cast<int>(rounded)];
        } else {
          z_noisy = kDisparityTimesMetres / std::floor(rounded);
        }
        // Step 3: sensor range.
        if (z_noisy < min_depth || z_noisy > max_depth) continue;
        noisy_row[x] = static_cast<float>(z_noisy);
      }
    }
  });
  return noisy;
}

}  // namespace panoscan
