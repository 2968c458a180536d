// A minimal owning image: interleaved channels, row-major, row 0 at the top.
#pragma once

#include <cstdint>
#include <vector>

#include "panoscan/core/allocator.h"

namespace panoscan {

template <typename T>
struct Image {
  int width = 0;
  int height = 0;
  int channels = 1;
  // Its resize(n) leaves the values uninitialised (allocator.h); the constructor below fills them.
  UninitialisedVector<T> data;

  Image() = default;
  Image(int w, int h, int c = 1, T fill = T()) : width(w), height(h), channels(c), data(std::size_t(w) * h * c, fill) {}

  // An image whose values are not initialised, for one that is written in full right away: the
  // simulator makes about eight images of a 640x480 frame, and their zero fill was 2% of its time.
  static Image uninitialised(int w, int h, int c = 1) {
    Image image;
    image.width = w;
    image.height = h;
    image.channels = c;
    image.data.resize(std::size_t(w) * h * c);
    return image;
  }

  bool empty() const { return data.empty(); }
  T& at(int x, int y, int c = 0) { return data[(std::size_t(y) * width + x) * channels + c]; }
  const T& at(int x, int y, int c = 0) const { return data[(std::size_t(y) * width + x) * channels + c]; }
  T* row(int y) { return data.data() + std::size_t(y) * width * channels; }
  const T* row(int y) const { return data.data() + std::size_t(y) * width * channels; }
};

using ImageU8 = Image<std::uint8_t>;
using ImageU16 = Image<std::uint16_t>;
using ImageF32 = Image<float>;
using ImageI32 = Image<std::int32_t>;

}  // namespace panoscan
