// The PNG writer's level-1 deflate (literals and runs, core/src/deflate_runs.h): every stream it
// writes inflates to its input with libdeflate's decoder (the Adler-32 checked too), on inputs that
// take each of its paths; its Huffman codes are complete and within their length limits; and PNGs
// of it are read by libpng (through OpenCV).
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <libdeflate.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "deflate_runs.h"
#include "panoscan/core/image_io.h"

namespace panoscan {
namespace {

std::vector<std::uint8_t> compress(const std::vector<std::uint8_t>& data) {
  std::vector<std::uint8_t> out(detail::zlib_runs_bound(data.size()));
  out.resize(detail::zlib_compress_runs(data.data(), data.size(), out.data()));
  return out;
}

// Inflates `stream` with libdeflate, expecting `size` bytes; empty on any error.
std::vector<std::uint8_t> inflate(const std::vector<std::uint8_t>& stream, std::size_t size) {
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  std::vector<std::uint8_t> out(size + 1);
  std::size_t got = 0;
  const libdeflate_result result =
      libdeflate_zlib_decompress(d, stream.data(), stream.size(), out.data(), out.size(), &got);
  libdeflate_free_decompressor(d);
  if (result != LIBDEFLATE_SUCCESS) return {};
  out.resize(got);
  return out;
}

void expect_round_trip(const std::vector<std::uint8_t>& data, const std::string& what) {
  const std::vector<std::uint8_t> stream = compress(data);
  ASSERT_LE(stream.size(), detail::zlib_runs_bound(data.size())) << what;
  const std::vector<std::uint8_t> back = inflate(stream, data.size());
  ASSERT_EQ(back.size(), data.size()) << what << ": did not inflate to its input";
  EXPECT_TRUE(back == data) << what;
  EXPECT_EQ(compress(data), stream) << what << ": not the same bytes a second time";
}

TEST(DeflateRuns, EveryStreamInflatesToItsInput) {
  std::mt19937 rng(7);
  expect_round_trip({}, "empty");
  expect_round_trip({42}, "one byte");
  expect_round_trip(std::vector<std::uint8_t>(1 << 20, 0), "1 MiB of zeros (runs of 258, many blocks)");
  // 4065 runs of the longest length: a run is followed past the 16-byte window it starts in.
  EXPECT_LT(compress(std::vector<std::uint8_t>(1 << 20, 0)).size(), 4096u) << "zeros not coded as runs of 258";
  // Random bytes: no runs to speak of; stored blocks are smaller than any Huffman code.
  std::vector<std::uint8_t> noise(200000);
  for (auto& b : noise) b = std::uint8_t(rng());
  expect_round_trip(noise, "random bytes");
  EXPECT_LE(compress(noise).size(), noise.size() + 64) << "random bytes grew more than the stored blocks' headers";
  // Runs of every length 1 ... 300 (every length symbol, runs longer than 258 split), of random
  // values, between random literals, at every alignment to the eight-byte steps.
  std::vector<std::uint8_t> runs;
  for (int length = 1; length <= 300; ++length)
    for (int repeat = 0; repeat < 3; ++repeat) {
      runs.insert(runs.end(), std::size_t(length), std::uint8_t(rng() % 4));
      for (int k = int(rng() % 9); k > 0; --k) runs.push_back(std::uint8_t(rng()));
    }
  expect_round_trip(runs, "runs of every length");
  EXPECT_LT(compress(runs).size(), runs.size() / 8) << "runs not coded as runs";
  // Sizes around the sixteen-byte steps (14 literals a step) and the block's token limit (32768).
  for (std::size_t size :
       {7u, 8u, 9u, 13u, 14u, 15u, 16u, 17u, 18u, 31u, 32u, 33u, 32767u, 32768u, 32769u, 65535u, 65536u, 65537u}) {
    std::vector<std::uint8_t> data(size);
    for (auto& b : data) b = std::uint8_t(rng() % 3);  // short runs, many literals
    expect_round_trip(data, "size " + std::to_string(size));
  }
  // Skewed symbol counts (a geometric spread over 200 symbols): Huffman's lengths would pass 15 bits.
  std::vector<std::uint8_t> skewed;
  for (int symbol = 0; symbol < 200; ++symbol) {
    const std::size_t count = std::size_t(1) << std::min(17, symbol / 2 + 1);
    for (std::size_t k = 0; k < std::min<std::size_t>(count, 3000); ++k) skewed.push_back(std::uint8_t(symbol));
    skewed.push_back(std::uint8_t(symbol + 1));  // no runs of one symbol only
  }
  std::shuffle(skewed.begin(), skewed.end(), rng);
  expect_round_trip(skewed, "skewed symbol counts");
}

// Kraft's sum of `lengths` in units of 2^-limit.
std::uint64_t kraft_sum(const std::vector<std::uint8_t>& lengths, int limit) {
  std::uint64_t sum = 0;
  for (std::uint8_t l : lengths)
    if (l) sum += std::uint64_t(1) << (limit - l);
  return sum;
}

TEST(DeflateRuns, HuffmanCodesAreCompleteAndWithinTheirLimit) {
  // Fibonacci weights give Huffman's deepest tree: 30 symbols reach depth 29 unlimited.
  std::vector<std::uint32_t> fibonacci(30);
  fibonacci[0] = fibonacci[1] = 1;
  for (std::size_t i = 2; i < fibonacci.size(); ++i) fibonacci[i] = fibonacci[i - 1] + fibonacci[i - 2];
  for (int limit : {7, 15}) {
    std::vector<std::uint8_t> lengths(fibonacci.size());
    detail::huffman_code_lengths(fibonacci.data(), int(fibonacci.size()), limit, lengths.data());
    for (std::uint8_t l : lengths) {
      EXPECT_GE(l, 1);
      EXPECT_LE(l, limit);
    }
    EXPECT_EQ(kraft_sum(lengths, limit), std::uint64_t(1) << limit) << "limit " << limit << ": not complete";
  }
  // Unlimited in effect, the lengths are Huffman's: weights 1, 1, 2, 4 -> 3, 3, 2, 1.
  const std::uint32_t small[4] = {1, 1, 2, 4};
  std::vector<std::uint8_t> lengths(4);
  detail::huffman_code_lengths(small, 4, 15, lengths.data());
  EXPECT_EQ(lengths, (std::vector<std::uint8_t>{3, 3, 2, 1}));
  // One symbol used, or none: two symbols get one bit each (a complete code).
  const std::uint32_t one_used[5] = {0, 0, 9, 0, 0}, none_used[3] = {0, 0, 0};
  lengths.assign(5, 0);
  detail::huffman_code_lengths(one_used, 5, 15, lengths.data());
  EXPECT_EQ(lengths, (std::vector<std::uint8_t>{1, 0, 1, 0, 0}));
  lengths.assign(3, 0);
  detail::huffman_code_lengths(none_used, 3, 7, lengths.data());
  EXPECT_EQ(lengths, (std::vector<std::uint8_t>{1, 1, 0}));
}

// A frame like the simulator's colour: flat regions (runs after the Sub filter) with sensor noise on
// part of them, read back by libpng; smaller than half its raw size.
TEST(DeflateRuns, ColourPngsOfTheFastestLevelReadByLibpng) {
  std::mt19937 rng(3);
  ImageU8 rgb(640, 480, 3);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x)
      for (int c = 0; c < 3; ++c) {
        const int flat = 60 + 40 * c + (x / 80) * 10;
        rgb.row(y)[3 * x + c] = std::uint8_t(y < 240 ? flat : flat + int(rng() % 5) - 2);
      }
  const std::string png = encode_png(rgb, 1);
  EXPECT_LT(png.size(), rgb.data.size() / 2);
  const cv::Mat back =
      cv::imdecode(cv::Mat(1, int(png.size()), CV_8UC1, const_cast<char*>(png.data())), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_8UC3);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(back.ptr<std::uint8_t>(y)[3 * x + (2 - c)], rgb.row(y)[3 * x + c]) << x << "," << y;
}

}  // namespace
}  // namespace panoscan
