// Shared helpers for the tests: temporary directories and tiny hand-made scenes.
#pragma once

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/mesh.h"

namespace panoscan::testutil {

// Runs `action`, expects it to throw panoscan::Error, and returns the message (empty, with a
// test failure, if it did not throw).
template <typename Action>
std::string error_of(Action&& action) {
  try {
    action();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected panoscan::Error to be thrown";
  return "";
}

// Writes `bytes` to `path` as they are (a binary stream) and returns the path.
inline std::filesystem::path write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

// A fresh directory under the system temp dir, removed when the object goes away.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("panoscan-test-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// A closed box room [x0,x1]x[y0,y1]x[0,h] with inward-facing triangles, a checker texture
// and one scanning position at `position` (floor point).
inline Scene make_box_room(double x0, double x1, double y0, double y1, double h, Eigen::Vector3d position) {
  Scene scene;
  scene.name = "box_room";
  Texture checker;
  checker.name = "checker";
  checker.width = checker.height = 64;
  checker.rgb.resize(64 * 64 * 3);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c)
        checker.rgb[(y * 64 + x) * 3 + c] = ((x / 8 + y / 8) % 2) ? 230 : std::uint8_t(20 + 40 * c);
  scene.textures.push_back(checker);
  scene.materials.push_back({"wall", {1.f, 1.f, 1.f}, 0});
  auto& m = scene.mesh;
  const Eigen::Vector3f corners[8] = {{float(x0), float(y0), 0.f},      {float(x1), float(y0), 0.f},
                                      {float(x1), float(y1), 0.f},      {float(x0), float(y1), 0.f},
                                      {float(x0), float(y0), float(h)}, {float(x1), float(y0), float(h)},
                                      {float(x1), float(y1), float(h)}, {float(x0), float(y1), float(h)}};
  for (const auto& c : corners) m.vertices.push_back(c);
  // Quads wound so that normals point into the room.
  const int quads[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1}, {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
  for (const auto& q : quads) {
    for (const auto& tri : {Eigen::Vector3i(q[0], q[1], q[2]), Eigen::Vector3i(q[0], q[2], q[3])}) {
      m.triangles.push_back(tri);
      m.triangle_material.push_back(0);
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3f& v = m.vertices[tri[k]];
        // Planar projection: 0.25 m per texture tile.
        m.corner_uvs.emplace_back((v.x() + v.y()) / 0.25f, (v.z() + v.y()) / 0.25f);
      }
    }
  }
  scene.lights.push_back({{float(0.5 * (x0 + x1)), float(0.5 * (y0 + y1)), float(h - 0.1)}, 1.f});
  ScanPosition p;
  p.name = "BOX-1";
  p.floor_point = position;
  scene.positions.push_back(p);
  return scene;
}

}  // namespace panoscan::testutil
