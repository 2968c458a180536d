// Panorama depth error on synthetic panoramas with known errors and holes.

#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/eval/panorama_metrics.h"
#include "test_util.h"

namespace panoscan::eval {
namespace {

using ::testing::HasSubstr;

constexpr int kH = 64, kW = 128;

ImageF32 truth_panorama() {
  ImageF32 truth(kW, kH, 1, 0.f);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) truth.at(u, v) = 2.0f + 0.5f * std::sin(0.1f * u) + 0.01f * v;
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < 4; ++u) truth.at(u, v) = 0.f;  // no ground truth in columns 0..3
  return truth;
}

TEST(PanoramaDepth, KnownErrorsAndHoles) {
  const ImageF32 truth = truth_panorama();
  ImageF32 estimated = truth;
  // Columns alternate +1 cm / -3 cm; rows 0..9 are holes; column 0..3 has depth the truth lacks.
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      if (v < 10) {
        estimated.at(u, v) = 0.f;
      } else if (u < 4) {
        estimated.at(u, v) = 3.f;
      } else {
        estimated.at(u, v) = truth.at(u, v) + (u % 2 ? -0.03f : 0.01f);
      }
    }
  estimated.at(51, 30) = std::numeric_limits<float>::quiet_NaN();  // NaN counts as no depth
  const PanoramaDepthError e = compare_panorama_depth(estimated, truth);
  const std::size_t overlap = std::size_t(kH - 10) * (kW - 4) - 1;
  EXPECT_EQ(e.overlap_pixels, overlap);
  EXPECT_EQ(e.estimated_only_pixels, std::size_t(kH - 10) * 4);
  EXPECT_EQ(e.truth_only_pixels, std::size_t(10) * (kW - 4) + 1);
  EXPECT_NEAR(e.coverage, double(overlap) / double(kH * (kW - 4)), 1e-12);
  // Half the pixels +1 cm, half -3 cm (the NaN pixel is an odd column: one fewer -3 cm).
  const double n_plus = (kH - 10) * (kW - 4) / 2, n_minus = n_plus - 1;
  const double rmse = std::sqrt((n_plus * 1e-4 + n_minus * 9e-4) / (n_plus + n_minus));
  EXPECT_NEAR(e.abs_error_m.rmse, rmse, 1e-6);  // float images: errors are float-rounded
  EXPECT_NEAR(e.mean_signed_error_m, (n_plus * 0.01 - n_minus * 0.03) / (n_plus + n_minus), 1e-6);
  EXPECT_NEAR(e.abs_error_m.max, 0.03, 1e-6);
  EXPECT_NEAR(e.rmse_solid_angle_weighted_m, rmse, 2e-4);  // the same mix in every row
  EXPECT_TRUE(std::isnan(e.error_m.at(0, 20)));
  EXPECT_TRUE(std::isnan(e.error_m.at(20, 5)));
  EXPECT_NEAR(e.error_m.at(20, 20), 0.01, 1e-6);
  EXPECT_NEAR(e.error_m.at(21, 20), -0.03, 1e-6);
}

TEST(PanoramaDepth, SolidAngleWeightingFavoursTheEquator) {
  const ImageF32 truth(kW, kH, 1, 3.f);
  ImageF32 estimated = truth;
  for (int u = 0; u < kW; ++u) estimated.at(u, 0) = 3.1f;  // error only in the top row
  const PanoramaDepthError e = compare_panorama_depth(estimated, truth);
  EXPECT_NEAR(e.abs_error_m.rmse, std::sqrt(0.01 / kH), 1e-6);
  EXPECT_LT(e.rmse_solid_angle_weighted_m, 0.3 * e.abs_error_m.rmse);
}

TEST(PanoramaDepth, ErrorPictureAndBadInput) {
  testutil::TempDir dir("pano");
  const ImageF32 truth = truth_panorama();
  ImageF32 estimated = truth;
  for (int v = 0; v < kH; ++v)
    for (int u = 4; u < kW; ++u) estimated.at(u, v) += v < kH / 2 ? 0.02f : -0.02f;
  const PanoramaDepthError e = compare_panorama_depth(estimated, truth);
  const ColourLegend legend = write_panorama_error_png(dir / "error.png", e.error_m, 0.05);
  EXPECT_DOUBLE_EQ(legend.min, -0.05);
  EXPECT_DOUBLE_EQ(legend.max, 0.05);
  const ImageU8 picture = read_rgb(dir / "error.png");
  ASSERT_EQ(picture.width, kW);
  EXPECT_EQ(picture.at(0, 10, 0) + picture.at(0, 10, 1) + picture.at(0, 10, 2), 0);  // no overlap: black
  EXPECT_GT(picture.at(10, 5, 0), picture.at(10, 5, 2));                             // too far: red
  EXPECT_LT(picture.at(10, 60, 0), picture.at(10, 60, 2));                           // too near: blue

  ImageF32 small(kW / 2, kH / 2, 1, 1.f);
  try {
    compare_panorama_depth(small, truth, "pano_SO-1.exr");
    FAIL();
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr("pano_SO-1.exr"));
    EXPECT_THAT(error.what(), HasSubstr("64x32"));
  }
  const ImageF32 holes(kW, kH, 1, 0.f);
  EXPECT_THROW(compare_panorama_depth(holes, truth), Error);
  EXPECT_THROW(compare_panorama_depth(ImageF32(), truth), Error);
}

}  // namespace
}  // namespace panoscan::eval
