// Radial-depth error of a reconstructed equirectangular panorama against a noiseless ground-truth
// panorama rendered from the same centre (docs/ARCHITECTURE.md §13). Both are ImageF32 of radial depth in metres,
// 0 (or non-finite) = no depth.
#pragma once

#include <filesystem>
#include <string>

#include "panoscan/core/image.h"
#include "panoscan/eval/colour_map.h"
#include "panoscan/eval/error_stats.h"

namespace panoscan::eval {

struct PanoramaDepthError {
  std::size_t overlap_pixels = 0;         // both valid: the pixels every figure below is over
  std::size_t estimated_only_pixels = 0;  // depth where the truth has none
  std::size_t truth_only_pixels = 0;      // truth the reconstruction missed
  double coverage = 0.0;                  // overlap / valid truth pixels
  ErrorStats abs_error_m;                 // |est - truth| per pixel: rmse is the per-pixel RMSE
  double mean_signed_error_m = 0.0;       // bias (positive = reconstruction too far)
  // RMSE with each pixel weighted by its solid angle (sin of the polar angle): every direction
  // counts equally, the poles are not over-represented.
  double rmse_solid_angle_weighted_m = 0.0;
  ImageF32 error_m;  // est - truth; NaN outside the overlap
};

// Throws Error naming `origin` if the images differ in size, are empty, not single-channel, or
// have no valid pixel in common.
PanoramaDepthError compare_panorama_depth(const ImageF32& estimated, const ImageF32& truth,
                                          const std::string& origin = "panorama");

// Colour picture of a signed error image (coolwarm: blue = too near, red = too far, black = no
// overlap), clamped to +-range_m (range_m <= 0: the 99th percentile of |error|). Atomic PNG.
ColourLegend write_panorama_error_png(const std::filesystem::path& path, const ImageF32& error_m, double range_m = 0.0);

}  // namespace panoscan::eval
