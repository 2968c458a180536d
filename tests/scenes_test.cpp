// Tests of the built-in scenes (geometry, materials, scanning positions, texture richness as ORB
// sees it), of their export to OBJ/MTL/PNG/PLY/JSON, and of loading scene files through assimp,
// including bad input rejected with an Error naming the file.
#include "panoscan/scenes/scenes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/eval/image_texture.h"
#include "panoscan/sim/renderer.h"
#include "panoscan/sim/scene_loader.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testutil::TempDir;

constexpr double kPi = 3.14159265358979323846;

// Generating a scene takes a fraction of a second; tests share one copy of each.
const Scene& builtin(const std::string& name, scenes::TextureDensity density = scenes::TextureDensity::kIcl) {
  static std::map<std::pair<std::string, scenes::TextureDensity>, Scene> cache;
  const auto key = std::make_pair(name, density);
  auto found = cache.find(key);
  if (found == cache.end())
    found = cache.emplace(key, scenes::make_builtin_scene(name, scenes::SceneStyle{density})).first;
  return found->second;
}
const Scene& rich(const std::string& name) { return builtin(name, scenes::TextureDensity::kRich); }

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Runs f expecting an Error whose message contains every one of `parts`.
template <typename F>
void expect_error(F f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no error (expected one mentioning " << parts.front() << ")";
  } catch (const Error& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
  }
}

// World-from-camera pose of a camera at `eye` looking at azimuth `heading` (from +x towards +y)
// pitched up by `pitch`, with OpenCV axes (x right, y down, z forward).
Rigid3d camera_pose(const Eigen::Vector3d& eye, double heading, double pitch) {
  const Eigen::Vector3d forward(std::cos(pitch) * std::cos(heading), std::cos(pitch) * std::sin(heading),
                                std::sin(pitch));
  const Eigen::Vector3d right(std::sin(heading), -std::cos(heading), 0.0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d rotation;
  rotation.col(0) = right;
  rotation.col(1) = down;
  rotation.col(2) = forward;
  return make_rigid(rotation, eye);
}

int orb_keypoints(const cv::Mat& rgb) {
  cv::Mat grey;
  cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::ORB::create()->detect(grey, keypoints);  // OpenCV defaults: 500 features, FAST threshold 20
  return static_cast<int>(keypoints.size());
}

// ------------------------------------------------------------------------------------------------

TEST(BuiltinScenes, Names) {
  EXPECT_EQ(scenes::builtin_scene_names(), (std::vector<std::string>{"living_room", "office"}));
  EXPECT_TRUE(scenes::is_builtin_scene("office"));
  EXPECT_FALSE(scenes::is_builtin_scene("kitchen"));
  expect_error([] { scenes::make_builtin_scene("kitchen"); }, {"kitchen", "living_room", "office"});
}

class BuiltinSceneTest : public ::testing::TestWithParam<std::string> {};

TEST_P(BuiltinSceneTest, IsAValidTexturedSceneOfTheRightSize) {
  const Scene& scene = rich(GetParam());
  EXPECT_EQ(scene.name, GetParam());
  EXPECT_NO_THROW(scene.check("<builtin:" + GetParam() + ">"));
  const std::size_t triangles = scene.mesh.num_triangles();
  EXPECT_GE(triangles, 20000u);
  EXPECT_LE(triangles, 150000u);
  ASSERT_EQ(scene.mesh.triangle_material.size(), triangles);
  ASSERT_EQ(scene.mesh.corner_uvs.size(), 3 * triangles);
  // Every triangle has a textured material, and the scene uses many different ones.
  std::set<int> used_materials;
  for (int material : scene.mesh.triangle_material) {
    ASSERT_GE(material, 0);
    ASSERT_GE(scene.materials[static_cast<std::size_t>(material)].texture, 0);
    used_materials.insert(material);
  }
  EXPECT_EQ(used_materials.size(), scene.materials.size()) << "every material is used";
  EXPECT_GE(scene.materials.size(), 20u);
  std::size_t texture_bytes = 0;
  for (const Texture& texture : scene.textures) {
    EXPECT_EQ(texture.width, texture.height) << texture.name;
    EXPECT_GE(texture.width, 256) << texture.name;
    EXPECT_LE(texture.width, 1024) << texture.name;
    texture_bytes += texture.rgb.size();
  }
  EXPECT_LT(texture_bytes, 40u * 1024 * 1024);
  std::printf("[ scene    ] %s: %zu triangles, %zu vertices, %zu materials, %zu textures (%.1f MB)\n",
              scene.name.c_str(), triangles, scene.mesh.vertices.size(), scene.materials.size(), scene.textures.size(),
              texture_bytes / 1048576.0);
  ASSERT_GE(scene.lights.size(), 2u);
  EXPECT_LE(scene.lights.size(), 4u);
}

TEST_P(BuiltinSceneTest, IsDeterministic) {
  const Scene again = scenes::make_builtin_scene(GetParam());
  const Scene& scene = builtin(GetParam());
  ASSERT_EQ(again.mesh.vertices.size(), scene.mesh.vertices.size());
  EXPECT_TRUE(again.mesh.vertices == scene.mesh.vertices);
  EXPECT_TRUE(again.mesh.triangles == scene.mesh.triangles);
  EXPECT_TRUE(again.mesh.corner_uvs == scene.mesh.corner_uvs);
  ASSERT_EQ(again.textures.size(), scene.textures.size());
  for (std::size_t i = 0; i < scene.textures.size(); ++i) EXPECT_TRUE(again.textures[i].rgb == scene.textures[i].rgb);
  ASSERT_EQ(again.materials.size(), scene.materials.size());
  for (std::size_t i = 0; i < scene.materials.size(); ++i)
    EXPECT_TRUE(again.materials[i].albedo == scene.materials[i].albedo);
}

// The texture density changes materials only: the geometry, texture coordinates, lights and
// positions are those of the rich look.
TEST_P(BuiltinSceneTest, TextureDensityChangesOnlyMaterials) {
  const Scene& reference = rich(GetParam());
  for (scenes::TextureDensity density : {scenes::TextureDensity::kIcl, scenes::TextureDensity::kPlain}) {
    const Scene& scene = builtin(GetParam(), density);
    EXPECT_TRUE(scene.mesh.vertices == reference.mesh.vertices);
    EXPECT_TRUE(scene.mesh.triangles == reference.mesh.triangles);
    // Texture coordinates are those of the rich look wherever a texture is still shown.
    ASSERT_EQ(scene.mesh.corner_uvs.size(), reference.mesh.corner_uvs.size());
    std::size_t differing = 0;
    for (std::size_t t = 0; t < scene.mesh.triangles.size(); ++t)
      if (scene.materials[std::size_t(scene.mesh.triangle_material[t])].texture >= 0)
        for (int k = 0; k < 3; ++k)
          differing += scene.mesh.corner_uvs[3 * t + k] != reference.mesh.corner_uvs[3 * t + k];
    EXPECT_EQ(differing, 0u);
    EXPECT_EQ(scene.materials.size(), reference.materials.size());
    ASSERT_EQ(scene.positions.size(), reference.positions.size());
    EXPECT_EQ(scene.lights.size(), reference.lights.size());
  }
}

// icl: walls, ceiling, trim and window reveals are uniform paint; the floor keeps a low-contrast
// texture; the objects keep their textures. plain: no texture at all.
TEST_P(BuiltinSceneTest, IclAndPlainDensities) {
  const Scene& scene = builtin(GetParam(), scenes::TextureDensity::kIcl);
  std::set<std::string> painted, textured;
  for (const Material& material : scene.materials) (material.texture < 0 ? painted : textured).insert(material.name);
  const std::set<std::string> expected_paint =
      GetParam() == "living_room"
          ? std::set<std::string>{"wall_paint_cream", "wall_paint_sage", "ceiling_paint", "trim_paint", "plaster"}
          : std::set<std::string>{"wall_paint_light_grey", "wall_paint_blue_grey", "ceiling_paint_office", "trim_paint",
                                  "plaster"};
  EXPECT_EQ(painted, expected_paint);
  EXPECT_GE(textured.size(), 15u);
  for (const char* object : {"oak_wood", "book_spines", "poster", "screen"})
    EXPECT_TRUE(textured.count(object)) << object;
  // Paint colours differ between walls and are not pure white.
  std::set<std::vector<float>> colours;
  for (const Material& material : scene.materials)
    if (material.texture < 0) {
      colours.insert({material.albedo.x(), material.albedo.y(), material.albedo.z()});
      EXPECT_LT(material.albedo.maxCoeff(), 0.9f) << material.name;
    }
  EXPECT_GE(colours.size(), 4u);
  // The floor texture: grey-level spread at most a fifth of the rich floor's.
  const std::string floor = GetParam() == "living_room" ? "parquet_floor" : "carpet_tiles";
  auto grey_std = [](const Texture& t) {
    double sum = 0, sum2 = 0;
    const std::size_t n = std::size_t(t.width) * t.height;
    for (std::size_t i = 0; i < n; ++i) {
      const double g = 0.299 * t.rgb[3 * i] + 0.587 * t.rgb[3 * i + 1] + 0.114 * t.rgb[3 * i + 2];
      sum += g;
      sum2 += g * g;
    }
    return std::sqrt(sum2 / n - (sum / n) * (sum / n));
  };
  auto texture_of = [&](const Scene& s, const std::string& name) -> const Texture* {
    for (const Material& material : s.materials)
      if (material.name == name && material.texture >= 0) return &s.textures[std::size_t(material.texture)];
    return nullptr;
  };
  const Texture* icl_floor = texture_of(scene, floor);
  const Texture* rich_floor = texture_of(rich(GetParam()), floor);
  ASSERT_TRUE(icl_floor && rich_floor);
  EXPECT_LE(grey_std(*icl_floor), 0.2 * grey_std(*rich_floor));
  std::printf("[ density  ] %s: %zu painted and %zu textured materials; floor grey std %.1f (rich %.1f)\n",
              GetParam().c_str(), painted.size(), textured.size(), grey_std(*icl_floor), grey_std(*rich_floor));

  const Scene& plain = builtin(GetParam(), scenes::TextureDensity::kPlain);
  EXPECT_TRUE(plain.textures.empty());
  for (const Material& material : plain.materials) {
    EXPECT_EQ(material.texture, -1) << material.name;
    EXPECT_TRUE((material.albedo.array() > 0.f).all() && (material.albedo.array() <= 1.f).all()) << material.name;
  }
}

// Share of flat pixels (grey-level std < 2 over 7x7) in a noiseless equirectangular panorama from
// the first scanning position at the rig's camera height: at least a third at the default (icl)
// density, as in ICL-NUIM's rooms; rich leaves far fewer, plain more.
TEST_P(BuiltinSceneTest, FlatPixelShareOfAPanoramaByDensity) {
  double share[3] = {0, 0, 0};
  const scenes::TextureDensity densities[3] = {scenes::TextureDensity::kRich, scenes::TextureDensity::kIcl,
                                               scenes::TextureDensity::kPlain};
  for (int d = 0; d < 3; ++d) {
    const Scene& scene = builtin(GetParam(), densities[d]);
    const Renderer renderer(scene);
    Equirectangular pano;
    pano.height = 256;
    const Rigid3d world_from_pano =
        make_rigid(Eigen::Matrix3d::Identity(), scene.positions[0].floor_point + Eigen::Vector3d(0, 0, 1.1));
    const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
    ImageU8 valid(view.depth.width, view.depth.height, 1, 0);
    for (std::size_t i = 0; i < valid.data.size(); ++i) valid.data[i] = view.depth.data[i] > 0.f;
    share[d] = eval::flat_pixel_share(eval::grey_levels(view.rgb), valid, 7, 2.0).share;
  }
  std::printf("[ flat     ] %s %s: flat pixels rich %.1f%%, icl %.1f%%, plain %.1f%%\n", GetParam().c_str(),
              builtin(GetParam()).positions[0].name.c_str(), 100 * share[0], 100 * share[1], 100 * share[2]);
  EXPECT_GE(share[1], 1.0 / 3.0);
  EXPECT_LT(share[0], 0.5 * share[1]);
  EXPECT_GE(share[2], share[1]);
}

// The room is closed and every surface seen from inside faces the viewer (walls wound inwards,
// furniture outwards): rays from each scanning position at camera height all hit something
// within the room, front faces first.
TEST_P(BuiltinSceneTest, IsAClosedRoomSeenFromTheFront) {
  const Scene& scene = builtin(GetParam());
  const Renderer renderer(scene);
  Eigen::Vector3f lo = scene.mesh.vertices[0], hi = lo;
  for (const Eigen::Vector3f& v : scene.mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  EXPECT_EQ(lo.z(), 0.f) << "the floor is at z = 0 and nothing pokes through it";
  const double diagonal = (hi - lo).norm();
  for (const ScanPosition& position : scene.positions) {
    const Eigen::Vector3d eye = position.floor_point + Eigen::Vector3d(0, 0, 1.1);
    const int rays = 4000;
    int front_hits = 0;
    for (int i = 0; i < rays; ++i) {
      // Fibonacci sphere: evenly spread directions.
      const double z = 1.0 - 2.0 * (i + 0.5) / rays, r = std::sqrt(1.0 - z * z), phi = i * 2.399963229728653;
      const Eigen::Vector3d direction(r * std::cos(phi), r * std::sin(phi), z);
      int triangle = -1;
      const double distance = renderer.cast(eye, direction, &triangle);
      ASSERT_GT(distance, 0.0) << position.name << ": ray " << direction.transpose() << " escapes";
      ASSERT_LT(distance, diagonal);
      const Eigen::Vector3i& tri = scene.mesh.triangles[static_cast<std::size_t>(triangle)];
      const Eigen::Vector3f& a = scene.mesh.vertices[tri[0]];
      const Eigen::Vector3f normal = (scene.mesh.vertices[tri[1]] - a).cross(scene.mesh.vertices[tri[2]] - a);
      if (normal.cast<double>().dot(direction) < 0) ++front_hits;
    }
    EXPECT_GE(front_hits, rays - rays / 200) << position.name << ": surfaces wound the wrong way";
  }
}

// Nothing pokes through the walls: outside the floor's rectangle there are only the window and door
// recesses (at most 0.25 m deep) and their fittings.
TEST_P(BuiltinSceneTest, NothingPokesThroughTheWalls) {
  const Scene& scene = builtin(GetParam());
  const TriangleMesh& mesh = scene.mesh;
  // The floor: the material of the largest triangle lying on z = 0.
  std::size_t largest = 0;
  double largest_area = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3f &a = mesh.vertices[mesh.triangles[t][0]], &b = mesh.vertices[mesh.triangles[t][1]],
                          &c = mesh.vertices[mesh.triangles[t][2]];
    const double area = 0.5 * (b - a).cross(c - a).norm();
    if (a.z() == 0.f && b.z() == 0.f && c.z() == 0.f && area > largest_area) {
      largest_area = area;
      largest = t;
    }
  }
  const int floor_material = mesh.triangle_material[largest];
  Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
  float ceiling = 0.f;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& v = mesh.vertices[mesh.triangles[t][k]];
      ceiling = std::max(ceiling, v.z());
      if (mesh.triangle_material[t] != floor_material) continue;
      lo = lo.cwiseMin(v.head<2>());
      hi = hi.cwiseMax(v.head<2>());
    }
  EXPECT_GT(largest_area, 5.0) << "the floor is one big rectangle";
  EXPECT_GE(ceiling, 2.6f);
  const std::set<std::string> fittings = {"plaster",    "outdoor_view",  "outdoor_view_1", "door_leaf",
                                          "trim_paint", "brushed_steel", "ceramic_tiles"};
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& v = mesh.vertices[mesh.triangles[t][k]];
      const float outside = std::max({lo.x() - v.x(), v.x() - hi.x(), lo.y() - v.y(), v.y() - hi.y()});
      if (outside <= 1e-4f) continue;
      const std::string& material = scene.materials[static_cast<std::size_t>(mesh.triangle_material[t])].name;
      ASSERT_LE(outside, 0.25f) << material << " at " << v.transpose();
      ASSERT_TRUE(fittings.count(material)) << material << " pokes through a wall at " << v.transpose();
    }
}

// Scanning positions: in the room, clear of everything up to 1.5 m by 0.6 m around the rotation
// axis (floor coverings excepted), and the paper's pairs within 3 m of each other.
TEST_P(BuiltinSceneTest, PositionsHaveClearanceAndAreCloseEnough) {
  const Scene& scene = builtin(GetParam());
  const std::vector<std::string> expected_names = GetParam() == "living_room"
                                                      ? std::vector<std::string>{"SL-1", "SL-2"}
                                                      : std::vector<std::string>{"SO-1", "SO-2", "SO-3", "SO-4"};
  ASSERT_EQ(scene.positions.size(), expected_names.size());
  std::map<std::string, Eigen::Vector3d> at;
  for (std::size_t i = 0; i < expected_names.size(); ++i) {
    EXPECT_EQ(scene.positions[i].name, expected_names[i]);
    at[scene.positions[i].name] = scene.positions[i].floor_point;
  }
  const TriangleMesh& mesh = scene.mesh;
  for (const ScanPosition& position : scene.positions) {
    EXPECT_EQ(position.floor_point.z(), 0.0);
    // Axis samples every 2 cm from 3 cm to 1.5 m: a triangle part within 0.6 m of the axis would
    // be within 0.6 m of one of them. Floor-level triangles (floor, rug) are not obstacles.
    double clearance = 1e9;
    std::string nearest;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const Eigen::Vector3d a = mesh.vertices[mesh.triangles[t][0]].cast<double>();
      const Eigen::Vector3d b = mesh.vertices[mesh.triangles[t][1]].cast<double>();
      const Eigen::Vector3d c = mesh.vertices[mesh.triangles[t][2]].cast<double>();
      if (std::max({a.z(), b.z(), c.z()}) < 0.03) continue;
      const Eigen::Vector2d p = position.floor_point.head<2>();
      const double horizontal =
          std::min({(a.head<2>() - p).norm(), (b.head<2>() - p).norm(), (c.head<2>() - p).norm()});
      const double span = std::max({(a - b).norm(), (b - c).norm(), (c - a).norm()});
      if (horizontal - span > 1.0) continue;  // far away: cannot be within 0.6 m
      for (double h = 0.03; h <= 1.5 + 1e-9; h += 0.02) {
        const double d = point_triangle_distance(Eigen::Vector3d(p.x(), p.y(), h), a, b, c);
        if (d < clearance) {
          clearance = d;
          nearest = scene.materials[static_cast<std::size_t>(mesh.triangle_material[t])].name;
        }
      }
    }
    EXPECT_GE(clearance, 0.6) << position.name << " is " << clearance << " m from " << nearest;
    std::printf("[ position ] %s at (%.2f, %.2f): clearance %.2f m (nearest: %s)\n", position.name.c_str(),
                position.floor_point.x(), position.floor_point.y(), clearance, nearest.c_str());
  }
  const std::vector<std::pair<std::string, std::string>> pairs =
      GetParam() == "living_room" ? std::vector<std::pair<std::string, std::string>>{{"SL-1", "SL-2"}}
                                  : std::vector<std::pair<std::string, std::string>>{
                                        {"SO-1", "SO-3"}, {"SO-1", "SO-4"}, {"SO-2", "SO-3"}, {"SO-2", "SO-4"}};
  for (const auto& [first, second] : pairs) {
    const double distance = (at[first] - at[second]).norm();
    EXPECT_LE(distance, 3.0) << first << "-" << second;
    EXPECT_GE(distance, 1.0) << first << "-" << second;
  }
}

// Texture richness of the rich density as the tracker sees it: views of the three sensors (pitch +45, 0, -45 degrees,
// 1.1 m above the floor, fx = 570 at 640x480) all round each position, rendered by the simulator's
// renderer, average at least 300 ORB keypoints with OpenCV's defaults.
TEST_P(BuiltinSceneTest, RenderedViewsHaveEnoughOrbKeypoints) {
  const Scene& scene = rich(GetParam());
  const Renderer renderer(scene);
  const PinholeIntrinsics intrinsics;
  for (const ScanPosition& position : scene.positions) {
    const Eigen::Vector3d eye = position.floor_point + Eigen::Vector3d(0, 0, 1.1);
    int total = 0, views = 0, fewest = 1 << 30;
    std::string per_pitch;
    for (double pitch_deg : {45.0, 0.0, -45.0}) {
      int pitch_total = 0, pitch_views = 0;
      for (int k = 0; k < 8; ++k) {
        const double heading = position.start_heading_rad + 2.0 * kPi * k / 8.0;
        const RenderedView view = renderer.render(camera_pose(eye, heading, pitch_deg * kPi / 180.0), intrinsics);
        const cv::Mat rgb(view.rgb.height, view.rgb.width, CV_8UC3, const_cast<std::uint8_t*>(view.rgb.data.data()));
        const int count = orb_keypoints(rgb);
        pitch_total += count;
        ++pitch_views;
        fewest = std::min(fewest, count);
      }
      total += pitch_total;
      views += pitch_views;
      per_pitch += " " + std::to_string(pitch_total / pitch_views);
    }
    const double mean = static_cast<double>(total) / views;
    std::printf("[ orb      ] %s: mean %.0f keypoints per view (pitch +45/0/-45:%s), fewest %d\n",
                position.name.c_str(), mean, per_pitch.c_str(), fewest);
    EXPECT_GE(mean, 300.0) << position.name;
    EXPECT_GE(fewest, 120) << position.name;
  }
}

// Each texture of the rich density on its own (tiled to 640x480 if smaller) carries plenty of ORB
// corners.
TEST_P(BuiltinSceneTest, TexturesAreRichInOrbKeypoints) {
  const Scene& scene = rich(GetParam());
  std::string summary;
  for (const Texture& texture : scene.textures) {
    const cv::Mat image(texture.height, texture.width, CV_8UC3, const_cast<std::uint8_t*>(texture.rgb.data()));
    cv::Mat tiled;
    cv::repeat(image, (480 + texture.height - 1) / texture.height, (640 + texture.width - 1) / texture.width, tiled);
    const int count = orb_keypoints(tiled(cv::Rect(0, 0, 640, 480)));
    EXPECT_GE(count, 150) << texture.name;
    summary += " " + texture.name + "=" + std::to_string(count);
  }
  std::printf("[ orb      ] textures of %s:%s\n", scene.name.c_str(), summary.c_str());
}

INSTANTIATE_TEST_SUITE_P(Scenes, BuiltinSceneTest, ::testing::Values("living_room", "office"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

// ------------------------------------------------------------------------------------------------
// Export and reload.

// Counts the triangles of `expected` that have no counterpart in `actual`: same material name and,
// in the same cyclic order (any starting corner), corners within `position_tolerance` and texture
// coordinates within `uv_tolerance`. Triangles are matched through a grid of their centroids, since
// a reader may reorder them and round the last digit of a coordinate.
int unmatched_triangles(const Scene& expected, const Scene& actual, float position_tolerance, float uv_tolerance) {
  const float cell = 0.01f;
  auto centroid_cell = [&](const TriangleMesh& mesh, std::size_t t) {
    const Eigen::Vector3f c = (mesh.vertices[mesh.triangles[t][0]] + mesh.vertices[mesh.triangles[t][1]] +
                               mesh.vertices[mesh.triangles[t][2]]) /
                              3.f;
    return Eigen::Vector3i(int(std::floor(c.x() / cell)), int(std::floor(c.y() / cell)), int(std::floor(c.z() / cell)));
  };
  auto key = [](const Eigen::Vector3i& c) { return std::make_tuple(c.x(), c.y(), c.z()); };
  std::map<std::tuple<int, int, int>, std::vector<std::size_t>> grid;
  for (std::size_t t = 0; t < actual.mesh.triangles.size(); ++t) grid[key(centroid_cell(actual.mesh, t))].push_back(t);
  std::vector<bool> used(actual.mesh.triangles.size(), false);
  auto same = [&](std::size_t e, std::size_t a, int rotation) {
    const TriangleMesh& em = expected.mesh;
    const TriangleMesh& am = actual.mesh;
    if (expected.materials[std::size_t(em.triangle_material[e])].name !=
        actual.materials[std::size_t(am.triangle_material[a])].name)
      return false;
    for (int k = 0; k < 3; ++k) {
      const int ka = (k + rotation) % 3;
      if ((em.vertices[em.triangles[e][k]] - am.vertices[am.triangles[a][ka]]).cwiseAbs().maxCoeff() >
          position_tolerance)
        return false;
      if ((em.corner_uvs[3 * e + k] - am.corner_uvs[3 * a + ka]).cwiseAbs().maxCoeff() > uv_tolerance) return false;
    }
    return true;
  };
  int unmatched = 0;
  for (std::size_t e = 0; e < expected.mesh.triangles.size(); ++e) {
    const Eigen::Vector3i c = centroid_cell(expected.mesh, e);
    bool found = false;
    for (int dx = -1; dx <= 1 && !found; ++dx)
      for (int dy = -1; dy <= 1 && !found; ++dy)
        for (int dz = -1; dz <= 1 && !found; ++dz) {
          auto bucket = grid.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (bucket == grid.end()) continue;
          for (std::size_t a : bucket->second) {
            if (used[a]) continue;
            for (int rotation = 0; rotation < 3 && !found; ++rotation)
              if (same(e, a, rotation)) {
                used[a] = true;
                found = true;
              }
            if (found) break;
          }
        }
    unmatched += found ? 0 : 1;
  }
  return unmatched;
}

class ExportTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ExportTest, ExportThenLoadGivesTheSameScene) {
  const Scene& scene = builtin(GetParam());
  TempDir dir("scene-export");
  scenes::export_scene(scene, dir.path());
  const std::string stem = scene.name;
  for (const std::string& file : {stem + ".obj", stem + ".mtl", stem + "_groundtruth.ply", stem + ".positions.json"})
    EXPECT_TRUE(fs::is_regular_file(dir / file)) << file;
  for (const Texture& texture : scene.textures)
    EXPECT_TRUE(fs::is_regular_file(dir.path() / "textures" / (texture.name + ".png"))) << texture.name;
  for (const auto& entry : fs::recursive_directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << "left over: " << entry.path();

  // The ground-truth PLY is the mesh itself.
  const TriangleMesh ground_truth = read_ply_mesh(dir / (stem + "_groundtruth.ply"));
  EXPECT_TRUE(ground_truth.vertices == scene.mesh.vertices);
  EXPECT_TRUE(ground_truth.triangles == scene.mesh.triangles);

  const Scene loaded = load_scene_file(dir / (stem + ".obj"));
  EXPECT_EQ(loaded.name, scene.name);
  ASSERT_EQ(loaded.mesh.num_triangles(), scene.mesh.num_triangles());
  ASSERT_EQ(loaded.materials.size(), scene.materials.size());
  for (std::size_t m = 0; m < scene.materials.size(); ++m) {
    EXPECT_EQ(loaded.materials[m].name, scene.materials[m].name);
    EXPECT_TRUE(loaded.materials[m].albedo.isApprox(scene.materials[m].albedo, 1e-6f));
    ASSERT_EQ(loaded.materials[m].texture >= 0, scene.materials[m].texture >= 0) << scene.materials[m].name;
    if (scene.materials[m].texture < 0) continue;
    const Texture& original = scene.textures[static_cast<std::size_t>(scene.materials[m].texture)];
    const Texture& reloaded = loaded.textures[static_cast<std::size_t>(loaded.materials[m].texture)];
    EXPECT_EQ(reloaded.name, original.name);
    EXPECT_TRUE(reloaded.rgb == original.rgb) << original.name;
  }
  EXPECT_EQ(loaded.textures.size(), scene.textures.size());
  // Same triangles (reordered by material in the OBJ), geometry within 1e-5 m.
  EXPECT_EQ(unmatched_triangles(scene, loaded, 1e-5f, 1e-4f), 0);
  ASSERT_EQ(loaded.positions.size(), scene.positions.size());
  for (std::size_t i = 0; i < scene.positions.size(); ++i) {
    EXPECT_EQ(loaded.positions[i].name, scene.positions[i].name);
    EXPECT_TRUE(loaded.positions[i].floor_point.isApprox(scene.positions[i].floor_point, 1e-9));
    EXPECT_NEAR(loaded.positions[i].start_heading_rad, scene.positions[i].start_heading_rad, 1e-9);
  }
  ASSERT_EQ(loaded.lights.size(), scene.lights.size());
  for (std::size_t i = 0; i < scene.lights.size(); ++i) {
    EXPECT_TRUE(loaded.lights[i].position.isApprox(scene.lights[i].position, 1e-6f));
    EXPECT_FLOAT_EQ(loaded.lights[i].intensity, scene.lights[i].intensity);
  }

  // The same geometry through assimp's PLY reader, with a shared positions.json.
  fs::copy_file(dir / (stem + ".positions.json"), dir / "positions.json");
  const Scene from_ply = load_scene_file(dir / (stem + "_groundtruth.ply"));
  EXPECT_EQ(from_ply.mesh.num_triangles(), scene.mesh.num_triangles());
}

INSTANTIATE_TEST_SUITE_P(Scenes, ExportTest, ::testing::Values("living_room", "office"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

// ------------------------------------------------------------------------------------------------
// Loading scene files.

const char* kPositionsJson = R"({"format": "panoscan-positions", "version": 1,
  "positions": [{"name": "P-1", "floor_point": [0.5, 0.5, 0.0], "start_heading_deg": 90}],
  "lights": [{"position": [0.5, 0.5, 2.0], "intensity": 0.5}]})";

// One textured quad (two triangles) in an OBJ file with its MTL and a 4x2 PNG texture.
void write_quad_obj(const fs::path& dir, const std::string& stem) {
  ImageU8 image(4, 2, 3);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = static_cast<std::uint8_t>(40 * x + 100 * y + c);
  write_png(dir / "quad.png", image);
  write_text(dir / (stem + ".mtl"), "newmtl painted\nKd 0.5 1 1\nmap_Kd quad.png\n");
  write_text(dir / (stem + ".obj"), "mtllib " + stem +
                                        ".mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 2 0\nvt 2 1\nvt 0 1\n"
                                        "usemtl painted\nf 1/1 2/2 3/3 4/4\n");
}

TEST(LoadScene, ReadsObjWithMaterialTextureAndPositions) {
  TempDir dir("load-scene");
  write_quad_obj(dir.path(), "quad");
  write_text(dir / "quad.positions.json", kPositionsJson);
  const Scene scene = load_scene(dir / "quad.obj");
  EXPECT_EQ(scene.name, "quad");
  ASSERT_EQ(scene.mesh.num_triangles(), 2u);  // the quad is triangulated
  ASSERT_EQ(scene.materials.size(), 1u);
  EXPECT_EQ(scene.materials[0].name, "painted");
  EXPECT_TRUE(scene.materials[0].albedo.isApprox(Eigen::Vector3f(0.5f, 1.f, 1.f)));
  ASSERT_EQ(scene.textures.size(), 1u);
  EXPECT_EQ(scene.textures[0].width, 4);
  EXPECT_EQ(scene.textures[0].rgb[3 * 5], 40 * 1 + 100 * 1);  // pixel (1, 1), row 0 at the top
  // Texture coordinates follow their corners.
  for (std::size_t t = 0; t < 2; ++t)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& p = scene.mesh.vertices[scene.mesh.triangles[t][k]];
      EXPECT_TRUE(scene.mesh.corner_uvs[3 * t + k].isApprox(Eigen::Vector2f(2.f * p.x(), p.y())));
    }
  ASSERT_EQ(scene.positions.size(), 1u);
  EXPECT_EQ(scene.positions[0].name, "P-1");
  EXPECT_NEAR(scene.positions[0].start_heading_rad, kPi / 2, 1e-12);
  ASSERT_EQ(scene.lights.size(), 1u);
  EXPECT_FLOAT_EQ(scene.lights[0].intensity, 0.5f);
}

TEST(LoadScene, BuiltinByName) {
  const Scene scene = load_scene("living_room");
  EXPECT_EQ(scene.name, "living_room");
  expect_error([] { load_scene("no_such_scene_or_file"); }, {"no_such_scene_or_file", "living_room"});
}

// glTF: node transforms applied, texture coordinates converted to the OBJ convention.
TEST(LoadScene, ReadsGltfWithNodeTransform) {
  TempDir dir("load-scene");
  ImageU8 image(2, 2, 3, 128);
  write_png(dir / "tex.png", image);
  // One triangle: positions (3 x vec3 float), uvs (3 x vec2 float), indices (3 x uint16 + pad).
  std::string buffer;
  auto put = [&](const void* data, std::size_t size) { buffer.append(static_cast<const char*>(data), size); };
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float uvs[6] = {0, 0, 1, 0, 0, 1};
  const std::uint16_t indices[4] = {0, 1, 2, 0};
  put(positions, sizeof(positions));
  put(uvs, sizeof(uvs));
  put(indices, sizeof(indices));
  write_text(dir / "tri.bin", buffer);
  write_text(dir / "tri.gltf", R"({
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "translation": [10, 20, 30]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "tri_material", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "textures": [{"source": 0}], "images": [{"uri": "tex.png"}],
    "buffers": [{"uri": "tri.bin", "byteLength": 68}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                    {"buffer": 0, "byteOffset": 60, "byteLength": 6}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                  {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}]})");
  write_text(dir / "positions.json", kPositionsJson);
  const Scene scene = load_scene_file(dir / "tri.gltf");
  ASSERT_EQ(scene.mesh.num_triangles(), 1u);
  ASSERT_EQ(scene.textures.size(), 1u);
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3f& p = scene.mesh.vertices[scene.mesh.triangles[0][k]];
    EXPECT_NEAR(p.z(), 30.f, 1e-5f);
    // glTF's (0, 0) is the top-left of the image: v = 1 in the OBJ convention.
    const Eigen::Vector2f& uv = scene.mesh.corner_uvs[static_cast<std::size_t>(k)];
    const Eigen::Vector2f local(p.x() - 10.f, p.y() - 20.f);
    EXPECT_NEAR(uv.x(), local.x(), 1e-6f);
    EXPECT_NEAR(uv.y(), 1.f - local.y(), 1e-6f);
  }
}

// glTF with the texture image inside its buffer (as GLB files carry them).
TEST(LoadScene, ReadsGltfWithEmbeddedTexture) {
  TempDir dir("load-scene");
  ImageU8 image(3, 2, 3);
  for (std::size_t i = 0; i < image.data.size(); ++i) image.data[i] = static_cast<std::uint8_t>(10 * i);
  write_png(dir / "source.png", image);
  std::ifstream png_in(dir / "source.png", std::ios::binary);
  const std::string png((std::istreambuf_iterator<char>(png_in)), std::istreambuf_iterator<char>());
  fs::remove(dir / "source.png");
  std::string buffer;
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float uvs[6] = {0, 0, 1, 0, 0, 1};
  const std::uint16_t indices[4] = {0, 1, 2, 0};
  buffer.append(reinterpret_cast<const char*>(positions), sizeof(positions));
  buffer.append(reinterpret_cast<const char*>(uvs), sizeof(uvs));
  buffer.append(reinterpret_cast<const char*>(indices), sizeof(indices));
  buffer += png;
  write_text(dir / "embedded.bin", buffer);
  write_text(dir / "embedded.gltf", R"({
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "embedded_material", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "textures": [{"source": 0}], "images": [{"bufferView": 3, "mimeType": "image/png"}],
    "buffers": [{"uri": "embedded.bin", "byteLength": )" +
                                        std::to_string(buffer.size()) + R"(}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                    {"buffer": 0, "byteOffset": 60, "byteLength": 6},
                    {"buffer": 0, "byteOffset": 68, "byteLength": )" +
                                        std::to_string(png.size()) + R"(}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                  {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}]})");
  write_text(dir / "positions.json", kPositionsJson);
  const Scene scene = load_scene_file(dir / "embedded.gltf");
  ASSERT_EQ(scene.textures.size(), 1u);
  EXPECT_EQ(scene.textures[0].width, 3);
  EXPECT_EQ(scene.textures[0].height, 2);
  EXPECT_TRUE(
      std::equal(scene.textures[0].rgb.begin(), scene.textures[0].rgb.end(), image.data.begin(), image.data.end()));
  ASSERT_EQ(scene.materials.size(), 1u);
  EXPECT_EQ(scene.materials[0].texture, 0);
}

// A 4 m x 4 m x 2.5 m room coloured only per vertex (no material, no texture), as scanned rooms in
// public datasets come: each face its own four vertices; the floor green, the ceiling grey, the
// north wall (y = 4) red at its west end grading to blue at its east end, the other walls yellow.
// ASCII PLY with uchar red/green/blue.
void write_vertex_coloured_room(const fs::path& path) {
  struct Face {
    Eigen::Vector3f corners[4];
    Eigen::Vector3i colours[4];
  };
  const float w = 4.f, h = 2.5f;
  const Eigen::Vector3i green(40, 200, 40), grey(180, 180, 180), red(230, 20, 20), blue(20, 20, 230),
      yellow(220, 200, 40);
  // Corners counter-clockwise seen from inside the room.
  const std::vector<Face> faces = {
      {{{0, 0, 0}, {w, 0, 0}, {w, w, 0}, {0, w, 0}}, {green, green, green, green}},
      {{{0, 0, h}, {0, w, h}, {w, w, h}, {w, 0, h}}, {grey, grey, grey, grey}},
      {{{0, w, 0}, {w, w, 0}, {w, w, h}, {0, w, h}}, {red, blue, blue, red}},
      {{{w, 0, 0}, {0, 0, 0}, {0, 0, h}, {w, 0, h}}, {yellow, yellow, yellow, yellow}},
      {{{0, 0, 0}, {0, w, 0}, {0, w, h}, {0, 0, h}}, {yellow, yellow, yellow, yellow}},
      {{{w, w, 0}, {w, 0, 0}, {w, 0, h}, {w, w, h}}, {yellow, yellow, yellow, yellow}},
  };
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 24\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 6\n"
      "property list uchar int vertex_indices\nend_header\n";
  for (const Face& face : faces)
    for (int k = 0; k < 4; ++k)
      ply += std::to_string(face.corners[k].x()) + " " + std::to_string(face.corners[k].y()) + " " +
             std::to_string(face.corners[k].z()) + " " + std::to_string(face.colours[k].x()) + " " +
             std::to_string(face.colours[k].y()) + " " + std::to_string(face.colours[k].z()) + "\n";
  for (int f = 0; f < 6; ++f)
    ply += "4 " + std::to_string(4 * f) + " " + std::to_string(4 * f + 1) + " " + std::to_string(4 * f + 2) + " " +
           std::to_string(4 * f + 3) + "\n";
  write_text(path, ply);
}

TEST(LoadScene, PerVertexColourIsRenderedInterpolated) {
  TempDir dir("vertex-colour");
  write_vertex_coloured_room(dir / "room.ply");
  write_text(dir / "room.positions.json", R"({"format": "panoscan-positions", "version": 1,
    "positions": [{"name": "R-1", "floor_point": [2.0, 1.0, 0.0]}],
    "lights": [{"position": [2.0, 2.0, 2.3], "intensity": 1.0}]})");
  const Scene scene = load_scene_file(dir / "room.ply");
  ASSERT_EQ(scene.mesh.vertex_colours.size(), scene.mesh.vertices.size());
  // Corners shared by differently coloured faces keep each face's colour.
  std::set<std::vector<float>> floor_colours;
  for (std::size_t i = 0; i < scene.mesh.vertices.size(); ++i)
    if (scene.mesh.vertices[i].z() == 0.f) {
      const Eigen::Vector3f c = 255.f * scene.mesh.vertex_colours[i];
      floor_colours.insert({std::round(c.x()), std::round(c.y()), std::round(c.z())});
    }
  EXPECT_EQ(floor_colours, (std::set<std::vector<float>>{{40, 200, 40}, {230, 20, 20}, {20, 20, 230}, {220, 200, 40}}));
  // The same colours through our own PLY reader.
  const TriangleMesh own = read_ply_mesh(dir / "room.ply");
  ASSERT_EQ(own.vertex_colours.size(), 24u);
  EXPECT_TRUE(own.vertex_colours[8].isApprox(Eigen::Vector3f(230, 20, 20) / 255.f, 1e-6f));

  // Looking north at the wall 3 m away: red on the left, blue on the right, purple between, the
  // floor green below; never the default grey. Colour ratios do not depend on the shading.
  const Renderer renderer(scene);
  PinholeIntrinsics k;
  k.width = 160;
  k.height = 120;
  k.fx = k.fy = 80;
  k.cx = 79.5;
  k.cy = 59.5;
  const RenderedView view = renderer.render(camera_pose(Eigen::Vector3d(2.0, 1.0, 1.2), kPi / 2, 0.0), k);
  auto rgb = [&](int x, int y) {
    return Eigen::Vector3f(view.rgb.at(x, y, 0), view.rgb.at(x, y, 1), view.rgb.at(x, y, 2));
  };
  // The wall spans x in [0, 4] at y = 4: 3 m ahead, 2 m either side, so columns 27..133.
  const Eigen::Vector3f left = rgb(35, 60), middle = rgb(80, 60), right = rgb(125, 60), floor = rgb(80, 115);
  EXPECT_GT(left.x(), 3.f * left.z()) << left.transpose();
  EXPECT_GT(right.z(), 3.f * right.x()) << right.transpose();
  EXPECT_NEAR(middle.x() / middle.z(), 1.f, 0.15f) << middle.transpose();
  EXPECT_LT(middle.y(), 0.3f * middle.x()) << middle.transpose();
  EXPECT_GT(floor.y(), 3.f * floor.x()) << floor.transpose();
  // Interpolated: red falls and blue rises monotonically across the wall.
  float previous_red = 1e9f, previous_blue = -1.f;
  for (int x = 30; x <= 130; x += 10) {
    const Eigen::Vector3f c = rgb(x, 60);
    EXPECT_LE(c.x() / (c.x() + c.z()), previous_red + 1e-3f);
    EXPECT_GE(c.z() / (c.x() + c.z()), previous_blue - 1e-3f);
    previous_red = c.x() / (c.x() + c.z());
    previous_blue = c.z() / (c.x() + c.z());
  }

  // Export writes the colours (OBJ "v x y z r g b", the ground-truth PLY) and they load back.
  scenes::export_scene(scene, dir / "export");
  const Scene reloaded = load_scene_file(dir / "export" / "room.obj");
  ASSERT_EQ(reloaded.mesh.vertex_colours.size(), reloaded.mesh.vertices.size());
  EXPECT_EQ(unmatched_triangles(scene, reloaded, 1e-5f, 1e-4f), 0);
  for (std::size_t i = 0; i < reloaded.mesh.vertices.size(); ++i) {
    // Find the same position in the original and compare colours (positions on the north wall are
    // shared by faces of other colours: compare only the wall's interior-free corners by face).
    const Eigen::Vector3f& p = reloaded.mesh.vertices[i];
    bool matched = false;
    for (std::size_t j = 0; j < scene.mesh.vertices.size() && !matched; ++j)
      matched = (scene.mesh.vertices[j] - p).norm() < 1e-5f &&
                (scene.mesh.vertex_colours[j] - reloaded.mesh.vertex_colours[i]).norm() < 1e-5f;
    EXPECT_TRUE(matched) << "vertex " << i << " at " << p.transpose();
  }
  const TriangleMesh ground_truth = read_ply_mesh(dir / "export" / "room_groundtruth.ply");
  ASSERT_EQ(ground_truth.vertex_colours.size(), ground_truth.vertices.size());
  for (std::size_t i = 0; i < ground_truth.vertices.size(); ++i)
    EXPECT_LT((ground_truth.vertex_colours[i] - scene.mesh.vertex_colours[i]).cwiseAbs().maxCoeff(),
              0.5f / 255.f + 1e-6f);
}

// glTF's COLOR_0 is read as per-vertex colour too.
TEST(LoadScene, ReadsGltfVertexColours) {
  TempDir dir("load-scene");
  std::string buffer;
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float colours[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::uint16_t indices[4] = {0, 1, 2, 0};
  buffer.append(reinterpret_cast<const char*>(positions), sizeof(positions));
  buffer.append(reinterpret_cast<const char*>(colours), sizeof(colours));
  buffer.append(reinterpret_cast<const char*>(indices), sizeof(indices));
  write_text(dir / "tri.bin", buffer);
  write_text(dir / "tri.gltf", R"({
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2}]}],
    "buffers": [{"uri": "tri.bin", "byteLength": 80}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 72, "byteLength": 6}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                  {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}]})");
  write_text(dir / "positions.json", kPositionsJson);
  const Scene scene = load_scene_file(dir / "tri.gltf");
  ASSERT_EQ(scene.mesh.num_triangles(), 1u);
  ASSERT_EQ(scene.mesh.vertex_colours.size(), scene.mesh.vertices.size());
  for (std::size_t i = 0; i < scene.mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& p = scene.mesh.vertices[i];
    const Eigen::Vector3f expected = p.x() > 0.5f   ? Eigen::Vector3f(0, 1, 0)
                                     : p.y() > 0.5f ? Eigen::Vector3f(0, 0, 1)
                                                    : Eigen::Vector3f(1, 0, 0);
    EXPECT_TRUE(scene.mesh.vertex_colours[i].isApprox(expected, 1e-6f)) << p.transpose();
  }
}

TEST(LoadScene, VertexColoursAreValidated) {
  Scene scene;
  scene.mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  scene.mesh.triangles = {{0, 1, 2}};
  scene.mesh.vertex_colours = {{1, 0, 0}, {0, 1, 0}};
  expect_error([&] { scene.check("three"); }, {"three", "vertex colours", "one per vertex"});
  scene.mesh.vertex_colours.push_back({0, 0, 2});
  expect_error([&] { scene.check("three"); }, {"vertex colour 2", "[0, 1]"});
  scene.mesh.vertex_colours.back() = {0, 0, 1};
  EXPECT_NO_THROW(scene.check("three"));
}

TEST(LoadScene, MissingFile) {
  TempDir dir("load-scene");
  const fs::path missing = dir / "absent.obj";
  expect_error([&] { load_scene_file(missing); }, {"absent.obj"});
  expect_error([&] { load_scene(missing.string()); }, {"absent.obj"});
}

TEST(LoadScene, MissingPositionsFile) {
  TempDir dir("load-scene");
  write_quad_obj(dir.path(), "quad");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.obj", "quad.positions.json"});
}

TEST(LoadScene, CorruptObj) {
  TempDir dir("load-scene");
  std::string garbage = "v 0 0 0\nf 1 2 3 4 5\n";
  for (int i = 0; i < 256; ++i) garbage += static_cast<char>((i * 37) & 0xff);
  write_text(dir / "corrupt.obj", garbage);
  write_text(dir / "positions.json", kPositionsJson);
  expect_error([&] { load_scene_file(dir / "corrupt.obj"); }, {"corrupt.obj"});
}

TEST(LoadScene, ObjWithoutFaces) {
  TempDir dir("load-scene");
  write_text(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  write_text(dir / "positions.json", kPositionsJson);
  expect_error([&] { load_scene_file(dir / "points.obj"); }, {"points.obj"});
}

TEST(LoadScene, BadTexture) {
  TempDir dir("load-scene");
  write_quad_obj(dir.path(), "quad");
  write_text(dir / "quad.png", "this is not a PNG");
  write_text(dir / "quad.positions.json", kPositionsJson);
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.obj", "quad.png", "painted"});
}

TEST(LoadScene, BadPositionsFile) {
  TempDir dir("load-scene");
  write_quad_obj(dir.path(), "quad");
  const fs::path positions = dir / "quad.positions.json";
  write_text(positions, R"({"format": "panoscan-positions", "version": 1, "positions": [{"name": "P-1"}]})");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.positions.json", "positions[0].floor_point"});
  write_text(positions, R"({"format": "panoscan-positions", "version": 1,
    "positions": [{"name": "P-1", "floor_point": [0, 0, "x"]}]})");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.positions.json", "positions[0].floor_point[2]"});
  write_text(positions, R"({"format": "panoscan-positions", "version": 2, "positions": []})");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.positions.json", "version"});
  write_text(positions, R"({"format": "panoscan-positions", "version": 1, "positions": [
    {"name": "P-1", "floor_point": [0, 0, 0]}], "lights": [{"intensity": 1}]})");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.positions.json", "lights[0].position"});
  write_text(positions, "{ not json");
  expect_error([&] { load_scene_file(dir / "quad.obj"); }, {"quad.positions.json", "JSON"});
}

}  // namespace
}  // namespace panoscan
