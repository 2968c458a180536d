// The file-level entry points behind `panoscan eval cloud` and `panoscan eval traj`: exact figures
// from files, the JSON report, the coloured PLY, the config keys, and every bad input named in the
// issue rejected with an Error that names the file.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/point_cloud.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/core/version.h"
#include "panoscan/eval/cloud_evaluation.h"
#include "panoscan/eval/report.h"
#include "panoscan/eval/trajectory_evaluation.h"
#include "test_util.h"

namespace panoscan::eval {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testutil::error_of;

// Closed box [0, 2] x [0, 1] x [0, 1.5].
TriangleMesh box_mesh() {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) mesh.vertices.emplace_back(i & 1 ? 2.f : 0.f, i & 2 ? 1.f : 0.f, i & 4 ? 1.5f : 0.f);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.triangles.emplace_back(q[0], q[1], q[2]);
    mesh.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return mesh;
}

class EvalFiles : public ::testing::Test {
 protected:
  testutil::TempDir dir{"evalfiles"};
  fs::path write_text(const std::string& name, const std::string& text) {
    std::ofstream(dir / name, std::ios::binary) << text;
    return dir / name;
  }
};

TEST_F(EvalFiles, CloudAgainstMeshFromFiles) {
  write_ply_mesh(dir / "gt.ply", box_mesh());
  PointCloud cloud;
  // Known distances 0.3, 0.25, 0.5 (edge), 0.3 (corner), 0.2 (inside).
  cloud.positions = {{1.0, 0.5, 1.8}, {2.25, 0.5, 0.7}, {2.3, 0.5, 1.9}, {-0.1, -0.2, -0.2}, {0.2, 0.5, 0.75}};
  cloud.colours.assign(5, Rgb8{1, 2, 3});
  cloud.variances.assign(5, 1e-6f);
  PlyWriteOptions ply;
  ply.double_positions = true;
  write_ply_point_cloud(dir / "rec.ply", cloud, ply);

  CloudEvalOptions options;
  options.metrics.completeness.samples_per_m2 = 500;
  options.coloured_ply = dir / "rec_error.ply";
  options.colouring.max_m = 0.5;
  const CloudEvalReport report = evaluate_cloud_files(dir / "gt.ply", dir / "rec.ply", options);
  const double rmse = std::sqrt((0.09 + 0.0625 + 0.25 + 0.09 + 0.04) / 5);
  EXPECT_NEAR(report.metrics.accuracy_m.rmse, rmse, 1e-6);  // float vertices, exact offsets
  EXPECT_EQ(report.cloud_points, 5u);
  EXPECT_TRUE(report.cloud_has_colours);
  EXPECT_TRUE(report.cloud_has_variances);
  EXPECT_EQ(report.mesh_triangles, 12u);
  EXPECT_NEAR(report.mesh_area_m2, 13.0, 1e-9);
  EXPECT_TRUE(report.metrics.has_completeness);
  EXPECT_EQ(report.metrics.surface_samples, 6500u);

  const PointCloud coloured = read_ply_point_cloud(dir / "rec_error.ply");
  EXPECT_EQ(coloured.size(), 5u);
  EXPECT_EQ(coloured.colours[2], colour_at(ColourMap::kViridis, 1.0));

  const std::string text = cloud_report_to_text(report);
  char expected[64];
  std::snprintf(expected, sizeof expected, "RMSE %.3f mm", 1e3 * rmse);
  EXPECT_THAT(text, HasSubstr(expected));
  const nlohmann::json json = nlohmann::json::parse(cloud_report_to_json(report));
  EXPECT_EQ(json["kind"], "cloud_evaluation");
  EXPECT_EQ(json["panoscan_version"], project_version());
  EXPECT_EQ(json.at("source_revision"), source_revision());
  EXPECT_NEAR(json["accuracy"]["rmse_m"].get<double>(), rmse, 1e-6);
  EXPECT_NEAR(json["accuracy"]["rmse_mm"].get<double>(), 1e3 * rmse, 1e-3);
  EXPECT_EQ(json["settings"]["thresholds_m"].size(), 3u);
  EXPECT_EQ(json["scores"].size(), 3u);
  EXPECT_EQ(json["histograms"]["accuracy"]["counts"].size(), 100u);
  EXPECT_TRUE(json["accuracy_within_cutoff"].is_null());
  EXPECT_EQ(json["coloured_ply"]["range_m"][1], 0.5);
}

TEST_F(EvalFiles, WarnsWhenMostPointsAreFarFromTheMesh) {
  // Points on the box's floor, then the same points 0.4 m off (a cloud in another frame).
  write_ply_mesh(dir / "gt.ply", box_mesh());
  PointCloud on_surface, shifted;
  for (int i = 0; i < 20; ++i) {
    on_surface.positions.emplace_back(0.1 + 0.09 * i, 0.5, 0.001 * (i % 3));
    shifted.positions.push_back(on_surface.positions.back() + Eigen::Vector3d(0.0, 0.0, 0.4));
  }
  write_ply_point_cloud(dir / "near.ply", on_surface);
  write_ply_point_cloud(dir / "far.ply", shifted);
  CloudEvalOptions options;
  options.metrics.completeness.enabled = false;
  const CloudEvalReport near = evaluate_cloud_files(dir / "gt.ply", dir / "near.ply", options);
  EXPECT_TRUE(near.warnings.empty());
  const CloudEvalReport far = evaluate_cloud_files(dir / "gt.ply", dir / "far.ply", options);
  ASSERT_EQ(far.warnings.size(), 1u);
  EXPECT_THAT(far.warnings[0], HasSubstr((dir / "far.ply").string()));
  EXPECT_THAT(far.warnings[0], HasSubstr("mesh's frame"));
  EXPECT_THAT(cloud_report_to_text(far), HasSubstr("warning: "));
  EXPECT_EQ(nlohmann::json::parse(cloud_report_to_json(far))["warnings"].size(), 1u);
}

TEST_F(EvalFiles, ViewpointsFromTrajectories) {
  write_ply_mesh(dir / "gt.ply", box_mesh());
  PointCloud cloud;
  cloud.positions = {{1.0, 0.5, 0.0}};
  write_ply_point_cloud(dir / "rec.ply", cloud);
  std::vector<StampedPose> poses(3);
  for (int i = 0; i < 3; ++i) {
    poses[i].timestamp = i;
    poses[i].world_from_cam.translation() = Eigen::Vector3d(0.9 + 0.1 * i, 0.5, 0.75);
  }
  write_tum_trajectory(dir / "cam0.txt", poses);
  CloudEvalOptions options;
  options.metrics.completeness.samples_per_m2 = 200;
  options.viewpoint_trajectories = {dir / "cam0.txt"};
  const CloudEvalReport report = evaluate_cloud_files(dir / "gt.ply", dir / "rec.ply", options);
  const auto& viewpoints = report.options.metrics.completeness.visibility.viewpoints;
  ASSERT_EQ(viewpoints.size(), 1u);
  EXPECT_TRUE(viewpoints[0].isApprox(Eigen::Vector3d(1.0, 0.5, 0.75)));
  EXPECT_EQ(report.metrics.visible_samples, report.metrics.surface_samples);  // inside a closed box
}

TEST_F(EvalFiles, BadCloudInputNamesTheFile) {
  write_ply_mesh(dir / "gt.ply", box_mesh());
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const fs::path empty = write_text("empty.ply", "ply\nformat ascii 1.0\nelement vertex 0\n" + xyz + "end_header\n");
  const fs::path nan =
      write_text("nan.ply", "ply\nformat ascii 1.0\nelement vertex 2\n" + xyz + "end_header\n1 2 3\n1 nan 3\n");
  const fs::path no_z = write_text("no_z.ply",
                                   "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                   "property float y\nend_header\n1 2\n");
  const fs::path no_triangles =
      write_text("no_triangles.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz +
                                         "element face 0\nproperty list uchar int vertex_indices\n"
                                         "end_header\n0 0 0\n1 0 0\n0 1 0\n");
  const fs::path points_only =
      write_text("points_only.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" + xyz + "end_header\n0 0 0\n");
  for (const fs::path& cloud : {empty, nan, no_z, dir / "absent.ply"}) {
    const std::string message = error_of([&] { evaluate_cloud_files(dir / "gt.ply", cloud); });
    EXPECT_THAT(message, HasSubstr(cloud.string()));
  }
  EXPECT_THAT(error_of([&] { evaluate_cloud_files(dir / "gt.ply", empty); }), HasSubstr("no points"));
  EXPECT_THAT(error_of([&] { evaluate_cloud_files(dir / "gt.ply", no_z); }), HasSubstr("property z"));
  for (const fs::path& mesh : {no_triangles, points_only, dir / "absent_mesh.ply"}) {
    const std::string message = error_of([&] { evaluate_cloud_files(mesh, points_only); });
    EXPECT_THAT(message, HasSubstr(mesh.string()));
  }
}

TEST_F(EvalFiles, TrajectoryFiles) {
  std::vector<StampedPose> gt, est;
  for (int i = 0; i < 90; ++i) {
    StampedPose pose;
    pose.timestamp = 10.0 + i / 30.0;
    pose.world_from_cam = make_rigid(so3_exp(Eigen::Vector3d(0, 0, 0.05 * i)),
                                     Eigen::Vector3d(std::cos(0.05 * i), std::sin(0.05 * i), 1.0));
    gt.push_back(pose);
    pose.world_from_cam.translation().z() += (i % 2 ? -0.002 : 0.002);
    est.push_back(pose);
  }
  write_tum_trajectory(dir / "gt.txt", gt);
  write_tum_trajectory(dir / "est.txt", est);
  const TrajectoryEvalReport report = evaluate_trajectory_files(dir / "gt.txt", dir / "est.txt");
  EXPECT_EQ(report.metrics.matched_poses, 90u);
  EXPECT_NEAR(report.metrics.ate_m.rmse, 0.002, 2e-4);
  EXPECT_THAT(trajectory_report_to_text(report), HasSubstr("ATE"));
  const nlohmann::json json = nlohmann::json::parse(trajectory_report_to_json(report));
  EXPECT_EQ(json["kind"], "trajectory_evaluation");
  EXPECT_EQ(json["matched"]["gt_positions"].size(), 90u);
  EXPECT_NEAR(json["ate"]["rmse_m"].get<double>(), report.metrics.ate_m.rmse, 1e-12);
  write_report(dir / "out" / "traj.json", trajectory_report_to_json(report));
  EXPECT_TRUE(fs::exists(dir / "out" / "traj.json"));

  // No common timestamps: both files named.
  for (auto& pose : est) pose.timestamp += 0.5 / 30.0;
  write_tum_trajectory(dir / "shifted.txt", est);
  const std::string message = error_of([&] { evaluate_trajectory_files(dir / "gt.txt", dir / "shifted.txt"); });
  EXPECT_THAT(message, HasSubstr((dir / "gt.txt").string()));
  EXPECT_THAT(message, HasSubstr((dir / "shifted.txt").string()));
  EXPECT_THAT(error_of([&] { evaluate_trajectory_files(dir / "gt.txt", dir / "absent.txt"); }),
              HasSubstr("absent.txt"));
  const fs::path empty = write_text("empty.txt", "# nothing\n");
  EXPECT_THAT(error_of([&] { evaluate_trajectory_files(dir / "gt.txt", empty); }), HasSubstr("empty.txt"));
}

TEST_F(EvalFiles, OptionsFromConfig) {
  Config config = Config::from_string(
      "thresholds_m: [0.005, 0.01]\noutlier_cutoff_m: 0.1\ncompleteness:\n  samples_per_m2: 1000\n"
      "visibility:\n  viewpoints: [1, 2, 1.2, 3, 4, 1.2]\n  max_abs_elevation_deg: 67.5\n"
      "colour:\n  map: turbo\n  range_m: [0, 0.02]\n",
      "eval.yaml");
  const CloudEvalOptions options = cloud_eval_options_from_config(config);
  config.check_all_used();
  EXPECT_EQ(options.metrics.thresholds_m, (std::vector<double>{0.005, 0.01}));
  EXPECT_EQ(options.metrics.outlier_cutoff_m, 0.1);
  EXPECT_EQ(options.metrics.completeness.samples_per_m2, 1000);
  ASSERT_EQ(options.metrics.completeness.visibility.viewpoints.size(), 2u);
  EXPECT_EQ(options.metrics.completeness.visibility.viewpoints[1], Eigen::Vector3d(3, 4, 1.2));
  EXPECT_EQ(options.metrics.completeness.visibility.max_abs_elevation_deg, 67.5);
  EXPECT_EQ(options.colouring.map, ColourMap::kTurbo);
  EXPECT_EQ(options.colouring.max_m, 0.02);

  Config bad = Config::from_string("visibility:\n  viewpoints: [1, 2]\n", "bad.yaml");
  EXPECT_THAT(error_of([&] { cloud_eval_options_from_config(bad); }), HasSubstr("bad.yaml"));
  Config negative = Config::from_string("thresholds_m: [0.01, -0.02]\n", "neg.yaml");
  EXPECT_THAT(error_of([&] { cloud_eval_options_from_config(negative); }), HasSubstr("thresholds_m"));

  Config traj = Config::from_string("rpe_delta_s: 0.5\nalign: false\n", "traj.yaml");
  const TrajectoryEvalOptions t = trajectory_eval_options_from_config(traj);
  EXPECT_EQ(t.metrics.rpe_delta_s, 0.5);
  EXPECT_FALSE(t.metrics.align);
}

}  // namespace
}  // namespace panoscan::eval
