// Per-pixel radial-depth error of a panorama against the noiseless ground-truth panorama.

#include "panoscan/eval/panorama_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"

namespace panoscan::eval {

namespace {

bool has_depth(float value) { return std::isfinite(value) && value > 0.f; }

}  // namespace

PanoramaDepthError compare_panorama_depth(const ImageF32& estimated, const ImageF32& truth, const std::string& origin) {
  if (estimated.empty() || truth.empty()) throw make_error(origin, "", "empty panorama");
  if (estimated.channels != 1 || truth.channels != 1)
    throw make_error(origin, "channels", "radial depth panoramas must have one channel");
  if (estimated.width != truth.width || estimated.height != truth.height)
    throw make_error(origin, "size",
                     "reconstruction is " + std::to_string(estimated.width) + "x" + std::to_string(estimated.height) +
                         " but the ground truth is " + std::to_string(truth.width) + "x" +
                         std::to_string(truth.height));
  PanoramaDepthError result;
  result.error_m = ImageF32(truth.width, truth.height, 1, std::numeric_limits<float>::quiet_NaN());
  std::vector<double> abs_errors;
  std::size_t truth_valid = 0;
  long double signed_sum = 0.0L, weighted_squares = 0.0L, weight_sum = 0.0L;
  for (int v = 0; v < truth.height; ++v) {
    // Solid angle of a pixel of row v is proportional to sin(theta), theta = pi (v + 0.5) / H.
    const double weight = std::sin(M_PI * (v + 0.5) / truth.height);
    for (int u = 0; u < truth.width; ++u) {
      const float e = estimated.at(u, v), t = truth.at(u, v);
      const bool e_valid = has_depth(e), t_valid = has_depth(t);
      truth_valid += t_valid;
      if (e_valid && !t_valid) ++result.estimated_only_pixels;
      if (!e_valid && t_valid) ++result.truth_only_pixels;
      if (!(e_valid && t_valid)) continue;
      const double error = static_cast<double>(e) - static_cast<double>(t);
      result.error_m.at(u, v) = static_cast<float>(error);
      abs_errors.push_back(std::abs(error));
      signed_sum += error;
      weighted_squares += weight * error * error;
      weight_sum += weight;
    }
  }
  result.overlap_pixels = abs_errors.size();
  if (result.overlap_pixels == 0)
    throw make_error(origin, "", "the reconstruction and the ground truth have no valid pixel in common");
  result.coverage = static_cast<double>(result.overlap_pixels) / static_cast<double>(truth_valid);
  result.mean_signed_error_m = static_cast<double>(signed_sum / static_cast<long double>(result.overlap_pixels));
  result.rmse_solid_angle_weighted_m = static_cast<double>(std::sqrt(weighted_squares / weight_sum));
  result.abs_error_m = summarize_errors(std::move(abs_errors));
  return result;
}

ColourLegend write_panorama_error_png(const std::filesystem::path& path, const ImageF32& error_m, double range_m) {
  if (error_m.empty() || error_m.channels != 1) throw make_error(path.string(), "", "needs a one-channel error image");
  ColourLegend legend;
  legend.map = ColourMap::kCoolWarm;
  if (!(range_m > 0)) {
    std::vector<double> magnitudes;
    for (float e : error_m.data)
      if (std::isfinite(e)) magnitudes.push_back(std::abs(e));
    std::sort(magnitudes.begin(), magnitudes.end());
    range_m = magnitudes.empty() ? 0.0 : percentile_of_sorted(magnitudes, 0.99);
    if (!(range_m > 0)) range_m = 1e-3;
  }
  legend.min = -range_m;
  legend.max = range_m;
  ImageU8 picture(error_m.width, error_m.height, 3, 0);  // black where there is no overlap
  for (int v = 0; v < error_m.height; ++v)
    for (int u = 0; u < error_m.width; ++u) {
      const float e = error_m.at(u, v);
      if (!std::isfinite(e)) continue;
      const Rgb8 colour = legend.colour(e);
      for (int c = 0; c < 3; ++c) picture.at(u, v, c) = colour[c];
    }
  write_png(path, picture);
  return legend;
}

}  // namespace panoscan::eval
