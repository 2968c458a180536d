// Point-cloud files for `recon register` (core/cloud_file.h): the input as a .pcd file (PCL's
// format: ascii, binary, binary_compressed headers and bodies) and as a .ply file (the cloud-file
// path of the PLY reader: positions, NaN points dropped, uncertainty columns and their checks).
#include "fuzz_target.h"
#include "panoscan/core/cloud_file.h"

#include <cstring>

namespace panoscan::fuzz {
namespace {
template <class T>
std::string le(T value) {
  std::string out(sizeof(T), '\0');
  std::memcpy(out.data(), &value, sizeof(T));  // the fuzz hosts are little-endian
  return out;
}
}  // namespace

std::vector<std::string> seed_inputs() {
  const std::string ascii =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb variance histogram\nSIZE 4 4 4 4 8 2\nTYPE F F F U F I\n"
      "COUNT 1 1 1 1 1 2\nWIDTH 2\nHEIGHT 2\nVIEWPOINT 0.5 0 1 1 0 0 0\nPOINTS 4\nDATA ascii\n"
      "1 2 3 4 1e-6 -1 2\nnan nan nan 0 0 0 0\n-0.5 0.25 10 7 2e-6 3 4\n4 5 6 0 0 0 0\n";
  std::string binary = "VERSION .7\nFIELDS x _ y sigma z\nSIZE 8 1 4 4 4\nTYPE F U F F F\nCOUNT 1 2 1 1 1\n"
                       "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary\n";
  for (int i = 0; i < 3; ++i) binary += le(0.5 * i) + "ab" + le(float(-i)) + le(0.002f) + le(float(1 + i));
  // binary_compressed: fields x y z (F 4) of 2 points as one LZF literal run of 24 bytes.
  std::string fields;
  for (float v : {0.f, 1.f, 2.f, 3.f, 4.f, 5.f}) fields += le(v);
  std::string compressed = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA binary_compressed\n";
  compressed += le(std::uint32_t(25)) + le(std::uint32_t(24)) + std::string(1, char(23)) + fields;
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property float cov_xx\nproperty float cov_xy\nproperty float cov_xz\nproperty float cov_yy\n"
      "property float cov_yz\nproperty float cov_zz\nelement range_grid 2\nproperty list uchar int vertex_indices\n"
      "end_header\n0 0 1 1e-6 0 0 1e-6 0 1e-6\nnan 0 0 0 0 0 0 0 0\n1 0\n0\n";
  return {ascii, binary, compressed, ply};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  for (const char* name : {"input.pcd", "input.ply"}) {
    const auto path = panoscan::fuzz::scratch_dir() / name;
    panoscan::fuzz::write_bytes(path, bytes);
    panoscan::fuzz::expect_clean(path.string(), [&] { panoscan::read_cloud_file(path); });
  }
  return 0;
}
