// The renderer and the simulator: exact ground truth (depth, normals, ids), determinism, bad input.
#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/scan.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

using namespace panoscan;
namespace fs = std::filesystem;

namespace {

SimOptions small_options() {
  SimOptions options;
  options.rig.width = 80;
  options.rig.height = 60;
  options.output.every = 90;  // 11 frames per camera over the whole turn
  options.seed = 21;
  return options;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The box room without its ceiling (rays out of the top hit nothing), each of its five faces in
// one of four materials, so that material ids differ across the room and from the triangle ids.
Scene open_top_room() {
  Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  scene.materials.push_back({"floor", {0.5f, 0.4f, 0.3f}, -1});
  scene.materials.push_back({"paint", {0.9f, 0.9f, 0.8f}, -1});
  scene.materials.push_back({"tiles", {1.f, 1.f, 1.f}, 0});
  TriangleMesh& mesh = scene.mesh;
  // make_box_room emits two triangles per face: floor, ceiling, then the walls y0, x1, y1, x0.
  const int face_material[6] = {1, -1, 3, 0, 2, 3};
  TriangleMesh open = mesh;
  open.triangles.clear(), open.triangle_material.clear(), open.corner_uvs.clear();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (face_material[t / 2] < 0) continue;
    open.triangles.push_back(mesh.triangles[t]);
    open.triangle_material.push_back(face_material[t / 2]);
    for (int k = 0; k < 3; ++k) open.corner_uvs.push_back(mesh.corner_uvs[3 * t + k]);
  }
  mesh = open;
  return scene;
}

// world_from_cam of a camera at `eye` looking along `forward` with the image's up towards +z (camera
// frame x right, y down, z forward).
Rigid3d camera_looking(const Eigen::Vector3d& eye, const Eigen::Vector3d& forward) {
  Eigen::Matrix3d rotation;
  rotation.col(2) = forward.normalized();
  rotation.col(0) = rotation.col(2).cross(Eigen::Vector3d::UnitZ()).normalized();
  rotation.col(1) = rotation.col(2).cross(rotation.col(0));
  return make_rigid(rotation, eye);
}

// The mesh's unit normal of triangle `id` (counter-clockwise), in the world frame.
Eigen::Vector3d triangle_normal(const TriangleMesh& mesh, int id) {
  const auto& tri = mesh.triangles[id];
  const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>(), b = mesh.vertices[tri[1]].cast<double>(),
                        c = mesh.vertices[tri[2]].cast<double>();
  return (b - a).cross(c - a).normalized();
}

// Checks normals against the mesh: each hit pixel's normal is its triangle's normal rotated into
// the camera frame and faces the camera; pixels without a hit have zero normal. `sign`: +1 if the
// camera sees the triangles' fronts (counter-clockwise side), -1 their backs, 0 either. Returns
// {hits, misses}.
std::pair<int, int> check_normals_against_mesh(const Scene& scene, const ImageF32& normal_cam,
                                               const ImageI32& triangle_id, const Rigid3d& world_from_cam,
                                               const PinholeIntrinsics& k, double sign) {
  EXPECT_EQ(normal_cam.width, k.width);
  EXPECT_EQ(normal_cam.height, k.height);
  EXPECT_EQ(normal_cam.channels, 3);
  if (normal_cam.data.size() != std::size_t(k.width) * k.height * 3) return {0, 0};
  int hits = 0, misses = 0;
  const Eigen::Matrix3d cam_from_world = world_from_cam.linear().transpose();
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d normal(normal_cam.at(x, y, 0), normal_cam.at(x, y, 1), normal_cam.at(x, y, 2));
      const int id = triangle_id.at(x, y);
      if (id < 0) {
        EXPECT_EQ(normal, Eigen::Vector3d::Zero()) << "pixel " << x << "," << y;
        ++misses;
        continue;
      }
      ++hits;
      const Eigen::Vector3d ray = k.backproject(x, y, 1.0);
      Eigen::Vector3d expected = cam_from_world * triangle_normal(scene.mesh, id);
      if (sign != 0.0) {
        expected *= sign;
      } else if (expected.dot(ray) > 0.0) {
        expected = -expected;
      }
      EXPECT_LT((normal - expected).norm(), 1e-5)
          << "pixel " << x << "," << y << ": " << normal.transpose() << " vs " << expected.transpose();
      EXPECT_LT(normal.dot(ray), 0.0) << "pixel " << x << "," << y << " faces away from the camera";
      if (::testing::Test::HasFailure()) return {hits, misses};  // one pixel's report is enough
    }
  return {hits, misses};
}

SimOptions ground_truth_options() {
  SimOptions options = small_options();
  options.output.normals = true;
  options.output.ids = true;
  return options;
}

}  // namespace

TEST(Renderer, DepthIsZAlongTheOpticalAxisAndIdsAreTheHitTriangles) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  const Renderer renderer(scene);
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(64, 48);
  const Rigid3d pose = make_rigid(so3_exp(Eigen::Vector3d(1.4, 0.3, -0.5)), Eigen::Vector3d(0.3, 0.2, 1.2));
  const RenderedView view = renderer.render(pose, k);
  int checked = 0;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const int id = view.triangle_id.at(x, y);
      ASSERT_GE(id, 0) << "closed room: every ray hits";
      const Eigen::Vector3d point = pose * k.backproject(x, y, view.depth.at(x, y));
      const auto& tri = scene.mesh.triangles[id];
      const auto& v = scene.mesh.vertices;
      const double d =
          point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(), v[tri[2]].cast<double>());
      ASSERT_LT(d, 1e-4) << "pixel " << x << "," << y;
      ++checked;
    }
  EXPECT_EQ(checked, 64 * 48);
}

TEST(Renderer, NormalsAreTheHitTrianglesInTheCameraFrameFacingTheCamera) {
  const Scene scene = open_top_room();
  const Renderer renderer(scene);
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(64, 48);
  RenderRequest request;
  request.normals = true;
  // Inside, looking up 35 degrees towards the x1 wall: wall, side walls and the open top. The room's
  // faces are wound towards its inside, so seen from inside they face the camera as they are.
  const Rigid3d inside = camera_looking(Eigen::Vector3d(0.3, 0.2, 1.2), Eigen::Vector3d(1.0, 0.1, 0.7));
  const RenderedView view = renderer.render(inside, k, request);
  ASSERT_EQ(view.normal_cam.channels, 3);
  const auto [hits, misses] = check_normals_against_mesh(scene, view.normal_cam, view.triangle_id, inside, k, +1.0);
  for (std::size_t i = 0; i < view.depth.data.size(); ++i)
    ASSERT_EQ(view.depth.data[i] == 0.f, view.triangle_id.data[i] < 0) << "pixel " << i;
  EXPECT_GT(hits, k.width * k.height / 10);
  EXPECT_GT(misses, k.width * k.height / 10);
  // Outside, looking at the back of the x1 wall: the normal is turned round to face the camera.
  const Rigid3d outside = camera_looking(Eigen::Vector3d(6.0, -0.3, 1.0), Eigen::Vector3d(-1.0, 0.2, 0.05));
  const RenderedView back = renderer.render(outside, k, request);
  EXPECT_GT(check_normals_against_mesh(scene, back.normal_cam, back.triangle_id, outside, k, -1.0).first,
            k.width * k.height / 2);
  // The same rays without normals: no normal image, and everything else unchanged.
  const RenderedView plain = renderer.render(inside, k);
  EXPECT_TRUE(plain.normal_cam.empty());
  EXPECT_EQ(plain.depth.data, view.depth.data);
  EXPECT_EQ(plain.rgb.data, view.rgb.data);
  EXPECT_EQ(plain.triangle_id.data, view.triangle_id.data);
  // render_rows with normals into a view allocated without them is refused, not a buffer overrun.
  RenderedView unallocated = Renderer::allocate(k);
  EXPECT_THROW(renderer.render_rows(inside, k, 0, 1, unallocated, request), Error);
}

// render() shades a row four pixels per SSE operation; it must give, bit for bit, what the scalar
// per-pixel shading gives (render_per_pixel): depth, incidence, ids, normals and colour, with lights
// (five: not a whole number of SIMD batches) and without (the headlight), from inside (textured
// walls, misses through the open top) and from outside (back faces), at a width that is not a
// whole number of 16-ray packets. The geometry is compared as floats; the lighting only through the
// 8-bit colour, where a last-bit change in one pixel's light rarely shows (an incidence computed
// with a reciprocal fails this test; a light's squared distance summed in another order did not).
TEST(Renderer, RowShadingIsBitIdenticalToThePerPixelShading) {
  Scene lit = open_top_room();
  lit.lights.clear();
  for (int i = 0; i < 5; ++i)
    lit.lights.push_back({Eigen::Vector3f(-1.5f + 1.1f * i, 0.4f * i - 1.f, 2.4f), 0.5f + 0.2f * i});
  Scene unlit = open_top_room();
  unlit.lights.clear();
  const PinholeIntrinsics k = PinholeIntrinsics::primesense(150, 113);
  RenderRequest request;
  request.normals = true;
  const Rigid3d views[2] = {camera_looking(Eigen::Vector3d(0.3, 0.2, 1.2), Eigen::Vector3d(1.0, 0.1, 0.7)),
                            camera_looking(Eigen::Vector3d(6.0, -0.3, 1.0), Eigen::Vector3d(-1.0, 0.2, 0.05))};
  const Scene* scenes[2] = {&lit, &unlit};
  for (const Scene* scene : scenes) {
    const Renderer renderer(*scene);
    for (const Rigid3d& pose : views) {
      SCOPED_TRACE(scene->lights.empty() ? "headlight" : "five lights");
      const RenderedView rows = renderer.render(pose, k, request);
      const RenderedView pixels = renderer.render_per_pixel(pose, k, request);
      EXPECT_EQ(rows.depth.data, pixels.depth.data);
      EXPECT_EQ(rows.incidence_cos.data, pixels.incidence_cos.data);
      EXPECT_EQ(rows.triangle_id.data, pixels.triangle_id.data);
      EXPECT_EQ(rows.normal_cam.data, pixels.normal_cam.data);
      EXPECT_EQ(rows.rgb.data, pixels.rgb.data);
      // A depth-only view: the same geometry, no colour.
      RenderRequest depth_only = request;
      depth_only.colour = false;
      const RenderedView geometry = renderer.render(pose, k, depth_only);
      EXPECT_EQ(geometry.depth.data, rows.depth.data);
      EXPECT_EQ(geometry.normal_cam.data, rows.normal_cam.data);
      EXPECT_EQ(std::count(geometry.rgb.data.begin(), geometry.rgb.data.end(), 0),
                std::ptrdiff_t(geometry.rgb.data.size()));
      // Without triangle ids (the simulator's views without --ids): the same images, no id image;
      // rows rendered into a view allocated without ids, with ids requested, are refused.
      RenderRequest no_ids = request;
      no_ids.triangle_ids = false;
      for (const RenderedView& view : {renderer.render(pose, k, no_ids), renderer.render_per_pixel(pose, k, no_ids)}) {
        EXPECT_TRUE(view.triangle_id.data.empty());
        EXPECT_EQ(view.depth.data, rows.depth.data);
        EXPECT_EQ(view.incidence_cos.data, rows.incidence_cos.data);
        EXPECT_EQ(view.normal_cam.data, rows.normal_cam.data);
        EXPECT_EQ(view.rgb.data, rows.rgb.data);
      }
      RenderedView without_ids = Renderer::allocate(k, no_ids);
      EXPECT_THROW(renderer.render_rows(pose, k, 0, k.height, without_ids, request), Error);
      // Not vacuous: hits with different colours, and misses.
      const std::set<std::uint8_t> reds(rows.rgb.data.begin(), rows.rgb.data.end());
      EXPECT_GT(reds.size(), 20u);
      if (&pose == &views[0]) {  // the open top
        EXPECT_GT(std::count(rows.triangle_id.data.begin(), rows.triangle_id.data.end(), -1), 0);
      }
    }
  }
}

// The texture path of render()'s row shading (eight pixels per AVX2 gather where the CPU has it)
// against the per-pixel albedo_at: textures of random texels (a level that differs from its
// neighbour by one shows in the colour, unlike a checker's flat squares) with odd sizes (the box
// filter drops a row and a column), uvs far outside [0, 1] and negative (the wrap), materials that
// tint the texture, and views from near and far at several image sizes, so that many mip levels
// and every border case are sampled. Fails with the level threshold, the wrap or a texel's
// corner order changed.
TEST(Renderer, RowTextureSamplingIsBitIdenticalToThePerPixelShading) {
  Scene scene = open_top_room();
  std::uint32_t state = 12345u;
  auto next_byte = [&state] {
    state = state * 1664525u + 1013904223u;
    return std::uint8_t(state >> 24);
  };
  scene.textures.clear();
  for (const auto& [width, height] : {std::pair{45, 29}, std::pair{128, 97}}) {
    Texture texture;
    texture.name = "noise" + std::to_string(width);
    texture.width = width;
    texture.height = height;
    texture.rgb.resize(std::size_t(width) * height * 3);
    for (std::uint8_t& byte : texture.rgb) byte = next_byte();
    scene.textures.push_back(texture);
  }
  scene.materials = {{"floor", {0.5f, 0.4f, 0.3f}, 1},
                     {"paint", {0.9f, 0.9f, 0.8f}, -1},
                     {"tiles", {1.f, 1.f, 1.f}, 0},
                     {"tinted", {0.7f, 1.f, 0.35f}, 1}};
  // Shift and scale the uvs so that they run through negative values and far past 1.
  for (Eigen::Vector2f& uv : scene.mesh.corner_uvs) uv = uv * 0.37f - Eigen::Vector2f(3.3f, 1.7f);
  const Renderer renderer(scene);
  const Rigid3d views[3] = {camera_looking(Eigen::Vector3d(0.3, 0.2, 1.2), Eigen::Vector3d(1.0, 0.1, -0.4)),
                            camera_looking(Eigen::Vector3d(-1.6, -2.0, 2.2), Eigen::Vector3d(1.0, 0.8, -0.6)),
                            camera_looking(Eigen::Vector3d(2.8, 1.8, 0.3), Eigen::Vector3d(-1.0, -0.9, 0.2))};
  std::set<std::uint8_t> reds;
  for (const int width : {320, 150, 41}) {
    const PinholeIntrinsics k = PinholeIntrinsics::primesense(width, width * 3 / 4);
    for (const Rigid3d& pose : views) {
      const RenderedView rows = renderer.render(pose, k);
      const RenderedView pixels = renderer.render_per_pixel(pose, k);
      ASSERT_EQ(rows.rgb.data, pixels.rgb.data) << "width " << width;
      reds.insert(rows.rgb.data.begin(), rows.rgb.data.end());
    }
  }
  EXPECT_GT(reds.size(), 200u);  // not vacuous: the random texels show
}

TEST(Renderer, EquirectangularDepthIsRadialAndLandsOnTheMesh) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  const Renderer renderer(scene);
  const Equirectangular pano{32};
  const Rigid3d world_from_pano =
      make_rigid(so3_exp(Eigen::Vector3d(0.02, -0.01, 0.7)), Eigen::Vector3d(0.3, 0.2, 1.2));
  const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
  for (int y = 0; y < pano.height; ++y)
    for (int x = 0; x < pano.width(); ++x) {
      const int id = view.triangle_id.at(x, y);
      ASSERT_GE(id, 0);
      const Eigen::Vector3d point = world_from_pano * (pano.direction(x, y) * view.depth.at(x, y));
      const auto& tri = scene.mesh.triangles[id];
      const auto& v = scene.mesh.vertices;
      ASSERT_LT(
          point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(), v[tri[2]].cast<double>()),
          1e-4);
    }
  // Straight up from 1.2 m in a 2.7 m room: the ceiling is 1.5 m away (nearly; the pano is tilted 1 deg).
  EXPECT_NEAR(view.depth.at(0, 0), 1.5, 0.01);
}

TEST(Simulator, NoiselessFramesBackProjectOntoTheMesh) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  SimOptions options = small_options();
  const Simulator sim(scene, 0, options);
  for (int c = 0; c < 3; ++c) {
    const SimulatedFrame frame = sim.render_frame(sim.schedule()[c][3]);
    const PinholeIntrinsics& k = sim.rig().intrinsics;
    std::size_t valid = 0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        const float z = frame.clean_depth.at(x, y);
        if (z <= 0) continue;
        ++valid;
        const Eigen::Vector3d point = frame.world_from_cam * k.backproject(x, y, z);
        const auto& tri = scene.mesh.triangles[frame.triangle_id.at(x, y)];
        const auto& v = scene.mesh.vertices;
        ASSERT_LT(point_triangle_distance(point, v[tri[0]].cast<double>(), v[tri[1]].cast<double>(),
                                          v[tri[2]].cast<double>()),
                  1e-4);
      }
    EXPECT_GT(valid, std::size_t(k.width * k.height / 2));
  }
}

TEST(Simulator, SameSeedSameBytesWithOneAndTwoThreads) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  testutil::TempDir tmp("determinism");
  SimOptions options = ground_truth_options();
  options.output.clean_depth = true;
  options.threads = 1;
  Simulator(scene, 0, options).write_scan(tmp / "one", false);
  options.threads = 2;
  Simulator(scene, 0, options).write_scan(tmp / "two", false);
  options.seed = 22;
  Simulator(scene, 0, options).write_scan(tmp / "other_seed", false);
  std::size_t files = 0, differing_from_other_seed = 0;
  for (const auto& entry : fs::recursive_directory_iterator(tmp / "one")) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), tmp / "one");
    ASSERT_TRUE(fs::exists(tmp / "two" / relative)) << relative;
    ASSERT_EQ(read_bytes(entry.path()), read_bytes(tmp / "two" / relative)) << relative;
    ++files;
    if (!fs::exists(tmp / "other_seed" / relative) ||
        read_bytes(entry.path()) != read_bytes(tmp / "other_seed" / relative))
      ++differing_from_other_seed;
  }
  EXPECT_GT(files, 60u);
  EXPECT_GT(differing_from_other_seed, files / 2);
}

TEST(Simulator, WrittenScanReadsBackWithGroundTruth) {
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  testutil::TempDir tmp("readback");
  SimOptions options = small_options();
  options.output.clean_depth = true;
  const Simulator sim(scene, 0, options);
  sim.write_scan(tmp / "scan", false);
  const ScanIndex scan = read_scan_index(tmp / "scan");
  ASSERT_EQ(scan.rig.sensors.size(), 3u);
  EXPECT_EQ(scan.rig.reference_sensor, 1);
  for (int c = 0; c < 3; ++c) {
    ASSERT_EQ(scan.frames[c].size(), sim.schedule()[c].size());
    const auto truth = read_groundtruth_trajectory(tmp / "scan", c);
    ASSERT_EQ(truth.size(), scan.frames[c].size());
    // Calibrated extrinsics differ from the truth by the configured error.
    const Rigid3d error = sim.rig().ref_from_cam_true[c].inverse() * scan.rig.sensors[c].ref_from_cam;
    if (c != 1) {
      EXPECT_NEAR(rad2deg(rotation_angle(error.linear())), 0.5, 1e-6);
      EXPECT_NEAR(error.translation().norm(), 0.005, 1e-6);
    }
    // Noiseless depth from disk back-projects onto the mesh within the PNG step (0.2 mm).
    const RgbdFrame frame = load_frame(scan, c, 2);
    EXPECT_EQ(frame.timestamp, truth[2].timestamp);
    const ImageF32 clean =
        depth_from_png_units(read_png16(tmp / "scan" / "groundtruth" / "depth_clean" / scan.rig.sensors[c].name /
                                        (format_timestamp(truth[2].timestamp) + ".png")),
                             5000.0);
    const PinholeIntrinsics& k = scan.rig.sensors[c].intrinsics;
    std::size_t valid = 0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        const float z = clean.at(x, y);
        if (z <= 0) continue;
        ++valid;
        const Eigen::Vector3d p = truth[2].world_from_cam * k.backproject(x, y, z);
        double best = 1e9;
        for (const auto& tri : scene.mesh.triangles)
          best = std::min(best, point_triangle_distance(p, scene.mesh.vertices[tri[0]].cast<double>(),
                                                        scene.mesh.vertices[tri[1]].cast<double>(),
                                                        scene.mesh.vertices[tri[2]].cast<double>()));
        // The PNG stores z in steps of 0.2 mm: at most 0.1 mm along z, i.e. 0.1 mm x |ray|.
        ASSERT_LT(best, 1e-4 * k.backproject(x, y, 1.0).norm() + 1e-6);
      }
    EXPECT_GT(valid, 1000u);
  }
}

TEST(Simulator, FramesCarryNormalsAndMaterialIdsOfTheHitTriangles) {
  Scene scene = open_top_room();
  const Simulator sim(scene, 0, ground_truth_options());
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  int hits = 0, misses = 0;
  std::set<int> materials_seen;
  for (int c = 0; c < 3; ++c)
    for (int f : {0, 3, 6, 9}) {  // around the turn: every wall
      const SimulatedFrame frame = sim.render_frame(sim.schedule()[c][f]);
      const auto [frame_hits, frame_misses] =
          check_normals_against_mesh(scene, frame.normal_cam, frame.triangle_id, frame.world_from_cam, k, +1.0);
      hits += frame_hits, misses += frame_misses;
      ASSERT_EQ(frame.material_id.data.size(), frame.triangle_id.data.size());
      for (std::size_t i = 0; i < frame.triangle_id.data.size(); ++i) {
        const int triangle = frame.triangle_id.data[i];
        ASSERT_EQ(frame.material_id.data[i], triangle < 0 ? -1 : scene.mesh.triangle_material[triangle]) << i;
        materials_seen.insert(frame.material_id.data[i]);
      }
    }
  EXPECT_GT(hits, 12 * k.width * k.height / 2);
  EXPECT_GT(misses, 0) << "the upper camera sees out of the open top";
  EXPECT_EQ(materials_seen, (std::set<int>{-1, 0, 1, 2, 3})) << "no hit, and all four materials";

  // A mesh without materials: material -1 on every pixel, hit or not.
  scene.mesh.triangle_material.clear();
  const Simulator unpainted(scene, 0, ground_truth_options());
  const SimulatedFrame frame = unpainted.render_frame(unpainted.schedule()[1][3]);
  EXPECT_EQ(frame.material_id.data, UninitialisedVector<std::int32_t>(frame.triangle_id.data.size(), -1));
  EXPECT_GT(std::count_if(frame.triangle_id.data.begin(), frame.triangle_id.data.end(), [](int t) { return t >= 0; }),
            0);

  // Not asked for: nothing computed.
  const Scene plain_scene = open_top_room();  // the simulator keeps a reference: not a temporary
  const Simulator plain(plain_scene, 0, small_options());
  const SimulatedFrame plain_frame = plain.render_frame(plain.schedule()[1][3]);
  EXPECT_TRUE(plain_frame.normal_cam.empty());
  EXPECT_TRUE(plain_frame.material_id.empty());
}

TEST(Simulator, WrittenScanHoldsNormalsAndIdsOfEveryFrameOnlyWhenAsked) {
  const Scene scene = open_top_room();
  testutil::TempDir tmp("normals-ids");
  const Simulator sim(scene, 0, ground_truth_options());
  sim.write_scan(tmp / "scan", false);
  const ScanIndex scan = read_scan_index(tmp / "scan");
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  std::size_t frames = 0, misses = 0;
  for (int c = 0; c < 3; ++c) {
    const std::string camera = scan.rig.sensors[c].name;
    ASSERT_EQ(scan.frames[c].size(), sim.schedule()[c].size());
    for (std::size_t f = 0; f < scan.frames[c].size(); ++f) {
      const SimulatedFrame rendered = sim.render_frame(sim.schedule()[c][f]);
      const double timestamp = scan.frames[c][f].timestamp;
      const fs::path normals_file =
          tmp / "scan" / "groundtruth" / "normals" / camera / (format_timestamp(timestamp) + ".exr");
      const fs::path ids_file = tmp / "scan" / "groundtruth" / "ids" / camera / (format_timestamp(timestamp) + ".exr");
      ASSERT_TRUE(fs::is_regular_file(normals_file)) << normals_file;
      ASSERT_TRUE(fs::is_regular_file(ids_file)) << ids_file;
      // What was rendered, exactly, through the scan readers and through the documented channels.
      ASSERT_EQ(read_groundtruth_normals(scan, c, timestamp).data, rendered.normal_cam.data) << normals_file;
      ASSERT_EQ(read_exr(normals_file, {"R", "G", "B"}, k.width, k.height).data, rendered.normal_cam.data);
      const ImageI32 ids = read_exr_i32(ids_file, {"triangle_id", "material_id"}, k.width, k.height);
      ASSERT_EQ(read_groundtruth_ids(scan, c, timestamp).data, ids.data);
      const ImageF32 triangle_as_float = read_exr(ids_file, {"triangle_id"});
      for (std::size_t i = 0; i < rendered.triangle_id.data.size(); ++i) {
        ASSERT_EQ(ids.data[2 * i], rendered.triangle_id.data[i]) << ids_file << " pixel " << i;
        ASSERT_EQ(ids.data[2 * i + 1], rendered.material_id.data[i]) << ids_file << " pixel " << i;
        if (rendered.triangle_id.data[i] < 0) {
          // Stored as UINT: "nothing hit" is 2^32 - 1 to readers outside PanoScan.
          ASSERT_EQ(triangle_as_float.data[i], 4294967296.0f);
          ++misses;
        }
      }
      ++frames;
    }
    // One file per frame, nothing else.
    std::size_t files = 0;
    for (const char* kind : {"normals", "ids"})
      for (const auto& entry : fs::directory_iterator(tmp / "scan" / "groundtruth" / kind / camera))
        files += entry.path().extension() == ".exr";
    EXPECT_EQ(files, 2 * scan.frames[c].size());
  }
  EXPECT_EQ(frames, 33u);
  EXPECT_GT(misses, 0u);
  const auto truth = nlohmann::json::parse(read_bytes(tmp / "scan" / "groundtruth" / "rig_truth.json"));
  EXPECT_EQ(truth["output"]["normals"], true);
  EXPECT_EQ(truth["output"]["ids"], true);
  EXPECT_EQ(truth["materials"], (nlohmann::json{"wall", "floor", "paint", "tiles"}));

  // Without the options nothing of it is written.
  Simulator(scene, 0, small_options()).write_scan(tmp / "plain", false);
  EXPECT_FALSE(fs::exists(tmp / "plain" / "groundtruth" / "normals"));
  EXPECT_FALSE(fs::exists(tmp / "plain" / "groundtruth" / "ids"));
  const auto plain_truth = nlohmann::json::parse(read_bytes(tmp / "plain" / "groundtruth" / "rig_truth.json"));
  EXPECT_EQ(plain_truth["output"]["normals"], false);
  EXPECT_EQ(plain_truth["output"]["ids"], false);
  EXPECT_FALSE(plain_truth.contains("materials"));
}

TEST(Simulator, BadInputIsAClearError) {
  Scene empty = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  empty.mesh.triangles.clear();
  empty.mesh.triangle_material.clear();
  empty.mesh.corner_uvs.clear();
  try {
    Simulator sim(empty, 0, small_options());
    FAIL() << "a scene without triangles was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no triangles"), std::string::npos) << e.what();
  }
  const Scene scene = testutil::make_box_room(-2, 3, -2.5, 2, 2.7, Eigen::Vector3d(0.3, 0.2, 0));
  EXPECT_THROW(Simulator(scene, 1, small_options()), Error);
  SimOptions bad = small_options();
  bad.shutter.fps = -30;
  try {
    Simulator sim(scene, 0, bad);
    FAIL() << "a negative frame rate was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shutter.fps"), std::string::npos) << e.what();
  }
  // An unwritable output folder (a path below a regular file) fails and leaves nothing behind.
  testutil::TempDir tmp("unwritable");
  { std::ofstream(tmp / "file") << "x"; }
  const Simulator sim(scene, 0, small_options());
  EXPECT_THROW(sim.write_scan(tmp / "file" / "scan", false), Error);
  std::size_t entries = 0;
  for (auto it = fs::directory_iterator(tmp.path()); it != fs::directory_iterator(); ++it) ++entries;
  EXPECT_EQ(entries, 1u);
}
