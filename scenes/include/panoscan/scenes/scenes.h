// Built-in ICL-NUIM-style scenes (the paper's living room "SL" and office "SO"), generated
// procedurally and deterministically, a seeded generator of further rooms, and their export to
// ordinary mesh files.
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

// ------------------------------------------------------------------------------------------------
// The seeded room generator. A room of `kind` is rectangular or L-shaped, 3-8 m across and
// 2.4-3 m high, with a door and one to three windows, furniture from the built-in scenes' library
// against its walls (bounding boxes of the drawn geometry pairwise disjoint, clear of the door's
// swing and the windows), pictures on free stretches of wall, ceiling lights, and 2-6 scanning
// positions (named GO-k for offices, GL-k for living rooms) whose rig axis is at least 0.6 m from
// every surface above the floor covering up to 1.5 m (so the cameras, <= 0.09 m off the axis, stay
// 0.5 m away), each 1.5-3 m from the previous one and sharing at least 60% of its view with it
// (evenly spread rays from one position whose hit points the other sees, both ways). All of it
// follows from the seed alone: the same spec gives the same scene, bit for bit.
enum class RoomKind { kOffice, kLivingRoom };
std::vector<std::string> room_kind_names();  // {"office", "living_room"}
std::string to_string(RoomKind kind);
RoomKind room_kind_from_string(const std::string& value, const std::string& field = "--kind");

struct RoomSpec {
  RoomKind kind = RoomKind::kOffice;
  std::uint64_t seed = 1;
  SceneStyle style;
};
// "<kind>_seed<seed>", e.g. "office_seed7": the scene's name and the exported files' stem.
std::string generated_room_name(const RoomSpec& spec);

struct GeneratedRoom {
  panoscan::Scene scene;
  std::vector<Eigen::Vector2f> outline;  // floor plan, counter-clockwise seen from above
  float height = 0.f;
  struct Placed {
    std::string what;
    Eigen::Vector3f lo, hi;  // bounding box of its triangles
  };
  std::vector<Placed> furniture;    // pieces and wall decorations
  std::vector<double> clearance_m;  // per position: rig axis to the nearest surface above the floor
  std::vector<double> shared_view;  // per consecutive pair of positions
  int attempt = 0;                  // layouts discarded before this one (no room for positions)
};
// Throws Error naming the spec if no layout of 24 leaves room for two positions (not seen in
// practice: rooms are at least 3 m x 3 m).
GeneratedRoom generate_room(const RoomSpec& spec);

// Writes, each file atomically, into out_dir (created if missing):
//   <name>.obj, <name>.mtl          the textured mesh (map_Kd textures/<texture>.png; uvs repeat;
//                                    per-vertex colours, if any, as "v x y z r g b")
//   textures/<texture>.png
//   <name>_groundtruth.ply           binary PLY of the geometry (write_ply_mesh; with the vertex
//                                    colours if any)
//   <name>.positions.json            scanning positions and lights (read by load_scene_file)
void export_scene(const panoscan::Scene& scene, const std::filesystem::path& out_dir);

// Appends the positions and lights of a positions file (what export_scene writes; format in
// sim/scene_loader.h) to `scene`. Throws Error naming the file and the field (missing, not finite,
// duplicate name, negative intensity, ...).
void read_positions_file(const std::filesystem::path& path, panoscan::Scene& scene);

}  // namespace panoscan::scenes
