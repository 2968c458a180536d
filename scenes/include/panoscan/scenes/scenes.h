// Built-in ICL-NUIM-style scenes (the paper's living room "SL" and office "SO"), generated
// procedurally and deterministically, and their export to ordinary mesh files.
//
// Scene frame: metres, z up, floor at z = 0. Texture coordinates are metric (textures tile). Each
// scene carries its scanning positions and a few point lights.
//
// Texture density (SceneStyle::texture, config key scene.texture):
//   icl    (default) as ICL-NUIM's rooms, which the paper scanned: walls and ceilings plain paint
//          (one uniform albedo each; the lighting's own shading only), floors plain or with a
//          low-contrast texture, high-frequency textures only on objects (posters, books, rugs,
//          wood, screens, fabrics).
//   rich   every surface textured with high-contrast patterns (wallpaper, brick, carpet tiles,
//          ceiling tiles): the built-in rooms' look before icl became the default, kept so that
//          older records can be reproduced.
//   plain  no texture anywhere: each material a uniform albedo (its texture's mean colour).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/mesh.h"

namespace panoscan {
class Config;
}

namespace panoscan::scenes {

enum class TextureDensity { kIcl, kRich, kPlain };

// {"icl", "rich", "plain"}.
std::vector<std::string> texture_density_names();
std::string to_string(TextureDensity density);
// Throws panoscan::Error naming `field` and the known values for anything else.
TextureDensity texture_density_from_string(const std::string& value, const std::string& field = "scene.texture");

// How a built-in or generated scene is dressed. Geometry does not depend on it.
struct SceneStyle {
  TextureDensity texture = TextureDensity::kIcl;
};
// Reads scene.texture (default icl) from a config; an unknown value throws naming the key.
SceneStyle scene_style_from_config(Config& config);

// {"living_room", "office"}.
std::vector<std::string> builtin_scene_names();
bool is_builtin_scene(const std::string& name);

// Builds a built-in scene. Throws panoscan::Error for an unknown name (the message lists the known
// ones). "living_room" has positions SL-1, SL-2; "office" has SO-1 .. SO-4.
panoscan::Scene make_builtin_scene(const std::string& name, const SceneStyle& style = {});

// Writes, each file atomically, into out_dir (created if missing):
//   <name>.obj, <name>.mtl          the textured mesh (map_Kd textures/<texture>.png; uvs repeat;
//                                    per-vertex colours, if any, as "v x y z r g b")
//   textures/<texture>.png
//   <name>_groundtruth.ply           binary PLY of the geometry (write_ply_mesh; with the vertex
//                                    colours if any)
//   <name>.positions.json            scanning positions and lights (read by load_scene_file)
void export_scene(const panoscan::Scene& scene, const std::filesystem::path& out_dir);

}  // namespace panoscan::scenes
