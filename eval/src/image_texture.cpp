#include "panoscan/eval/image_texture.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "panoscan/core/error.h"

namespace panoscan::eval {

namespace {

template <typename T>
ImageF32 luma(const Image<T>& rgb, float scale, const char* what) {
  if (rgb.channels != 3 || rgb.empty()) throw make_error(what, "", "expected a non-empty 3-channel image");
  ImageF32 grey(rgb.width, rgb.height, 1);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x)
      grey.at(x, y) =
          scale * (0.299f * float(rgb.at(x, y, 0)) + 0.587f * float(rgb.at(x, y, 1)) + 0.114f * float(rgb.at(x, y, 2)));
  return grey;
}

}  // namespace

ImageF32 grey_levels(const ImageU8& rgb) { return luma(rgb, 1.f, "grey_levels"); }
ImageF32 grey_levels_from_unit(const ImageF32& rgb01) { return luma(rgb01, 255.f, "grey_levels_from_unit"); }

FlatPixelShare flat_pixel_share(const ImageF32& grey, const ImageU8& valid, int window, double std_threshold) {
  if (window <= 0 || window % 2 == 0)
    throw make_error("flat_pixel_share", "window", "must be odd and positive, got " + std::to_string(window));
  if (grey.channels != 1) throw make_error("flat_pixel_share", "grey", "expected a single-channel image");
  const bool all_valid = valid.empty();
  if (!all_valid && (valid.width != grey.width || valid.height != grey.height || valid.channels != 1))
    throw make_error("flat_pixel_share", "valid", "mask does not match the grey image's size");
  const int w = grey.width, h = grey.height;
  // Integral images (double: exact enough for 8-bit levels over any realistic image) of the count,
  // sum and sum of squares of valid grey levels.
  const std::size_t stride = std::size_t(w) + 1;
  std::vector<double> count((std::size_t(h) + 1) * stride, 0.0), sum(count.size(), 0.0), sum2(count.size(), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool ok = (all_valid || valid.at(x, y) != 0) && std::isfinite(grey.at(x, y));
      const double g = ok ? grey.at(x, y) : 0.0;
      const std::size_t i = (std::size_t(y) + 1) * stride + std::size_t(x) + 1;
      count[i] = (ok ? 1.0 : 0.0) + count[i - 1] + count[i - stride] - count[i - stride - 1];
      sum[i] = g + sum[i - 1] + sum[i - stride] - sum[i - stride - 1];
      sum2[i] = g * g + sum2[i - 1] + sum2[i - stride] - sum2[i - stride - 1];
    }
  auto box = [&](const std::vector<double>& table, int x0, int y0, int x1, int y1) {  // [x0, x1) x [y0, y1)
    return table[std::size_t(y1) * stride + x1] - table[std::size_t(y0) * stride + x1] -
           table[std::size_t(y1) * stride + x0] + table[std::size_t(y0) * stride + x0];
  };
  const int r = window / 2;
  const double threshold2 = std_threshold * std_threshold;
  FlatPixelShare result;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!((all_valid || valid.at(x, y) != 0) && std::isfinite(grey.at(x, y)))) continue;
      ++result.valid_pixels;
      const int x0 = std::max(0, x - r), x1 = std::min(w, x + r + 1), y0 = std::max(0, y - r),
                y1 = std::min(h, y + r + 1);
      const double n = box(count, x0, y0, x1, y1);
      if (n < 0.5 * double(x1 - x0) * double(y1 - y0)) continue;
      const double mean = box(sum, x0, y0, x1, y1) / n;
      const double variance = std::max(0.0, box(sum2, x0, y0, x1, y1) / n - mean * mean);
      if (variance < threshold2) ++result.flat_pixels;
    }
  result.share = result.valid_pixels ? double(result.flat_pixels) / double(result.valid_pixels) : 0.0;
  return result;
}

}  // namespace panoscan::eval
