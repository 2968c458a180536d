// Cloud files written by an outside tool: PCL's own PCD writer (ascii, binary, binary_compressed)
// and PLY writer (ASCII and binary, with its camera element and the range grid of an organised
// cloud) read back by read_cloud_file (core/cloud_file.h). PCL appears in this test only.

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>

#include <gtest/gtest.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "panoscan/core/cloud_file.h"
#include "test_util.h"

struct PointWithSigma {
  PCL_ADD_POINT4D;
  float intensity;
  float sigma;
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};
POINT_CLOUD_REGISTER_POINT_STRUCT(PointWithSigma,
                                  (float, x, x)(float, y, y)(float, z, z)(float, intensity, intensity)(float, sigma, sigma))

namespace panoscan {
namespace {

namespace fs = std::filesystem;

// An organised 12 x 9 cloud with every 7th point invalid (NaN), a sensor origin and a sigma field.
pcl::PointCloud<PointWithSigma> organised_cloud() {
  pcl::PointCloud<PointWithSigma> cloud(12, 9);
  cloud.is_dense = false;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    PointWithSigma& p = cloud[i];
    const bool invalid = i % 7 == 3;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    p.x = invalid ? nan : 0.01f * float(i % 12) - 0.05f;
    p.y = invalid ? nan : -0.02f * float(i / 12);
    p.z = invalid ? nan : 1.5f + 0.001f * float(i);
    p.intensity = float(i);
    p.sigma = 0.001f + 1e-5f * float(i);
  }
  cloud.sensor_origin_ = Eigen::Vector4f(0.25f, -0.5f, 1.0f, 0.0f);
  return cloud;
}

// `nan_written`: the file holds the invalid points as NaN (dropped by the reader), not left out.
void expect_same_points(const pcl::PointCloud<PointWithSigma>& written, const CloudFile& read, bool sigma,
                        bool nan_written = true) {
  std::size_t k = 0, invalid = 0;
  for (const PointWithSigma& p : written) {
    if (!std::isfinite(p.x)) {
      ++invalid;
      continue;
    }
    ASSERT_LT(k, read.points.size());
    EXPECT_EQ(read.points[k], Eigen::Vector3d(p.x, p.y, p.z)) << read.path << " point " << k;
    if (sigma) {
      ASSERT_EQ(read.covariances.size(), read.points.size());
      EXPECT_NEAR(read.covariances[k](0, 0), double(p.sigma) * double(p.sigma), 1e-12);
    }
    ++k;
  }
  EXPECT_EQ(k, read.points.size()) << read.path;
  EXPECT_EQ(nan_written ? invalid : 0, read.dropped_invalid) << read.path;
}

TEST(CloudFilePcl, PcdOfEveryDataKindFromPclsWriter) {
  testutil::TempDir dir("cloudfile-pcl");
  const auto cloud = organised_cloud();
  const fs::path ascii = dir / "a.pcd", binary = dir / "b.pcd", compressed = dir / "c.pcd";
  ASSERT_EQ(pcl::io::savePCDFileASCII(ascii.string(), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinary(binary.string(), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(compressed.string(), cloud), 0);
  for (const fs::path& path : {ascii, binary, compressed}) {
    const CloudFile read = read_cloud_file(path);
    EXPECT_EQ(read.declared_points, cloud.size());
    EXPECT_EQ(read.uncertainty, "sigma");
    EXPECT_TRUE(read.has_viewpoint);
    EXPECT_EQ(read.viewpoint, Eigen::Vector3d(0.25, -0.5, 1.0));
    // ASCII is printed with 8 significant digits: float-exact.
    expect_same_points(cloud, read, true);
  }
  EXPECT_EQ(read_cloud_file(ascii).format, "pcd ascii");
  EXPECT_EQ(read_cloud_file(binary).format, "pcd binary");
  EXPECT_EQ(read_cloud_file(compressed).format, "pcd binary_compressed");
}

TEST(CloudFilePcl, PlyWithCameraAndRangeGridFromPclsWriter) {
  testutil::TempDir dir("cloudfile-pcl");
  pcl::PointCloud<pcl::PointXYZRGBNormal> cloud(12, 9);
  cloud.is_dense = false;
  const auto source = organised_cloud();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    auto& p = cloud[i];
    p.x = source[i].x, p.y = source[i].y, p.z = source[i].z;
    p.r = std::uint8_t(i), p.g = 7, p.b = 200;
    p.normal_x = 0, p.normal_y = 0, p.normal_z = 1, p.curvature = 0.5f;
  }
  const fs::path ascii = dir / "a.ply", binary = dir / "b.ply", grid = dir / "grid.ply";
  // With its camera element (and an empty face element): the NaN points are written.
  ASSERT_EQ(pcl::io::savePLYFile(ascii.string(), cloud, false), 0);
  ASSERT_EQ(pcl::io::savePLYFile(binary.string(), cloud, true), 0);
  // Without the camera: an organised cloud's valid points and a range_grid element after them.
  pcl::PCLPointCloud2 blob;
  pcl::toPCLPointCloud2(cloud, blob);
  ASSERT_EQ(pcl::io::savePLYFile(grid.string(), blob, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), true, false),
            0);
  for (const fs::path& path : {ascii, binary, grid}) {
    std::ifstream in(path, std::ios::binary);
    const std::string bytes(std::istreambuf_iterator<char>(in), {});
    const std::string header = bytes.substr(0, bytes.find("end_header"));
    EXPECT_NE(header.find(path == grid ? "element range_grid" : "element camera"), std::string::npos) << header;
    const CloudFile read = read_cloud_file(path);
    EXPECT_EQ(read.uncertainty, "");
    expect_same_points(source, read, false, path != grid);
  }
}

}  // namespace
}  // namespace panoscan
