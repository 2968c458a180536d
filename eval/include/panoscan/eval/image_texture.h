// How much of an image is textureless: the share of its valid pixels that lie in flat regions,
// i.e. whose window x window neighbourhood has a grey-level standard deviation below a threshold
// (grey levels on the 8-bit scale, 0..255). Used to compare the texture density of rooms: a
// scanned, texture-poor room has about half its pixels flat; high-contrast textures on every
// surface leave almost none.
#pragma once

#include <cstddef>

#include "panoscan/core/image.h"

namespace panoscan::eval {

struct FlatPixelShare {
  std::size_t valid_pixels = 0;
  std::size_t flat_pixels = 0;
  double share = 0.0;  // flat / valid (0 if no valid pixel)
};

// Grey levels (Rec. 601 luma, 0..255) of an 8-bit RGB image or of a float colour image on the
// 0..1 scale (a panorama's colour). Throws Error unless the image has 3 channels.
ImageF32 grey_levels(const ImageU8& rgb);
ImageF32 grey_levels_from_unit(const ImageF32& rgb01);

// `valid`: empty (every pixel valid) or single-channel of the grey image's size, non-zero = valid.
// A valid pixel is flat if the valid pixels of its window (cut at the image border; invalid ones
// left out) are at least half of the window's part inside the image and their grey levels'
// standard deviation is below `std_threshold`. Throws Error for an even or non-positive window or mismatched sizes.
FlatPixelShare flat_pixel_share(const ImageF32& grey, const ImageU8& valid, int window = 7, double std_threshold = 2.0);

}  // namespace panoscan::eval
