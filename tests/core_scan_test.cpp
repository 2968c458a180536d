// Tests of the scan format: writing a small scan (3 sensors, 8x6 images) and reading it back
// bit-exact, rig.json round trips and validation, every kind of bad input the reader must
// refuse with an Error naming the file and the field, and the writer's atomicity.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/scan.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ::testing::HasSubstr;

constexpr int kWidth = 8;
constexpr int kHeight = 6;
constexpr int kSensors = 3;
constexpr int kFrames = 4;

using testutil::error_of;

RigInfo make_rig(int sensors = kSensors) {
  RigInfo rig;
  rig.description = "test rig: three cameras 120 degrees apart";
  rig.reference_sensor = 0;
  for (int s = 0; s < sensors; ++s) {
    SensorInfo sensor;
    sensor.name = "cam" + std::to_string(s);
    sensor.intrinsics.width = kWidth;
    sensor.intrinsics.height = kHeight;
    sensor.intrinsics.fx = 7.1 + s;
    sensor.intrinsics.fy = 7.3 + s;
    sensor.intrinsics.cx = 3.5 + 0.01 * s;
    sensor.intrinsics.cy = 2.5 - 0.01 * s;
    sensor.depth_scale = 5000.0;
    sensor.nominal_fps = 30.0;
    if (s > 0) {
      sensor.ref_from_cam = make_rigid(
          Eigen::Quaterniond(Eigen::AngleAxisd(2.0943951 * s + 0.01, Eigen::Vector3d(0.01, -1.0, 0.02).normalized())),
          Eigen::Vector3d(0.05 * s, -0.013, 0.1 / 3.0));
    }
    rig.sensors.push_back(sensor);
  }
  return rig;
}

// Unsynchronised shutters: each sensor has its own phase.
double frame_timestamp(int sensor, int frame) { return 100.0 + frame / 30.0 + 0.0111 * sensor; }

ImageU8 make_rgb(int sensor, int frame, int width = kWidth, int height = kHeight) {
  ImageU8 image(width, height, 3);
  for (std::size_t i = 0; i < image.data.size(); ++i)
    image.data[i] = static_cast<std::uint8_t>((i * 31 + sensor * 71 + frame * 13) % 256);
  return image;
}

ImageU16 make_depth(int sensor, int frame, int width = kWidth, int height = kHeight) {
  ImageU16 image(width, height, 1);
  for (std::size_t i = 0; i < image.data.size(); ++i)
    image.data[i] = static_cast<std::uint16_t>(2000 + i * 517 + sensor * 1001 + frame * 7);
  image.data[0] = 0;  // an invalid pixel
  image.data[1] = 65535;
  return image;
}

std::vector<StampedPose> make_trajectory(int sensor) {
  std::vector<StampedPose> poses;
  for (int f = 0; f < kFrames; ++f) {
    StampedPose pose;
    pose.timestamp = frame_timestamp(sensor, f);
    pose.world_from_cam = make_rigid(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * f + sensor, Eigen::Vector3d::UnitZ())),
                                     Eigen::Vector3d(1.0, 2.0, 1.5 + 0.001 * f));
    poses.push_back(pose);
  }
  return poses;
}

class ScanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("panoscan_scan_test_" + std::string(info->name()) + "_" +
                                        std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  // Writes the standard small scan to dir_/scan; each sensor in its own thread.
  fs::path write_scan(bool with_groundtruth = false) {
    const fs::path scan_dir = dir_ / "scan";
    ScanWriter writer(scan_dir, make_rig(), /*overwrite=*/false);
    std::vector<std::thread> threads;
    for (int s = 0; s < kSensors; ++s) {
      threads.emplace_back([&writer, s] {
        for (int f = 0; f < kFrames; ++f)
          writer.write_frame(s, frame_timestamp(s, f), make_rgb(s, f), make_depth(s, f));
      });
    }
    for (std::thread& thread : threads) thread.join();
    if (with_groundtruth) {
      for (int s = 0; s < kSensors; ++s) {
        writer.write_groundtruth_trajectory(s, make_trajectory(s));
        writer.write_clean_depth(s, frame_timestamp(s, 0), make_depth(s, 100));
      }
      writer.write_groundtruth_file("rig_truth.json", "{\"seed\": 7}\n");
      TriangleMesh mesh;
      mesh.vertices = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}};
      mesh.triangles = {{0, 1, 2}};
      writer.write_groundtruth_mesh(mesh);
    }
    writer.commit();
    return scan_dir;
  }

  // Entries directly in dir_ (to check that no temporary directory is left behind).
  std::vector<std::string> entries_of(const fs::path& path) const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(path)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// The "timestamp filename" lines of a listing, without its comment header.
std::vector<std::string> listing_lines(const fs::path& path) {
  std::vector<std::string> lines;
  std::istringstream in(read_text(path));
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  }
  return lines;
}

void write_listing(const fs::path& path, const std::vector<std::string>& lines) {
  std::string text = "# timestamp filename\n";
  for (const std::string& line : lines) text += line + "\n";
  write_text(path, text);
}

void expect_same_rig(const RigInfo& a, const RigInfo& b) {
  EXPECT_EQ(a.description, b.description);
  EXPECT_EQ(a.reference_sensor, b.reference_sensor);
  EXPECT_EQ(a.motion, b.motion);
  ASSERT_EQ(a.sensors.size(), b.sensors.size());
  for (std::size_t s = 0; s < a.sensors.size(); ++s) {
    const SensorInfo& x = a.sensors[s];
    const SensorInfo& y = b.sensors[s];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.intrinsics.width, y.intrinsics.width);
    EXPECT_EQ(x.intrinsics.height, y.intrinsics.height);
    EXPECT_EQ(x.intrinsics.fx, y.intrinsics.fx);
    EXPECT_EQ(x.intrinsics.fy, y.intrinsics.fy);
    EXPECT_EQ(x.intrinsics.cx, y.intrinsics.cx);
    EXPECT_EQ(x.intrinsics.cy, y.intrinsics.cy);
    EXPECT_EQ(x.depth_scale, y.depth_scale);
    EXPECT_EQ(x.nominal_fps, y.nominal_fps);
    // Through a quaternion with full double precision: equal to rounding.
    EXPECT_LT((x.ref_from_cam.matrix() - y.ref_from_cam.matrix()).cwiseAbs().maxCoeff(), 1e-14) << x.name;
  }
}

// ---------------------------------------------------------------- write and read back

TEST_F(ScanTest, WrittenScanReadsBackBitExact) {
  const fs::path scan_dir = write_scan(/*with_groundtruth=*/true);
  EXPECT_EQ(entries_of(dir_), std::vector<std::string>{"scan"});  // the temporary directory is gone

  const ScanIndex scan = read_scan_index(scan_dir);
  EXPECT_EQ(scan.root, scan_dir);
  expect_same_rig(scan.rig, make_rig());
  ASSERT_EQ(scan.frames.size(), std::size_t(kSensors));
  for (int s = 0; s < kSensors; ++s) {
    ASSERT_EQ(scan.frames[s].size(), std::size_t(kFrames));
    for (int f = 0; f < kFrames; ++f) {
      const FrameEntry& entry = scan.frames[s][f];
      const std::string ts = format_timestamp(frame_timestamp(s, f));
      EXPECT_EQ(format_timestamp(entry.timestamp), ts);
      EXPECT_NEAR(entry.timestamp, frame_timestamp(s, f), 5e-7);
      EXPECT_EQ(entry.rgb_file, "rgb/" + ts + ".png");
      EXPECT_EQ(entry.depth_file, "depth/" + ts + ".png");

      const RgbdFrame frame = load_frame(scan, s, f);
      EXPECT_EQ(frame.timestamp, entry.timestamp);
      EXPECT_EQ(frame.rgb.width, kWidth);
      EXPECT_EQ(frame.rgb.height, kHeight);
      EXPECT_EQ(frame.rgb.channels, 3);
      EXPECT_EQ(frame.rgb.data, make_rgb(s, f).data);
      // The depth in metres converts back to exactly the units written.
      EXPECT_EQ(depth_to_png_units(frame.depth, 5000.0).data, make_depth(s, f).data);
      EXPECT_EQ(frame.depth.data, depth_from_png_units(make_depth(s, f), 5000.0).data);
    }
  }

  // Listings: a comment header, then "timestamp filename" in time order.
  const std::string rgb_listing = read_text(scan_dir / "cam1" / "rgb.txt");
  EXPECT_EQ(rgb_listing.rfind("# timestamp filename\n", 0), 0u);
  EXPECT_THAT(rgb_listing, HasSubstr("100.011100 rgb/100.011100.png\n"));
  EXPECT_THAT(read_text(scan_dir / "cam1" / "depth.txt"), HasSubstr("100.011100 depth/100.011100.png\n"));

  // Ground truth.
  EXPECT_EQ(groundtruth_dir(scan_dir), scan_dir / "groundtruth");
  for (int s = 0; s < kSensors; ++s) {
    const std::vector<StampedPose> truth = read_groundtruth_trajectory(scan_dir, s);
    ASSERT_EQ(truth.size(), std::size_t(kFrames));
    for (int f = 0; f < kFrames; ++f) {
      EXPECT_EQ(format_timestamp(truth[f].timestamp), format_timestamp(frame_timestamp(s, f)));
      EXPECT_LT(
          (truth[f].world_from_cam.matrix() - make_trajectory(s)[f].world_from_cam.matrix()).cwiseAbs().maxCoeff(),
          1e-8);
    }
    const fs::path clean = scan_dir / "groundtruth" / "depth_clean" / ("cam" + std::to_string(s)) /
                           (format_timestamp(frame_timestamp(s, 0)) + ".png");
    EXPECT_EQ(read_png16(clean).data, make_depth(s, 100).data);
  }
  EXPECT_EQ(read_text(scan_dir / "groundtruth" / "rig_truth.json"), "{\"seed\": 7}\n");
  EXPECT_TRUE(fs::is_regular_file(scan_dir / "groundtruth" / "mesh.ply"));
  const TriangleMesh mesh = read_ply_mesh(scan_dir / "groundtruth" / "mesh.ply");
  EXPECT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.triangles.size(), 1u);

  const std::string message = error_of([&] { read_groundtruth_trajectory(scan_dir, 3); });
  EXPECT_THAT(message, HasSubstr("rig.json"));
}

TEST_F(ScanTest, TempPathIsInsideTheScanAndCommittedWithIt) {
  const fs::path scan_dir = dir_ / "scan";
  ScanWriter writer(scan_dir, make_rig(1), false);
  const fs::path extra = writer.temp_path("groundtruth/notes/extra.txt");
  EXPECT_FALSE(fs::exists(scan_dir));  // nothing appears at the final path before commit
  write_text(extra, "hello");
  writer.write_frame(0, 1.0, make_rgb(0, 0), make_depth(0, 0));
  EXPECT_THAT(error_of([&] { writer.temp_path("../escape.txt"); }), HasSubstr("escape.txt"));
  writer.commit();
  EXPECT_EQ(read_text(scan_dir / "groundtruth" / "notes" / "extra.txt"), "hello");
  // No writes after commit.
  const std::string message = error_of([&] { writer.write_frame(0, 2.0, make_rgb(0, 1), make_depth(0, 1)); });
  EXPECT_THAT(message, HasSubstr(scan_dir.string()));
  EXPECT_THAT(message, HasSubstr("committed"));
}

TEST_F(ScanTest, EncodedFramesReadBackAsWrittenFrames) {
  const fs::path scan_dir = dir_ / "scan";
  {
    ScanWriter writer(scan_dir, make_rig(1), false);
    for (int f = 0; f < kFrames; ++f)
      writer.write_encoded_frame(0, frame_timestamp(0, f), encode_png(make_rgb(0, f)), encode_png16(make_depth(0, f)));
    writer.commit();
  }
  const ScanIndex scan = read_scan_index(scan_dir);
  ASSERT_EQ(scan.frames[0].size(), std::size_t(kFrames));
  for (int f = 0; f < kFrames; ++f) {
    const RgbdFrame frame = load_frame(scan, 0, f);
    EXPECT_EQ(frame.rgb.data, make_rgb(0, f).data);
    EXPECT_EQ(depth_to_png_units(frame.depth, 5000.0).data, make_depth(0, f).data);
  }
}

TEST_F(ScanTest, EncodedFramesOfTheWrongShapeOrOrderAreRefused) {
  ScanWriter writer(dir_ / "scan", make_rig(1), false);
  const std::string rgb = encode_png(make_rgb(0, 0)), depth = encode_png16(make_depth(0, 0));
  std::string message = error_of([&] { writer.write_encoded_frame(0, 1.0, encode_png(make_rgb(0, 0, 4, 3)), depth); });
  EXPECT_THAT(message, HasSubstr("cam0 rgb image size"));
  EXPECT_THAT(message, HasSubstr("expected 8x6, found 4x3"));
  message = error_of([&] { writer.write_encoded_frame(0, 1.0, rgb, rgb); });
  EXPECT_THAT(message, HasSubstr("cam0 depth image"));
  EXPECT_THAT(message, HasSubstr("bit depth 8"));
  message = error_of([&] { writer.write_encoded_frame(0, 1.0, "not a png", depth); });
  EXPECT_THAT(message, HasSubstr("not an encoded PNG"));
  writer.write_encoded_frame(0, 2.0, rgb, depth);
  message = error_of([&] { writer.write_encoded_frame(0, 1.5, rgb, depth); });
  EXPECT_THAT(message, HasSubstr("does not increase"));
}

// ---------------------------------------------------------------- rig.json

TEST(RigJson, RoundTrip) {
  const RigInfo rig = make_rig();
  const std::string text = rig_to_json(rig);
  for (const char* field :
       {"\"format\"", "\"version\"", "\"description\"", "\"reference_sensor\"", "\"sensors\"", "\"name\"", "\"width\"",
        "\"height\"", "\"fx\"", "\"fy\"", "\"cx\"", "\"cy\"", "\"depth_scale\"", "\"nominal_fps\"", "\"ref_from_cam\"",
        "\"translation\"", "\"rotation_quaternion_xyzw\"", "panoscan-scan"}) {
    EXPECT_THAT(text, HasSubstr(field));
  }
  const RigInfo back = rig_from_json(text, "rig.json");
  expect_same_rig(back, rig);
  // A second trip is stable.
  expect_same_rig(rig_from_json(rig_to_json(back), "rig.json"), rig);
}

TEST(RigJson, MotionIsRotatorUnlessSaidAndRoundTrips) {
  RigInfo rig = make_rig(1);
  EXPECT_EQ(rig.motion, RigMotion::kRotator);
  EXPECT_THAT(rig_to_json(rig), HasSubstr("\"motion\": \"rotator\""));
  rig.motion = RigMotion::kHandheld;
  EXPECT_EQ(rig_from_json(rig_to_json(rig), "rig.json").motion, RigMotion::kHandheld);
  // Scans written before the field existed have none: they are rotator scans.
  json document = json::parse(rig_to_json(rig));
  document.erase("motion");
  EXPECT_EQ(rig_from_json(document.dump(), "rig.json").motion, RigMotion::kRotator);
}

TEST(RigJson, AnotherReferenceSensorAndNoDescription) {
  RigInfo rig = make_rig(2);
  rig.sensors[0].ref_from_cam = rig.sensors[1].ref_from_cam.inverse();
  rig.sensors[1].ref_from_cam = Rigid3d::Identity();
  rig.reference_sensor = 1;
  json document = json::parse(rig_to_json(rig));
  document.erase("description");
  const RigInfo back = rig_from_json(document.dump(), "rig.json");
  EXPECT_EQ(back.reference_sensor, 1);
  EXPECT_EQ(back.description, "");
}

// Each case mutates a valid rig.json; the error must name rig.json, the field, and say what.
struct RigCase {
  std::string label;
  std::function<void(json&)> mutate;
  std::string expected_field;
  std::string expected_text;
};

TEST(RigJson, BadRigFilesAreRejectedNamingTheField) {
  const std::vector<RigCase> cases = {
      {"other format", [](json& j) { j["format"] = "tum"; }, "rig.json: format: ", "'tum'"},
      {"format missing", [](json& j) { j.erase("format"); }, "rig.json: format: ", "missing field"},
      {"other version", [](json& j) { j["version"] = 2; }, "rig.json: version: ", "expected 1, found 2"},
      {"version as text", [](json& j) { j["version"] = "1"; }, "rig.json: version: ", "expected an integer"},
      {"no sensors", [](json& j) { j["sensors"] = json::array(); }, "rig.json: sensors: ", "no sensors"},
      {"unknown motion", [](json& j) { j["motion"] = "robot"; },
       "rig.json: motion: ", "expected 'rotator' or 'handheld', found 'robot'"},
      {"motion not a string", [](json& j) { j["motion"] = 1; }, "rig.json: motion: ", "expected a string"},
      {"sensors not a list", [](json& j) { j["sensors"] = 3; }, "rig.json: sensors: ", "expected a list"},
      {"sensors missing", [](json& j) { j.erase("sensors"); }, "rig.json: sensors: ", "missing field"},
      {"reference out of range", [](json& j) { j["reference_sensor"] = 3; },
       "rig.json: reference_sensor: ", "out of range"},
      {"reference negative", [](json& j) { j["reference_sensor"] = -1; },
       "rig.json: reference_sensor: ", "out of range"},
      {"missing fx", [](json& j) { j["sensors"][1].erase("fx"); }, "rig.json: sensors[1].fx: ", "missing field"},
      {"fx as text", [](json& j) { j["sensors"][0]["fx"] = "570"; }, "rig.json: sensors[0].fx: ", "expected a number"},
      {"fy zero", [](json& j) { j["sensors"][2]["fy"] = 0.0; }, "rig.json: sensors[2].fy: ", "positive"},
      {"negative depth scale", [](json& j) { j["sensors"][0]["depth_scale"] = -5000; },
       "rig.json: sensors[0].depth_scale: ", "positive"},
      {"fps null", [](json& j) { j["sensors"][0]["nominal_fps"] = nullptr; },
       "rig.json: sensors[0].nominal_fps: ", "expected a number"},
      {"width zero", [](json& j) { j["sensors"][1]["width"] = 0; }, "rig.json: sensors[1].width: ", "found 0"},
      {"height fractional", [](json& j) { j["sensors"][1]["height"] = 6.5; },
       "rig.json: sensors[1].height: ", "expected an integer"},
      {"name missing", [](json& j) { j["sensors"][0].erase("name"); }, "rig.json: sensors[0].name: ", "missing field"},
      {"duplicate name", [](json& j) { j["sensors"][2]["name"] = "cam1"; }, "rig.json: sensors[2].name: ", "twice"},
      {"name with slash", [](json& j) { j["sensors"][2]["name"] = "../cam"; },
       "rig.json: sensors[2].name: ", "not a valid sensor name"},
      {"name groundtruth", [](json& j) { j["sensors"][2]["name"] = "groundtruth"; },
       "rig.json: sensors[2].name: ", "not a valid"},
      {"unknown sensor field", [](json& j) { j["sensors"][0]["fz"] = 1.0; },
       "rig.json: sensors[0].fz: ", "unknown field"},
      {"unknown top field", [](json& j) { j["sensor"] = json::array(); }, "rig.json: sensor: ", "unknown field"},
      {"pose missing", [](json& j) { j["sensors"][1].erase("ref_from_cam"); },
       "rig.json: sensors[1].ref_from_cam: ", "missing field"},
      {"translation short",
       [](json& j) {
         j["sensors"][1]["ref_from_cam"]["translation"] = {1.0, 2.0};
       },
       "rig.json: sensors[1].ref_from_cam.translation: ", "list of 3 numbers"},
      {"translation item text", [](json& j) { j["sensors"][1]["ref_from_cam"]["translation"][2] = "x"; },
       "rig.json: sensors[1].ref_from_cam.translation[2]: ", "expected a number"},
      {"quaternion not unit",
       [](json& j) {
         j["sensors"][1]["ref_from_cam"]["rotation_quaternion_xyzw"] = {0.0, 0.0, 0.0, 2.0};
       },
       "rig.json: sensors[1].ref_from_cam.rotation_quaternion_xyzw: ", "unit length"},
      {"reference not identity",
       [](json& j) {
         j["sensors"][0]["ref_from_cam"]["translation"] = {0.0, 0.0, 1e-6};
       },
       "rig.json: sensors[0].ref_from_cam: ", "identity"},
      {"reference rotated", [](json& j) { j["reference_sensor"] = 1; },
       "rig.json: sensors[1].ref_from_cam: ", "identity"},
  };
  const json valid = json::parse(rig_to_json(make_rig()));
  for (const RigCase& c : cases) {
    json document = valid;
    c.mutate(document);
    const std::string message = error_of([&] { rig_from_json(document.dump(2), "rig.json"); });
    EXPECT_THAT(message, HasSubstr(c.expected_field)) << c.label;
    EXPECT_THAT(message, HasSubstr(c.expected_text)) << c.label;
  }
}

TEST(RigJson, NonJsonAndNonObjectAndHugeNumbers) {
  std::string message = error_of([] { rig_from_json("{\"format\": ", "scan/rig.json"); });
  EXPECT_THAT(message, HasSubstr("scan/rig.json"));
  EXPECT_THAT(message, HasSubstr("not valid JSON"));
  message = error_of([] { rig_from_json("[1, 2]", "scan/rig.json"); });
  EXPECT_THAT(message, HasSubstr("scan/rig.json"));
  // JSON cannot hold NaN; an overflowing number is its closest relative.
  std::string text = rig_to_json(make_rig());
  text.replace(text.find("\"fx\": ") + 6, 3, "1e999");
  message = error_of([&] { rig_from_json(text, "scan/rig.json"); });
  EXPECT_THAT(message, HasSubstr("scan/rig.json"));
}

TEST(RigJson, WriterSideValidation) {
  RigInfo rig = make_rig();
  rig.sensors[1].intrinsics.fx = std::numeric_limits<double>::quiet_NaN();
  std::string message = error_of([&] { rig_to_json(rig); });
  EXPECT_THAT(message, HasSubstr("sensors[1].fx"));
  rig = make_rig();
  rig.sensors[2].ref_from_cam.linear() *= 2.0;  // not a rotation
  message = error_of([&] { rig_to_json(rig); });
  EXPECT_THAT(message, HasSubstr("sensors[2].ref_from_cam"));
}

// ---------------------------------------------------------------- bad scans on disk

TEST_F(ScanTest, WrongImageSizeNamesFileAndSizes) {
  const fs::path scan_dir = write_scan();
  const std::string ts = format_timestamp(frame_timestamp(1, 2));
  const fs::path rgb = scan_dir / "cam1" / "rgb" / (ts + ".png");
  write_png(rgb, make_rgb(1, 2, 4, 3));
  const ScanIndex scan = read_scan_index(scan_dir);  // the index does not open images
  std::string message = error_of([&] { load_frame(scan, 1, 2); });
  EXPECT_THAT(message, HasSubstr(rgb.string()));
  EXPECT_THAT(message, HasSubstr("image size: expected 8x6, found 4x3"));

  const fs::path depth = scan_dir / "cam2" / "depth" / (format_timestamp(frame_timestamp(2, 0)) + ".png");
  write_png16(depth, make_depth(2, 0, 6, 8));
  message = error_of([&] { load_frame(scan, 2, 0); });
  EXPECT_THAT(message, HasSubstr(depth.string()));
  EXPECT_THAT(message, HasSubstr("image size: expected 8x6, found 6x8"));
}

TEST_F(ScanTest, CorruptPngNamesTheFile) {
  const fs::path scan_dir = write_scan();
  const fs::path depth = scan_dir / "cam0" / "depth" / (format_timestamp(frame_timestamp(0, 3)) + ".png");
  write_text(depth, "\x89PNG\r\n\x1a\n but then garbage");
  const ScanIndex scan = read_scan_index(scan_dir);
  std::string message = error_of([&] { load_frame(scan, 0, 3); });
  EXPECT_THAT(message, HasSubstr(depth.string()));
  // A colour image where depth belongs.
  write_png(depth, make_rgb(0, 3));
  message = error_of([&] { load_frame(scan, 0, 3); });
  EXPECT_THAT(message, HasSubstr(depth.string()));
}

TEST_F(ScanTest, OutOfOrderTimestampsNameListingAndLine) {
  const fs::path scan_dir = write_scan();
  const fs::path listing = scan_dir / "cam0" / "rgb.txt";
  std::vector<std::string> lines = listing_lines(listing);
  std::swap(lines[1], lines[2]);
  write_listing(listing, lines);
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr(listing.string()));
  EXPECT_THAT(message, HasSubstr("line 4"));  // header, two good lines, then the offender
  EXPECT_THAT(message, HasSubstr("is before"));
}

TEST_F(ScanTest, RepeatedTimestampNamesListingAndLine) {
  const fs::path scan_dir = write_scan();
  const fs::path listing = scan_dir / "cam2" / "depth.txt";
  std::vector<std::string> lines = listing_lines(listing);
  lines.insert(lines.begin() + 1, lines[0]);
  write_listing(listing, lines);
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr(listing.string()));
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("repeats"));
}

TEST_F(ScanTest, MissingListingEntryNamesTimestampAndListing) {
  const fs::path scan_dir = write_scan();
  const fs::path rgb_listing = scan_dir / "cam1" / "rgb.txt";
  std::vector<std::string> lines = listing_lines(rgb_listing);
  lines.erase(lines.begin() + 2);
  write_listing(rgb_listing, lines);
  std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr(rgb_listing.string()));
  EXPECT_THAT(message, HasSubstr("timestamp " + format_timestamp(frame_timestamp(1, 2))));
  EXPECT_THAT(message, HasSubstr("depth.txt"));

  // The last entry missing from depth.txt instead (on a freshly written scan).
  fs::remove_all(scan_dir);
  const fs::path again = write_scan();
  const fs::path depth_listing = again / "cam1" / "depth.txt";
  lines = listing_lines(depth_listing);
  lines.pop_back();
  write_listing(depth_listing, lines);
  message = error_of([&] { read_scan_index(again); });
  EXPECT_THAT(message, HasSubstr(depth_listing.string()));
  EXPECT_THAT(message, HasSubstr("timestamp " + format_timestamp(frame_timestamp(1, kFrames - 1))));
  EXPECT_THAT(message, HasSubstr("rgb.txt"));
}

TEST_F(ScanTest, MissingImageFileIsNamed) {
  const fs::path scan_dir = write_scan();
  const fs::path depth = scan_dir / "cam0" / "depth" / (format_timestamp(frame_timestamp(0, 1)) + ".png");
  fs::remove(depth);
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr((scan_dir / "cam0" / "depth.txt").string()));
  EXPECT_THAT(message, HasSubstr(depth.string()));
  EXPECT_THAT(message, HasSubstr("not found"));
}

TEST_F(ScanTest, MissingListingIsNamed) {
  const fs::path scan_dir = write_scan();
  fs::remove(scan_dir / "cam2" / "rgb.txt");
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr((scan_dir / "cam2" / "rgb.txt").string()));
  EXPECT_THAT(message, HasSubstr("not found"));
}

TEST_F(ScanTest, MalformedListingLinesNameTheLine) {
  const fs::path scan_dir = write_scan();
  const fs::path listing = scan_dir / "cam1" / "depth.txt";
  const std::vector<std::string> good = listing_lines(listing);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"abc depth/x.png", "'abc'"},
      {"101.5", "expected 'timestamp filename'"},
      {"101.5 a.png b.png", "expected 'timestamp filename'"},
      {"inf depth/x.png", "not a finite number"},
      {"101.5 ../cam0/depth/x.png", "relative"},
      {"101.5 /etc/passwd", "relative"},
  };
  for (const auto& [bad_line, expected] : cases) {
    std::vector<std::string> lines = good;
    lines.push_back(bad_line);
    write_listing(listing, lines);
    const std::string message = error_of([&] { read_scan_index(scan_dir); });
    EXPECT_THAT(message, HasSubstr(listing.string())) << bad_line;
    EXPECT_THAT(message, HasSubstr("line " + std::to_string(2 + kFrames))) << bad_line;
    EXPECT_THAT(message, HasSubstr(expected)) << bad_line;
  }
  // An empty listing is refused as well.
  write_listing(listing, {});
  EXPECT_THAT(error_of([&] { read_scan_index(scan_dir); }), HasSubstr("no frames"));
}

TEST_F(ScanTest, ListingsWithCommentsAndBlankLinesAreAccepted) {
  const fs::path scan_dir = write_scan();
  const fs::path listing = scan_dir / "cam0" / "rgb.txt";
  std::string text = "# a converter's header\n\n";
  for (const std::string& line : listing_lines(listing)) text += line + "\r\n   \n# comment\n";
  write_text(listing, text);
  EXPECT_EQ(read_scan_index(scan_dir).frames[0].size(), std::size_t(kFrames));
}

TEST_F(ScanTest, RigJsonOfAnotherVersionIsRefused) {
  const fs::path scan_dir = write_scan();
  const fs::path rig_path = scan_dir / "rig.json";
  json document = json::parse(read_text(rig_path));
  document["version"] = 2;
  write_text(rig_path, document.dump(2));
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr(rig_path.string() + ": version: expected 1, found 2"));
}

TEST_F(ScanTest, RigJsonMissingAFieldIsRefused) {
  const fs::path scan_dir = write_scan();
  const fs::path rig_path = scan_dir / "rig.json";
  json document = json::parse(read_text(rig_path));
  document["sensors"][2].erase("depth_scale");
  write_text(rig_path, document.dump(2));
  const std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr(rig_path.string() + ": sensors[2].depth_scale: missing field"));
}

TEST_F(ScanTest, MissingRigJsonAndMissingScanAreNamed) {
  const fs::path scan_dir = write_scan();
  fs::remove(scan_dir / "rig.json");
  std::string message = error_of([&] { read_scan_index(scan_dir); });
  EXPECT_THAT(message, HasSubstr((scan_dir / "rig.json").string()));
  message = error_of([&] { read_scan_index(dir_ / "no_such_scan"); });
  EXPECT_THAT(message, HasSubstr((dir_ / "no_such_scan").string()));
}

TEST_F(ScanTest, LoadFrameIndicesAreChecked) {
  const ScanIndex scan = read_scan_index(write_scan());
  EXPECT_THAT(error_of([&] { load_frame(scan, kSensors, 0); }), HasSubstr("out of range"));
  EXPECT_THAT(error_of([&] { load_frame(scan, -1, 0); }), HasSubstr("out of range"));
  EXPECT_THAT(error_of([&] { load_frame(scan, 0, kFrames); }), HasSubstr("cam0"));
}

// ---------------------------------------------------------------- the writer

TEST_F(ScanTest, UnwritableOutputFolderFails) {
  write_text(dir_ / "blocker", "a regular file");
  const fs::path scan_dir = dir_ / "blocker" / "scan";
  const std::string message = error_of([&] { ScanWriter writer(scan_dir, make_rig(), false); });
  EXPECT_THAT(message, HasSubstr(scan_dir.string()));
}

TEST_F(ScanTest, WriterDestroyedWithoutCommitLeavesNothing) {
  {
    ScanWriter writer(dir_ / "scan", make_rig(), false);
    writer.write_frame(0, 1.0, make_rgb(0, 0), make_depth(0, 0));
    writer.write_groundtruth_file("rig_truth.json", "{}");
    EXPECT_FALSE(entries_of(dir_).empty());  // the temporary directory exists meanwhile
  }
  EXPECT_TRUE(entries_of(dir_).empty());
}

TEST_F(ScanTest, ExistingScanIsNotOverwrittenUnlessAsked) {
  const fs::path scan_dir = write_scan();
  const std::string rig_before = read_text(scan_dir / "rig.json");
  std::string message = error_of([&] { ScanWriter writer(scan_dir, make_rig(1), false); });
  EXPECT_THAT(message, HasSubstr(scan_dir.string()));
  EXPECT_EQ(read_text(scan_dir / "rig.json"), rig_before);

  // With overwrite, the old scan stays until commit, then is replaced as a whole.
  {
    ScanWriter writer(scan_dir, make_rig(1), /*overwrite=*/true);
    writer.write_frame(0, 5.0, make_rgb(0, 9), make_depth(0, 9));
    EXPECT_EQ(read_text(scan_dir / "rig.json"), rig_before);
    writer.commit();
  }
  const ScanIndex scan = read_scan_index(scan_dir);
  EXPECT_EQ(scan.rig.sensors.size(), 1u);
  EXPECT_FALSE(fs::exists(scan_dir / "cam2"));
  EXPECT_EQ(entries_of(dir_), std::vector<std::string>{"scan"});

  // An overwriting writer abandoned before commit leaves the old scan alone.
  {
    ScanWriter writer(scan_dir, make_rig(), /*overwrite=*/true);
    writer.write_frame(0, 1.0, make_rgb(0, 0), make_depth(0, 0));
  }
  EXPECT_EQ(read_scan_index(scan_dir).rig.sensors.size(), 1u);
  EXPECT_EQ(entries_of(dir_), std::vector<std::string>{"scan"});
}

TEST_F(ScanTest, FramesFromFilesAreCopiedOrHardLinkedUnderTheWritersNames) {
  const fs::path sources = dir_ / "sources";
  fs::create_directories(sources);
  write_png(sources / "c.png", make_rgb(0, 3));
  write_png16(sources / "d.png", make_depth(0, 3));
  {
    ScanWriter writer(dir_ / "scan", make_rig(1), false);
    writer.add_frame_files(0, 1.5, sources / "c.png", sources / "d.png", ScanWriter::FileTransfer::kCopy);
    writer.add_frame_files(0, 2.5, sources / "c.png", sources / "d.png", ScanWriter::FileTransfer::kHardLink);
    // The ordering rule of write_frame holds here too.
    EXPECT_THAT(error_of([&] {
                  writer.add_frame_files(0, 2.0, sources / "c.png", sources / "d.png", ScanWriter::FileTransfer::kCopy);
                }),
                HasSubstr("does not increase"));
    EXPECT_THAT(error_of([&] {
                  writer.add_frame_files(0, 3.0, sources / "none.png", sources / "d.png",
                                         ScanWriter::FileTransfer::kCopy);
                }),
                HasSubstr((sources / "none.png").string()));
    writer.commit();
  }
  const ScanIndex scan = read_scan_index(dir_ / "scan");
  ASSERT_EQ(scan.frames[0].size(), 2u);
  EXPECT_EQ(scan.frames[0][0].rgb_file, "rgb/1.500000.png");
  EXPECT_EQ(scan.frames[0][1].depth_file, "depth/2.500000.png");
  for (std::size_t f = 0; f < 2; ++f) {
    const RgbdFrame frame = load_frame(scan, 0, f);
    EXPECT_EQ(frame.rgb.data, make_rgb(0, 3).data);
    EXPECT_EQ(depth_to_png_units(frame.depth, 5000.0).data, make_depth(0, 3).data);
  }
  EXPECT_EQ(fs::hard_link_count(dir_ / "scan" / "cam0" / "rgb" / "1.500000.png"), 1u);
  EXPECT_EQ(fs::hard_link_count(dir_ / "scan" / "cam0" / "depth" / "2.500000.png"), 2u);
}

TEST_F(ScanTest, FramesOfOneSensorMustIncreaseInTime) {
  ScanWriter writer(dir_ / "scan", make_rig(), false);
  writer.write_frame(1, 2.0, make_rgb(1, 0), make_depth(1, 0));
  // Another sensor may be behind: only the order within one sensor matters.
  writer.write_frame(0, 1.0, make_rgb(0, 0), make_depth(0, 0));
  std::string message = error_of([&] { writer.write_frame(1, 1.5, make_rgb(1, 1), make_depth(1, 1)); });
  EXPECT_THAT(message, HasSubstr("cam1"));
  EXPECT_THAT(message, HasSubstr("1.500000"));
  message = error_of([&] { writer.write_frame(1, 2.0, make_rgb(1, 1), make_depth(1, 1)); });
  EXPECT_THAT(message, HasSubstr("cam1"));
  // Different doubles, same 6-decimal text: would share a file name.
  message = error_of([&] { writer.write_frame(1, 2.0000001, make_rgb(1, 1), make_depth(1, 1)); });
  EXPECT_THAT(message, HasSubstr("cam1"));
  message = error_of([&] { writer.write_frame(1, std::nan(""), make_rgb(1, 1), make_depth(1, 1)); });
  EXPECT_THAT(message, HasSubstr("cam1"));
}

TEST_F(ScanTest, PerFrameNormalsAndIdsRoundTripUnderGroundtruth) {
  const fs::path scan_dir = dir_ / "scan";
  ScanWriter writer(scan_dir, make_rig(), false);
  ImageF32 normals(kWidth, kHeight, 3, 0.f);
  ImageI32 triangles(kWidth, kHeight, 1, -1), materials(kWidth, kHeight, 1, -1);
  for (int i = 1; i < kWidth * kHeight; ++i) {
    normals.data[3 * i] = 0.6f, normals.data[3 * i + 2] = -0.8f - 1e-7f * float(i);
    triangles.data[i] = 70000 * i;  // beyond a float's exact integers
    materials.data[i] = i % 5;
  }
  for (int s = 0; s < kSensors; ++s) {
    writer.write_frame(s, frame_timestamp(s, 0), make_rgb(s, 0), make_depth(s, 0));
    writer.write_groundtruth_normals(s, frame_timestamp(s, 0), normals);
    writer.write_groundtruth_ids(s, frame_timestamp(s, 0), triangles, materials);
  }
  EXPECT_THAT(error_of([&] { writer.write_groundtruth_normals(1, 1.0, ImageF32(kWidth, kHeight, 1)); }),
              HasSubstr("cam1 normal image"));
  EXPECT_THAT(error_of([&] { writer.write_groundtruth_ids(2, 1.0, triangles, ImageI32(kWidth, 5, 1)); }),
              HasSubstr("cam2 material id image size"));
  writer.commit();

  const ScanIndex scan = read_scan_index(scan_dir);
  const double timestamp = frame_timestamp(2, 0);
  const fs::path ids_file = scan_dir / "groundtruth" / "ids" / "cam2" / (format_timestamp(timestamp) + ".exr");
  EXPECT_EQ(groundtruth_ids_path(scan_dir, "cam2", timestamp), ids_file);
  EXPECT_EQ(groundtruth_normals_path(scan_dir, "cam2", timestamp),
            scan_dir / "groundtruth" / "normals" / "cam2" / (format_timestamp(timestamp) + ".exr"));
  EXPECT_EQ(read_groundtruth_normals(scan, 2, timestamp).data, normals.data);
  const ImageI32 ids = read_groundtruth_ids(scan, 2, timestamp);
  ASSERT_EQ(ids.channels, 2);
  for (int i = 0; i < kWidth * kHeight; ++i) {
    ASSERT_EQ(ids.data[2 * i], triangles.data[i]);
    ASSERT_EQ(ids.data[2 * i + 1], materials.data[i]);
  }
  // The documented file format, read without the scan helpers.
  EXPECT_EQ(read_exr_i32(ids_file, {"triangle_id", "material_id"}).data, ids.data);

  // Ids other than indices and -1 are refused naming the file and the channel.
  ImageI32 corrupt = ids;
  corrupt.data[5] = -7;
  write_exr_i32(ids_file, corrupt, {"triangle_id", "material_id"});
  const std::string message = error_of([&] { read_groundtruth_ids(scan, 2, timestamp); });
  EXPECT_THAT(message, HasSubstr(ids_file.string()));
  EXPECT_THAT(message, HasSubstr("channel material_id"));
  EXPECT_THAT(error_of([&] { read_groundtruth_normals(scan, 3, timestamp); }), HasSubstr("sensor"));
  EXPECT_THAT(error_of([&] { read_groundtruth_normals(scan, 0, timestamp); }), HasSubstr("EXR file not found"));
}

TEST_F(ScanTest, WriterChecksImagesAndIndices) {
  ScanWriter writer(dir_ / "scan", make_rig(), false);
  std::string message = error_of([&] { writer.write_frame(2, 1.0, make_rgb(2, 0, 4, 3), make_depth(2, 0)); });
  EXPECT_THAT(message, HasSubstr("cam2 rgb image size"));
  EXPECT_THAT(message, HasSubstr("expected 8x6, found 4x3"));
  message = error_of([&] { writer.write_frame(2, 1.0, make_rgb(2, 0), make_depth(2, 0, 8, 5)); });
  EXPECT_THAT(message, HasSubstr("cam2 depth image size"));
  message = error_of([&] { writer.write_frame(0, 1.0, ImageU8(kWidth, kHeight, 1), make_depth(0, 0)); });
  EXPECT_THAT(message, HasSubstr("cam0 rgb image"));
  message = error_of([&] { writer.write_frame(3, 1.0, make_rgb(0, 0), make_depth(0, 0)); });
  EXPECT_THAT(message, HasSubstr("sensor"));
  message = error_of([&] { writer.write_clean_depth(1, 1.0, make_depth(1, 0, 3, 3)); });
  EXPECT_THAT(message, HasSubstr("cam1 clean depth image size"));
  message = error_of([&] { writer.write_groundtruth_trajectory(-1, {}); });
  EXPECT_THAT(message, HasSubstr("sensor"));
  message = error_of([&] { writer.write_groundtruth_file("../outside.json", "{}"); });
  EXPECT_THAT(message, HasSubstr("outside.json"));
  // A sensor without frames cannot be committed (the reader would refuse the scan).
  writer.write_frame(0, 1.0, make_rgb(0, 0), make_depth(0, 0));
  message = error_of([&] { writer.commit(); });
  EXPECT_THAT(message, HasSubstr("cam1"));
  EXPECT_THAT(message, HasSubstr("no frames"));
  EXPECT_FALSE(fs::exists(dir_ / "scan"));
}

TEST_F(ScanTest, InvalidRigOrCompressionIsRefusedBeforeAnythingIsCreated) {
  RigInfo rig = make_rig();
  rig.sensors[1].name = "cam0";
  std::string message = error_of([&] { ScanWriter writer(dir_ / "scan", rig, false); });
  EXPECT_THAT(message, HasSubstr("sensors[1].name"));
  message = error_of([&] { ScanWriter writer(dir_ / "scan", make_rig(), false, 12); });
  EXPECT_THAT(message, HasSubstr("png_compression"));
  EXPECT_TRUE(entries_of(dir_).empty());
}

// ---------------------------------------------------------------- depth units

TEST(DepthUnits, MetresToUnitsRoundsAndInvalidatesBadValues) {
  ImageF32 depth(10, 1, 1);
  depth.data = {1.0f,
                0.00009f,
                0.00011f,
                0.0f,
                -1.0f,
                std::numeric_limits<float>::quiet_NaN(),
                std::numeric_limits<float>::infinity(),
                13.107f,
                13.2f,
                2.5f};
  const ImageU16 units = depth_to_png_units(depth, 5000.0);
  EXPECT_EQ(units.width, 10);
  EXPECT_EQ(units.channels, 1);
  const UninitialisedVector<std::uint16_t> expected = {
      5000, 0 /* 0.45 units rounds to 0 */, 1 /* 0.55 */, 0, 0, 0, 0, 65535, 0, 12500};
  EXPECT_EQ(units.data, expected);

  const ImageF32 metres = depth_from_png_units(units, 5000.0);
  EXPECT_EQ(metres.data[0], 1.0f);
  EXPECT_EQ(metres.data[3], 0.0f);
  EXPECT_FLOAT_EQ(metres.data[7], 13.107f);
  EXPECT_EQ(metres.data[9], 2.5f);

  // Every unit value survives metres and back.
  ImageU16 all(65536, 1, 1);
  for (int i = 0; i < 65536; ++i) all.data[i] = static_cast<std::uint16_t>(i);
  EXPECT_EQ(depth_to_png_units(depth_from_png_units(all, 5000.0), 5000.0).data, all.data);

  EXPECT_THAT(error_of([&] { depth_to_png_units(depth, 0.0); }), HasSubstr("depth_scale"));
  EXPECT_THAT(error_of([&] { depth_from_png_units(units, -1.0); }), HasSubstr("depth_scale"));
}

// The conversion rounds half away from zero as std::lround does, also at the floats on either side
// of every half unit, where an x + 0.5 shortcut would round the wrong way.
TEST(DepthUnits, RoundsAsLroundAtAndAroundHalfUnits) {
  std::vector<float> values;
  for (int unit = 0; unit < 65535; unit += 97) {
    const float half = (float(unit) + 0.5f) / 1000.0f;
    values.push_back(std::nextafter(half, 0.0f));
    values.push_back(half);
    values.push_back(std::nextafter(half, 1e9f));
    values.push_back(float(unit) / 1000.0f);
  }
  ImageF32 depth(int(values.size()), 1, 1);
  depth.data.assign(values.begin(), values.end());
  for (const double scale : {1000.0, 5000.0, 1.0 / 0.3}) {
    const ImageU16 units = depth_to_png_units(depth, scale);
    for (std::size_t i = 0; i < values.size(); ++i) {
      const double scaled = double(values[i]) * scale;
      const long expected =
          values[i] > 0 && scaled <= 65535.5 && std::lround(scaled) <= 65535 ? std::lround(scaled) : 0;
      ASSERT_EQ(units.data[i], expected) << "depth " << values[i] << " m at scale " << scale;
    }
  }
}

}  // namespace
}  // namespace panoscan
