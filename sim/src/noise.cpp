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
  // that the per-pixel lookup needs no division.
  ImageF32 inverse_depth(width, height, 1, 0.0f);
  for (std::size_t i = 0; i < clean.data.size(); ++i) {
    const double z = clean.data[i];
    if (z >= options.min_depth_m && z <= options.max_depth_m) inverse_depth.data[i] = float(1.0 / z);
  }

  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      // One stream per (purpose, row): the result does not depend on how rows are scheduled.
      RandomStream shift_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthShift, y);
      RandomStream disparity_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthDisparity, y);
      RandomStream lateral_rng(seed, input.sensor, input.frame, RandomPurpose::kDepthLateral, y);
      RandomStream speckle_rng(seed, input.sensor, input.frame, RandomPurpose::kSpeckle, y);
      const bool in_band = options.ir_speckle && band_rows > 0 &&
                           ((input.speckle_top && y < band_rows) || (input.speckle_bottom && y >= height - band_rows));
      for (int x = 0; x < width; ++x) {
        const double z_clean = clean.at(x, y);
        const double cos_incidence = incidence.at(x, y);
        if (!noisy_preset) {
          if (z_clean > 0 && depth_valid(z_clean, cos_incidence, options)) noisy.at(x, y) = float(z_clean);
          continue;
        }
        // Draw every variate for every pixel so that validity never shifts the streams.
        const double shift_x = shift_rng.normal() * options.shift_std_px;
        const double shift_y = shift_rng.normal() * options.shift_std_px;
        const double disparity_noise = disparity_rng.normal() * disparity_std;
        const double lateral_noise = lateral ? lateral_rng.normal() : 0.0;
        double speckle_noise = 0.0;
        bool speckle_hole = false;
        if (in_band) {
          speckle_hole = speckle_rng.uniform() < options.ir_dropout;
          speckle_noise = speckle_rng.normal() * options.ir_disparity_std;
        }
        if (z_clean <= 0 || cos_incidence < min_cos || speckle_hole) continue;

        // Step 1: sub-pixel shift, bilinear interpolation of inverse depth (clamped at the border);
        // a lookup touching an invalid neighbour is invalid.
        const double sx = std::clamp(x + shift_x, 0.0, double(width - 1));
        const double sy = std::clamp(y + shift_y, 0.0, double(height - 1));
        const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
        const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
        const double fx = sx - x0, fy = sy - y0;
        const double i00 = inverse_depth.at(x0, y0), i10 = inverse_depth.at(x1, y0);
        const double i01 = inverse_depth.at(x0, y1), i11 = inverse_depth.at(x1, y1);
        if (i00 == 0 || i10 == 0 || i01 == 0 || i11 == 0) continue;
        double inv = (1 - fy) * ((1 - fx) * i00 + fx * i10) + fy * ((1 - fx) * i01 + fx * i11);

        if (lateral) {
          // handa-icl: displacement along the surface normal with Nguyen et al.'s lateral std
          // sigma_L = (0.8 + 0.035 theta / (pi/2 - theta)) * Z / f; along the ray this moves the
          // range by delta / cos(theta), i.e. z by delta / (cos(theta) * |ray|) for a z-unit ray.
          double z = 1.0 / inv;
          const double c = std::max(cos_incidence, 0.1);
          const double theta = std::acos(std::min(c, 1.0));
          const double sigma_px = 0.8 + 0.035 * theta / std::max(M_PI / 2 - theta, 1e-3);
          const double delta = lateral_noise * sigma_px * z / k.fx;
          const double ray_x = (x - k.cx) / k.fx, ray_y = (y - k.cy) / k.fy;
          z += delta / (c * std::sqrt(1.0 + ray_x * ray_x + ray_y * ray_y));
          if (z <= 0) continue;
          inv = 1.0 / z;
        }

        // Step 2: disparity noise and unbiased rounding to whole disparity units.
        const double disparity = kDisparityTimesMetres * inv + disparity_noise + speckle_noise;
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
        if (z_noisy < options.min_depth_m || z_noisy > options.max_depth_m) continue;
        noisy.at(x, y) = static_cast<float>(z_noisy);
      }
    }
  });
  return noisy;
}

}  // namespace panoscan
