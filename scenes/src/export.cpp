// Export of a scene to files any viewer opens: Wavefront OBJ + MTL with PNG textures, a binary PLY
// of the geometry (the ground truth for evaluation) and the scanning positions as JSON.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/mesh_io.h"
#include "panoscan/scenes/scenes.h"

namespace fs = std::filesystem;

namespace panoscan::scenes {

namespace {

// Names go into file names and MTL statements: keep them to a portable character set.
std::string sanitize(const std::string& name, const std::string& fallback) {
  std::string out;
  for (char c : name) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
    out += ok ? c : '_';
  }
  if (out.empty() || out == "." || out == "..") out = fallback;
  return out;
}

// Makes every name unique by appending _2, _3, ... to repeats.
std::vector<std::string> unique_names(std::vector<std::string> names) {
  std::set<std::string> used;
  for (std::string& name : names) {
    std::string candidate = name;
    for (int k = 2; used.count(candidate); ++k) candidate = name + "_" + std::to_string(k);
    used.insert(candidate);
    name = candidate;
  }
  return names;
}

struct UvKey {
  float u, v;
  bool operator==(const UvKey& other) const { return std::memcmp(this, &other, sizeof(UvKey)) == 0; }
};
struct UvKeyHash {
  std::size_t operator()(const UvKey& key) const {
    std::uint64_t bits;
    std::memcpy(&bits, &key, sizeof(bits));
    return std::hash<std::uint64_t>()(bits);
  }
};

constexpr const char* kDefaultMaterial = "panoscan_default";

// A float as the double with the same shortest decimal form (2.45f is written 2.45, not
// 2.450000047683716).
double tidy(float value) {
  const std::string text = fmt::format("{}", value);
  double result = value;
  std::from_chars(text.data(), text.data() + text.size(), result);  // locale-independent
  return result;
}

}  // namespace

void export_scene(const Scene& scene, const fs::path& out_dir) {
  scene.check("<export " + scene.name + ">");
  const std::string stem = sanitize(scene.name, "scene");
  std::error_code ec;
  fs::create_directories(out_dir / "textures", ec);
  if (ec) throw make_error(out_dir.string(), "", "cannot create the output folder: " + ec.message());

  std::vector<std::string> texture_names, material_names;
  for (std::size_t i = 0; i < scene.textures.size(); ++i)
    texture_names.push_back(sanitize(scene.textures[i].name, "texture_" + std::to_string(i)));
  for (std::size_t i = 0; i < scene.materials.size(); ++i)
    material_names.push_back(sanitize(scene.materials[i].name, "material_" + std::to_string(i)));
  texture_names = unique_names(texture_names);
  material_names = unique_names(material_names);

  // Textures.
  for (std::size_t i = 0; i < scene.textures.size(); ++i) {
    const Texture& texture = scene.textures[i];
    ImageU8 image(texture.width, texture.height, 3);
    image.data.assign(texture.rgb.begin(), texture.rgb.end());
    write_png(out_dir / "textures" / (texture_names[i] + ".png"), image, 6);
  }

  // Materials. Kd multiplies the texture, as Material::albedo does.
  const TriangleMesh& mesh = scene.mesh;
  const bool has_materials = !mesh.triangle_material.empty();
  std::string mtl = fmt::format("# PanoScan scene '{}': materials\n", scene.name);
  for (std::size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& material = scene.materials[i];
    mtl += fmt::format("\nnewmtl {}\nKa 0 0 0\nKd {} {} {}\nKs 0 0 0\nd 1\nillum 1\n", material_names[i],
                       material.albedo.x(), material.albedo.y(), material.albedo.z());
    if (material.texture >= 0)
      mtl += fmt::format("map_Kd textures/{}.png\n", texture_names[static_cast<std::size_t>(material.texture)]);
  }
  const bool any_untextured_face =
      !has_materials || std::any_of(mesh.triangle_material.begin(), mesh.triangle_material.end(),
                                    [](int material) { return material < 0; });
  if (any_untextured_face)
    mtl += fmt::format("\nnewmtl {}\nKa 0 0 0\nKd 0.8 0.8 0.8\nKs 0 0 0\nd 1\nillum 1\n", kDefaultMaterial);
  write_file_atomic(out_dir / (stem + ".mtl"), mtl);

  // Geometry: vertices, deduplicated texture coordinates, faces grouped by material.
  std::string obj = fmt::format("# PanoScan scene '{}': {} vertices, {} triangles; metres, z up\n", scene.name,
                                mesh.vertices.size(), mesh.triangles.size());
  obj += fmt::format("mtllib {}.mtl\no {}\n", stem, stem);
  // Per-vertex colours as the common "v x y z r g b" extension (assimp, MeshLab and Blender read it).
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& v = mesh.vertices[i];
    if (mesh.vertex_colours.empty()) {
      obj += fmt::format("v {} {} {}\n", v.x(), v.y(), v.z());
    } else {
      const Eigen::Vector3f& c = mesh.vertex_colours[i];
      obj += fmt::format("v {} {} {} {} {} {}\n", v.x(), v.y(), v.z(), c.x(), c.y(), c.z());
    }
  }
  const bool has_uvs = !mesh.corner_uvs.empty();
  std::vector<int> corner_uv_index(mesh.corner_uvs.size());
  if (has_uvs) {
    std::unordered_map<UvKey, int, UvKeyHash> uv_index;
    for (std::size_t c = 0; c < mesh.corner_uvs.size(); ++c) {
      const UvKey key{mesh.corner_uvs[c].x(), mesh.corner_uvs[c].y()};
      auto [it, inserted] = uv_index.emplace(key, static_cast<int>(uv_index.size()) + 1);
      if (inserted) obj += fmt::format("vt {} {}\n", key.u, key.v);
      corner_uv_index[c] = it->second;
    }
  }
  std::vector<std::size_t> order(mesh.triangles.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  auto material_of = [&](std::size_t t) { return has_materials ? mesh.triangle_material[t] : -1; };
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return material_of(a) < material_of(b); });
  int current = -2;
  for (std::size_t t : order) {
    const int material = material_of(t);
    if (material != current) {
      obj += fmt::format("usemtl {}\n", material >= 0 ? material_names[static_cast<std::size_t>(material)]
                                                      : std::string(kDefaultMaterial));
      current = material;
    }
    const Eigen::Vector3i& tri = mesh.triangles[t];
    if (has_uvs)
      obj += fmt::format("f {}/{} {}/{} {}/{}\n", tri[0] + 1, corner_uv_index[3 * t], tri[1] + 1,
                         corner_uv_index[3 * t + 1], tri[2] + 1, corner_uv_index[3 * t + 2]);
    else
      obj += fmt::format("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1);
  }
  write_file_atomic(out_dir / (stem + ".obj"), obj);

  write_ply_mesh(out_dir / (stem + "_groundtruth.ply"), mesh);

  // Scanning positions and lights, in the format load_scene_file reads back.
  using Json = nlohmann::ordered_json;  // keeps "format" and "version" first
  Json positions = Json::array();
  for (const ScanPosition& p : scene.positions)
    positions.push_back({{"name", p.name},
                         {"floor_point", {p.floor_point.x(), p.floor_point.y(), p.floor_point.z()}},
                         {"start_heading_deg", p.start_heading_rad * 180.0 / 3.14159265358979323846}});
  Json lights = Json::array();
  for (const PointLight& l : scene.lights)
    lights.push_back({{"position", {tidy(l.position.x()), tidy(l.position.y()), tidy(l.position.z())}},
                      {"intensity", tidy(l.intensity)}});
  const Json document = {{"format", "panoscan-positions"},
                         {"version", 1},
                         {"scene", scene.name},
                         {"positions", positions},
                         {"lights", lights}};
  write_file_atomic(out_dir / (stem + ".positions.json"), document.dump(2) + "\n");
}

}  // namespace panoscan::scenes
