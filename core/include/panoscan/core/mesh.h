// In-memory scene description shared by the scene generators, the scene loader, the simulator
// and evaluation: a triangle mesh with per-triangle materials, per-corner texture coordinates,
// textures, light positions for simple shading, and the scanning positions of the scene.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace panoscan {

// 8-bit RGB texture, row-major, row 0 at the top (v = 1 in OBJ's convention maps to row 0).
// Sampled with wrap-around ("repeat"), so texture coordinates outside [0, 1] tile it.
struct Texture {
  std::string name;  // also the file stem when exported (<name>.png)
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3
};

struct Material {
  std::string name;
  Eigen::Vector3f albedo{0.8f, 0.8f, 0.8f};  // linear [0, 1]; multiplies the texture if any
  int texture = -1;                          // index into Scene::textures, or -1
};

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;    // metres, scene frame
  std::vector<Eigen::Vector3i> triangles;   // counter-clockwise seen from outside/front
  std::vector<Eigen::Vector2f> corner_uvs;  // empty, or 3 per triangle (corner order)
  std::vector<int> triangle_material;       // empty, or 1 per triangle (index into materials)
  // Empty, or 1 per vertex: the surface's base colour, components in [0, 1] used as stored (like
  // texels, /255 for 8-bit sources), interpolated over each triangle. Where present it takes the
  // place of the material's albedo (assimp's formats give a default grey diffuse colour to meshes
  // coloured only per vertex) and still multiplies the material's texture, if any.
  std::vector<Eigen::Vector3f> vertex_colours;

  std::size_t num_triangles() const { return triangles.size(); }
};

struct PointLight {
  Eigen::Vector3f position{0.f, 0.f, 2.5f};
  float intensity = 1.f;  // relative; shading is normalised so one light of 1 at 2 m gives ~1
};

// Where the robot stands for one panoramic scan: the rotation axis passes (nominally) through
// floor_point, vertically; the sensors sit at the rig's height above it.
struct ScanPosition {
  std::string name;  // e.g. "SO-1"
  Eigen::Vector3d floor_point = Eigen::Vector3d::Zero();
  double start_heading_rad = 0.0;  // azimuth of the rig's forward direction at the start
};

struct Scene {
  std::string name;
  TriangleMesh mesh;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<PointLight> lights;
  std::vector<ScanPosition> positions;

  // Throws Error (naming `origin` and the offending field) if the scene is unusable: no
  // triangles, indices out of range, non-finite vertices, inconsistent uv/material arrays,
  // textures of the wrong size.
  void check(const std::string& origin) const;
};

}  // namespace panoscan
