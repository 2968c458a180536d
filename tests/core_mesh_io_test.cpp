// Tests of PLY mesh files: exact binary round trip, ASCII and binary files written by other tools
// (extra properties and elements, polygons, doubles, other index types), and bad input rejected
// with an Error that names the file and the element or field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "panoscan/core/error.h"
#include "panoscan/core/mesh_io.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testutil::TempDir;

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <typename T>
void append(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));  // the test machines are little-endian (x86-64, arm64)
  bytes.append(raw, sizeof(T));
}

// Runs `read_ply_mesh(path)` expecting an Error whose message names the file and contains `part`.
void expect_ply_error(const fs::path& path, const std::string& part) {
  try {
    read_ply_mesh(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.filename().string()));
    EXPECT_THAT(e.what(), HasSubstr(part));
  }
}

TriangleMesh small_mesh() {
  TriangleMesh mesh;
  mesh.vertices = {{0.f, 0.f, 0.f}, {1.5f, 0.f, 0.f}, {1.5f, 2.25f, 0.f}, {0.f, 2.25f, 0.f}, {0.1f, -3.f, 1e-7f}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 1, 0}};
  return mesh;
}

TEST(MeshIo, BinaryRoundTripIsExact) {
  TempDir dir("mesh-io");
  const TriangleMesh mesh = small_mesh();
  write_ply_mesh(dir / "mesh.ply", mesh);
  const TriangleMesh read = read_ply_mesh(dir / "mesh.ply");
  ASSERT_EQ(read.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(read.triangles.size(), mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) EXPECT_EQ(read.vertices[i], mesh.vertices[i]);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) EXPECT_EQ(read.triangles[t], mesh.triangles[t]);
  // No temporary file is left beside it.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) files += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1);
}

TEST(MeshIo, WriterRejectsBadMeshes) {
  TempDir dir("mesh-io");
  TriangleMesh mesh = small_mesh();
  mesh.triangles.push_back({0, 1, 7});
  EXPECT_THROW(write_ply_mesh(dir / "bad.ply", mesh), Error);
  mesh = small_mesh();
  mesh.vertices[1].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(write_ply_mesh(dir / "bad.ply", mesh), Error);
  EXPECT_FALSE(fs::exists(dir / "bad.ply"));
}

TEST(MeshIo, ReadsAsciiWithExtraPropertiesPolygonsAndElements) {
  TempDir dir("mesh-io");
  write_bytes(dir / "ascii.ply",
              "ply\r\n"
              "format ascii 1.0\r\n"
              "comment written by hand\r\n"
              "obj_info some tool\r\n"
              "element vertex 5\r\n"
              "property double x\r\n"
              "property float nx\r\n"
              "property double y\r\n"
              "property uchar red\r\n"
              "property double z\r\n"
              "property list uchar float texcoord\r\n"
              "element face 2\r\n"
              "property uchar flags\r\n"
              "property list uchar uint vertex_indices\r\n"
              "property list uchar float texcoord\r\n"
              "element edge 1\r\n"
              "property int vertex1\r\n"
              "property int vertex2\r\n"
              "end_header\r\n"
              "0 0.5 0 255 0 2 0.1 0.2\n"
              "1 0.5 0 0 0 0\n"
              "1 0.5 1 10 0 1 0.7\n"
              "0 0.5 1 20 0 0\n"
              "0.5 0 2.5 30 -1e-3 0\n"
              "7 4 0 1 2 3 8 0 0 1 0 1 1 0 1\n"
              "0 3 4 1 0 0\n"
              "0 1\n");
  const TriangleMesh mesh = read_ply_mesh(dir / "ascii.ply");
  ASSERT_EQ(mesh.vertices.size(), 5u);
  EXPECT_EQ(mesh.vertices[4], Eigen::Vector3f(0.5f, 2.5f, -1e-3f));
  ASSERT_EQ(mesh.triangles.size(), 3u);  // the quad is fan-triangulated
  EXPECT_EQ(mesh.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(mesh.triangles[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(mesh.triangles[2], Eigen::Vector3i(4, 1, 0));
}

TEST(MeshIo, ReadsBinaryWithDoublesAndOtherIndexTypes) {
  TempDir dir("mesh-io");
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\n"
      "element material 1\nproperty float ambient\n"
      "element vertex 3\nproperty short flag\nproperty double x\nproperty double y\nproperty double z\n"
      "property list ushort int extra\n"
      "element face 1\nproperty list ushort uint vertex_index\nproperty double quality\nend_header\n";
  append(bytes, 0.5f);  // material
  const double coordinates[3][3] = {{0.0, 0.0, 0.0}, {2.0, 0.0, 0.0}, {0.0, 3.0, 1.25}};
  for (const auto& c : coordinates) {
    append(bytes, std::int16_t{-2});
    for (double v : c) append(bytes, v);
    append(bytes, std::uint16_t{2});
    append(bytes, std::int32_t{11});
    append(bytes, std::int32_t{12});
  }
  append(bytes, std::uint16_t{3});
  for (std::uint32_t i : {2u, 1u, 0u}) append(bytes, i);
  append(bytes, 0.75);
  write_bytes(dir / "binary.ply", bytes);
  const TriangleMesh mesh = read_ply_mesh(dir / "binary.ply");
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[2], Eigen::Vector3f(0.f, 3.f, 1.25f));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], Eigen::Vector3i(2, 1, 0));
}

TEST(MeshIo, MissingFile) {
  TempDir dir("mesh-io");
  expect_ply_error(dir / "nothing_here.ply", "not found");
}

TEST(MeshIo, MissingMagic) {
  TempDir dir("mesh-io");
  write_bytes(dir / "not_a_ply.ply", "solid cube\nfacet normal 0 0 1\n");
  expect_ply_error(dir / "not_a_ply.ply", "'ply'");
}

TEST(MeshIo, MissingCoordinateProperty) {
  TempDir dir("mesh-io");
  write_bytes(dir / "no_z.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n");
  expect_ply_error(dir / "no_z.ply", "'z'");
}

TEST(MeshIo, MissingFaceElement) {
  TempDir dir("mesh-io");
  write_bytes(dir / "points.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "end_header\n0 0 0\n1 0 0\n0 1 0\n");
  expect_ply_error(dir / "points.ply", "element face");
}

TEST(MeshIo, NoFaces) {
  TempDir dir("mesh-io");
  write_bytes(dir / "empty_faces.ply",
              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n");
  expect_ply_error(dir / "empty_faces.ply", "element face");
}

TEST(MeshIo, IndexOutOfRange) {
  TempDir dir("mesh-io");
  write_bytes(dir / "bad_index.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
              "3 0 1 2\n3 0 1 3\n");
  expect_ply_error(dir / "bad_index.ply", "face 1");
}

TEST(MeshIo, NonFiniteCoordinates) {
  TempDir dir("mesh-io");
  write_bytes(dir / "nan.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  expect_ply_error(dir / "nan.ply", "vertex 1");

  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, std::numeric_limits<float>::infinity(), 0.f, 1.f, 0.f}) append(bytes, v);
  append(bytes, std::uint8_t{3});
  for (std::int32_t i : {0, 1, 2}) append(bytes, i);
  write_bytes(dir / "inf.ply", bytes);
  expect_ply_error(dir / "inf.ply", "vertex 1");
}

TEST(MeshIo, TruncatedData) {
  TempDir dir("mesh-io");
  write_ply_mesh(dir / "whole.ply", small_mesh());
  std::ifstream in(dir / "whole.ply", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  write_bytes(dir / "cut.ply", bytes.substr(0, bytes.size() - 5));
  expect_ply_error(dir / "cut.ply", "truncated");
  write_bytes(dir / "cut_header.ply", bytes.substr(0, 60));
  expect_ply_error(dir / "cut_header.ply", "end_header");
  write_bytes(dir / "cut_ascii.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n");
  expect_ply_error(dir / "cut_ascii.ply", "truncated");
}

TEST(MeshIo, MalformedAsciiNumber) {
  TempDir dir("mesh-io");
  write_bytes(dir / "word.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n");
  expect_ply_error(dir / "word.ply", "vertex 1");
}

}  // namespace
}  // namespace panoscan
