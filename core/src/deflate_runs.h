// The PNG writer's fastest level: zlib streams (RFC 1950) whose DEFLATE blocks (RFC 1951) hold
// literals and matches of one kind only, coded with Huffman codes fitted to each block: runs
// (matches at distance 1) for colour, repeats of one of the nearby pixels for 16-bit depth.
// Internal to panoscan_core (png_encode.cpp); docs/ARCHITECTURE.md §3.4 and sim/README.md say why it
// exists beside libdeflate.
#pragma once

#include <cstddef>
#include <cstdint>

namespace panoscan::detail {

// The zlib stream of `data[0, size)` written to `out`, which has room for
// zlib_runs_bound(size) bytes; returns its size. Each block of up to 32768 literals and runs is
// written as a dynamic-Huffman block, or stored where that is smaller. Any inflater decodes it
// (zlib, libdeflate, libpng). The same input gives the same bytes.
std::size_t zlib_compress_runs(const std::uint8_t* data, std::size_t size, std::uint8_t* out);
std::size_t zlib_runs_bound(std::size_t size);

// The zlib stream of `rows` PNG rows of 16-bit greyscale samples (each a filter byte, then
// `row_pixels` samples of 2 bytes: `rows * (1 + 2 * row_pixels)` bytes), written to `out`, which has
// room for zlib_runs_bound of that size; returns its size. Literals and matches of whole pixels that
// repeat one of the 16 pixels before in the row or the pixel above (the repeats of quantised depth),
// with Huffman codes fitted per block of rows. Any inflater decodes it; the same input gives the same
// bytes.
std::size_t zlib_compress_repeats16(const std::uint8_t* data, std::size_t rows, std::size_t row_pixels,
                                    std::uint8_t* out);

// Code lengths of a Huffman code for `count` symbols of weights `freq` (0: unused, given length 0),
// none longer than `max_length`; at least two symbols get a length, so the code is complete. Exposed
// for tests.
void huffman_code_lengths(const std::uint32_t* freq, int count, int max_length, std::uint8_t* lengths);

}  // namespace panoscan::detail
