// Tests of the image files (PNG 8/16-bit, EXR) and of TUM trajectory files: bit-exact round
// trips, and bad input rejected with an Error that names the file (and the line or field).

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/trajectory.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class IoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("panoscan_io_test_" + std::string(info->name()) + "_" +
                                        std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  fs::path write_text(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  // Names of everything in the test directory (to check that no temporary files are left).
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  fs::path dir_;
};

using testutil::error_of;

// An image whose every sample differs from its neighbours, so swapped channels or rows show.
ImageU8 make_rgb(int width, int height) {
  ImageU8 image(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = static_cast<std::uint8_t>((x * 37 + y * 91 + c * 53) % 256);
  return image;
}

ImageU16 make_depth_units(int width, int height) {
  ImageU16 image(width, height, 1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) image.at(x, y) = static_cast<std::uint16_t>((x * 7919 + y * 104729) % 65536);
  image.at(0, 0) = 0;
  image.at(1, 0) = 65535;
  image.at(2, 0) = 256;  // high byte only: catches byte-order mistakes
  image.at(3, 0) = 1;
  return image;
}

// ---------------------------------------------------------------- atomic folders

TEST_F(IoTest, AFolderLeftByAKilledRunIsRemovedByTheNextRunToTheSamePlace) {
  const fs::path out = dir_ / "scan";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // a run killed while writing: no destructor, no commit
    AtomicDirectory folder(out, false);
    std::ofstream(folder.temp_path() / "frame.png") << "half";
    ::kill(::getpid(), SIGKILL);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  const std::vector<std::string> left = listing();
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0].rfind(".scan.tmp-", 0), 0u) << left[0];
  // Leftovers this host cannot judge stay: another host's, and one of a live process (pid 1).
  const std::string rest = left[0].substr(std::string(".scan.tmp-").size());  // <host>-<pid>-<counter>
  const std::string host = rest.substr(0, rest.rfind('-', rest.rfind('-') - 1));
  const std::string live = ".scan.tmp-" + host + "-1-0";
  fs::create_directory(dir_ / live);
  fs::create_directory(dir_ / ".scan.tmp-elsewhere-999999-0");
  {
    AtomicDirectory next(out, false);
    std::ofstream(next.temp_path() / "frame.png") << "whole";
    next.commit();
  }
  const std::vector<std::string> after = listing();
  EXPECT_EQ(std::count(after.begin(), after.end(), left[0]), 0) << "the killed run's folder is removed";
  EXPECT_EQ(std::count(after.begin(), after.end(), "scan"), 1);
  EXPECT_EQ(std::count(after.begin(), after.end(), ".scan.tmp-elsewhere-999999-0"), 1);
  EXPECT_EQ(std::count(after.begin(), after.end(), live), 1);
  EXPECT_EQ(remove_stale_temporaries(out), 0);
}

// ---------------------------------------------------------------- PNG

TEST_F(IoTest, Png8BitRgbRoundTripIsExact) {
  const ImageU8 image = make_rgb(8, 6);
  const fs::path path = dir_ / "colour.png";
  write_png(path, image);
  const ImageU8 back = read_rgb(path);
  EXPECT_EQ(back.width, 8);
  EXPECT_EQ(back.height, 6);
  EXPECT_EQ(back.channels, 3);
  EXPECT_EQ(back.data, image.data);
  EXPECT_EQ(listing(), std::vector<std::string>{"colour.png"});  // no temporary file left behind
}

TEST_F(IoTest, PngCompressionLevelsGiveTheSameImage) {
  const ImageU8 image = make_rgb(13, 7);
  for (int level : {0, 9}) {
    const fs::path path = dir_ / ("level" + std::to_string(level) + ".png");
    write_png(path, image, level);
    EXPECT_EQ(read_rgb(path).data, image.data) << "compression " << level;
  }
}

TEST_F(IoTest, Png8BitGreyIsReadAsRgb) {
  ImageU8 grey(5, 4, 1);
  for (std::size_t i = 0; i < grey.data.size(); ++i) grey.data[i] = static_cast<std::uint8_t>(i * 11);
  const fs::path path = dir_ / "grey.png";
  write_png(path, grey);
  const ImageU8 back = read_rgb(path);
  ASSERT_EQ(back.channels, 3);
  ASSERT_EQ(back.width, 5);
  ASSERT_EQ(back.height, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(back.at(x, y, c), grey.at(x, y));
}

TEST_F(IoTest, Png16BitRoundTripIsExact) {
  const ImageU16 image = make_depth_units(8, 6);
  const fs::path path = dir_ / "depth.png";
  write_png16(path, image);
  const ImageU16 back = read_png16(path);
  EXPECT_EQ(back.width, 8);
  EXPECT_EQ(back.height, 6);
  EXPECT_EQ(back.channels, 1);
  EXPECT_EQ(back.data, image.data);
}

// The encoder's filters (none at levels 0-1, a choice per row among all five from 2 on) and both sample
// formats on an image with flat areas, gradients and noise, as a rendered frame has.
TEST_F(IoTest, EncodedPngsDecodeExactlyAtEveryLevel) {
  ImageU8 rgb(37, 23, 3), grey(37, 23, 1);
  ImageU16 depth(37, 23, 1);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x) {
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = std::uint8_t(x < 10 ? 200 : (x * 7 + y * 3 + c * 50 + x * y) % 256);
      grey.at(x, y) = std::uint8_t((x * x + y) % 256);
      depth.at(x, y) = std::uint16_t(y < 5 ? 0 : 2500 + 300 * x + (x * y * 977) % 4000);
    }
  for (int level = 0; level <= 9; ++level) {
    const fs::path rgb_path = dir_ / "rgb.png", grey_path = dir_ / "grey.png", depth_path = dir_ / "depth.png";
    write_file_atomic(rgb_path, encode_png(rgb, level));
    write_file_atomic(grey_path, encode_png(grey, level));
    write_file_atomic(depth_path, encode_png16(depth, level));
    EXPECT_EQ(read_rgb(rgb_path).data, rgb.data) << "level " << level;
    const ImageU8 grey_back = read_rgb(grey_path);
    for (int y = 0; y < 23; ++y)
      for (int x = 0; x < 37; ++x) ASSERT_EQ(grey_back.at(x, y, 1), grey.at(x, y)) << "level " << level;
    EXPECT_EQ(read_png16(depth_path).data, depth.data) << "level " << level;
    const PngHeader header = read_png_header(depth_path);
    EXPECT_EQ(header.bit_depth, 16);
    EXPECT_EQ(header.channels, 1);
  }
}

TEST_F(IoTest, WritePngWritesTheEncodedBytes) {
  const ImageU8 image = make_rgb(13, 7);
  const fs::path path = dir_ / "colour.png";
  write_png(path, image, 1);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes, encode_png(image, 1));
  EXPECT_EQ(encode_png(image, 1), encode_png(image, 1));  // deterministic
}

TEST_F(IoTest, EncodingRefusesBadImagesAndLevels) {
  ImageU8 two_channels(4, 3, 2);
  EXPECT_THAT(testutil::error_of([&] { encode_png(two_channels); }), HasSubstr("4x3x2"));
  ImageU16 inconsistent(4, 3, 1);
  inconsistent.data.pop_back();
  EXPECT_THAT(testutil::error_of([&] { encode_png16(inconsistent); }), HasSubstr("inconsistent"));
  EXPECT_THAT(testutil::error_of([&] { encode_png(make_rgb(4, 3), 10); }), HasSubstr("[0, 9]"));
}

TEST_F(IoTest, WritingOverAnExistingPngReplacesIt) {
  const fs::path path = dir_ / "depth.png";
  write_png16(path, ImageU16(4, 3, 1, 7));
  const ImageU16 second = make_depth_units(6, 5);
  write_png16(path, second);
  EXPECT_EQ(read_png16(path).data, second.data);
}

TEST_F(IoTest, ReadingAMissingImageNamesTheFile) {
  const fs::path path = dir_ / "missing.png";
  std::string message = error_of([&] { read_rgb(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  message = error_of([&] { read_png16(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
}

TEST_F(IoTest, ATextFileNamedPngIsRejected) {
  const fs::path path = write_text("notes.png", "this is not an image\n");
  std::string message = error_of([&] { read_rgb(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  message = error_of([&] { read_png16(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
}

TEST_F(IoTest, ATruncatedPngIsRejected) {
  const fs::path good = dir_ / "good.png";
  write_png(good, make_rgb(32, 32));
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const fs::path truncated = write_text("truncated.png", bytes.substr(0, bytes.size() / 2));
  const std::string message = error_of([&] { read_rgb(truncated); });
  EXPECT_THAT(message, HasSubstr(truncated.string()));
}

TEST_F(IoTest, An8BitPngIsNotADepthImage) {
  const fs::path path = dir_ / "colour.png";
  write_png(path, make_rgb(8, 6));
  std::string message = error_of([&] { read_png16(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("16-bit"));

  // Single-channel 8-bit is not 16-bit either.
  const fs::path grey = dir_ / "grey.png";
  write_png(grey, ImageU8(8, 6, 1, 100));
  message = error_of([&] { read_png16(grey); });
  EXPECT_THAT(message, HasSubstr(grey.string()));
}

TEST_F(IoTest, WritingIntoAnUnwritableFolderFails) {
  // A path "below" a regular file can never be created.
  const fs::path blocker = write_text("blocker", "a regular file");
  const fs::path path = blocker / "sub" / "image.png";
  std::string message = error_of([&] { write_png(path, make_rgb(4, 4)); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  message = error_of([&] { write_png16(path, make_depth_units(4, 4)); });
  EXPECT_THAT(message, HasSubstr(path.string()));
}

// ---------------------------------------------------------------- EXR

ImageF32 make_float_image(int width, int height, int channels) {
  ImageF32 image(width, height, channels);
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    // Values that do not survive a trip through half floats or 8 bits.
    image.data[i] = static_cast<float>(std::sin(0.37 * double(i)) * 1234.5678 + 1e-3 * double(i));
  }
  image.data[0] = 0.0f;
  image.data[1] = -7.25e-6f;
  image.data[2] = 3.0e20f;
  return image;
}

TEST_F(IoTest, ExrMultiChannelRoundTripIsExact) {
  const ImageF32 image = make_float_image(8, 6, 3);
  const fs::path path = dir_ / "colour.exr";
  write_exr(path, image, {"R", "G", "B"});
  const ImageF32 back = read_exr(path, {"R", "G", "B"});
  EXPECT_EQ(back.width, 8);
  EXPECT_EQ(back.height, 6);
  EXPECT_EQ(back.channels, 3);
  EXPECT_EQ(back.data, image.data);

  // One channel alone, and channels in another order.
  const ImageF32 green = read_exr(path, {"G"});
  ASSERT_EQ(green.channels, 1);
  const ImageF32 swapped = read_exr(path, {"B", "R"});
  ASSERT_EQ(swapped.channels, 2);
  for (int y = 0; y < 6; ++y) {
    for (int x = 0; x < 8; ++x) {
      EXPECT_EQ(green.at(x, y), image.at(x, y, 1));
      EXPECT_EQ(swapped.at(x, y, 0), image.at(x, y, 2));
      EXPECT_EQ(swapped.at(x, y, 1), image.at(x, y, 0));
    }
  }
  EXPECT_EQ(listing(), std::vector<std::string>{"colour.exr"});
}

TEST_F(IoTest, ExrSingleChannelRoundTripIsExact) {
  const ImageF32 image = make_float_image(7, 5, 1);
  const fs::path path = dir_ / "depth.exr";
  write_exr(path, image, {"Z"});
  EXPECT_EQ(read_exr(path, {"Z"}).data, image.data);
}

TEST_F(IoTest, ExrMissingChannelIsNamed) {
  const fs::path path = dir_ / "depth.exr";
  write_exr(path, make_float_image(4, 3, 1), {"Z"});
  const std::string message = error_of([&] { read_exr(path, {"R"}); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("R"));
}

TEST_F(IoTest, ExrIntegerIdsRoundTripBitExactAsUint) {
  ImageI32 ids(5, 4, 2);
  for (std::size_t i = 0; i < ids.data.size(); ++i)
    ids.data[i] = std::int32_t(i * 104729);  // beyond 2^24: not float-exact
  ids.data[0] = -1;
  ids.data[1] = std::numeric_limits<std::int32_t>::max();
  ids.data[2] = 16777217;  // 2^24 + 1, the first integer a float cannot hold
  const fs::path path = dir_ / "ids.exr";
  write_exr_i32(path, ids, {"triangle_id", "material_id"});
  const ImageI32 back = read_exr_i32(path, {"triangle_id", "material_id"}, 5, 4);
  EXPECT_EQ(back.channels, 2);
  EXPECT_EQ(back.data, ids.data);
  // Stored as UINT by bit pattern: a float reader sees -1 as 2^32 - 1 (rounded to 2^32).
  EXPECT_EQ(read_exr(path, {"triangle_id"}).data[0], 4294967296.0f);
  // A float channel is refused, never converted, and the message names the file and the channel.
  const fs::path floats = dir_ / "floats.exr";
  write_exr(floats, make_float_image(5, 4, 1), {"triangle_id"});
  const std::string message = error_of([&] { read_exr_i32(floats, {"triangle_id"}); });
  EXPECT_THAT(message, HasSubstr(floats.string()));
  EXPECT_THAT(message, HasSubstr("channel triangle_id"));
  EXPECT_THAT(message, HasSubstr("expected 32-bit unsigned integer"));
  EXPECT_THAT(error_of([&] { read_exr_i32(path, {"object_id"}); }), HasSubstr("object_id"));
  EXPECT_THAT(error_of([&] { read_exr_i32(path, {"triangle_id"}, 6, 4); }), HasSubstr("expected 6x4"));
}

TEST_F(IoTest, ExrBadInputIsRejected) {
  std::string message = error_of([&] { read_exr(dir_ / "missing.exr", {"Z"}); });
  EXPECT_THAT(message, HasSubstr((dir_ / "missing.exr").string()));
  const fs::path text = write_text("notes.exr", "not an EXR file");
  message = error_of([&] { read_exr(text, {"Z"}); });
  EXPECT_THAT(message, HasSubstr(text.string()));
  // Channel names must match the image's channel count.
  message = error_of([&] { write_exr(dir_ / "bad.exr", make_float_image(4, 3, 2), {"Z"}); });
  EXPECT_THAT(message, HasSubstr((dir_ / "bad.exr").string()));
}

TEST_F(IoTest, ExrHeadersThatWouldAllocateGigabytesAreRefusedFirst) {
  // Found by fuzz/panorama_fuzz.cpp: OpenEXR 3.1 allocates an attribute's declared size, and parses
  // typed attributes by their layout, so a few corrupt header bytes asked for 1.7 GB.
  const fs::path good = dir_ / "good.exr";
  write_exr(good, make_float_image(8, 4, 1), {"Z"});
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto corrupt = [&](const std::string& name, const std::string& attribute, const std::string& replacement) {
    std::string changed = bytes;
    const std::size_t at = changed.find(attribute);
    EXPECT_NE(at, std::string::npos) << attribute;
    changed.replace(at, replacement.size(), replacement);
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << changed;
    return path;
  };
  // "compression\0compression\0" + size 1: the size made 0x7f000001.
  std::string huge_size = std::string("compression\0compression\0", 24) + std::string("\x01\x00\x00\x7f", 4);
  const fs::path oversized = corrupt("oversized.exr", std::string("compression\0compression\0", 24), huge_size);
  std::string message = error_of([&] { read_exr(oversized, {"Z"}); });
  EXPECT_THAT(message, HasSubstr(oversized.string()));
  EXPECT_THAT(message, HasSubstr("exceeds the file"));
  // A box2i of the wrong size (OpenEXR would read 16 bytes and misread every later field).
  const fs::path misaligned = corrupt("misaligned.exr", std::string("dataWindow\0box2i\0\x10", 18),
                                      std::string("dataWindow\0box2i\0\x11", 18));
  message = error_of([&] { read_exr(misaligned, {"Z"}); });
  EXPECT_THAT(message, HasSubstr("dataWindow"));
  // The size panorama.json promises, checked before the pixels are allocated.
  message = error_of([&] { read_exr(good, {"Z"}, 16, 8); });
  EXPECT_THAT(message, HasSubstr("expected 16x8"));
  // An EXR where a PNG belongs is not handed to OpenCV's EXR decoder.
  const fs::path disguised = dir_ / "flags.png";
  fs::copy_file(good, disguised);
  EXPECT_THAT(error_of([&] { read_rgb(disguised); }), HasSubstr("not a PNG, JPEG"));
  EXPECT_THAT(error_of([&] { read_png16(disguised); }), HasSubstr("not a PNG file"));
}

// ---------------------------------------------------------------- TUM trajectories

std::vector<StampedPose> make_trajectory() {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 20; ++i) {
    StampedPose pose;
    pose.timestamp = 1.0 + i / 30.0;
    const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5 + 0.05 * i, 1.0).normalized();
    pose.world_from_cam = make_rigid(Eigen::Quaterniond(Eigen::AngleAxisd(0.31 * i - 2.5, axis)),
                                     Eigen::Vector3d(0.123456789 * i, -2.0 + 0.01 * i, 1.5 - 1e-4 * i));
    poses.push_back(pose);
  }
  return poses;
}

TEST_F(IoTest, FormatTimestampUsesSixDecimals) {
  EXPECT_EQ(format_timestamp(1.5), "1.500000");
  EXPECT_EQ(format_timestamp(1.0 / 30.0), "0.033333");
  EXPECT_EQ(format_timestamp(0.0), "0.000000");
  EXPECT_EQ(format_timestamp(1234567.0000004), "1234567.000000");
}

TEST_F(IoTest, TrajectoryRoundTrip) {
  const std::vector<StampedPose> poses = make_trajectory();
  const fs::path path = dir_ / "traj.txt";
  write_tum_trajectory(path, poses);
  EXPECT_EQ(listing(), std::vector<std::string>{"traj.txt"});
  const std::vector<StampedPose> back = read_tum_trajectory(path);
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    // Timestamps are kept to 6 decimals (the canonical text), poses to 9.
    EXPECT_NEAR(back[i].timestamp, poses[i].timestamp, 5e-7 + 1e-12);
    EXPECT_EQ(format_timestamp(back[i].timestamp), format_timestamp(poses[i].timestamp));
    EXPECT_LT((back[i].world_from_cam.translation() - poses[i].world_from_cam.translation()).cwiseAbs().maxCoeff(),
              1e-9);
    // 9-decimal quaternion components re-normalised: the rotation matrix agrees to a few 1e-9.
    EXPECT_LT((back[i].world_from_cam.linear() - poses[i].world_from_cam.linear()).cwiseAbs().maxCoeff(), 3e-9);
  }
}

TEST_F(IoTest, TrajectoryExactValuesSurvive) {
  // Timestamps with 6 decimals and positions with 9 decimals are reproduced exactly.
  const fs::path path = write_text("exact.txt", "1.033333 0.123456789 -1.5 2.000000001 0 0 0 1\n");
  const std::vector<StampedPose> poses = read_tum_trajectory(path);
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].timestamp, 1.033333);
  EXPECT_EQ(poses[0].world_from_cam.translation(), Eigen::Vector3d(0.123456789, -1.5, 2.000000001));
  EXPECT_TRUE(poses[0].world_from_cam.linear().isIdentity(0.0));
  const fs::path written = dir_ / "written.txt";
  write_tum_trajectory(written, poses);
  const std::vector<StampedPose> back = read_tum_trajectory(written);
  EXPECT_EQ(back[0].timestamp, 1.033333);
  EXPECT_EQ(back[0].world_from_cam.translation(), poses[0].world_from_cam.translation());
}

TEST_F(IoTest, TrajectoryCommentsBlankLinesAndUnnormalisedQuaternions) {
  const fs::path path = write_text("comments.txt",
                                   "# TUM trajectory\n"
                                   "\n"
                                   "   # indented comment\n"
                                   "0.5 1 2 3 0 0 0 2\r\n"  // Windows line end, quaternion of norm 2
                                   "\t\n"
                                   "0.6 1 2 3 0 0 1 1\n");
  const std::vector<StampedPose> poses = read_tum_trajectory(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].timestamp, 0.5);
  EXPECT_TRUE(poses[0].world_from_cam.linear().isIdentity(1e-15));
  EXPECT_EQ(poses[0].world_from_cam.translation(), Eigen::Vector3d(1, 2, 3));
  // (0, 0, 1, 1) normalised is a rotation by 90 degrees about z.
  EXPECT_NEAR(rotation_angle(poses[1].world_from_cam.linear()), M_PI / 2, 1e-12);
  EXPECT_NEAR((poses[1].world_from_cam.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0,
              1e-12);
}

TEST_F(IoTest, EmptyTrajectoryFileHasNoPoses) {
  const fs::path path = write_text("empty.txt", "# nothing yet\n");
  EXPECT_TRUE(read_tum_trajectory(path).empty());
}

TEST_F(IoTest, TrajectoryBadLinesNameFileAndLine) {
  struct Case {
    std::string line;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"1.1 1 2 3 0 0 0", "expected 8 numbers"},
      {"1.1 1 2 3 0 0 0 1 9", "expected 8 numbers"},
      {"1.1 1 2 x 0 0 0 1", "'x'"},
      {"1.1 1 2 3 0 0 0 1e999", "'1e999'"},
      {"1.1 nan 2 3 0 0 0 1", "'nan'"},
      {"1.1 1 2 3 0 0 0 0", "zero length"},
      {"1.1 1 2 3,0 0 0 1", "expected 8 numbers"},
  };
  for (const Case& c : cases) {
    const fs::path path = write_text("bad.txt", "# header\n1.0 0 0 0 0 0 0 1\n" + c.line + "\n");
    const std::string message = error_of([&] { read_tum_trajectory(path); });
    EXPECT_THAT(message, HasSubstr(path.string())) << c.line;
    EXPECT_THAT(message, HasSubstr("line 3")) << c.line;
    EXPECT_THAT(message, HasSubstr(c.expected)) << c.line;
  }
}

TEST_F(IoTest, TrajectoryRepeatedTimestampIsRejected) {
  const fs::path path = write_text("dup.txt", "1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 0 1\n");
  const std::string message = error_of([&] { read_tum_trajectory(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("repeats"));
}

TEST_F(IoTest, TrajectoryDecreasingTimestampIsRejected) {
  const fs::path path = write_text("back.txt", "# c\n2.0 0 0 0 0 0 0 1\n1.5 0 0 0 0 0 0 1\n");
  const std::string message = error_of([&] { read_tum_trajectory(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("is before"));
}

TEST_F(IoTest, MissingTrajectoryFileIsNamed) {
  const fs::path path = dir_ / "nope.txt";
  const std::string message = error_of([&] { read_tum_trajectory(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
}

TEST_F(IoTest, TrajectoryWriterRefusesWhatTheReaderWouldReject) {
  std::vector<StampedPose> poses(2);
  poses[0].timestamp = 1.0;
  poses[1].timestamp = 1.0000001;  // the same timestamp once written with 6 decimals
  const fs::path path = dir_ / "out.txt";
  std::string message = error_of([&] { write_tum_trajectory(path, poses); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("pose 1"));

  poses[1].timestamp = 2.0;
  poses[1].world_from_cam.translation().x() = std::numeric_limits<double>::quiet_NaN();
  message = error_of([&] { write_tum_trajectory(path, poses); });
  EXPECT_THAT(message, HasSubstr("pose 1"));
  EXPECT_FALSE(fs::exists(path));  // nothing half-written
  EXPECT_TRUE(listing().empty());
}

TEST_F(IoTest, TrajectoryWriteIntoAnUnwritableFolderFails) {
  const fs::path blocker = write_text("blocker", "x");
  const fs::path path = blocker / "traj.txt";
  const std::string message = error_of([&] { write_tum_trajectory(path, make_trajectory()); });
  EXPECT_THAT(message, HasSubstr(path.string()));
}

TEST_F(IoTest, PngHeaderGivesSizeBitDepthAndChannelsWithoutDecoding) {
  const fs::path depth = dir_ / "depth.png";
  write_png16(depth, ImageU16(7, 5, 1, 1234));
  PngHeader header = read_png_header(depth);
  EXPECT_EQ(header.width, 7);
  EXPECT_EQ(header.height, 5);
  EXPECT_EQ(header.bit_depth, 16);
  EXPECT_EQ(header.channels, 1);
  const fs::path colour = dir_ / "colour.png";
  write_png(colour, ImageU8(4, 3, 3, 9));
  header = read_png_header(colour);
  EXPECT_EQ(header.width, 4);
  EXPECT_EQ(header.height, 3);
  EXPECT_EQ(header.bit_depth, 8);
  EXPECT_EQ(header.channels, 3);

  const fs::path text = write_text("text.png", "not a png at all");
  EXPECT_THAT(error_of([&] { read_png_header(text); }), HasSubstr(text.string() + ": format: not a PNG"));
  const std::string bytes = [&] {
    std::ifstream in(depth, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  const fs::path truncated = write_text("truncated.png", bytes.substr(0, 20));
  EXPECT_THAT(error_of([&] { read_png_header(truncated); }), HasSubstr(truncated.string() + ": header: truncated"));
  EXPECT_THAT(error_of([&] { read_png_header(dir_ / "missing.png"); }), HasSubstr("missing.png: image file not found"));
}

StampedPose stamped(double t, double angle, const Eigen::Vector3d& translation) {
  StampedPose pose;
  pose.timestamp = t;
  pose.world_from_cam = make_rigid(Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d(0.2, -1.0, 0.4).normalized())),
                                   translation);
  return pose;
}

TEST(InterpolateTrajectory, ExactStampsLerpAndSlerpBetweenAndNothingOutsideOrAcrossGaps) {
  const std::vector<StampedPose> poses = {stamped(1.00, 0.1, {0, 0, 0}), stamped(1.01, 0.3, {1, 2, 3}),
                                          stamped(1.50, 0.5, {0, 0, 1})};
  const std::vector<double> times = {1.00, 1.0025, 1.01, 0.999, 1.2, 1.50, 1.51};
  const std::vector<std::optional<Rigid3d>> result = interpolate_trajectory(poses, times, 0.02);
  ASSERT_EQ(result.size(), times.size());
  ASSERT_TRUE(result[0] && result[1] && result[2] && result[5]);
  EXPECT_TRUE(result[0]->isApprox(poses[0].world_from_cam, 1e-15));
  EXPECT_TRUE(result[2]->isApprox(poses[1].world_from_cam, 1e-15));
  EXPECT_TRUE(result[5]->isApprox(poses[2].world_from_cam, 1e-15));
  // A quarter of the way: translation a quarter, rotation angle 0.1 + 0.25 * 0.2 about the same axis.
  EXPECT_NEAR((result[1]->translation() - Eigen::Vector3d(0.25, 0.5, 0.75)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(result[1]->linear()).angle(), 0.15, 1e-12);
  EXPECT_FALSE(result[3]);  // before the first pose
  EXPECT_FALSE(result[4]);  // in the 0.49 s gap
  EXPECT_FALSE(result[6]);  // after the last pose
  // A wide enough window bridges the gap.
  EXPECT_TRUE(interpolate_trajectory(poses, {1.2}, 0.5)[0].has_value());
  EXPECT_TRUE(interpolate_trajectory({}, {1.0}, 0.02)[0] == std::nullopt);
}

TEST(InterpolateTrajectory, TakesTheShortRotationAndRefusesUnsortedPosesOrABadWindow) {
  // Quaternions of opposite sign (the same rotation): no detour through the long way round.
  StampedPose a = stamped(0.0, 0.2, {0, 0, 0});
  StampedPose b = stamped(1.0, 0.2, {0, 0, 0});
  const Eigen::Quaterniond q(b.world_from_cam.linear());
  const Eigen::Quaterniond negated(-q.w(), -q.x(), -q.y(), -q.z());
  b.world_from_cam = make_rigid(negated, Eigen::Vector3d::Zero());
  const auto mid = interpolate_trajectory({a, b}, {0.5}, 1.0)[0];
  ASSERT_TRUE(mid);
  EXPECT_TRUE(mid->isApprox(a.world_from_cam, 1e-12));
  EXPECT_THAT(error_of([&] { interpolate_trajectory({b, a}, {0.5}, 1.0); }), HasSubstr("strictly increase"));
  EXPECT_THAT(error_of([&] { interpolate_trajectory({a, b}, {0.5}, -1.0); }), HasSubstr("max_dt"));
}

TEST(PoseMatrixText, RoundTripAndRefusals) {
  testutil::TempDir dir("posematrix");
  const Rigid3d pose = make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                                  Eigen::Vector3d(0.1, -2.5, 1e-3));
  const std::string text = pose_matrix_text(pose);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 4);
  EXPECT_THAT(text, ::testing::EndsWith("\n0 0 0 1\n"));
  std::ofstream(dir / "m.txt") << "# a comment\n" << text;
  const Rigid3d back = read_pose_file(dir / "m.txt");
  EXPECT_LT((back.matrix() - pose.matrix()).cwiseAbs().maxCoeff(), 1e-15);
  const struct {
    const char* name;
    const char* text;
    const char* needle;
  } cases[] = {
      {"three_rows.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n", "3 rows"},
      {"five.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n0 0 0 1\n", "line 5"},
      {"short_row.txt", "1 0 0 0\n0 1 0\n0 0 1 0\n0 0 0 1\n", "line 2"},
      {"word.txt", "1 0 0 0\n0 1 0 0\n0 0 one 0\n0 0 0 1\n", "'one' is not a finite number"},
      {"last_row.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n", "last row"},
      {"scaled.txt", "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "not a rotation"},
      {"mirror.txt", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "not a rotation"},
  };
  for (const auto& c : cases) {
    std::ofstream(dir / c.name) << c.text;
    const std::string message = error_of([&] { read_pose_file(dir / c.name); });
    EXPECT_THAT(message, HasSubstr((dir / c.name).string())) << c.name;
    EXPECT_THAT(message, HasSubstr(c.needle)) << c.name;
  }
}

}  // namespace
}  // namespace panoscan
