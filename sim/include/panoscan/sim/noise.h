// Depth noise models (docs/ARCHITECTURE.md §4): Handa et al. 2014 (ICL-NUIM) as fixed there, its
// ICL-NUIM-code variant, a real-Kinect-level preset, and the switchable interference speckle.
#pragma once

#include <cstdint>

#include "panoscan/core/camera.h"
#include "panoscan/core/image.h"
#include "panoscan/sim/options.h"

namespace panoscan {

// Constant of the disparity model: d = kHandaDisparityConstant / Z_cm in 1/8-pixel units
// (8 x 585.5 px x 7.5 cm).
constexpr double kHandaDisparityConstant = 35130.0;

// Predicted depth standard deviation of the `handa` preset at depth z (metres): quantisation
// (1/12) plus Gaussian (1/36) disparity variance = 1/9 units^2 -> sigma_Z = Z^2 / 351.3 / 3.
double handa_depth_std(double z_m);
// The same for any disparity noise std (units of 1/8 px).
double disparity_model_depth_std(double z_m, double disparity_std);

struct DepthNoiseInput {
  const ImageF32* clean_depth = nullptr;    // z in metres, 0 = no hit
  const ImageF32* incidence_cos = nullptr;  // |cos| of the angle between ray and normal
  const PinholeIntrinsics* intrinsics = nullptr;
  int sensor = 0;
  int frame = 0;
  // Rows near the top / bottom edge that overlap a neighbouring camera's projector (speckle).
  bool speckle_top = false;
  bool speckle_bottom = false;
  // The Handa model's kernel: eight pixels per AVX-512 operation where the CPU has AVX-512, else
  // four per AVX2 operation, else the scalar loop; each bit for bit the scalar loop's result. The
  // tests force each one to compare it with the scalar loop.
  enum class Kernel { kFastest, kAvx2, kScalar };
  Kernel kernel = Kernel::kFastest;
};

// Returns the noisy depth (metres, 0 = invalid). Deterministic in (seed, sensor, frame).
ImageF32 apply_depth_noise(const DepthNoiseInput& input, const NoiseOptions& options, std::uint64_t seed);

// Range and incidence validity without noise (the `none` preset and clean ground truth).
bool depth_valid(double z_m, double incidence_cos, const NoiseOptions& options);

}  // namespace panoscan
