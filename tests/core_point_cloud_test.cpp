// PLY point clouds: exact round trips of every optional attribute, ASCII and binary input with
// extra elements and properties, a mesh PLY read as its vertices, and every kind of bad file
// rejected with an Error naming the file (and the property or vertex).

#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/point_cloud.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testutil::error_of;
using testutil::write_bytes;


// Points with float-representable coordinates so that a float PLY round trip is exact.
PointCloud make_cloud(std::size_t n, bool normals, bool colours, bool variances) {
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.emplace_back(0.25 * i, -1.5 + 0.125 * i, 3.0 - 0.0625 * i);
    if (normals) cloud.normals.push_back(Eigen::Vector3f(1.f, 2.f, float(i)).normalized());
    if (colours) cloud.colours.push_back({std::uint8_t(i), std::uint8_t(255 - i), std::uint8_t(7 * i)});
    if (variances) cloud.variances.push_back(1e-6f * float(i + 1));
  }
  return cloud;
}

void expect_equal(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.normals.size(), b.normals.size());
  ASSERT_EQ(a.colours.size(), b.colours.size());
  ASSERT_EQ(a.variances.size(), b.variances.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.positions[i], b.positions[i]) << "point " << i;
    if (a.has_normals()) {
      EXPECT_EQ(a.normals[i], b.normals[i]);
    }
    if (a.has_colours()) {
      EXPECT_EQ(a.colours[i], b.colours[i]);
    }
    if (a.has_variances()) {
      EXPECT_EQ(a.variances[i], b.variances[i]);
    }
  }
}

TEST(PointCloudIo, BinaryRoundTripWithEveryAttribute) {
  testutil::TempDir dir("pcio");
  const PointCloud cloud = make_cloud(50, true, true, true);
  write_ply_point_cloud(dir / "cloud.ply", cloud);
  expect_equal(cloud, read_ply_point_cloud(dir / "cloud.ply"));
  // Only the final file is left: the write went through a temporary name.
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "cloud.ply");
  }
  EXPECT_EQ(files, 1u);
}

TEST(PointCloudIo, PositionsOnlyAndDoublePrecision) {
  testutil::TempDir dir("pcio");
  PointCloud cloud;
  cloud.positions = {{0.1, 0.2, 0.3}, {1.0 / 3.0, -2.0 / 7.0, 1e-9}};
  PlyWriteOptions options;
  options.double_positions = true;
  write_ply_point_cloud(dir / "d.ply", cloud, options);
  const PointCloud back = read_ply_point_cloud(dir / "d.ply");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.positions[1], cloud.positions[1]);  // bit-exact with double
  EXPECT_FALSE(back.has_colours());
  EXPECT_FALSE(back.has_variances());
  EXPECT_FALSE(back.has_normals());
  // With float positions the error is float rounding only.
  write_ply_point_cloud(dir / "f.ply", cloud);
  const PointCloud rounded = read_ply_point_cloud(dir / "f.ply");
  EXPECT_NEAR((rounded.positions[1] - cloud.positions[1]).norm(), 0.0, 1e-7);
}

TEST(PointCloudIo, ExtraPropertiesAndCommentsAreWritten) {
  testutil::TempDir dir("pcio");
  const PointCloud cloud = make_cloud(3, false, true, false);
  PlyWriteOptions options;
  options.comments = {"hello world"};
  options.extra_properties.emplace_back("distance", std::vector<float>{0.5f, 1.5f, 2.5f});
  write_ply_point_cloud(dir / "e.ply", cloud, options);
  std::ifstream in(dir / "e.ply", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(bytes, HasSubstr("comment hello world\n"));
  EXPECT_THAT(bytes, HasSubstr("property float distance\n"));
  expect_equal(cloud, read_ply_point_cloud(dir / "e.ply"));  // unknown properties are skipped
  options.extra_properties[0].second.pop_back();
  EXPECT_THAT(error_of([&] { write_ply_point_cloud(dir / "bad.ply", cloud, options); }), HasSubstr("distance"));
  EXPECT_FALSE(fs::exists(dir / "bad.ply"));
}

TEST(PointCloudIo, AsciiWithOtherElementsAndProperties) {
  testutil::TempDir dir("pcio");
  const fs::path path = write_bytes(dir / "a.ply",
                                    "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
                                    "element camera 1\r\nproperty float view_x\r\nproperty list uchar int ids\r\n"
                                    "element vertex 2\r\nproperty double x\r\nproperty float confidence\r\n"
                                    "property double y\r\nproperty double z\r\nproperty uchar red\r\n"
                                    "property uchar green\r\nproperty uchar blue\r\nproperty float variance\r\n"
                                    "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
                                    "1.5 3 7 8 9\r\n"
                                    "0.5 0.9 -1.25 2e-3 10 20 30 0.0001\r\n"
                                    "1 1 2 3 255 0 128 0\r\n"
                                    "3 0 1 1\r\n");
  const PointCloud cloud = read_ply_point_cloud(path);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.positions[0], Eigen::Vector3d(0.5, -1.25, 2e-3));
  EXPECT_EQ(cloud.positions[1], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(cloud.colours[0], (Rgb8{10, 20, 30}));
  EXPECT_EQ(cloud.colours[1], (Rgb8{255, 0, 128}));
  EXPECT_FLOAT_EQ(cloud.variances[0], 1e-4f);
}

// Big-endian bytes of a value, built by shifts (independent of the host).
template <class T>
std::string big_endian(T value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(T));
  std::string out;
  for (int k = int(sizeof(T)) - 1; k >= 0; --k) out.push_back(char((bits >> (8 * k)) & 0xFF));
  return out;
}

TEST(PointCloudIo, BigEndianWithMixedTypesAndAnElementBefore) {
  testutil::TempDir dir("pcio");
  std::string bytes =
      "ply\nformat binary_big_endian 1.0\nelement range_grid 2\nproperty list uchar int vertex_indices\n"
      "element vertex 2\nproperty double x\nproperty short intensity\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty double variance\nend_header\n";
  bytes += big_endian<std::uint8_t>(1) + big_endian<std::int32_t>(0) + big_endian<std::uint8_t>(0);
  bytes += big_endian(0.125) + big_endian<std::int16_t>(-300) + big_endian(-2.5f) + big_endian(3.75f) +
           std::string("\x0a\x14\x1e") + big_endian(1e-4);
  bytes += big_endian(-7.0) + big_endian<std::int16_t>(12) + big_endian(0.5f) + big_endian(1e3f) +
           std::string("\xff\x00\x80", 3) + big_endian(0.0);
  const PointCloud cloud = read_ply_point_cloud(write_bytes(dir / "be.ply", bytes));
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.positions[0], Eigen::Vector3d(0.125, -2.5, 3.75));
  EXPECT_EQ(cloud.positions[1], Eigen::Vector3d(-7, 0.5, 1000));
  EXPECT_EQ(cloud.colours[0], (Rgb8{10, 20, 30}));
  EXPECT_EQ(cloud.colours[1], (Rgb8{255, 0, 128}));
  EXPECT_FLOAT_EQ(cloud.variances[0], 1e-4f);
  // Cut inside the second vertex: truncated, naming it.
  const fs::path cut = write_bytes(dir / "cut.ply", bytes.substr(0, bytes.size() - 10));
  const std::string message = error_of([&] { read_ply_point_cloud(cut); });
  EXPECT_THAT(message, HasSubstr(cut.string()));
  EXPECT_THAT(message, HasSubstr("vertex 1"));
  EXPECT_THAT(message, HasSubstr("truncated"));
}

TEST(PointCloudIo, MeshFileReadsAsItsVertices) {
  testutil::TempDir dir("pcio");
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 1, 2}, {0, 1, 3}};
  write_ply_mesh(dir / "mesh.ply", mesh);
  const PointCloud cloud = read_ply_point_cloud(dir / "mesh.ply");
  ASSERT_EQ(cloud.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(cloud.positions[i], mesh.vertices[i].cast<double>());
}

TEST(PointCloudIo, ZeroVerticesReadAsAnEmptyCloud) {
  testutil::TempDir dir("pcio");
  const fs::path path = write_bytes(dir / "empty.ply",
                                    "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n");
  EXPECT_TRUE(read_ply_point_cloud(path).empty());
}

TEST(PointCloudIo, BadFilesNameTheFileAndTheField) {
  testutil::TempDir dir("pcio");
  const std::string header_xyz = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
  struct Case {
    std::string name, bytes, field;
  };
  const std::vector<Case> cases = {
      {"not_ply.ply", "hello\nworld\n", "not a PLY"},
      {"no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", "end_header"},
      {"big_endian.ply", "ply\nformat binary_big_endian 1.0\n" + header_xyz + "end_header\n", "truncated"},
      {"no_vertex.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
       "vertex"},
      {"missing_z.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n", "property z"},
      {"partial_colour.ply",
       "ply\nformat ascii 1.0\n" + header_xyz + "property uchar red\nproperty uchar green\nend_header\n1 2 3 4 5\n",
       "property blue"},
      {"float_colour.ply",
       "ply\nformat ascii 1.0\n" + header_xyz +
           "property float red\nproperty float green\nproperty float blue\nend_header\n1 2 3 0.1 0.2 0.3\n",
       "uchar"},
      {"nan.ply", "ply\nformat ascii 1.0\n" + header_xyz + "end_header\n1 nan 3\n", "vertex 0"},
      {"word.ply", "ply\nformat ascii 1.0\n" + header_xyz + "end_header\n1 two 3\n", "'two' is not a number"},
      {"short_ascii.ply", "ply\nformat ascii 1.0\n" + header_xyz + "end_header\n1 2\n", "truncated"},
      {"short_binary.ply",
       "ply\nformat binary_little_endian 1.0\n" + header_xyz + "end_header\n" + std::string(8, '\0'), "truncated"},
      {"huge_count.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n" +
           std::string(12, '\0'),
       "too short"},
      {"negative_variance.ply",
       "ply\nformat ascii 1.0\n" + header_xyz + "property float variance\nend_header\n1 2 3 -1\n", "variance"},
      {"bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n", "quad"},
  };
  for (const Case& c : cases) {
    const fs::path path = write_bytes(dir / c.name, c.bytes);
    const std::string message = error_of([&] { read_ply_point_cloud(path); });
    EXPECT_THAT(message, HasSubstr(path.string())) << c.name;
    EXPECT_THAT(message, HasSubstr(c.field)) << c.name;
  }
  const std::string missing = error_of([&] { read_ply_point_cloud(dir / "absent.ply"); });
  EXPECT_THAT(missing, HasSubstr("absent.ply"));
  EXPECT_THAT(missing, HasSubstr("not found"));
}

TEST(PointCloudIo, WriterRefusesInconsistentClouds) {
  testutil::TempDir dir("pcio");
  PointCloud cloud = make_cloud(4, false, true, false);
  cloud.colours.pop_back();
  EXPECT_THAT(error_of([&] { write_ply_point_cloud(dir / "x.ply", cloud); }), HasSubstr("colours"));
  cloud = make_cloud(4, false, false, false);
  cloud.positions[2].y() = std::nan("");
  EXPECT_THAT(error_of([&] { write_ply_point_cloud(dir / "x.ply", cloud); }), HasSubstr("point 2"));
  EXPECT_FALSE(fs::exists(dir / "x.ply"));
}

}  // namespace
}  // namespace panoscan
