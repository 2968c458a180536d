#include "scene_builder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace panoscan::scenes {

namespace {

constexpr float kTwoPi = 6.28318530717958647692f;

// Newell's method: robust normal of a planar polygon (length = twice its area).
Vec3 polygon_normal(const std::vector<Vec3>& points) {
  Vec3 normal = Vec3::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& a = points[i];
    const Vec3& b = points[(i + 1) % points.size()];
    normal.x() += (a.y() - b.y()) * (a.z() + b.z());
    normal.y() += (a.z() - b.z()) * (a.x() + b.x());
    normal.z() += (a.x() - b.x()) * (a.y() + b.y());
  }
  return normal;
}

// Texture axes for planar projection of a face with the given normal. Near-horizontal faces use the
// local x and y axes; other faces keep "up" on the texture pointing up (local z), with u to the right
// of a viewer facing the front (so pictures and text are neither upside down nor mirrored).
void planar_axes(const Vec3& unit_normal, Vec3* u_axis, Vec3* v_axis) {
  if (std::abs(unit_normal.z()) >= 0.8f) {
    *u_axis = Vec3::UnitX();
    *v_axis = unit_normal.z() > 0.f ? Vec3::UnitY() : Vec3(-Vec3::UnitY());
    return;
  }
  *v_axis = (Vec3::UnitZ() - unit_normal.z() * unit_normal).normalized();
  *u_axis = v_axis->cross(unit_normal);
}

}  // namespace

Pose3 place(const Vec3& translation, float yaw_rad) {
  Pose3 pose = Pose3::Identity();
  pose.linear() = Eigen::AngleAxisf(yaw_rad, Vec3::UnitZ()).toRotationMatrix();
  pose.translation() = translation;
  return pose;
}

Pose3 tilt_x(const Vec3& translation, float angle_rad) {
  Pose3 pose = Pose3::Identity();
  pose.linear() = Eigen::AngleAxisf(angle_rad, Vec3::UnitX()).toRotationMatrix();
  pose.translation() = translation;
  return pose;
}

Pose3 tilt_y(const Vec3& translation, float angle_rad) {
  Pose3 pose = Pose3::Identity();
  pose.linear() = Eigen::AngleAxisf(angle_rad, Vec3::UnitY()).toRotationMatrix();
  pose.translation() = translation;
  return pose;
}

SceneBuilder::SceneBuilder(std::string scene_name) {
  scene_.name = std::move(scene_name);
  frames_.push_back(Pose3::Identity());
}

int SceneBuilder::add_texture(Texture texture) {
  scene_.textures.push_back(std::move(texture));
  return static_cast<int>(scene_.textures.size()) - 1;
}

int SceneBuilder::add_material(const std::string& name, int texture, float tile_size_m, const Vec3& albedo) {
  Material material;
  material.name = name;
  material.texture = texture;
  material.albedo = albedo;
  scene_.materials.push_back(material);
  material_tile_size_m_.push_back(tile_size_m);
  return static_cast<int>(scene_.materials.size()) - 1;
}

void SceneBuilder::push(const Pose3& parent_from_child) { frames_.push_back(frames_.back() * parent_from_child); }

void SceneBuilder::pop() {
  if (frames_.size() <= 1) throw std::logic_error("SceneBuilder::pop without push");
  frames_.pop_back();
}

float SceneBuilder::tile_size(int material) const {
  return material_tile_size_m_.at(static_cast<std::size_t>(material));
}

void SceneBuilder::emit_triangle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec2& uv_a, const Vec2& uv_b,
                                 const Vec2& uv_c, int material) {
  // Slivers with no area (cone tips, collapsed caps) carry nothing and would only upset the renderer.
  if ((b - a).cross(c - a).norm() < 1e-10f) return;
  const Pose3& scene_from_local = frames_.back();
  const int first = static_cast<int>(mesh_.vertices.size());
  mesh_.vertices.push_back(scene_from_local * a);
  mesh_.vertices.push_back(scene_from_local * b);
  mesh_.vertices.push_back(scene_from_local * c);
  mesh_.triangles.emplace_back(first, first + 1, first + 2);
  mesh_.corner_uvs.push_back(uv_a);
  mesh_.corner_uvs.push_back(uv_b);
  mesh_.corner_uvs.push_back(uv_c);
  mesh_.triangle_material.push_back(material);
}

void SceneBuilder::add_polygon(const std::vector<Vec3>& points, int material) {
  if (points.size() < 3) return;
  const Vec3 normal = polygon_normal(points);
  if (normal.norm() < 1e-12f) return;
  Vec3 u_axis, v_axis;
  planar_axes(normal.normalized(), &u_axis, &v_axis);
  const float inv_tile = 1.f / tile_size(material);
  std::vector<Vec2> uvs;
  uvs.reserve(points.size());
  for (const Vec3& p : points) uvs.emplace_back(p.dot(u_axis) * inv_tile, p.dot(v_axis) * inv_tile);
  for (std::size_t i = 1; i + 1 < points.size(); ++i)
    emit_triangle(points[0], points[i], points[i + 1], uvs[0], uvs[i], uvs[i + 1], material);
}

void SceneBuilder::add_polygon_facing(std::vector<Vec3> points, const Vec3& front_normal, int material) {
  if (polygon_normal(points).dot(front_normal) < 0.f) std::reverse(points.begin(), points.end());
  add_polygon(points, material);
}

void SceneBuilder::add_fitted_quad(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, int material,
                                   const Vec2& uv_min, const Vec2& uv_max) {
  const Vec2 uv0 = uv_min, uv1(uv_max.x(), uv_min.y()), uv2 = uv_max, uv3(uv_min.x(), uv_max.y());
  emit_triangle(p0, p1, p2, uv0, uv1, uv2, material);
  emit_triangle(p0, p2, p3, uv0, uv2, uv3, material);
}

namespace {

// The four corners of the face of box [lo, hi] perpendicular to `axis` at its min (side 0) or max
// (side 1) end, in no particular winding.
std::vector<Vec3> box_face(const Vec3& lo, const Vec3& hi, int axis, int side) {
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  std::vector<Vec3> corners;
  const float fixed = side ? hi[axis] : lo[axis];
  const float u[4] = {lo[a1], hi[a1], hi[a1], lo[a1]};
  const float v[4] = {lo[a2], lo[a2], hi[a2], hi[a2]};
  for (int k = 0; k < 4; ++k) {
    Vec3 p;
    p[axis] = fixed;
    p[a1] = u[k];
    p[a2] = v[k];
    corners.push_back(p);
  }
  return corners;
}

}  // namespace

void SceneBuilder::add_box(const Vec3& min_corner, const Vec3& max_corner, int material, unsigned faces) {
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (!(faces & (1u << (2 * axis + side)))) continue;
      Vec3 outward = Vec3::Zero();
      outward[axis] = side ? 1.f : -1.f;
      add_polygon_facing(box_face(min_corner, max_corner, axis, side), outward, material);
    }
}

void SceneBuilder::add_inward_box(const Vec3& min_corner, const Vec3& max_corner, int material, unsigned faces) {
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (!(faces & (1u << (2 * axis + side)))) continue;
      Vec3 inward = Vec3::Zero();
      inward[axis] = side ? -1.f : 1.f;
      add_polygon_facing(box_face(min_corner, max_corner, axis, side), inward, material);
    }
}

void SceneBuilder::add_lathe(const Vec3& base_center, const std::vector<Vec2>& radius_height, int segments,
                             int material, bool cap_bottom, bool cap_top) {
  if (radius_height.size() < 2 || segments < 3) return;
  const float inv_tile = 1.f / tile_size(material);
  // v runs along the profile (arc length), u around the axis (arc length at that radius), so the
  // texture is unrolled onto the surface without seams between segments.
  std::vector<float> profile_length(radius_height.size(), 0.f);
  for (std::size_t i = 1; i < radius_height.size(); ++i)
    profile_length[i] = profile_length[i - 1] + (radius_height[i] - radius_height[i - 1]).norm();
  auto point = [&](std::size_t row, int column) {
    const float angle = kTwoPi * static_cast<float>(column) / static_cast<float>(segments);
    const float r = radius_height[row].x();
    return Vec3(base_center.x() + r * std::cos(angle), base_center.y() + r * std::sin(angle),
                base_center.z() + radius_height[row].y());
  };
  auto uv = [&](std::size_t row, int column) {
    const float angle = kTwoPi * static_cast<float>(column) / static_cast<float>(segments);
    return Vec2(angle * radius_height[row].x() * inv_tile, profile_length[row] * inv_tile);
  };
  for (std::size_t row = 0; row + 1 < radius_height.size(); ++row)
    for (int column = 0; column < segments; ++column) {
      // (bottom-left, bottom-right, top-right, top-left) is counter-clockwise seen from the side the
      // profile's right-hand normal points to: outwards for a profile running upwards.
      const Vec3 p00 = point(row, column), p10 = point(row, column + 1);
      const Vec3 p11 = point(row + 1, column + 1), p01 = point(row + 1, column);
      const Vec2 t00 = uv(row, column), t10 = uv(row, column + 1);
      const Vec2 t11 = uv(row + 1, column + 1), t01 = uv(row + 1, column);
      emit_triangle(p00, p10, p11, t00, t10, t11, material);
      emit_triangle(p00, p11, p01, t00, t11, t01, material);
    }
  auto cap = [&](std::size_t row, const Vec3& normal) {
    if (radius_height[row].x() <= 0.f) return;
    std::vector<Vec3> ring;
    for (int column = 0; column < segments; ++column) ring.push_back(point(row, column));
    add_polygon_facing(ring, normal, material);
  };
  if (cap_bottom) cap(0, -Vec3::UnitZ());
  if (cap_top) cap(radius_height.size() - 1, Vec3::UnitZ());
}

void SceneBuilder::add_rod(const Vec3& from, const Vec3& to, float radius, int segments, int material) {
  const Vec3 axis = to - from;
  const float length = axis.norm();
  if (length <= 0.f) return;
  Pose3 pose = Pose3::Identity();
  pose.linear() = Eigen::Quaternionf::FromTwoVectors(Vec3::UnitZ(), axis / length).toRotationMatrix();
  pose.translation() = from;
  push(pose);
  add_cylinder(Vec3::Zero(), radius, length, segments, material);
  pop();
}

void SceneBuilder::add_prism(const std::vector<Vec2>& profile_yz, float x0, float x1, int material) {
  const std::size_t n = profile_yz.size();
  if (n < 3) return;
  const float inv_tile = 1.f / tile_size(material);
  float perimeter = 0.f;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = profile_yz[i];
    const Vec2& b = profile_yz[(i + 1) % n];
    const Vec2 edge = b - a;
    const float edge_length = edge.norm();
    if (edge_length <= 0.f) continue;
    // Outward normal of an edge of a counter-clockwise profile: the edge direction turned clockwise.
    const Vec3 outward(0.f, edge.y(), -edge.x());
    std::vector<Vec3> quad = {Vec3(x0, a.x(), a.y()), Vec3(x1, a.x(), a.y()), Vec3(x1, b.x(), b.y()),
                              Vec3(x0, b.x(), b.y())};
    std::vector<Vec2> uvs = {Vec2(x0, perimeter), Vec2(x1, perimeter), Vec2(x1, perimeter + edge_length),
                             Vec2(x0, perimeter + edge_length)};
    for (Vec2& t : uvs) t *= inv_tile;
    if (polygon_normal(quad).dot(outward) < 0.f) {
      std::reverse(quad.begin(), quad.end());
      std::reverse(uvs.begin(), uvs.end());
    }
    emit_triangle(quad[0], quad[1], quad[2], uvs[0], uvs[1], uvs[2], material);
    emit_triangle(quad[0], quad[2], quad[3], uvs[0], uvs[2], uvs[3], material);
    perimeter += edge_length;
  }
  std::vector<Vec3> cap_low, cap_high;
  for (const Vec2& q : profile_yz) {
    cap_low.emplace_back(x0, q.x(), q.y());
    cap_high.emplace_back(x1, q.x(), q.y());
  }
  add_polygon_facing(cap_low, -Vec3::UnitX(), material);
  add_polygon_facing(cap_high, Vec3::UnitX(), material);
}

void SceneBuilder::add_swept_slab(const std::vector<Vec2>& path_xy, float thickness, float z0, float z1, int material) {
  const std::size_t n = path_xy.size();
  if (n < 2) return;
  const float inv_tile = 1.f / tile_size(material);
  const float half = 0.5f * thickness;
  // Right-hand normals of the segments, then mitred offsets at the joints.
  std::vector<Vec2> segment_normal(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Vec2 d = (path_xy[k + 1] - path_xy[k]).normalized();
    segment_normal[k] = Vec2(d.y(), -d.x());
  }
  std::vector<Vec2> right(n), left(n);
  for (std::size_t k = 0; k < n; ++k) {
    Vec2 offset;
    if (k == 0) {
      offset = segment_normal[0] * half;
    } else if (k == n - 1) {
      offset = segment_normal[n - 2] * half;
    } else {
      const Vec2 mitre = (segment_normal[k - 1] + segment_normal[k]).normalized();
      offset = mitre * (half / std::max(0.2f, mitre.dot(segment_normal[k])));
    }
    right[k] = path_xy[k] + offset;
    left[k] = path_xy[k] - offset;
  }
  auto at = [](const Vec2& p, float z) { return Vec3(p.x(), p.y(), z); };
  float along = 0.f;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const float length = (path_xy[k + 1] - path_xy[k]).norm();
    const Vec3 out_right(segment_normal[k].x(), segment_normal[k].y(), 0.f);
    for (int side = 0; side < 2; ++side) {
      const std::vector<Vec2>& rail = side == 0 ? right : left;
      const Vec3 outward = side == 0 ? out_right : Vec3(-out_right);
      std::vector<Vec3> quad = {at(rail[k], z0), at(rail[k + 1], z0), at(rail[k + 1], z1), at(rail[k], z1)};
      std::vector<Vec2> uvs = {Vec2(along, z0), Vec2(along + length, z0), Vec2(along + length, z1), Vec2(along, z1)};
      for (Vec2& t : uvs) t *= inv_tile;
      if (polygon_normal(quad).dot(outward) < 0.f) {
        std::reverse(quad.begin(), quad.end());
        std::reverse(uvs.begin(), uvs.end());
      }
      emit_triangle(quad[0], quad[1], quad[2], uvs[0], uvs[1], uvs[2], material);
      emit_triangle(quad[0], quad[2], quad[3], uvs[0], uvs[2], uvs[3], material);
    }
    add_polygon_facing({at(left[k], z1), at(right[k], z1), at(right[k + 1], z1), at(left[k + 1], z1)}, Vec3::UnitZ(),
                       material);
    add_polygon_facing({at(left[k], z0), at(right[k], z0), at(right[k + 1], z0), at(left[k + 1], z0)}, -Vec3::UnitZ(),
                       material);
    along += length;
  }
  const Vec2 d_start = (path_xy[1] - path_xy[0]).normalized();
  const Vec2 d_end = (path_xy[n - 1] - path_xy[n - 2]).normalized();
  add_polygon_facing({at(left[0], z0), at(right[0], z0), at(right[0], z1), at(left[0], z1)},
                     Vec3(-d_start.x(), -d_start.y(), 0.f), material);
  add_polygon_facing({at(left[n - 1], z0), at(right[n - 1], z0), at(right[n - 1], z1), at(left[n - 1], z1)},
                     Vec3(d_end.x(), d_end.y(), 0.f), material);
}

void SceneBuilder::add_wall(const Vec2& start, const Vec2& end, float height, const std::vector<WallOpening>& openings,
                            int material) {
  const float length = (end - start).norm();
  if (length <= 0.f) return;
  const Vec2 direction = (end - start) / length;
  // Split the wall into a grid at every opening edge and keep the cells outside all openings.
  std::vector<float> s_cuts = {0.f, length}, t_cuts = {0.f, height};
  for (const WallOpening& o : openings) {
    s_cuts.insert(s_cuts.end(), {o.s0, o.s1});
    t_cuts.insert(t_cuts.end(), {o.t0, o.t1});
  }
  std::sort(s_cuts.begin(), s_cuts.end());
  std::sort(t_cuts.begin(), t_cuts.end());
  s_cuts.erase(std::unique(s_cuts.begin(), s_cuts.end()), s_cuts.end());
  t_cuts.erase(std::unique(t_cuts.begin(), t_cuts.end()), t_cuts.end());
  auto wall_point = [&](float s, float t) {
    const Vec2 p = start + direction * s;
    return Vec3(p.x(), p.y(), t);
  };
  for (std::size_t i = 0; i + 1 < s_cuts.size(); ++i)
    for (std::size_t j = 0; j + 1 < t_cuts.size(); ++j) {
      const float s0 = s_cuts[i], s1 = s_cuts[i + 1], t0 = t_cuts[j], t1 = t_cuts[j + 1];
      const float s_mid = 0.5f * (s0 + s1), t_mid = 0.5f * (t0 + t1);
      const bool in_hole = std::any_of(openings.begin(), openings.end(), [&](const WallOpening& o) {
        return s_mid > o.s0 && s_mid < o.s1 && t_mid > o.t0 && t_mid < o.t1;
      });
      if (in_hole) continue;
      // s grows to the viewer's right and t upwards: counter-clockwise seen from inside.
      add_quad(wall_point(s0, t0), wall_point(s1, t0), wall_point(s1, t1), wall_point(s0, t1), material);
    }
}

namespace {

struct PositionKey {
  float x, y, z;
  bool operator==(const PositionKey& other) const { return std::memcmp(this, &other, sizeof(PositionKey)) == 0; }
};
struct PositionKeyHash {
  std::size_t operator()(const PositionKey& key) const {
    std::uint32_t bits[3];
    std::memcpy(bits, &key, sizeof(bits));
    std::uint64_t h = 1469598103934665603ull;
    for (std::uint32_t b : bits) h = (h ^ b) * 1099511628211ull;
    return static_cast<std::size_t>(h);
  }
};

}  // namespace

bool SceneBuilder::bounds_since(std::size_t first_triangle, Vec3* lo, Vec3* hi) const {
  if (first_triangle >= mesh_.triangles.size()) return false;
  // Before finish() every triangle has its own three vertices, in order.
  *lo = Vec3::Constant(1e30f);
  *hi = Vec3::Constant(-1e30f);
  for (std::size_t v = 3 * first_triangle; v < mesh_.vertices.size(); ++v) {
    *lo = lo->cwiseMin(mesh_.vertices[v]);
    *hi = hi->cwiseMax(mesh_.vertices[v]);
  }
  return true;
}

void SceneBuilder::truncate(std::size_t first_triangle) {
  if (first_triangle >= mesh_.triangles.size()) return;
  mesh_.triangles.resize(first_triangle);
  mesh_.vertices.resize(3 * first_triangle);
  mesh_.corner_uvs.resize(3 * first_triangle);
  mesh_.triangle_material.resize(first_triangle);
}

Scene SceneBuilder::finish(std::vector<PointLight> lights, std::vector<ScanPosition> positions) {
  // Faces were emitted with their own corners; share coincident vertices so the mesh is connected
  // where surfaces meet (texture coordinates stay per corner, so nothing is lost).
  std::unordered_map<PositionKey, int, PositionKeyHash> index_of;
  std::vector<Eigen::Vector3f> merged;
  std::vector<int> remap(mesh_.vertices.size());
  for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) {
    Vec3 v = mesh_.vertices[i];
    for (int k = 0; k < 3; ++k)
      if (v[k] == 0.f) v[k] = 0.f;  // -0 and +0 are one position
    const PositionKey key{v.x(), v.y(), v.z()};
    auto [it, inserted] = index_of.emplace(key, static_cast<int>(merged.size()));
    if (inserted) merged.push_back(v);
    remap[i] = it->second;
  }
  for (Eigen::Vector3i& triangle : mesh_.triangles)
    for (int k = 0; k < 3; ++k) triangle[k] = remap[static_cast<std::size_t>(triangle[k])];
  mesh_.vertices = std::move(merged);

  Scene scene = std::move(scene_);
  scene.mesh = std::move(mesh_);
  scene.lights = std::move(lights);
  scene.positions = std::move(positions);
  return scene;
}

}  // namespace panoscan::scenes
