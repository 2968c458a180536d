// Point-cloud files of outside tools (core/cloud_file.h): PLY (ASCII, little- and big-endian, extra
// elements and properties) and PCD (ASCII, binary, binary_compressed; any SIZE/TYPE/COUNT), the
// uncertainty fields, NaN points, and every kind of bad file refused with an Error naming the file
// and the field, line or point.

#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/cloud_file.h"
#include "panoscan/core/error.h"
#include "panoscan/core/point_cloud.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testutil::error_of;
using testutil::write_bytes;


template <class T>
std::string little_endian(T value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(T));
  std::string out;
  for (std::size_t k = 0; k < sizeof(T); ++k) out.push_back(char((bits >> (8 * k)) & 0xFF));
  return out;
}

// An LZF stream of `data` (liblzf's format): greedy back references to the previous 8 KiB, literals
// otherwise. Slow (quadratic), for test sizes only; enough to exercise every code of the decoder.
std::string lzf_compress(const std::string& data) {
  std::string out, literal;
  auto flush = [&] {
    for (std::size_t start = 0; start < literal.size(); start += 32) {
      const std::size_t n = std::min<std::size_t>(32, literal.size() - start);
      out.push_back(char(n - 1));
      out += literal.substr(start, n);
    }
    literal.clear();
  };
  std::size_t i = 0;
  while (i < data.size()) {
    std::size_t best_length = 0, best_back = 0;
    const std::size_t window = std::min<std::size_t>(i, 8192);
    for (std::size_t back = 1; back <= window; ++back) {
      std::size_t length = 0;
      while (i + length < data.size() && length < 264 && data[i + length] == data[i - back + length]) ++length;
      if (length > best_length) best_length = length, best_back = back;
    }
    if (best_length < 3) {
      literal.push_back(data[i++]);
      continue;
    }
    flush();
    const std::size_t length = best_length - 2, offset = best_back - 1;
    if (length < 7) {
      out.push_back(char((length << 5) | (offset >> 8)));
    } else {
      out.push_back(char((7 << 5) | (offset >> 8)));
      out.push_back(char(length - 7));
    }
    out.push_back(char(offset & 0xFF));
    i += best_length;
  }
  flush();
  return out;
}

void expect_error(const fs::path& path, const std::vector<std::string>& needles) {
  const std::string message = error_of([&] { read_cloud_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string())) << path.filename();
  for (const auto& needle : needles) EXPECT_THAT(message, HasSubstr(needle)) << path.filename();
}

TEST(CloudFile, ExtensionDecides) {
  EXPECT_TRUE(is_cloud_file_path("a/b.PLY"));
  EXPECT_TRUE(is_cloud_file_path("scan.pcd"));
  EXPECT_FALSE(is_cloud_file_path("panorama_dir"));
  EXPECT_FALSE(is_cloud_file_path("x.obj"));
  testutil::TempDir dir("cloudfile");
  expect_error(write_bytes(dir / "cloud.xyz", "1 2 3\n"), {"extension", ".pcd"});
  expect_error(dir / "absent.pcd", {"not found"});
}

TEST(CloudFile, AsciiPlyWithExtraElementsAndPropertiesAndCovariances) {
  testutil::TempDir dir("cloudfile");
  // Float colours, intensity, normals, a list property and two other elements: all skipped.
  const std::string path = write_bytes(dir / "a.ply",
                                       "ply\nformat ascii 1.0\ncomment by hand\n"
                                       "element camera 1\nproperty float view_px\nproperty list uchar int ids\n"
                                       "element vertex 3\nproperty float x\nproperty double y\nproperty float z\n"
                                       "property float nx\nproperty float ny\nproperty float nz\n"
                                       "property float red\nproperty float green\nproperty float blue\n"
                                       "property ushort intensity\nproperty list uchar float extra\n"
                                       "property float cov_xx\nproperty float cov_xy\nproperty float cov_xz\n"
                                       "property float cov_yy\nproperty float cov_yz\nproperty float cov_zz\n"
                                       "element range_grid 4\nproperty list uchar int vertex_indices\n"
                                       "end_header\n"
                                       "1.5 2 7 8\n"
                                       "1 2 3 0 0 1 0.1 0.2 0.3 100 2 0.5 0.5 4e-6 1e-6 0 3e-6 0 2e-6\n"
                                       "nan 2 3 0 0 1 0.1 0.2 0.3 100 0 1 0 0 1 0 1\n"
                                       "-1 -2 -3 0 0 1 0.1 0.2 0.3 100 1 9 1e-6 0 0 1e-6 0 1e-6\n"
                                       "1 0\n0\n1 2\n0\n")
                                 .string();
  const CloudFile cloud = read_cloud_file(path);
  EXPECT_EQ(cloud.format, "ply ascii");
  EXPECT_EQ(cloud.declared_points, 3u);
  EXPECT_EQ(cloud.dropped_invalid, 1u);  // the NaN vertex
  ASSERT_EQ(cloud.points.size(), 2u);
  EXPECT_EQ(cloud.points[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(cloud.uncertainty, "cov_xx..cov_zz");
  ASSERT_EQ(cloud.covariances.size(), 2u);
  EXPECT_FLOAT_EQ(float(cloud.covariances[0](0, 0)), 4e-6f);
  EXPECT_FLOAT_EQ(float(cloud.covariances[0](1, 0)), 1e-6f);
  EXPECT_FLOAT_EQ(float(cloud.covariances[0](0, 1)), 1e-6f);
  EXPECT_FLOAT_EQ(float(cloud.covariances[0](2, 2)), 2e-6f);
  EXPECT_FALSE(cloud.has_viewpoint);
}

TEST(CloudFile, PlyVarianceAndSigmaAreIsotropic) {
  testutil::TempDir dir("cloudfile");
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
  const CloudFile v = read_cloud_file(
      write_bytes(dir / "v.ply", head + "property double variance\nend_header\n0 0 0 1e-6\n1 1 1 4e-6\n"));
  EXPECT_EQ(v.uncertainty, "variance");
  EXPECT_EQ(v.covariances[1], Eigen::Matrix3d::Identity() * 4e-6);
  const CloudFile s =
      read_cloud_file(write_bytes(dir / "s.ply", head + "property float sigma\nend_header\n0 0 0 0.001\n1 1 1 0.002\n"));
  EXPECT_EQ(s.uncertainty, "sigma");
  EXPECT_NEAR(s.covariances[1](1, 1), 4e-6, 1e-12);
  EXPECT_EQ(s.covariances[1](0, 1), 0.0);
  const CloudFile none = read_cloud_file(write_bytes(dir / "n.ply", head + "end_header\n0 0 0\n1 1 1\n"));
  EXPECT_EQ(none.uncertainty, "");
  EXPECT_TRUE(none.covariances.empty());
}

TEST(CloudFile, BinaryPlyOfEitherByteOrder) {
  testutil::TempDir dir("cloudfile");
  PointCloud cloud;
  for (int i = 0; i < 20; ++i) cloud.positions.emplace_back(0.5 * i, -0.25 * i, 1.0 + i);
  cloud.variances.assign(20, 1e-6f);
  write_ply_point_cloud(dir / "le.ply", cloud);
  const CloudFile le = read_cloud_file(dir / "le.ply");
  EXPECT_EQ(le.format, "ply binary_little_endian");
  ASSERT_EQ(le.points.size(), 20u);
  EXPECT_EQ(le.points[7], cloud.positions[7]);
  EXPECT_EQ(le.uncertainty, "variance");
  std::string be = "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty double x\nproperty int y\n"
                   "property float z\nend_header\n";
  auto big = [](auto value) {
    std::string s = little_endian(value);
    return std::string(s.rbegin(), s.rend());
  };
  be += big(1.25) + big(std::int32_t(-3)) + big(2.5f) + big(-1.0) + big(std::int32_t(7)) + big(0.125f);
  const CloudFile b = read_cloud_file(write_bytes(dir / "be.ply", be));
  EXPECT_EQ(b.format, "ply binary_big_endian");
  ASSERT_EQ(b.points.size(), 2u);
  EXPECT_EQ(b.points[0], Eigen::Vector3d(1.25, -3, 2.5));
  EXPECT_EQ(b.points[1], Eigen::Vector3d(-1, 7, 0.125));
}

const char* kPcdHeaderAscii =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z rgb normal_x normal_y normal_z histogram variance intensity\n"
    "SIZE 4 4 4 4 4 4 4 4 8 2\n"
    "TYPE F F F F F F F F F U\n"
    "COUNT 1 1 1 1 1 1 1 3 1 1\n"
    "WIDTH 2\n"
    "HEIGHT 2\n"
    "VIEWPOINT 0.5 -1 2 1 0 0 0\n"
    "POINTS 4\n"
    "DATA ascii\n";

TEST(CloudFile, AsciiPcdWithOtherFieldsCountsAndViewpoint) {
  testutil::TempDir dir("cloudfile");
  const std::string body =
      "1 2 3 4.2108e+06 0 0 1 1 2 3 1e-6 17\n"
      "nan nan nan 0 nan nan nan 0 0 0 0 0\n"
      "\n"
      "-0.5 +0.25 1e1 0 0 1 0 0 0 0 2.5e-5 65535\r\n"
      "4 5 6 0 0 0 1 0 0 0 0 0";  // no final newline
  const CloudFile cloud = read_cloud_file(write_bytes(dir / "a.pcd", kPcdHeaderAscii + body));
  EXPECT_EQ(cloud.format, "pcd ascii");
  EXPECT_EQ(cloud.declared_points, 4u);
  EXPECT_EQ(cloud.dropped_invalid, 1u);
  ASSERT_EQ(cloud.points.size(), 3u);
  EXPECT_EQ(cloud.points[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(-0.5, 0.25, 10));
  EXPECT_EQ(cloud.uncertainty, "variance");
  EXPECT_EQ(cloud.covariances[1], Eigen::Matrix3d::Identity() * 2.5e-5);
  EXPECT_TRUE(cloud.has_viewpoint);
  EXPECT_EQ(cloud.viewpoint, Eigen::Vector3d(0.5, -1, 2));
}

// A PCD of `n` points with fields x (F8), pad (U1, COUNT 3), y (F4), label (I2), z (F4), sigma (F4).
std::string binary_pcd(int n, const std::string& data_kind, std::string* records, std::string* by_field) {
  std::string header = "VERSION .7\nFIELDS x _ y label z sigma\nSIZE 8 1 4 2 4 4\nTYPE F U F I F F\n"
                       "COUNT 1 3 1 1 1 1\nWIDTH " +
                       std::to_string(n) + "\nHEIGHT 1\nPOINTS " + std::to_string(n) + "\nDATA " + data_kind + "\n";
  std::vector<std::string> fields(6);
  records->clear();
  for (int i = 0; i < n; ++i) {
    const std::string x = little_endian(0.001 * i), pad = std::string(3, char(i)), y = little_endian(float(-0.5 * i)),
                      label = little_endian(std::int16_t(-i)), z = little_endian(float(2.0 + 0.25 * i)),
                      sigma = little_endian(0.002f);
    *records += x + pad + y + label + z + sigma;
    fields[0] += x, fields[1] += pad, fields[2] += y, fields[3] += label, fields[4] += z, fields[5] += sigma;
  }
  by_field->clear();
  for (const auto& f : fields) *by_field += f;
  return header;
}

TEST(CloudFile, BinaryAndCompressedPcdWithMixedSizesAndTypes) {
  testutil::TempDir dir("cloudfile");
  std::string records, by_field;
  const std::string header = binary_pcd(300, "binary", &records, &by_field);
  const CloudFile b = read_cloud_file(write_bytes(dir / "b.pcd", header + records));
  EXPECT_EQ(b.format, "pcd binary");
  ASSERT_EQ(b.points.size(), 300u);
  EXPECT_EQ(b.points[299], Eigen::Vector3d(0.001 * 299, double(float(-0.5 * 299)), double(float(2.0 + 0.25 * 299))));
  EXPECT_EQ(b.uncertainty, "sigma");
  EXPECT_NEAR(b.covariances[5](2, 2), 4e-6, 1e-12);
  EXPECT_FALSE(b.has_viewpoint);

  const std::string compressed_header = binary_pcd(300, "binary_compressed", &records, &by_field);
  const std::string compressed = lzf_compress(by_field);
  ASSERT_LT(compressed.size(), by_field.size());  // back references were used
  const std::string body = little_endian(std::uint32_t(compressed.size())) +
                           little_endian(std::uint32_t(by_field.size())) + compressed;
  const CloudFile c = read_cloud_file(write_bytes(dir / "c.pcd", compressed_header + body));
  EXPECT_EQ(c.format, "pcd binary_compressed");
  ASSERT_EQ(c.points.size(), 300u);
  for (std::size_t i = 0; i < 300; ++i) ASSERT_EQ(c.points[i], b.points[i]) << i;
  EXPECT_EQ(c.covariances[17], b.covariances[17]);

  // Corrupt compressed data: named, never a crash.
  std::string bad = body;
  bad[8] = char(0xE0);  // a long back reference before any output
  expect_error(write_bytes(dir / "c_bad.pcd", compressed_header + bad), {"binary_compressed", "corrupt"});
  expect_error(write_bytes(dir / "c_cut.pcd", compressed_header + body.substr(0, body.size() - 5)),
               {"binary_compressed", "truncated"});
  std::string wrong_size = little_endian(std::uint32_t(compressed.size())) +
                           little_endian(std::uint32_t(by_field.size() + 4)) + compressed;
  expect_error(write_bytes(dir / "c_size.pcd", compressed_header + wrong_size), {"uncompressed size"});
}

TEST(CloudFile, MalformedFilesNameTheFileAndTheField) {
  testutil::TempDir dir("cloudfile");
  const std::string xyz = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  struct Case {
    std::string name, bytes;
    std::vector<std::string> needles;
  };
  std::string records, by_field;
  const std::string binary_header = binary_pcd(10, "binary", &records, &by_field);
  const std::string ply_xyz = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
  const std::vector<Case> cases = {
      {"not_pcd.pcd", "hello world\n", {"not a PCD"}},
      {"no_data.pcd", xyz + "WIDTH 1\nHEIGHT 1\nPOINTS 1\n", {"DATA"}},
      {"no_z.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2\n", {"field z", "missing"}},
      {"size_count.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", {"SIZE", "2 entries for 3"}},
      {"type_count.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F\nWIDTH 1\nDATA ascii\n1 2 3\n", {"TYPE"}},
      {"count_count.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1\nWIDTH 1\nDATA ascii\n1 2 3\n",
       {"COUNT", "2 entries for 3"}},
      {"bad_size.pcd", "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", {"SIZE", "'z'"}},
      {"f_size.pcd", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", {"SIZE", "'z'", "F of size"}},
      {"bad_type.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 1\nDATA ascii\n1 2 3\n", {"TYPE", "'Q'"}},
      {"x_count.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 2 1 1\nWIDTH 1\nDATA ascii\n1 1 2 3\n",
       {"field x", "COUNT 1"}},
      {"points_mismatch.pcd", xyz + "WIDTH 3\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n", {"POINTS", "WIDTH"}},
      {"few_lines.pcd", xyz + "WIDTH 3\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n", {"POINTS", "truncated"}},
      {"many_lines.pcd", xyz + "WIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n4 5 6\n", {"line 10", "more data lines"}},
      {"short_line.pcd", xyz + "WIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n4 5\n", {"line 10", "2 values, expected 3"}},
      {"word.pcd", xyz + "WIDTH 1\nPOINTS 1\nDATA ascii\n1 two 3\n", {"line 9 field y", "'two' is not a number"}},
      {"not_int.pcd", "FIELDS x y z i\nSIZE 4 4 4 2\nTYPE F F F U\nWIDTH 1\nDATA ascii\n1 2 3 0.5\n",
       {"line 6 field i", "not an integer"}},
      {"inf.pcd", xyz + "WIDTH 1\nPOINTS 1\nDATA ascii\n1 inf 3\n", {"line 9", "infinite"}},
      {"bad_kind.pcd", xyz + "WIDTH 1\nDATA zipped\n", {"DATA", "zipped"}},
      {"bad_viewpoint.pcd", xyz + "WIDTH 1\nVIEWPOINT 0 0 0 1 0 0\nDATA ascii\n1 2 3\n", {"VIEWPOINT"}},
      {"bad_width.pcd", xyz + "WIDTH -1\nDATA ascii\n", {"WIDTH"}},
      {"duplicate.pcd", "FIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 4\n",
       {"FIELDS", "twice"}},
      {"bad_keyword.pcd", xyz + "WIDTH 1\nFOO 3\nDATA ascii\n1 2 3\n", {"header line 7", "FOO"}},
      {"truncated.pcd", binary_header + records.substr(0, records.size() - 1), {"DATA binary", "truncated"}},
      {"huge.pcd", xyz + "WIDTH 999999999999\nDATA binary\n" + std::string(24, '\0'), {"truncated"}},
      {"huge_ascii.pcd", xyz + "WIDTH 999999999999\nDATA ascii\n1 2 3\n", {"POINTS", "truncated"}},
      {"bad_variance.pcd", "FIELDS x y z variance\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 2\nDATA ascii\n1 2 3 0\n1 2 3 -1\n",
       {"point 1 (line 7)", "variance"}},
      {"partial_cov.pcd", "FIELDS x y z cov_xx\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 1\n",
       {"cov_xy", "go together"}},
      {"indefinite_cov.ply",
       ply_xyz + "property float cov_xx\nproperty float cov_xy\nproperty float cov_xz\nproperty float cov_yy\n"
                 "property float cov_yz\nproperty float cov_zz\nend_header\n0 0 0 1 0 0 1 0 1\n1 1 1 1 2 0 1 0 1\n",
       {"vertex 1", "positive semi-definite"}},
      {"ply_no_z.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
       {"property z"}},
      {"ply_word.ply", ply_xyz + "end_header\n1 2 3\n1 zwei 3\n", {"vertex 1 property y", "'zwei' is not a number"}},
      {"ply_cut.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
       "end_header\n" +
           std::string(20, '\0'),
       {"vertex 1 property z", "truncated"}},
      {"ply_count.ply", ply_xyz + "end_header\n1 2 3\n", {"vertex 1", "truncated"}},
      {"ply_list_sigma.ply", ply_xyz + "property list uchar float sigma\nend_header\n1 2 3 0\n1 2 3 0\n",
       {"property sigma", "scalar"}},
  };
  for (const Case& c : cases) expect_error(write_bytes(dir / c.name, c.bytes), c.needles);
}

}  // namespace
}  // namespace panoscan
