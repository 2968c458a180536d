// PNG decoding of the layouts a scan holds (8-bit grey / RGB / RGBA colour, 16-bit grey depth,
// not interlaced) with libdeflate. OpenCV's decoder (libpng + zlib) took a quarter of a tracking
// run's instructions, most of it inflating; libdeflate inflates several times faster. Every other
// layout (palette, grey + alpha, 16-bit colour, sub-byte depths, Adam7, colour-keyed
// transparency) is left to OpenCV: decode_png_fast returns false.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>

namespace panoscan {

struct DecodedPng {
  int width = 0, height = 0, channels = 0, bit_depth = 0;
  // The inflated image data, unfiltered in place: each row is one filter byte, then the samples as
  // stored (8-bit as bytes, 16-bit big-endian, PNG's order). Not zero-filled first (a memset of
  // every frame cost 3% of a tracking run).
  std::unique_ptr<unsigned char[]> data;
  std::size_t row_stride = 0;
  const unsigned char* row(int y) const { return data.get() + std::size_t(y) * row_stride + 1; }
};

// True and `out` filled for the layouts above; false for another layout (decode it elsewhere).
// Throws Error naming the file and the chunk for a corrupt or truncated file (CRC, zlib stream,
// sizes, filter types).
bool decode_png_fast(const std::filesystem::path& path, DecodedPng* out);

}  // namespace panoscan
