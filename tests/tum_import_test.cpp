// `import tum` (core/tum_import.h, app/commands_import.cpp): a small simulated scan exported as TUM
// RGB-D sequences (one per camera: rgb.txt, depth.txt, groundtruth.txt, the images) and imported
// again gives the same frames (pixel-equal), poses (1e-6), intrinsics and extrinsics; the
// association drops what has no partner; every refusal names the file and the line (or the
// option); the program's exit codes and import.json.

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_util.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/tum_import.h"
#include "panoscan/sim/options.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ::testing::HasSubstr;
using testutil::error_of;
using testutil::TempDir;

constexpr int kWidth = 64;
constexpr int kHeight = 48;

// One small simulated scan (three cameras, 64x48, every 120th frame), shared by the tests.
const fs::path& simulated_scan() {
  static TempDir dir("tum-import-sim");
  static const fs::path scan = [] {
    const Scene scene = testutil::make_box_room(-1.6, 3.3, -2.1, 2.4, 2.7, Eigen::Vector3d(0, 0, 0));
    SimOptions options;
    options.rig.width = kWidth;
    options.rig.height = kHeight;
    options.output.every = 120;
    options.threads = 1;
    options.seed = 3;
    Simulator(scene, 0, options).write_scan(dir / "scan", false);
    return dir / "scan";
  }();
  return scan;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string full(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

struct ExportOptions {
  double depth_offset_s = 0.0;  // depth images stamped this much after their colour image
  bool extra_depth = false;     // one more depth image, far from every colour image
};

// The scan as TUM sequences out/seq<K>/ (TUM's own layout and headers), an extrinsics file
// out/extrinsics.json, and the --intrinsics of each camera. Returns the sequence folders.
std::vector<fs::path> export_as_tum(const ScanIndex& scan, const fs::path& out, std::vector<std::string>* intrinsics,
                                    const ExportOptions& options = {}) {
  std::vector<fs::path> sequences;
  json extrinsics;
  extrinsics["reference_sensor"] = scan.rig.reference_sensor;
  extrinsics["ref_from_cam"] = json::array();
  for (std::size_t s = 0; s < scan.rig.sensors.size(); ++s) {
    const SensorInfo& info = scan.rig.sensors[s];
    const fs::path seq = out / ("seq" + std::to_string(s));
    fs::create_directories(seq / "rgb");
    fs::create_directories(seq / "depth");
    std::string rgb_listing = "# color images\n# file: 'exported.bag'\n# timestamp filename\n";
    std::string depth_listing = "# depth maps\n# file: 'exported.bag'\n# timestamp filename\n";
    for (const FrameEntry& frame : scan.frames[s]) {
      const std::string rgb_name = "rgb/" + format_timestamp(frame.timestamp) + ".png";
      const std::string depth_name = "depth/" + format_timestamp(frame.timestamp + options.depth_offset_s) + ".png";
      fs::copy_file(scan.root / info.name / frame.rgb_file, seq / rgb_name);
      fs::copy_file(scan.root / info.name / frame.depth_file, seq / depth_name);
      rgb_listing += format_timestamp(frame.timestamp) + " " + rgb_name + "\n";
      depth_listing += format_timestamp(frame.timestamp + options.depth_offset_s) + " " + depth_name + "\n";
    }
    if (options.extra_depth) {
      const double late = scan.frames[s].back().timestamp + 1.0;
      const std::string name = "depth/" + format_timestamp(late) + ".png";
      fs::copy_file(scan.root / info.name / scan.frames[s].back().depth_file, seq / name);
      depth_listing += format_timestamp(late) + " " + name + "\n";
    }
    write_text(seq / "rgb.txt", rgb_listing);
    write_text(seq / "depth.txt", depth_listing);
    // TUM's groundtruth.txt: the same line format as groundtruth/camK.txt, world_from_cam.
    write_text(seq / "groundtruth.txt",
               "# ground truth trajectory\n# file: 'exported.bag'\n# timestamp tx ty tz qx qy qz qw\n" +
                   read_text(groundtruth_dir(scan.root) / (info.name + ".txt")));
    json matrix = json::array();
    const Eigen::Matrix4d m = info.ref_from_cam.matrix();
    for (int r = 0; r < 4; ++r) matrix.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
    extrinsics["ref_from_cam"].push_back(matrix);
    const PinholeIntrinsics& k = info.intrinsics;
    intrinsics->push_back(full(k.fx) + "," + full(k.fy) + "," + full(k.cx) + "," + full(k.cy));
    sequences.push_back(seq);
  }
  write_text(out / "extrinsics.json", extrinsics.dump());
  return sequences;
}

void expect_same_scan(const ScanIndex& imported, const ScanIndex& original) {
  ASSERT_EQ(imported.rig.sensors.size(), original.rig.sensors.size());
  EXPECT_EQ(imported.rig.reference_sensor, original.rig.reference_sensor);
  for (std::size_t s = 0; s < original.rig.sensors.size(); ++s) {
    const SensorInfo& a = imported.rig.sensors[s];
    const SensorInfo& b = original.rig.sensors[s];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.intrinsics.width, b.intrinsics.width);
    EXPECT_EQ(a.intrinsics.height, b.intrinsics.height);
    EXPECT_EQ(a.intrinsics.fx, b.intrinsics.fx);
    EXPECT_EQ(a.intrinsics.fy, b.intrinsics.fy);
    EXPECT_EQ(a.intrinsics.cx, b.intrinsics.cx);
    EXPECT_EQ(a.intrinsics.cy, b.intrinsics.cy);
    EXPECT_EQ(a.depth_scale, b.depth_scale);
    EXPECT_LT((a.ref_from_cam.matrix() - b.ref_from_cam.matrix()).cwiseAbs().maxCoeff(), 1e-9) << a.name;

    ASSERT_EQ(imported.frames[s].size(), original.frames[s].size()) << a.name;
    for (std::size_t f = 0; f < original.frames[s].size(); ++f) {
      EXPECT_EQ(format_timestamp(imported.frames[s][f].timestamp), format_timestamp(original.frames[s][f].timestamp));
      const RgbdFrame x = load_frame(imported, int(s), f);
      const RgbdFrame y = load_frame(original, int(s), f);
      EXPECT_EQ(x.rgb.data, y.rgb.data) << a.name << " frame " << f;
      EXPECT_EQ(x.depth.data, y.depth.data) << a.name << " frame " << f;
    }
    const std::vector<StampedPose> got = read_groundtruth_trajectory(imported.root, int(s));
    const std::vector<StampedPose> want = read_groundtruth_trajectory(original.root, int(s));
    ASSERT_EQ(got.size(), want.size()) << a.name;
    for (std::size_t f = 0; f < want.size(); ++f) {
      EXPECT_EQ(format_timestamp(got[f].timestamp), format_timestamp(want[f].timestamp));
      EXPECT_LT((got[f].world_from_cam.matrix() - want[f].world_from_cam.matrix()).cwiseAbs().maxCoeff(), 1e-6);
    }
  }
}

TEST(TumImport, ASimulatedScanExportedAsTumSequencesComesBackTheSame) {
  const ScanIndex original = read_scan_index(simulated_scan());
  ASSERT_EQ(original.rig.sensors.size(), 3u);
  ASSERT_GE(original.frames[0].size(), 5u);
  TempDir dir("tum-import-roundtrip");
  TumImportOptions options;
  options.inputs = export_as_tum(original, dir.path(), &options.intrinsics);
  options.extrinsics_file = dir / "extrinsics.json";
  options.out = dir / "imported";
  options.motion = RigMotion::kRotator;
  const TumImportReport report = import_tum(options);
  expect_same_scan(read_scan_index(options.out), original);
  EXPECT_EQ(read_scan_index(options.out).rig.motion, RigMotion::kRotator);
  ASSERT_EQ(report.sensors.size(), 3u);
  for (std::size_t s = 0; s < 3; ++s) {
    EXPECT_EQ(report.sensors[s].frames, original.frames[s].size());
    EXPECT_EQ(report.sensors[s].rgb_dropped, 0u);
    EXPECT_EQ(report.sensors[s].depth_dropped, 0u);
    EXPECT_EQ(report.sensors[s].frames_with_pose, original.frames[s].size());
    EXPECT_EQ(report.sensors[s].intrinsics_source, "--intrinsics");
  }

  // import.json: the inputs, the options and the counts.
  const json provenance = read_json_file(options.out / "import.json");
  EXPECT_EQ(provenance["format"], "panoscan-import");
  EXPECT_EQ(provenance["options"]["motion"], "rotator");
  EXPECT_EQ(provenance["options"]["depth_scale"], 5000.0);
  EXPECT_EQ(provenance["options"]["reference_sensor"], original.rig.reference_sensor);
  ASSERT_EQ(provenance["sensors"].size(), 3u);
  EXPECT_EQ(provenance["sensors"][1]["frames"], original.frames[1].size());
  EXPECT_EQ(provenance["sensors"][1]["groundtruth"]["frames_without_pose"], 0);
  EXPECT_EQ(provenance["sensors"][2]["input"], fs::absolute(options.inputs[2]).lexically_normal().string());
}

TEST(TumImport, UnsynchronisedDepthIsAssociatedAndTheUnpairedDropped) {
  const ScanIndex original = read_scan_index(simulated_scan());
  TempDir dir("tum-import-offset");
  ExportOptions exported;
  exported.depth_offset_s = 0.007;  // as a Kinect's depth lags its colour
  exported.extra_depth = true;
  TumImportOptions options;
  options.inputs = export_as_tum(original, dir.path(), &options.intrinsics, exported);
  options.extrinsics_file = dir / "extrinsics.json";
  options.out = dir / "imported";
  options.hard_link = true;
  const TumImportReport report = import_tum(options);
  // The frames carry the colour timestamps: the same scan, but handheld (the importer's default).
  const ScanIndex imported = read_scan_index(options.out);
  expect_same_scan(imported, original);
  EXPECT_EQ(imported.rig.motion, RigMotion::kHandheld);
  for (const TumImportSensorReport& s : report.sensors) {
    EXPECT_EQ(s.depth_listed, s.frames + 1);
    EXPECT_EQ(s.depth_dropped, 1u);
    EXPECT_NEAR(s.max_abs_dt, 0.007, 1e-6);
  }
  // Hard links: the scan's images are the sequence's files.
  const FrameEntry& first = imported.frames[0][0];
  EXPECT_EQ(fs::hard_link_count(options.out / "cam0" / first.depth_file), 2u);
  // A window narrower than the lag pairs nothing: refused, naming the listings.
  options.max_dt = 0.005;
  options.out = dir / "again";
  const std::string message = error_of([&] { import_tum(options); });
  EXPECT_THAT(message, HasSubstr((options.inputs[0] / "depth.txt").string()));
  EXPECT_THAT(message, HasSubstr("no depth image within"));
  EXPECT_FALSE(fs::exists(options.out));
}

TEST(TumImport, GroundTruthIsInterpolatedAtTheFrameTimesAndFramesOutsideItHaveNoPose) {
  TempDir dir("tum-import-gt");
  const fs::path seq = dir / "rgbd_dataset_freiburg3_test";
  std::string rgb = "# timestamp filename\n", depth = rgb;
  for (int f = 0; f < 3; ++f) {
    const std::string t = format_timestamp(10.0 + 0.1 * f);
    write_png(seq / "rgb" / (t + ".png"), ImageU8(640, 480, 3, std::uint8_t(10 * f)));
    write_png16(seq / "depth" / (t + ".png"), ImageU16(640, 480, 1, std::uint16_t(5000 + f)));
    rgb += t + " rgb/" + t + ".png\n";
    depth += t + " depth/" + t + ".png\n";
  }
  write_text(seq / "rgb.txt", rgb);
  write_text(seq / "depth.txt", depth);
  // Poses every 10 ms around the first two frames only; the third frame is 90 ms past the last.
  write_text(seq / "groundtruth.txt",
             "# timestamp tx ty tz qx qy qz qw\n"
             "9.995 0 0 0 0 0 0 1\n10.005 1 0 0 0 0 0 1\n10.095 2 0 0 0 0 0 1\n10.105 3 0 0 0 0 0 1\n");
  TumImportOptions options;
  options.inputs = {seq};
  options.out = dir / "scan";
  const TumImportReport report = import_tum(options);
  EXPECT_EQ(report.sensors[0].intrinsics_source, "folder name: fr3");
  EXPECT_EQ(report.sensors[0].groundtruth_poses, 4u);
  EXPECT_EQ(report.sensors[0].frames_with_pose, 2u);
  const ScanIndex scan = read_scan_index(options.out);
  EXPECT_EQ(scan.rig.sensors[0].intrinsics.fx, 535.4);
  EXPECT_EQ(scan.rig.sensors[0].intrinsics.cy, 247.6);
  EXPECT_NEAR(scan.rig.sensors[0].nominal_fps, 10.0, 1e-6);
  const std::vector<StampedPose> poses = read_groundtruth_trajectory(options.out, 0);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_NEAR(poses[0].world_from_cam.translation().x(), 0.5, 1e-9);
  EXPECT_NEAR(poses[1].world_from_cam.translation().x(), 2.5, 1e-9);
  EXPECT_EQ(format_timestamp(poses[1].timestamp), "10.100000");
}

// A valid one-camera TUM folder (640x480, the fr1 preset by name) that each case then breaks.
class TumImportErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string rgb = "# color images\n# timestamp filename\n", depth = "# depth maps\n# timestamp filename\n";
    for (int f = 0; f < 3; ++f) {
      const std::string t = format_timestamp(1305031102.175304 + f / 30.0);
      const std::string td = format_timestamp(1305031102.175304 + f / 30.0 + 0.004);
      write_png(seq_ / "rgb" / (t + ".png"), ImageU8(640, 480, 3, 7));
      write_png16(seq_ / "depth" / (td + ".png"), ImageU16(640, 480, 1, 5000));
      rgb += t + " rgb/" + t + ".png\n";
      depth += td + " depth/" + td + ".png\n";
    }
    write_text(seq_ / "rgb.txt", rgb);
    write_text(seq_ / "depth.txt", depth);
    options_.inputs = {seq_};
    options_.out = dir_ / "scan";
  }
  // Replaces line `line` (1-based) of `listing`.
  void replace_line(const std::string& listing, int line, const std::string& text) {
    std::vector<std::string> lines;
    std::ifstream in(seq_ / listing);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    lines.at(line - 1) = text;
    std::string out;
    for (const std::string& l : lines) out += l + "\n";
    write_text(seq_ / listing, out);
  }
  std::string listed_file(const std::string& listing, int line) {
    std::ifstream in(seq_ / listing);
    std::string l;
    for (int i = 0; i < line; ++i) std::getline(in, l);
    return l.substr(l.find(' ') + 1);
  }
  std::string import_error() { return error_of([&] { import_tum(options_); }); }

  TempDir dir_{"tum-import-errors"};
  fs::path seq_ = dir_ / "rgbd_dataset_freiburg1_xyz";
  TumImportOptions options_;
};

TEST_F(TumImportErrors, TheValidFolderImportsWithTheFr1Preset) {
  const TumImportReport report = import_tum(options_);
  EXPECT_EQ(report.sensors[0].frames, 3u);
  EXPECT_EQ(report.sensors[0].intrinsics_source, "folder name: fr1");
  EXPECT_FALSE(report.sensors[0].has_groundtruth);
  const SensorInfo sensor = read_scan_index(options_.out).rig.sensors[0];  // a copy: the index is a temporary
  EXPECT_EQ(sensor.intrinsics.fx, 517.3);
  EXPECT_EQ(sensor.intrinsics.cx, 318.6);
  EXPECT_FALSE(fs::exists(groundtruth_dir(options_.out)));
  // An existing output is kept unless overwrite is asked for.
  EXPECT_THAT(import_error(), HasSubstr("already exists"));
  options_.overwrite = true;
  options_.cameras = {"ros"};
  import_tum(options_);
  EXPECT_EQ(read_scan_index(options_.out).rig.sensors[0].intrinsics.fx, 525.0);
}

TEST_F(TumImportErrors, AMissingListingNamesIt) {
  fs::remove(seq_ / "depth.txt");
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "depth.txt").string() + ": listing not found"));
  EXPECT_FALSE(fs::exists(options_.out));
}

TEST_F(TumImportErrors, AListedFileThatIsNotThereNamesTheListingAndLine) {
  fs::remove(seq_ / listed_file("rgb.txt", 4));
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "rgb.txt").string() + ": line 4: listed file not found"));
}

TEST_F(TumImportErrors, ADepthImageThatIsNot16BitNamesTheListingLineAndImage) {
  const std::string file = listed_file("depth.txt", 5);
  write_png(seq_ / file, ImageU8(640, 480, 1, 9));
  const std::string message = import_error();
  EXPECT_THAT(message, HasSubstr((seq_ / "depth.txt").string() + ": line 5: "));
  EXPECT_THAT(message, HasSubstr((seq_ / file).string()));
  EXPECT_THAT(message, HasSubstr("16-bit"));
  // A colour image instead of a depth PNG, and not a PNG at all.
  write_png(seq_ / file, ImageU8(640, 480, 3, 9));
  EXPECT_THAT(import_error(), HasSubstr("found 3 channel(s) of 8-bit data"));
  write_text(seq_ / file, "not an image");
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "depth.txt").string() + ": line 5: " + (seq_ / file).string() +
                                        ": format: not a PNG"));
}

TEST_F(TumImportErrors, ColourThatIsNot8BitOrImagesOfAnotherSizeNameTheLine) {
  write_png16(seq_ / listed_file("rgb.txt", 3), ImageU16(640, 480, 1, 9));
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "rgb.txt").string() + ": line 3: "));
  EXPECT_THAT(import_error(), HasSubstr("expected an 8-bit colour image"));
  write_png(seq_ / listed_file("rgb.txt", 3), ImageU8(640, 480, 3, 9));
  write_png16(seq_ / listed_file("depth.txt", 4), ImageU16(320, 240, 1, 9));
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "depth.txt").string() + ": line 4: "));
  EXPECT_THAT(import_error(), HasSubstr("is 320x240, the first colour image 640x480"));
}

TEST_F(TumImportErrors, TimestampsOutOfOrderNameTheListingAndLine) {
  replace_line("depth.txt", 4, "1305031102.0 " + listed_file("depth.txt", 4));
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "depth.txt").string() + ": line 4: timestamp 1305031102.0 is before"));
  SetUp();
  const std::string second = format_timestamp(1305031102.175304 + 1 / 30.0);
  replace_line("rgb.txt", 5, second + " " + listed_file("rgb.txt", 5));
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "rgb.txt").string() + ": line 5: timestamp " + second + " repeats"));
}

TEST_F(TumImportErrors, NoAssociablePairsNamesBothListings) {
  options_.max_dt = 0.001;  // depth is 4 ms after colour
  const std::string message = import_error();
  EXPECT_THAT(message, HasSubstr((seq_ / "depth.txt").string() + ": no depth image within"));
  EXPECT_THAT(message, HasSubstr((seq_ / "rgb.txt").string()));
}

TEST_F(TumImportErrors, BadGroundTruthNamesTheFileAndLine) {
  write_text(seq_ / "groundtruth.txt", "# timestamp tx ty tz qx qy qz qw\n1305031102.17 0 0 0 0 0 0 1\n"
                                       "1305031102.16 0 0 0 0 0 0 1\n");
  EXPECT_THAT(import_error(), HasSubstr((seq_ / "groundtruth.txt").string() + ": line 3: "));
}

TEST_F(TumImportErrors, IntrinsicsPresetsAndExtrinsicsOptionsAreChecked) {
  // The folder name tells the preset; another name does not.
  const fs::path other = dir_ / "my_recording";
  fs::rename(seq_, other);
  options_.inputs = {other};
  EXPECT_THAT(import_error(), HasSubstr(other.string() + ": cannot tell the camera from the folder name"));
  options_.cameras = {"fr4"};
  EXPECT_THAT(import_error(), HasSubstr("--camera: unknown camera 'fr4' (known: fr1, fr2, fr3, ros)"));
  options_.cameras = {"fr2"};
  options_.intrinsics = {"500,500,320,240"};
  EXPECT_THAT(import_error(), HasSubstr("either --intrinsics or --camera"));
  options_.cameras.clear();
  for (const char* bad : {"500,500,320", "500,500,320,240,1", "500,x,320,240", "-1,500,320,240", "500,500,320,240,"}) {
    options_.intrinsics = {bad};
    EXPECT_THAT(import_error(), HasSubstr("--intrinsics: '" + std::string(bad) + "'")) << bad;
  }
  options_.intrinsics = {"500,500,320,240", "500,500,320,240"};
  EXPECT_THAT(import_error(), HasSubstr("given 2 times for 1 inputs"));
  // Two inputs need extrinsics; a bad extrinsics file is named with its field.
  options_.intrinsics = {"500,500,320,240"};
  options_.inputs = {other, other};
  EXPECT_THAT(import_error(), HasSubstr("--extrinsics: required for 2 inputs"));
  const fs::path extrinsics = dir_ / "extrinsics.json";
  options_.extrinsics_file = extrinsics;
  write_text(extrinsics, R"({"ref_from_cam": [[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]]})");
  EXPECT_THAT(import_error(), HasSubstr(extrinsics.string() + ": ref_from_cam: expected a list of 2 poses"));
  write_text(extrinsics, R"({"ref_from_cam": [[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
                              [[1,0,0,0],[0,2,0,0],[0,0,1,0],[0,0,0,1]]]})");
  EXPECT_THAT(import_error(), HasSubstr(extrinsics.string() + ": ref_from_cam[1]: the 3x3 block is not a rotation"));
  write_text(extrinsics, R"({"ref_from_cam": [[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
                              [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]]})");
  EXPECT_THAT(import_error(), HasSubstr("ref_from_cam[1]: the last row must be [0, 0, 0, 1]"));
  write_text(extrinsics, R"({"ref_from_cam": [[[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
                              {"translation": [0,0,0], "rotation_quaternion_xyzw": [0,0,0,1]}]})");
  EXPECT_THAT(import_error(), HasSubstr("ref_from_cam[0]: the reference sensor's pose in its own frame must be identity"));
  write_text(extrinsics, R"({"ref_from_cam": [], "reference": 1})");
  EXPECT_THAT(import_error(), HasSubstr(extrinsics.string() + ": reference: unknown field"));
  // Two cameras of one sequence, the second 10 cm to the right as a pose object: imported.
  write_text(extrinsics, R"({"reference_sensor": 0, "ref_from_cam": [[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
                              {"translation": [0.1,0,0], "rotation_quaternion_xyzw": [0,0,0,1]}]})");
  import_tum(options_);
  const ScanIndex scan = read_scan_index(options_.out);
  ASSERT_EQ(scan.rig.sensors.size(), 2u);
  EXPECT_NEAR(scan.rig.sensors[1].ref_from_cam.translation().x(), 0.1, 1e-12);
}

TEST_F(TumImportErrors, APresetIsRefusedForImagesOfAnotherSize) {
  TempDir small("tum-import-small");
  const fs::path seq = small / "rgbd_dataset_freiburg2_small";
  const std::string t = format_timestamp(5.0);
  write_png(seq / "rgb" / "a.png", ImageU8(320, 240, 3, 1));
  write_png16(seq / "depth" / "a.png", ImageU16(320, 240, 1, 1));
  write_text(seq / "rgb.txt", t + " rgb/a.png\n");
  write_text(seq / "depth.txt", t + " depth/a.png\n");
  options_.inputs = {seq};
  EXPECT_THAT(import_error(), HasSubstr("the camera preset fr2 (folder name: fr2) is for 640x480 images, these are 320x240"));
}

// The program: exit 0 and a summary; exit 2 with one line naming the file and line.
TEST_F(TumImportErrors, TheProgramImportsAndRefusesNamingTheFile) {
  testutil::RunResult r = testutil::run_panoscan("import tum --input " + seq_.string() + " --out " +
                                                 options_.out.string() + " --max-dt 0.01 --motion rotator");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("cam0 <- " + seq_.string() + ": 3 frames 640x480"));
  EXPECT_THAT(r.output, HasSubstr("intrinsics 517.3,516.5,318.6,255.3 (folder name: fr1)"));
  EXPECT_EQ(read_scan_index(options_.out).rig.motion, RigMotion::kRotator);

  r = testutil::run_panoscan("import tum --input " + seq_.string() + " --out " + (dir_ / "b").string() +
                             " --motion robot");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--motion: expected 'rotator' or 'handheld', found 'robot'"));
  replace_line("rgb.txt", 4, "oops");
  r = testutil::run_panoscan("import tum --input " + seq_.string() + " --out " + (dir_ / "b").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("panoscan: " + (seq_ / "rgb.txt").string() + ": line 4: "));
  EXPECT_FALSE(fs::exists(dir_ / "b"));
  r = testutil::run_panoscan("import tum --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("--hard-link"));
}

// Colour as JPEG (as many recordings have it) goes through OpenCV's decoders, which the program loads
// only then (core/src/opencv_decoder.cpp): the import must find and use them.
TEST_F(TumImportErrors, TheProgramImportsJpegColour) {
  std::string rgb = "# color images\n# timestamp filename\n";
  for (int line = 3; line <= 5; ++line) {
    const fs::path png = seq_ / listed_file("rgb.txt", line);
    const fs::path jpeg = fs::path(png).replace_extension(".jpg");
    const cv::Mat colour(480, 640, CV_8UC3, cv::Scalar(40, 90, 200));  // BGR
    ASSERT_TRUE(cv::imwrite(jpeg.string(), colour, {cv::IMWRITE_JPEG_QUALITY, 95}));
    fs::remove(png);
    rgb += png.stem().string() + " rgb/" + jpeg.filename().string() + "\n";
  }
  write_text(seq_ / "rgb.txt", rgb);
  const testutil::RunResult r =
      testutil::run_panoscan("import tum --input " + seq_.string() + " --out " + options_.out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("cam0 <- " + seq_.string() + ": 3 frames 640x480"));
  const ScanIndex index = read_scan_index(options_.out);
  ASSERT_EQ(index.frames.at(0).size(), 3u);
  const ImageU8 colour = load_frame(index, 0, 0).rgb;
  ASSERT_EQ(colour.width, 640);
  // RGB order; JPEG keeps a flat colour within a unit or two.
  EXPECT_NEAR(colour.at(320, 240, 0), 200, 2);
  EXPECT_NEAR(colour.at(320, 240, 1), 90, 2);
  EXPECT_NEAR(colour.at(320, 240, 2), 40, 2);
}

}  // namespace
}  // namespace panoscan
