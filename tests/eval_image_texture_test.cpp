// The flat-pixel share on synthetic images whose answer is known.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/eval/image_texture.h"

namespace panoscan::eval {
namespace {

TEST(FlatPixelShare, UniformImageIsFlatEverywhere) {
  const ImageF32 grey(40, 30, 1, 128.f);
  const FlatPixelShare s = flat_pixel_share(grey, ImageU8());
  EXPECT_EQ(s.valid_pixels, 1200u);
  EXPECT_EQ(s.flat_pixels, 1200u);
  EXPECT_DOUBLE_EQ(s.share, 1.0);
}

TEST(FlatPixelShare, CheckerboardIsNeverFlat) {
  ImageF32 grey(40, 30, 1);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) grey.at(x, y) = ((x + y) % 2) ? 100.f : 110.f;  // std 5 in every window
  EXPECT_EQ(flat_pixel_share(grey, ImageU8()).flat_pixels, 0u);
}

TEST(FlatPixelShare, ThresholdAndHalfTexturedImage) {
  // Left half: noise-free ramp of 0.5 grey levels per pixel (std over 7 columns = 1.0 < 2: flat);
  // right half: stripes of +-3 levels (std 3: not flat). Pixels within 3 columns of the boundary
  // see both halves.
  ImageF32 grey(64, 20, 1);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 64; ++x) grey.at(x, y) = x < 32 ? 50.f + 0.5f * x : (x % 2 ? 97.f : 103.f);
  const FlatPixelShare s = flat_pixel_share(grey, ImageU8());
  EXPECT_EQ(s.valid_pixels, 64u * 20u);
  // Columns 0..28 are flat (their windows stay in the ramp), 32.. are not; 29..31 mix both.
  EXPECT_GE(s.flat_pixels, 29u * 20u);
  EXPECT_LE(s.flat_pixels, 32u * 20u);
  // The same ramp is not flat for a threshold below its std.
  ImageF32 ramp(32, 20, 1);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 32; ++x) ramp.at(x, y) = 0.5f * x;
  // (Only the three columns at either border, whose windows are cut to 4-6 columns, stay flat.)
  EXPECT_EQ(flat_pixel_share(ramp, ImageU8(), 7, 0.9).flat_pixels, 6u * 20u);
  EXPECT_GT(flat_pixel_share(ramp, ImageU8(), 7, 1.1).share, 0.8);
}

TEST(FlatPixelShare, InvalidPixelsAreLeftOut) {
  // Invalid pixels carry wild values that would break flatness if they were counted.
  ImageF32 grey(30, 30, 1, 80.f);
  ImageU8 valid(30, 30, 1, 1);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; x += 3) {
      grey.at(x, y) = 255.f;
      valid.at(x, y) = 0;
    }
  const FlatPixelShare s = flat_pixel_share(grey, valid);
  EXPECT_EQ(s.valid_pixels, 600u);
  EXPECT_EQ(s.flat_pixels, 600u);
  // A valid pixel whose window is mostly invalid is not called flat.
  ImageU8 sparse(30, 30, 1, 0);
  sparse.at(15, 15) = 1;
  const FlatPixelShare lonely = flat_pixel_share(grey, sparse);
  EXPECT_EQ(lonely.valid_pixels, 1u);
  EXPECT_EQ(lonely.flat_pixels, 0u);
}

TEST(FlatPixelShare, GreyLevelsAndErrors) {
  ImageU8 rgb(2, 1, 3, 0);
  rgb.at(0, 0, 0) = rgb.at(0, 0, 1) = rgb.at(0, 0, 2) = 200;
  rgb.at(1, 0, 1) = 100;
  const ImageF32 grey = grey_levels(rgb);
  EXPECT_NEAR(grey.at(0, 0), 200.f, 1e-3f);
  EXPECT_NEAR(grey.at(1, 0), 58.7f, 1e-3f);
  ImageF32 unit(1, 1, 3, 0.5f);
  EXPECT_NEAR(grey_levels_from_unit(unit).at(0, 0), 127.5f, 1e-3f);
  EXPECT_THROW(grey_levels(ImageU8(2, 2, 1)), Error);
  EXPECT_THROW(flat_pixel_share(ImageF32(4, 4, 1), ImageU8(), 6), Error);
  EXPECT_THROW(flat_pixel_share(ImageF32(4, 4, 1), ImageU8(3, 4, 1)), Error);
}

}  // namespace
}  // namespace panoscan::eval
