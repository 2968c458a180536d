// The PNG writer's fastest level: a zlib stream (RFC 1950) whose DEFLATE blocks (RFC 1951) hold
// literals and runs (matches at distance 1) only, coded with Huffman codes fitted to each block.
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

// Code lengths of a Huffman code for `count` symbols of weights `freq` (0: unused, given length 0),
// none longer than `max_length`; at least two symbols get a length, so the code is complete. Exposed
// for tests.
void huffman_code_lengths(const std::uint32_t* freq, int count, int max_length, std::uint8_t* lengths);

}  // namespace panoscan::detail
