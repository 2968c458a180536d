// PLY files, as meshes (ground truth, `eval cloud --mesh`) and as point clouds (`eval cloud`,
// panorama clouds): both readers on the same bytes.
#include "fuzz_target.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/core/point_cloud.h"

namespace panoscan::fuzz {
std::vector<std::string> seed_inputs() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  mesh.vertex_colours = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  write_ply_mesh(scratch_dir() / "seed_mesh.ply", mesh);
  PointCloud cloud;
  cloud.positions = {{0, 0, 1}, {0.5, -0.25, 2}};
  cloud.normals = {{0, 0, 1}, {1, 0, 0}};
  cloud.colours = {{10, 20, 30}, {200, 100, 0}};
  cloud.variances = {1e-6f, 4e-6f};
  write_ply_point_cloud(scratch_dir() / "seed_cloud.ply", cloud);
  const std::string ascii =
      "ply\nformat ascii 1.0\ncomment seed\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n";
  return {read_bytes(scratch_dir() / "seed_mesh.ply"), read_bytes(scratch_dir() / "seed_cloud.ply"), ascii};
}
}  // namespace panoscan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = panoscan::fuzz::scratch_dir() / "input.ply";
  panoscan::fuzz::write_bytes(path, std::string(reinterpret_cast<const char*>(data), size));
  panoscan::fuzz::expect_clean(path.string(), [&] { panoscan::read_ply_mesh(path); });
  panoscan::fuzz::expect_clean(path.string(), [&] { panoscan::read_ply_point_cloud(path); });
  return 0;
}
