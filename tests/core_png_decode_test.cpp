// The libdeflate PNG decoder behind read_rgb / read_png16 against OpenCV's (libpng) on the layouts
// it takes, written by libpng with its adaptive filters (all five filter types occur), and its
// errors on corrupt files; and our encoder's files read by libpng.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "test_util.h"

namespace panoscan {
namespace {

// Smooth gradients plus noise: libpng's heuristic picks different filters on different rows.
cv::Mat test_image(int type, int width, int height, std::uint32_t seed) {
  cv::Mat mat(height, width, type);
  std::mt19937 rng(seed);
  const int channels = mat.channels();
  const bool wide = mat.depth() == CV_16U;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < channels; ++c) {
        const int base = (x * (c + 1) + y * 3) % 256;
        const int value = (y % 7 == 0) ? int(rng() % 256) : base;
        if (wide)
          mat.ptr<std::uint16_t>(y)[x * channels + c] = std::uint16_t(value * 250 + int(rng() % 7));
        else
          mat.ptr<std::uint8_t>(y)[x * channels + c] = std::uint8_t(value);
      }
  return mat;
}

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(PngDecode, ColourLayoutsMatchOpenCv) {
  testutil::TempDir dir("png");
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4}) {
    for (int level : {0, 1, 6, 9}) {
      const cv::Mat written = test_image(type, 67, 41, std::uint32_t(type + level));
      const auto path = dir.path() / ("c" + std::to_string(type) + "_" + std::to_string(level) + ".png");
      ASSERT_TRUE(cv::imwrite(path.string(), written, {cv::IMWRITE_PNG_COMPRESSION, level}));
      const cv::Mat reference = cv::imread(path.string(), cv::IMREAD_UNCHANGED);  // BGR(A) or grey
      const ImageU8 image = read_rgb(path);
      ASSERT_EQ(image.width, 67);
      ASSERT_EQ(image.height, 41);
      ASSERT_EQ(image.channels, 3);
      const int channels = reference.channels();
      for (int y = 0; y < 41; ++y)
        for (int x = 0; x < 67; ++x) {
          const std::uint8_t* ref = reference.ptr<std::uint8_t>(y) + x * channels;
          const std::uint8_t* got = image.row(y) + 3 * x;
          const std::uint8_t r = channels == 1 ? ref[0] : ref[2], g = channels == 1 ? ref[0] : ref[1], b = ref[0];
          ASSERT_EQ(got[0], r) << "type " << type << " level " << level << " at " << x << "," << y;
          ASSERT_EQ(got[1], g);
          ASSERT_EQ(got[2], b);
        }
    }
  }
}

TEST(PngDecode, DepthMatchesOpenCv) {
  testutil::TempDir dir("png");
  for (int level : {0, 1, 9}) {
    const cv::Mat written = test_image(CV_16UC1, 80, 33, std::uint32_t(level));
    const auto path = dir.path() / ("d" + std::to_string(level) + ".png");
    ASSERT_TRUE(cv::imwrite(path.string(), written, {cv::IMWRITE_PNG_COMPRESSION, level}));
    const ImageU16 image = read_png16(path);
    ASSERT_EQ(image.width, 80);
    ASSERT_EQ(image.height, 33);
    for (int y = 0; y < 33; ++y)
      for (int x = 0; x < 80; ++x) ASSERT_EQ(image.row(y)[x], written.ptr<std::uint16_t>(y)[x]) << x << "," << y;
  }
}

// The other way round: the files our encoder writes, read by libpng (through OpenCV), at the levels
// with different filtering: 0 (stored), 1 (the simulator's default: one fixed filter) and 6 (a filter
// chosen per row). A 640x480 frame spans several deflate blocks.
TEST(PngDecode, OurEncodedFilesReadByOpenCv) {
  const cv::Mat colour = test_image(CV_8UC3, 640, 480, 11), depth = test_image(CV_16UC1, 640, 480, 12);
  ImageU8 rgb(640, 480, 3);
  ImageU16 depth16(640, 480, 1);
  for (int y = 0; y < 480; ++y) {
    std::memcpy(rgb.row(y), colour.ptr<std::uint8_t>(y), 640 * 3);
    std::memcpy(depth16.row(y), depth.ptr<std::uint16_t>(y), 640 * 2);
  }
  for (int level : {0, 1, 6}) {
    const std::string rgb_png = encode_png(rgb, level), depth_png = encode_png16(depth16, level);
    const cv::Mat rgb_back =
        cv::imdecode(cv::Mat(1, int(rgb_png.size()), CV_8UC1, const_cast<char*>(rgb_png.data())), cv::IMREAD_UNCHANGED);
    const cv::Mat depth_back = cv::imdecode(
        cv::Mat(1, int(depth_png.size()), CV_8UC1, const_cast<char*>(depth_png.data())), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(rgb_back.type(), CV_8UC3) << "level " << level;
    ASSERT_EQ(depth_back.type(), CV_16UC1) << "level " << level;
    cv::Mat bgr(colour.size(), colour.type());  // OpenCV decodes to BGR; our image is RGB
    const int swap_red_blue[] = {0, 2, 1, 1, 2, 0};
    cv::mixChannels(&colour, 1, &bgr, 1, swap_red_blue, 3);
    EXPECT_EQ(cv::norm(rgb_back, bgr, cv::NORM_INF), 0.0) << "level " << level;
    EXPECT_EQ(cv::norm(depth_back, depth, cv::NORM_INF), 0.0) << "level " << level;
    if (level > 0) {
      EXPECT_LT(rgb_png.size(), rgb.data.size() / 2) << "level " << level << ": not compressed";
    }
  }
}

TEST(PngDecode, OtherLayoutsStillDecode) {
  // 16-bit colour is not the fast path's: OpenCV decodes it and read_rgb refuses it as before;
  // an 8-bit depth image is refused by read_png16 naming the bit depth.
  testutil::TempDir dir("png");
  const auto colour16 = dir.path() / "c16.png";
  ASSERT_TRUE(cv::imwrite(colour16.string(), test_image(CV_16UC3, 10, 10, 1)));
  try {
    read_rgb(colour16);
    FAIL() << "16-bit colour accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("8-bit"), std::string::npos) << e.what();
  }
  const auto grey8 = dir.path() / "g8.png";
  ASSERT_TRUE(cv::imwrite(grey8.string(), test_image(CV_8UC1, 10, 10, 2)));
  try {
    read_png16(grey8);
    FAIL() << "8-bit depth accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("16-bit"), std::string::npos) << e.what();
  }
}

TEST(PngDecode, CorruptFilesAreClearErrors) {
  testutil::TempDir dir("png");
  const auto good = dir.path() / "good.png";
  ASSERT_TRUE(cv::imwrite(good.string(), test_image(CV_8UC3, 50, 20, 3)));
  const std::string bytes = read_bytes(good);
  const std::size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  auto expect_error = [&](const std::string& name, const std::string& content, const std::string& field) {
    const auto path = dir.path() / name;
    write_bytes(path, content);
    try {
      read_rgb(path);
      FAIL() << name << " accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path.string()), std::string::npos) << what;
      EXPECT_NE(what.find(field), std::string::npos) << name << ": " << what;
    }
  };
  std::string flipped = bytes;
  flipped[idat + 10] = char(flipped[idat + 10] ^ 0x40);  // inside the compressed data: the CRC catches it
  expect_error("crc.png", flipped, "chunk IDAT");
  expect_error("truncated.png", bytes.substr(0, idat + 30), "chunk");
  expect_error("signature_only.png", bytes.substr(0, 8), "IHDR");
}

}  // namespace
}  // namespace panoscan
