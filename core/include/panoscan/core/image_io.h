// PNG and EXR image files. Every reader validates and throws Error naming the file on a missing,
// unreadable or wrongly-shaped image. Every writer is atomic (temp file + rename).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/image.h"

namespace panoscan {

// 8-bit PNG with 1 or 3 channels (RGB order in memory). compression: 0 (fast) .. 9 (small).
void write_png(const std::filesystem::path& path, const ImageU8& image, int compression = 1);
// 16-bit single-channel PNG (depth).
void write_png16(const std::filesystem::path& path, const ImageU16& image, int compression = 1);
// The bytes of the PNG file write_png / write_png16 write, encoded in memory: for writers that
// encode frames in parallel and write them in order (the simulator's scan writer).
std::string encode_png(const ImageU8& image, int compression = 1);
std::string encode_png16(const ImageU16& image, int compression = 1);

// Reads an 8-bit PNG, JPEG, BMP, TIFF, WebP or PNM image as RGB (3 channels), the format told by the
// file's first bytes, not its name. Throws if the file is missing, of another format, or corrupt.
ImageU8 read_rgb(const std::filesystem::path& path);
// Reads a 16-bit single-channel PNG. Throws if it is not a PNG (by content) or not 16-bit single-channel.
ImageU16 read_png16(const std::filesystem::path& path);

// The image container by its first bytes: "PNG", "JPEG", "BMP", "TIFF", "WebP", "PNM" (the formats
// read_rgb reads), or "" for anything else or a file that cannot be read.
std::string image_file_format(const std::filesystem::path& path);

// A PNG's size and sample format from its IHDR chunk, without decoding the pixels.
struct PngHeader {
  int width = 0, height = 0;
  int bit_depth = 0;  // bits per sample: 1, 2, 4, 8 or 16
  int channels = 0;   // 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA; a palette image counts as 3 (it decodes to RGB)
};
// Throws Error naming the file when it is missing, not a PNG (by content) or its header is
// truncated or invalid.
PngHeader read_png_header(const std::filesystem::path& path);

// Float EXR with named channels (e.g. {"R","G","B"} or {"Z"}); image.channels == names.size().
void write_exr(const std::filesystem::path& path, const ImageF32& image, const std::vector<std::string>& channel_names);
// Reads the named channels of a float EXR (throws naming the file and channel if one is missing).
// A size larger than kMaxExrSide per side or kMaxExrPixels in all, or other than expected_width x
// expected_height when those are given (> 0), is an Error raised before the pixels are allocated.
constexpr std::int64_t kMaxExrSide = 65536;
constexpr std::int64_t kMaxExrPixels = std::int64_t(1) << 30;
ImageF32 read_exr(const std::filesystem::path& path, const std::vector<std::string>& channel_names,
                  int expected_width = 0, int expected_height = 0);

// 32-bit integer EXR (ids): named channels of OpenEXR's only integer type, UINT, holding each int32
// by its bit pattern, so -1 reads as 4294967295 in other tools (numpy: .view(np.int32) gives -1).
void write_exr_i32(const std::filesystem::path& path, const ImageI32& image,
                   const std::vector<std::string>& channel_names);
// Reads named UINT channels as int32 (bit pattern); the size checks of read_exr. A channel of
// another type is an Error naming the file and the channel (never converted: a float cannot hold
// every 32-bit id).
ImageI32 read_exr_i32(const std::filesystem::path& path, const std::vector<std::string>& channel_names,
                      int expected_width = 0, int expected_height = 0);

}  // namespace panoscan
