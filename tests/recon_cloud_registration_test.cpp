// Registration of point-cloud files (recon/pipeline's cloud_registration.h, `recon register` on
// .ply / .pcd): two noisy range scans of the built-in office from sensor poses a few degrees and
// centimetres apart, written in every supported format (binary PLY of either byte order, ASCII PLY
// with extra properties and elements, ASCII and binary PCD) with their per-point covariance (or
// variance, or sigma), registered from the identity and compared with the known transform; the
// fallback without covariances; the refusals; and the program's JSON and 4x4 matrix outputs.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "panoscan/core/cloud_file.h"
#include "panoscan/core/error.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/pose_json.h"
#include "panoscan/core/random.h"
#include "panoscan/recon/cloud_registration.h"
#include "panoscan/recon/point_covariance.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/renderer.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testutil::error_of;

// A simulated range scan in its sensor's frame: points and their measurement covariances.
struct Scan {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Matrix3d> covariances;
  std::vector<double> sigmas;  // the radial std of each point
};

// An equirectangular range scan of the office from `world_from_sensor` with radial noise of std
// 1 mm + 1 mm * d^2 (a Kinect-like growth with depth) and half a pixel of angular noise; the
// covariance of Eq. 9 for each point.
Scan range_scan(const Renderer& renderer, const Rigid3d& world_from_sensor, int height, std::uint64_t seed) {
  const Equirectangular pano{height};
  const RenderedView view = renderer.render_equirectangular(world_from_sensor, pano);
  RandomStream rng(seed, 0, 0, RandomPurpose::kGeneric);
  const double sigma_angle = 0.5 * M_PI / height;
  Scan scan;
  for (int v = 0; v < pano.height; ++v)
    for (int u = 0; u < pano.width(); ++u) {
      const double depth = view.depth.at(u, v);
      if (!(depth > 0)) continue;
      const double sigma = 0.001 + 0.001 * depth * depth;
      const double phi = 2 * M_PI * (u + 0.5) / pano.width(), theta = M_PI * (v + 0.5) / pano.height;
      const double noisy = depth + sigma * rng.normal();
      const double du = sigma_angle * rng.normal() * pano.width() / (2 * M_PI);
      const double dv = sigma_angle * rng.normal() * pano.height / M_PI;
      scan.points.push_back(pano.direction(u + du, v + dv) * noisy);
      scan.covariances.push_back(equirectangular_point_covariance(phi, theta, noisy, sigma_angle, sigma));
      scan.sigmas.push_back(sigma);
    }
  return scan;
}

// The two scans and the truth: the target sensor is the source's moved by 4 degrees about a tilted
// axis and (4, -3, 1.5) cm.
struct Pair {
  Scan source, target;
  Rigid3d target_from_source;
};

const Pair& office_pair() {
  static const Pair pair = [] {
    const Scene scene = scenes::make_builtin_scene("office");
    const Renderer renderer(scene);
    const Rigid3d world_from_source =
        make_rigid(Eigen::Matrix3d::Identity(), scene.positions[0].floor_point + Eigen::Vector3d(0, 0, 1.3));
    const Rigid3d motion = make_rigid(
        Eigen::Matrix3d(Eigen::AngleAxisd(4.0 * M_PI / 180, Eigen::Vector3d(0.3, -0.2, 1.0).normalized())),
        Eigen::Vector3d(0.04, -0.03, 0.015));
    const Rigid3d world_from_target = world_from_source * motion;
    Pair p;
    p.source = range_scan(renderer, world_from_source, 160, 1);
    p.target = range_scan(renderer, world_from_target, 160, 2);
    p.target_from_source = world_from_target.inverse() * world_from_source;
    return p;
  }();
  return pair;
}

// ---- Writers of the formats (independent of the reader under test).

template <class T>
std::string bytes_of(T value, bool big_endian = false) {
  std::string out(sizeof(T), '\0');
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(T));
  for (std::size_t k = 0; k < sizeof(T); ++k)
    out[big_endian ? sizeof(T) - 1 - k : k] = char((bits >> (8 * k)) & 0xFF);
  return out;
}

const char* kCov[6] = {"cov_xx", "cov_xy", "cov_xz", "cov_yy", "cov_yz", "cov_zz"};
double cov_entry(const Eigen::Matrix3d& c, int k) {
  const int rows[6] = {0, 0, 0, 1, 1, 2}, cols[6] = {0, 1, 2, 1, 2, 2};
  return c(rows[k], cols[k]);
}

// Binary little-endian PLY by the project's writer, the covariance as six extra float properties.
fs::path write_binary_ply_cov(const fs::path& path, const Scan& scan) {
  PointCloud cloud;
  cloud.positions = scan.points;
  PlyWriteOptions options;
  options.double_positions = true;
  for (int k = 0; k < 6; ++k) {
    std::vector<float> values;
    for (const auto& c : scan.covariances) values.push_back(float(cov_entry(c, k)));
    options.extra_properties.emplace_back(kCov[k], values);
  }
  write_ply_point_cloud(path, cloud, options);
  return path;
}

// Binary big-endian PLY with an isotropic `variance` (double) and an intensity (ushort).
fs::path write_big_endian_ply_variance(const fs::path& path, const Scan& scan) {
  std::string out = "ply\nformat binary_big_endian 1.0\ncomment by the test\nelement vertex " +
                    std::to_string(scan.points.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty ushort intensity\n"
                    "property double variance\nend_header\n";
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) out += bytes_of(float(scan.points[i][k]), true);
    out += bytes_of(std::uint16_t(i % 65536), true);
    out += bytes_of(scan.sigmas[i] * scan.sigmas[i], true);
  }
  std::ofstream(path, std::ios::binary) << out;
  return path;
}

// ASCII PLY with normals, colour, intensity, a `sigma`, a camera element before the vertices and a
// range grid after them.
fs::path write_ascii_ply_sigma(const fs::path& path, const Scan& scan) {
  std::ostringstream out;
  out.precision(9);
  out << "ply\nformat ascii 1.0\nelement camera 1\nproperty float view_px\nproperty float view_py\n"
      << "element vertex " << scan.points.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
         "property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty float intensity\n"
         "property float sigma\nelement range_grid 3\nproperty list uchar int vertex_indices\nend_header\n"
      << "0 0\n";
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    const Eigen::Vector3d& p = scan.points[i];
    out << p.x() << ' ' << p.y() << ' ' << p.z() << " 0 0 1 10 20 30 0.5 " << scan.sigmas[i] << '\n';
  }
  out << "1 0\n0\n1 1\n";
  std::ofstream(path, std::ios::binary) << out.str();
  return path;
}

// PCD with x y z, an rgb, a COUNT-3 field, the covariance (F 8) and a VIEWPOINT at the sensor.
fs::path write_pcd_cov(const fs::path& path, const Scan& scan, bool binary) {
  std::ostringstream out;
  out << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
         "FIELDS x y z rgb hist cov_xx cov_xy cov_xz cov_yy cov_yz cov_zz\n"
         "SIZE 4 4 4 4 2 8 8 8 8 8 8\nTYPE F F F U I F F F F F F\nCOUNT 1 1 1 1 3 1 1 1 1 1 1\n"
      << "WIDTH " << scan.points.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << scan.points.size()
      << "\nDATA " << (binary ? "binary" : "ascii") << "\n";
  std::string body;
  std::ostringstream text;
  text.precision(17);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    const Eigen::Vector3d& p = scan.points[i];
    if (binary) {
      for (int k = 0; k < 3; ++k) body += bytes_of(float(p[k]));
      body += bytes_of(std::uint32_t(0x00FF8000));
      for (int k = 0; k < 3; ++k) body += bytes_of(std::int16_t(k - 1));
      for (int k = 0; k < 6; ++k) body += bytes_of(cov_entry(scan.covariances[i], k));
    } else {
      text << float(p.x()) << ' ' << float(p.y()) << ' ' << float(p.z()) << " 16744448 -1 0 1";
      for (int k = 0; k < 6; ++k) text << ' ' << cov_entry(scan.covariances[i], k);
      text << '\n';
    }
  }
  std::ofstream(path, std::ios::binary) << out.str() << (binary ? body : text.str());
  return path;
}

// Positions only (no uncertainty): PCD ascii.
fs::path write_pcd_plain(const fs::path& path, const Scan& scan) {
  std::ostringstream out;
  out.precision(9);
  out << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << scan.points.size()
      << "\nHEIGHT 1\nPOINTS " << scan.points.size() << "\nDATA ascii\n";
  for (const auto& p : scan.points) out << float(p.x()) << ' ' << float(p.y()) << ' ' << float(p.z()) << '\n';
  std::ofstream(path, std::ios::binary) << out.str();
  return path;
}

struct Errors {
  double rotation_deg, translation_mm;
};
Errors errors_of(const Rigid3d& estimate, const Rigid3d& truth) {
  const Rigid3d difference = truth.inverse() * estimate;
  return {rad2deg(rotation_angle(difference.linear())), 1000 * difference.translation().norm()};
}

CloudRegistrationOptions default_options() {
  Config config;
  return cloud_registration_options_from_config(config);
}

// The thresholds: the measured errors (see the README, "Registering point clouds") are 0.006-0.012
// deg and 0.3-0.7 mm at this size; the identity (the initial pose) is 4 deg and 52 mm off.
constexpr double kMaxRotationDeg = 0.05;
constexpr double kMaxTranslationMm = 2.0;

TEST(CloudRegistration, KnownMotionFromEveryFormatWithTheFilesCovariance) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg");
  struct Case {
    std::string name;
    fs::path source, target;
    std::string source_uncertainty, target_uncertainty;
  };
  const std::vector<Case> cases = {
      {"binary PLY (cov) -> binary PLY (cov)", write_binary_ply_cov(dir / "s.ply", pair.source),
       write_binary_ply_cov(dir / "t.ply", pair.target), "cov_xx..cov_zz", "cov_xx..cov_zz"},
      {"ASCII PLY (sigma, extra elements) -> big-endian PLY (variance)", write_ascii_ply_sigma(dir / "s_a.ply", pair.source),
       write_big_endian_ply_variance(dir / "t_be.ply", pair.target), "sigma", "variance"},
      {"ASCII PCD (cov) -> binary PCD (cov)", write_pcd_cov(dir / "s_a.pcd", pair.source, false),
       write_pcd_cov(dir / "t_b.pcd", pair.target, true), "cov_xx..cov_zz", "cov_xx..cov_zz"},
  };
  const Errors identity = errors_of(Rigid3d::Identity(), pair.target_from_source);
  EXPECT_GT(identity.rotation_deg, 3.9);
  for (const Case& c : cases) {
    const CloudFile source = read_cloud_file(c.source), target = read_cloud_file(c.target);
    EXPECT_EQ(source.uncertainty, c.source_uncertainty) << c.name;
    EXPECT_EQ(target.uncertainty, c.target_uncertainty) << c.name;
    EXPECT_EQ(source.points.size(), pair.source.points.size()) << c.name;
    const CloudPairRegistration r = register_cloud_files(source, target, Rigid3d::Identity(), default_options());
    EXPECT_EQ(r.method_used, IcpMethod::kGicpMeasured) << c.name;
    EXPECT_TRUE(r.source_covariance && r.target_covariance) << c.name;
    const Errors e = errors_of(r.target_from_source, pair.target_from_source);
    std::printf("%s: %.4f deg, %.3f mm, %d iterations, overlap %.3f\n", c.name.c_str(), e.rotation_deg,
                e.translation_mm, r.icp.iterations, r.overlap);
    EXPECT_LT(e.rotation_deg, kMaxRotationDeg) << c.name;
    EXPECT_LT(e.translation_mm, kMaxTranslationMm) << c.name;
    EXPECT_GT(r.overlap, 0.8) << c.name;
  }
}

TEST(CloudRegistration, WithoutCovariancesGicpOursIsPlainGicpAndSaysSo) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg");
  const CloudFile source = read_cloud_file(write_pcd_plain(dir / "s.pcd", pair.source));
  const CloudFile target = read_cloud_file(write_pcd_plain(dir / "t.pcd", pair.target));
  const CloudPairRegistration r = register_cloud_files(source, target, Rigid3d::Identity(), default_options());
  EXPECT_EQ(r.method_used, IcpMethod::kGicp);
  EXPECT_THAT(r.covariance_note, HasSubstr("fell back to plain GICP"));
  const Errors e = errors_of(r.target_from_source, pair.target_from_source);
  std::printf("plain GICP (no covariances): %.4f deg, %.3f mm\n", e.rotation_deg, e.translation_mm);
  EXPECT_LT(e.rotation_deg, kMaxRotationDeg);
  EXPECT_LT(e.translation_mm, kMaxTranslationMm);
  // One side with a covariance: gicp-ours, the other side adds none.
  const CloudFile target_cov = read_cloud_file(write_binary_ply_cov(dir / "t.ply", pair.target));
  const CloudPairRegistration mixed = register_cloud_files(source, target_cov, Rigid3d::Identity(), default_options());
  EXPECT_EQ(mixed.method_used, IcpMethod::kGicpMeasured);
  EXPECT_FALSE(mixed.source_covariance);
  EXPECT_TRUE(mixed.target_covariance);
  EXPECT_THAT(mixed.covariance_note, HasSubstr("carries none"));
}

TEST(CloudRegistration, VoxelGridKeepsTheAccuracy) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg");
  const CloudFile source = read_cloud_file(write_binary_ply_cov(dir / "s.ply", pair.source));
  const CloudFile target = read_cloud_file(write_binary_ply_cov(dir / "t.ply", pair.target));
  CloudRegistrationOptions options = default_options();
  options.voxel_m = 0.05;
  const CloudPairRegistration r = register_cloud_files(source, target, Rigid3d::Identity(), options);
  EXPECT_LT(r.source_points, source.points.size() * 6 / 10);
  const Errors e = errors_of(r.target_from_source, pair.target_from_source);
  std::printf("voxel 5 cm (%zu and %zu points): %.4f deg, %.3f mm\n", r.source_points, r.target_points,
              e.rotation_deg, e.translation_mm);
  EXPECT_LT(e.rotation_deg, 2 * kMaxRotationDeg);
  EXPECT_LT(e.translation_mm, 2 * kMaxTranslationMm);
}

TEST(CloudRegistration, RefusalsNameTheFiles) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg");
  const fs::path s = write_binary_ply_cov(dir / "s.ply", pair.source), t = write_binary_ply_cov(dir / "t.ply", pair.target);
  const CloudFile source = read_cloud_file(s), target = read_cloud_file(t);
  // Outside the room (5 m off): nothing to correspond to.
  const Rigid3d outside = make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(5.0, 0.0, 0.0));
  const std::string no_overlap = error_of([&] { register_cloud_files(source, target, outside, default_options()); });
  EXPECT_THAT(no_overlap, HasSubstr(s.string()));
  EXPECT_THAT(no_overlap, HasSubstr(t.string()));
  // 60 degrees and 2 m off: ICP ends in a wrong minimum that still finds walls for more than half of
  // the points (overlap 0.58 against 0.92 at the truth, a box-like room); only a stricter
  // registration.min_fitness tells (see the README: clouds have no feature check).
  const Rigid3d far = make_rigid(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI / 3, Eigen::Vector3d::UnitZ())),
                                 Eigen::Vector3d(2.0, 0.5, 0.0));
  CloudRegistrationOptions strict = default_options();
  strict.min_fitness = 0.8;
  const std::string wrong = error_of([&] { register_cloud_files(source, target, far, strict); });
  EXPECT_THAT(wrong, HasSubstr(s.string()));
  EXPECT_THAT(wrong, HasSubstr("do not overlap"));
  EXPECT_THAT(wrong, HasSubstr("registration.min_fitness 80%"));
  CloudRegistrationOptions def = default_options();
  def.icp.method = IcpMethod::kGicpNoiseModel;
  EXPECT_THAT(error_of([&] { register_cloud_files(source, target, Rigid3d::Identity(), def); }),
              HasSubstr("registration.method"));
  CloudFile tiny = source;
  tiny.points.resize(5);
  tiny.covariances.resize(5);
  const std::string few = error_of([&] { register_cloud_files(tiny, target, Rigid3d::Identity(), default_options()); });
  EXPECT_THAT(few, HasSubstr(s.string()));
  EXPECT_THAT(few, HasSubstr("at least 10"));
}

// ---- The program: JSON, the 4x4 matrix, --initial from a matrix, one-line refusals (exit 2).

Eigen::Matrix4d read_matrix(const fs::path& path) {
  std::ifstream in(path);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> m(r, c);
  EXPECT_TRUE(bool(in)) << path;
  std::string rest;
  in >> rest;
  EXPECT_TRUE(rest.empty()) << "more than 16 numbers in " << path;
  return m;
}

TEST(CloudRegistrationCli, WritesTheJsonAndTheMatrix) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg-cli");
  const fs::path s = write_pcd_cov(dir / "s.pcd", pair.source, true), t = write_binary_ply_cov(dir / "t.ply", pair.target);
  const std::string out = (dir / "reg.json").string();
  const auto run = testutil::run_panoscan("recon register --source " + s.string() + " --target " + t.string() +
                                          " --out " + out + " --threads 2");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("reg.txt"));
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["kind"], "point-clouds");
  EXPECT_EQ(j["method"], "gicp-ours");
  EXPECT_EQ(j["method_used"], "gicp-ours");
  EXPECT_EQ(j["initial"]["kind"], "identity");
  EXPECT_EQ(j["clouds"]["source"]["format"], "pcd binary");
  EXPECT_EQ(j["clouds"]["source"]["viewpoint_from"], "VIEWPOINT");
  EXPECT_EQ(j["clouds"]["target"]["uncertainty_field"], "cov_xx..cov_zz");
  // Where the ICP's time went: its phases, summing to no more than the whole command.
  double phases = 0;
  for (const char* phase : {"setup", "correspondences", "linearisation", "solve"}) {
    ASSERT_TRUE(j["icp"]["seconds"].contains(phase)) << phase;
    EXPECT_GE(j["icp"]["seconds"][phase].get<double>(), 0.0) << phase;
    phases += j["icp"]["seconds"][phase].get<double>();
  }
  EXPECT_GT(phases, 0.0);
  EXPECT_LE(phases, j["seconds"].get<double>());
  EXPECT_EQ(j["icp"]["coarse_levels"], 2);
  const Rigid3d from_json = pose_from_json(j["target_from_source"], out, "target_from_source");
  const Errors e = errors_of(from_json, pair.target_from_source);
  EXPECT_LT(e.rotation_deg, kMaxRotationDeg);
  EXPECT_LT(e.translation_mm, kMaxTranslationMm);
  // The matrix file (default: --out with .txt) holds the same transform: p_target = M p_source.
  const fs::path matrix = dir / "reg.txt";
  ASSERT_TRUE(fs::exists(matrix));
  const Eigen::Matrix4d m = read_matrix(matrix);
  EXPECT_LT((m - from_json.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(m.row(3), Eigen::RowVector4d(0, 0, 0, 1));
  EXPECT_EQ(j["matrix_file"], fs::absolute(matrix).lexically_normal().string());

  // --initial from that matrix, --matrix elsewhere, plain GICP by request: converges at once.
  const auto again = testutil::run_panoscan("recon register --source " + s.string() + " --target " + t.string() +
                                            " --out " + (dir / "again.json").string() + " --matrix " +
                                            (dir / "m.txt").string() + " --initial " + matrix.string() +
                                            " --method gicp --threads 2");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const Eigen::Matrix4d m2 = read_matrix(dir / "m.txt");
  EXPECT_LT((m2.topRightCorner<3, 1>() - m.topRightCorner<3, 1>()).norm(), 2e-3);
  EXPECT_FALSE(fs::exists(dir / "again.txt"));

  // An existing output is kept without --overwrite (also the matrix).
  const auto exists = testutil::run_panoscan("recon register --source " + s.string() + " --target " + t.string() +
                                             " --out " + (dir / "new.json").string() + " --matrix " + matrix.string());
  EXPECT_EQ(exists.exit_code, 2);
  testutil::expect_failure_naming(exists, {matrix.string(), "already exists"});
  EXPECT_FALSE(fs::exists(dir / "new.json"));
}

TEST(CloudRegistrationCli, RefusalsAreOneLineWithExitCode2) {
  const Pair& pair = office_pair();
  testutil::TempDir dir("cloudreg-cli");
  const fs::path s = write_pcd_cov(dir / "s.pcd", pair.source, true), t = write_binary_ply_cov(dir / "t.ply", pair.target);
  auto out = [&](const std::string& name) { return " --out " + (dir / (name + ".json")).string(); };
  // Too little overlap at the end (registration.min_fitness; 60 degrees and 2 m off, see
  // RefusalsNameTheFiles): the result can tell it is wrong.
  std::ofstream(dir / "initial_far.txt") << "0.5 -0.8660254037844386 0 2\n0.8660254037844386 0.5 0 0.5\n0 0 1 0\n0 0 0 1\n";
  const auto far = testutil::run_panoscan("recon register --source " + s.string() + " --target " + t.string() +
                                          out("far") + " --initial " + (dir / "initial_far.txt").string() +
                                          " --set registration.min_fitness=0.8");
  EXPECT_EQ(far.exit_code, 2) << far.output;
  testutil::expect_failure_naming(far, {s.string(), t.string(), "do not overlap"});
  EXPECT_EQ(std::count(far.output.begin(), far.output.end(), '\n'), 1) << far.output;
  EXPECT_FALSE(fs::exists(dir / "far.json"));
  EXPECT_FALSE(fs::exists(dir / "far.txt"));
  // A cloud and a panorama folder.
  fs::create_directories(dir / "pano");
  const auto mixed = testutil::run_panoscan("recon register --source " + s.string() + " --target " +
                                            (dir / "pano").string() + out("mixed"));
  EXPECT_EQ(mixed.exit_code, 2);
  testutil::expect_failure_naming(mixed, {"two of a kind"});
  // A malformed cloud names the file and the field.
  std::ofstream(dir / "bad.pcd") << "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA ascii\n1 2 3\n4 5 x\n";
  const auto bad = testutil::run_panoscan("recon register --source " + (dir / "bad.pcd").string() + " --target " +
                                          t.string() + out("bad"));
  EXPECT_EQ(bad.exit_code, 2);
  testutil::expect_failure_naming(bad, {(dir / "bad.pcd").string(), "line 7 field z", "not a number"});
  // A file that is not a cloud.
  std::ofstream(dir / "notes.xyz") << "1 2 3\n";
  const auto other = testutil::run_panoscan("recon register --source " + (dir / "notes.xyz").string() + " --target " +
                                            t.string() + out("bad"));
  EXPECT_EQ(other.exit_code, 2);
  testutil::expect_failure_naming(other, {"notes.xyz", "neither a panorama folder nor a point-cloud file"});
  // --voxel on panoramas.
  const auto voxel = testutil::run_panoscan("recon register --source " + (dir / "pano").string() + " --target " +
                                            (dir / "pano").string() + out("voxel") + " --voxel 0.01");
  EXPECT_EQ(voxel.exit_code, 2);
  testutil::expect_failure_naming(voxel, {"--voxel"});
}

}  // namespace
}  // namespace panoscan
