// Internal to panoscan_scenes: a small modelling kit for the built-in scenes.
//
// Every primitive is a closed solid (or, for the room shell, a surface facing into the room), with
// triangles counter-clockwise seen from outside and per-corner texture coordinates. Texture
// coordinates are metric: a surface point is projected onto a plane (or unrolled along its arc
// length on curved parts) in metres and divided by the material's tile size, the number of metres
// one repeat of its texture covers. So texel density is set per material, in mm per texel, and does
// not depend on the size of the object it is painted on.
//
// Primitives are described in a local frame; push()/pop() place that frame in the scene. Texture
// coordinates are taken in the local frame, so a texture turns with the object it is painted on.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "panoscan/core/mesh.h"

namespace panoscan::scenes {

using Vec2 = Eigen::Vector2f;
using Vec3 = Eigen::Vector3f;
using Pose3 = Eigen::Isometry3f;  // parent_from_child, rigid

// Rigid placement: a rotation about z (yaw, counter-clockwise seen from above), then a translation.
Pose3 place(const Vec3& translation, float yaw_rad = 0.f);
// Rotation about the local x axis (positive tilts +y towards +z) followed by a translation.
Pose3 tilt_x(const Vec3& translation, float angle_rad);
// Rotation about the local y axis (positive tilts +z towards +x) followed by a translation.
Pose3 tilt_y(const Vec3& translation, float angle_rad);

// Which faces of a box to emit (a box standing on the floor needs no bottom, for instance).
enum BoxFace : unsigned {
  kFaceMinX = 1u << 0,
  kFaceMaxX = 1u << 1,
  kFaceMinY = 1u << 2,
  kFaceMaxY = 1u << 3,
  kFaceMinZ = 1u << 4,
  kFaceMaxZ = 1u << 5,
  kAllFaces = 63u,
};

// A rectangular hole in a wall, in wall coordinates: s along the wall from its start, t = height.
struct WallOpening {
  float s0 = 0.f, s1 = 0.f;
  float t0 = 0.f, t1 = 0.f;
};

class SceneBuilder {
 public:
  explicit SceneBuilder(std::string scene_name);

  // Returns the index of the texture.
  int add_texture(Texture texture);
  // Returns the material index. tile_size_m: metres covered by one repeat of the texture.
  int add_material(const std::string& name, int texture, float tile_size_m, const Vec3& albedo = Vec3(1.f, 1.f, 1.f));

  // Local frame stack: push(parent_from_child) makes child the current frame.
  void push(const Pose3& parent_from_child);
  void pop();
  // The current frame's pose in the scene.
  const Pose3& scene_from_local() const { return frames_.back(); }

  // Convex planar polygon, counter-clockwise seen from its front, metric planar texture coordinates.
  void add_polygon(const std::vector<Vec3>& points, int material);
  // As add_polygon, but the winding is fixed up so that the front faces along `front_normal`.
  void add_polygon_facing(std::vector<Vec3> points, const Vec3& front_normal, int material);
  void add_quad(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, int material) {
    add_polygon({p0, p1, p2, p3}, material);
  }
  // Quad whose texture is stretched once over it: uv (0,0) at p0, (1,0) at p1, (1,1) at p2, (0,1) at
  // p3 (so p3 -> p2 is the picture's top edge). For posters, screens, rugs, the view out of a window.
  // uv_min/uv_max select a sub-rectangle of the texture instead (one spine of a book-spine atlas).
  void add_fitted_quad(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, int material,
                       const Vec2& uv_min = Vec2(0.f, 0.f), const Vec2& uv_max = Vec2(1.f, 1.f));

  // Axis-aligned box in the local frame, faces pointing out.
  void add_box(const Vec3& min_corner, const Vec3& max_corner, int material, unsigned faces = kAllFaces);
  // Box with faces pointing in (a cavity: the room shell, a window recess).
  void add_inward_box(const Vec3& min_corner, const Vec3& max_corner, int material, unsigned faces = kAllFaces);

  // Solid of revolution about the local z axis through `base_center`: profile points (radius, height
  // above base) from bottom to top. Ends with a non-zero radius get flat caps when requested.
  // Cylinders, cones, frusta, vases, pots and lampshades are all lathes.
  void add_lathe(const Vec3& base_center, const std::vector<Vec2>& radius_height, int segments, int material,
                 bool cap_bottom = true, bool cap_top = true);
  void add_cylinder(const Vec3& base_center, float radius, float height, int segments, int material,
                    bool cap_bottom = true, bool cap_top = true) {
    add_lathe(base_center, {Vec2(radius, 0.f), Vec2(radius, height)}, segments, material, cap_bottom, cap_top);
  }
  void add_frustum(const Vec3& base_center, float bottom_radius, float top_radius, float height, int segments,
                   int material, bool cap_bottom = true, bool cap_top = true) {
    add_lathe(base_center, {Vec2(bottom_radius, 0.f), Vec2(top_radius, height)}, segments, material, cap_bottom,
              cap_top);
  }
  // Cylinder between two arbitrary points (legs, rods, handles).
  void add_rod(const Vec3& from, const Vec3& to, float radius, int segments, int material);

  // A convex profile in the local (y, z) plane, counter-clockwise seen from +x, extruded along x from
  // x0 to x1, with caps: sofa arms with round tops, slanted backrests, wedges, leaves.
  void add_prism(const std::vector<Vec2>& profile_yz, float x0, float x1, int material);

  // A slab of the given thickness swept along a polyline in the local xy plane, from z0 to z1:
  // curved chair backs, curtains, bent panels. Closed (both ends capped).
  void add_swept_slab(const std::vector<Vec2>& path_xy, float thickness, float z0, float z1, int material);

  // A wall of the room shell, seen from inside: it runs from `start` to `end` (floor points, z = 0),
  // `end` lying to the right of a viewer inside the room facing it, from z = 0 to `height`, with
  // rectangular holes (the recesses that close them are separate: see add_window, add_door).
  void add_wall(const Vec2& start, const Vec2& end, float height, const std::vector<WallOpening>& openings,
                int material);

  std::size_t num_triangles() const { return mesh_.triangles.size(); }
  // Bounding box (scene frame) of the triangles emitted since `first_triangle`; false if none.
  bool bounds_since(std::size_t first_triangle, Vec3* lo, Vec3* hi) const;
  // Drops every triangle emitted since `first_triangle` (a placement that did not fit).
  void truncate(std::size_t first_triangle);

  // Merges coincident vertices, attaches lights and scanning positions and returns the scene.
  Scene finish(std::vector<PointLight> lights, std::vector<ScanPosition> positions);

 private:
  // Adds one triangle given in the local frame with its texture coordinates.
  void emit_triangle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec2& uv_a, const Vec2& uv_b, const Vec2& uv_c,
                     int material);
  float tile_size(int material) const;

  Scene scene_;
  TriangleMesh mesh_;
  std::vector<float> material_tile_size_m_;
  std::vector<Pose3> frames_;
};

}  // namespace panoscan::scenes
