// PNG decoding of the layouts scans use, with libdeflate (see png_decode.h for why and what).
#include "png_decode.h"

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <libdeflate.h>

#include "panoscan/core/error.h"
#include "ply_header.h"  // ply::read_whole_file

namespace panoscan {

namespace {

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

// Paeth predictor (PNG specification §9.4).
inline int paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// Reverses the filter of one row in place for a pixel of BPP bytes; `previous` is the unfiltered
// row above (zeros for the first row). Sub, Average and Paeth add the reconstructed pixel to the
// left, which the byte loop read back from the row it had just written: every byte waited on the
// store of the byte BPP before it (store-to-load forwarding), and the Sub rows of a scan's colour
// images made this three quarters of the decoder's own time. The left (and upper-left) pixel is
// carried in locals instead, so each channel's chain is one register addition per pixel.
template <std::size_t BPP>
bool unfilter_row_bpp(int filter, unsigned char* row, const unsigned char* previous, std::size_t size) {
  switch (filter) {
    case 0: return true;
    case 1: {
      std::uint8_t left[BPP] = {};
      for (std::size_t i = 0; i + BPP <= size; i += BPP)
        for (std::size_t c = 0; c < BPP; ++c) row[i + c] = left[c] = std::uint8_t(row[i + c] + left[c]);
      return true;
    }
    case 2:
      for (std::size_t i = 0; i < size; ++i) row[i] = std::uint8_t(row[i] + previous[i]);
      return true;
    case 3: {
      std::uint8_t left[BPP] = {};
      for (std::size_t i = 0; i + BPP <= size; i += BPP)
        for (std::size_t c = 0; c < BPP; ++c)
          row[i + c] = left[c] = std::uint8_t(row[i + c] + ((left[c] + previous[i + c]) >> 1));
      return true;
    }
    case 4: {
      std::uint8_t left[BPP] = {}, upper_left[BPP] = {};
      for (std::size_t i = 0; i + BPP <= size; i += BPP)
        for (std::size_t c = 0; c < BPP; ++c) {
          const std::uint8_t up = previous[i + c];
          row[i + c] = left[c] = std::uint8_t(row[i + c] + paeth(left[c], up, upper_left[c]));
          upper_left[c] = up;
        }
      return true;
    }
    default: return false;
  }
}

// The same for the pixel sizes the fast path decodes (grey 1, 16-bit grey 2, RGB 3, RGBA 4 bytes);
// `size` is a whole number of pixels.
bool unfilter_row(int filter, unsigned char* row, const unsigned char* previous, std::size_t size, std::size_t bpp) {
  switch (bpp) {
    case 1: return unfilter_row_bpp<1>(filter, row, previous, size);
    case 2: return unfilter_row_bpp<2>(filter, row, previous, size);
    case 3: return unfilter_row_bpp<3>(filter, row, previous, size);
    case 4: return unfilter_row_bpp<4>(filter, row, previous, size);
    default: return false;
  }
}


struct Decompressor {
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  ~Decompressor() { libdeflate_free_decompressor(d); }
};

}  // namespace

bool decode_png_fast(const std::filesystem::path& path, DecodedPng* out) {
  // In one read (an istreambuf_iterator copied it byte by byte).
  const std::string file = ply::read_whole_file(path.string());
  const auto* bytes = reinterpret_cast<const unsigned char*>(file.data());
  const std::size_t size = file.size();
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 || std::memcmp(bytes, kSignature, 8) != 0) throw make_error(path.string(), "format", "not a PNG file");

  int width = 0, height = 0, bit_depth = 0, colour_type = -1;
  bool have_header = false, ended = false;
  // The zlib stream: the IDAT chunk's data in place when there is one chunk (the encoders of scans
  // write one), else the chunks' data joined.
  std::string joined;
  const unsigned char* compressed = nullptr;
  std::size_t compressed_size = 0;
  int idat_chunks = 0;
  for (std::size_t at = 8; at < size && !ended;) {
    if (size - at < 12) throw make_error(path.string(), "chunk", "truncated PNG chunk");
    const std::uint32_t length = be32(bytes + at);
    if (length > 0x7fffffffu || length > size - at - 12)
      throw make_error(path.string(), "chunk", "PNG chunk longer than the file (truncated or corrupt)");
    const unsigned char* type = bytes + at + 4;
    const unsigned char* data = type + 4;
    const std::uint32_t crc = be32(data + length);
    if (libdeflate_crc32(0, type, length + 4) != crc)
      throw make_error(path.string(), std::string("chunk ") + std::string(reinterpret_cast<const char*>(type), 4),
                       "CRC mismatch (corrupt PNG)");
    if (std::memcmp(type, "IHDR", 4) == 0) {
      if (length != 13) throw make_error(path.string(), "IHDR", "wrong length");
      const std::uint32_t w = be32(data), h = be32(data + 4);
      if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu)
        throw make_error(path.string(), "IHDR", "invalid PNG size");
      bit_depth = data[8];
      colour_type = data[9];
      const int compression = data[10], filter_method = data[11], interlace = data[12];
      // Only the layouts the fast path handles; OpenCV decodes the others (palette, grey + alpha,
      // 16-bit colour, sub-byte depths, Adam7).
      const bool layout = (bit_depth == 8 && (colour_type == 0 || colour_type == 2 || colour_type == 6)) ||
                          (bit_depth == 16 && colour_type == 0);
      if (!layout || compression != 0 || filter_method != 0 || interlace != 0) return false;
      // The same ceiling as OpenCV's (CV_IO_MAX_IMAGE_PIXELS): a corrupt header must not allocate
      // gigabytes.
      if (std::uint64_t(w) * h > (std::uint64_t(1) << 30))
        throw make_error(path.string(), "IHDR", "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
      width = int(w), height = int(h);
      have_header = true;
    } else if (std::memcmp(type, "IDAT", 4) == 0) {
      if (!have_header) throw make_error(path.string(), "IDAT", "image data before the IHDR chunk");
      if (++idat_chunks == 1) {
        compressed = data;
      } else {
        if (idat_chunks == 2) joined.assign(reinterpret_cast<const char*>(compressed), compressed_size);
        joined.append(reinterpret_cast<const char*>(data), length);
        compressed = reinterpret_cast<const unsigned char*>(joined.data());
      }
      compressed_size += length;
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      ended = true;
    } else if (std::memcmp(type, "PLTE", 4) == 0 || std::memcmp(type, "tRNS", 4) == 0) {
      return false;  // transparency keyed to a colour: OpenCV's handling, not ours
    }
    at += std::size_t(length) + 12;
  }
  if (!have_header) throw make_error(path.string(), "IHDR", "missing (not a PNG image)");
  if (compressed_size == 0) throw make_error(path.string(), "IDAT", "no image data");

  const int channels = colour_type == 0 ? 1 : colour_type == 2 ? 3 : 4;
  const std::size_t bpp = std::size_t(channels) * (bit_depth / 8);
  const std::size_t row_bytes = std::size_t(width) * bpp;
  const std::size_t raw_size = std::size_t(height) * (row_bytes + 1);
  std::unique_ptr<unsigned char[]> raw(new unsigned char[raw_size]);
  thread_local Decompressor decompressor;
  std::size_t got = 0;
  const libdeflate_result result = libdeflate_zlib_decompress(decompressor.d, compressed, compressed_size,
                                                              raw.get(), raw_size, &got);
  if (result != LIBDEFLATE_SUCCESS || got != raw_size)
    throw make_error(path.string(), "IDAT",
                     result == LIBDEFLATE_BAD_DATA ? "corrupt compressed image data"
                                                   : "image data does not match the IHDR size (truncated or corrupt)");
  const std::vector<unsigned char> zero_row(row_bytes, 0);
  for (int y = 0; y < height; ++y) {
    unsigned char* filtered = raw.get() + std::size_t(y) * (row_bytes + 1);
    const unsigned char* previous = y == 0 ? zero_row.data() : filtered - row_bytes;  // the row above's samples
    if (!unfilter_row(filtered[0], filtered + 1, previous, row_bytes, bpp))
      throw make_error(path.string(), "IDAT", "invalid filter type " + std::to_string(filtered[0]) + " in row " +
                                                  std::to_string(y));
  }
  out->width = width;
  out->height = height;
  out->channels = channels;
  out->bit_depth = bit_depth;
  out->row_stride = row_bytes + 1;
  out->data = std::move(raw);
  return true;
}

}  // namespace panoscan
