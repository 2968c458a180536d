// PNG encoding in memory with libdeflate, and at level 1 for colour our literals-and-runs deflate
// (deflate_runs.h) (docs/ARCHITECTURE.md §3.4 for the images). Written here
// rather than through OpenCV/libpng because the simulator writes two PNGs per frame and libpng +
// zlib were 28% of a sim run's CPU time: libpng's adaptive filter heuristic tries every filter on
// every row, zlib is slower than libdeflate at the same level, and the file had to be written by
// the encoding thread. Encoding to memory lets frames encode in parallel and be written in order
// (sim/README.md has the measurements).
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>

#include <libdeflate.h>

#include "deflate_runs.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"

namespace panoscan {

namespace {

void put_be32(std::string& out, std::uint32_t value) {
  const char bytes[4] = {char(value >> 24), char(value >> 16), char(value >> 8), char(value)};
  out.append(bytes, 4);
}

// Appends one chunk: length, type, data, CRC over type and data.
void put_chunk(std::string& out, const char* type, const unsigned char* data, std::size_t size) {
  put_be32(out, std::uint32_t(size));
  const std::size_t type_at = out.size();
  out.append(type, 4);
  if (size > 0) out.append(reinterpret_cast<const char*>(data), size);
  const auto* crc_begin = reinterpret_cast<const unsigned char*>(out.data() + type_at);
  put_be32(out, libdeflate_crc32(0, crc_begin, size + 4));
}

std::uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return std::uint8_t(a);
  return std::uint8_t(pb <= pc ? b : c);
}

// PNG filter `type` (0 none, 1 sub, 2 up, 3 average, 4 paeth) of one row of `n` bytes with `bpp`
// bytes per pixel; `prior` is the row above (all zero for the first row). None and Sub have loops of
// their own: the generic one's switch per byte halves their speed.
void filter_row(int type, const std::uint8_t* row, const std::uint8_t* prior, std::size_t n, int bpp,
                std::uint8_t* out) {
  if (type == 0) {
    std::memcpy(out, row, n);
    return;
  }
  const std::size_t lead = std::min<std::size_t>(std::size_t(bpp), n);
  if (type == 1) {
    std::memcpy(out, row, lead);
    for (std::size_t i = lead; i < n; ++i) out[i] = std::uint8_t(row[i] - row[i - bpp]);
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const int a = i >= std::size_t(bpp) ? row[i - bpp] : 0;
    const int b = prior[i];
    const int c = i >= std::size_t(bpp) ? prior[i - bpp] : 0;
    int predicted = 0;
    switch (type) {
      case 2: predicted = b; break;
      case 3: predicted = (a + b) >> 1; break;
      default: predicted = paeth(a, b, c); break;
    }
    out[i] = std::uint8_t(row[i] - predicted);
  }
}

// Sum of the filtered bytes as signed values: libpng's heuristic for choosing a row's filter.
std::size_t filtered_cost(const std::uint8_t* filtered, std::size_t n) {
  std::size_t sum = 0;
  for (std::size_t i = 0; i < n; ++i) sum += filtered[i] < 128 ? filtered[i] : 256 - filtered[i];
  return sum;
}

// How level 1 codes an image: the rows unfiltered and libdeflate's level 1 (depth), or Sub-filtered
// and coded as literals and runs (colour; deflate_runs.h).
enum class FastestLevel { kUnfilteredLibdeflate, kSubFilteredRuns };

// `raw`: rows of `row_bytes` bytes, samples already in PNG byte order. Level 0 stores the rows
// unfiltered; level 1 as `fastest` says: choosing a filter per row would cost more than it saves;
// levels 2-9 choose each row's filter as libpng does and compress with libdeflate at that level.
std::string encode(const std::uint8_t* raw, int width, int height, int channels, int bit_depth, int compression,
                   FastestLevel fastest) {
  const bool runs = compression == 1 && fastest == FastestLevel::kSubFilteredRuns;
  if (compression < 0 || compression > 9)
    throw make_error("<png>", "compression", "expected an integer in [0, 9], found " + std::to_string(compression));
  const int bpp = channels * bit_depth / 8;
  const std::size_t row_bytes = std::size_t(width) * bpp;
  // Not value-initialised: every byte is written below, and zeroing a frame's worth first was a
  // pass over memory per image.
  const std::size_t filtered_size = (row_bytes + 1) * height;
  const std::unique_ptr<std::uint8_t[]> filtered(new std::uint8_t[filtered_size]);
  std::vector<std::uint8_t> zero_row(row_bytes, 0), candidate(row_bytes);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = raw + row_bytes * y;
    const std::uint8_t* prior = y > 0 ? row - row_bytes : zero_row.data();
    std::uint8_t* out = filtered.get() + (row_bytes + 1) * y;
    if (compression <= 1 && !runs) {
      out[0] = 0;
      std::memcpy(out + 1, row, row_bytes);
    } else if (runs) {
      out[0] = 1;
      filter_row(1, row, prior, row_bytes, bpp, out + 1);
    } else {
      std::size_t best_cost = ~std::size_t(0);
      for (int type = 0; type <= 4; ++type) {
        filter_row(type, row, prior, row_bytes, bpp, candidate.data());
        const std::size_t cost = filtered_cost(candidate.data(), row_bytes);
        if (cost < best_cost) {
          best_cost = cost;
          out[0] = std::uint8_t(type);
          std::memcpy(out + 1, candidate.data(), row_bytes);
        }
      }
    }
  }

  std::unique_ptr<std::uint8_t[]> compressed;
  std::size_t compressed_size = 0;
  if (runs) {
    // Literals and runs only: 2x libdeflate's level 1 on the simulator's colour frames, 5% larger.
    compressed.reset(new std::uint8_t[detail::zlib_runs_bound(filtered_size)]);
    compressed_size = detail::zlib_compress_runs(filtered.get(), filtered_size, compressed.get());
  } else {
    // libdeflate rather than zlib: about 3x faster at the same level and smaller output (the
    // measurements are in sim/README.md). Level 0 maps to its "store" level.
    libdeflate_compressor* compressor = libdeflate_alloc_compressor(compression);
    if (!compressor) throw make_error("<png>", "", "libdeflate: cannot allocate a compressor");
    const std::size_t bound = libdeflate_zlib_compress_bound(compressor, filtered_size);
    compressed.reset(new std::uint8_t[bound]);
    compressed_size = libdeflate_zlib_compress(compressor, filtered.get(), filtered_size, compressed.get(), bound);
    libdeflate_free_compressor(compressor);
    if (compressed_size == 0) throw make_error("<png>", "", "libdeflate: compression failed");
  }

  std::string png;
  png.reserve(compressed_size + 64);
  png.append("\x89PNG\r\n\x1a\n", 8);
  unsigned char header[13];
  const auto be32_at = [&](int at, std::uint32_t v) {
    header[at] = std::uint8_t(v >> 24);
    header[at + 1] = std::uint8_t(v >> 16);
    header[at + 2] = std::uint8_t(v >> 8);
    header[at + 3] = std::uint8_t(v);
  };
  be32_at(0, std::uint32_t(width));
  be32_at(4, std::uint32_t(height));
  header[8] = std::uint8_t(bit_depth);
  header[9] = channels == 3 ? 2 : 0;         // colour type: truecolour or greyscale
  header[10] = header[11] = header[12] = 0;  // deflate, adaptive filtering, no interlace
  put_chunk(png, "IHDR", header, sizeof header);
  put_chunk(png, "IDAT", compressed.get(), compressed_size);
  put_chunk(png, "IEND", nullptr, 0);
  return png;
}

void check_encodable(int width, int height, int channels, std::size_t size, int expected_channels_mask) {
  if (width <= 0 || height <= 0 || size != std::size_t(width) * height * channels ||
      !((1 << channels) & expected_channels_mask))
    throw make_error("<png>", "image",
                     "inconsistent image buffer (" + std::to_string(width) + "x" + std::to_string(height) + "x" +
                         std::to_string(channels) + ")");
}

}  // namespace

std::string encode_png(const ImageU8& image, int compression) {
  check_encodable(image.width, image.height, image.channels, image.data.size(), (1 << 1) | (1 << 3));
  // Level 1: Sub-filtered literals and runs. On the simulator's 640x480 colour frames (plain walls,
  // the sensor's colour noise) this is 1.5 ms and 185 KB per frame against libdeflate's level 1
  // without a filter, 2.8 ms and 176 KB (its smallest and fastest filter there; sim/README.md).
  return encode(image.data.data(), image.width, image.height, image.channels, 8, compression,
                FastestLevel::kSubFilteredRuns);
}

std::string encode_png16(const ImageU16& image, int compression) {
  check_encodable(image.width, image.height, image.channels, image.data.size(), 1 << 1);
  const std::size_t bytes = image.data.size() * 2;
  const std::unique_ptr<std::uint8_t[]> big_endian(new std::uint8_t[bytes]);  // every byte written below
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    big_endian[2 * i] = std::uint8_t(image.data[i] >> 8);
    big_endian[2 * i + 1] = std::uint8_t(image.data[i]);
  }
  // Level 1: no filter and libdeflate. Depth's runs of zeros (no measurement) and of equal quantised
  // values are matches as they stand; on simulated frames this is both the fastest and the smallest
  // of libdeflate's (Sub +10%, Up and Paeth +50% in size). Literals and runs would take 1.3 instead
  // of 1.9 ms but write 137 instead of 84 KB per frame, a fifth more disk per scan.
  return encode(big_endian.get(), image.width, image.height, 1, 16, compression, FastestLevel::kUnfilteredLibdeflate);
}

}  // namespace panoscan
