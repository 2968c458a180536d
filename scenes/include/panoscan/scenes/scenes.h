// Built-in ICL-NUIM-style scenes (the paper's living room "SL" and office "SO"), generated
// procedurally and deterministically, and their export to ordinary mesh files.
//
// Scene frame: metres, z up, floor at z = 0. Every surface is textured (textures tile; texture
// coordinates are metric). Each scene carries its scanning positions and a few point lights.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "panoscan/core/mesh.h"

namespace panoscan::scenes {

// {"living_room", "office"}.
std::vector<std::string> builtin_scene_names();
bool is_builtin_scene(const std::string& name);

// Builds a built-in scene. Throws panoscan::Error for an unknown name (the message lists the known
// ones). "living_room" has positions SL-1, SL-2; "office" has SO-1 .. SO-4.
panoscan::Scene make_builtin_scene(const std::string& name);

// Writes, each file atomically, into out_dir (created if missing):
//   <name>.obj, <name>.mtl          the textured mesh (map_Kd textures/<texture>.png; uvs repeat)
//   textures/<texture>.png
//   <name>_groundtruth.ply           binary PLY of the geometry (write_ply_mesh)
//   <name>.positions.json            scanning positions and lights (read by load_scene_file)
void export_scene(const panoscan::Scene& scene, const std::filesystem::path& out_dir);

}  // namespace panoscan::scenes
