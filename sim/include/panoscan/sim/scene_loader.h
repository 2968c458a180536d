// Loading scenes: a built-in scene by name, or a mesh file through assimp.
//
// A scene file (OBJ, PLY, glTF/GLB, and whatever else assimp reads) gives the triangles, per-face
// materials with their diffuse colour and texture (texture files relative to the model file, or
// embedded), texture coordinates (channel 0, OBJ convention: v = 1 is the top row) and per-vertex
// colours (channel 0: PLY red/green/blue, OBJ "v x y z r g b", glTF COLOR_0; see
// TriangleMesh::vertex_colours for how they combine with materials). Node transforms are applied. The scanning
// positions and lights come from a JSON file beside the model: <stem>.positions.json, else positions.json in the same
// folder:
//   {"format": "panoscan-positions", "version": 1,
//    "positions": [{"name": "SO-1", "floor_point": [x, y, z], "start_heading_deg": 0.0}, ...],
//    "lights": [{"position": [x, y, z], "intensity": 1.0}, ...]}
// "start_heading_deg" defaults to 0 and "intensity" to 1; "lights" may be left out (then one light of
// intensity 1 hangs 0.3 m under the top of the mesh's bounding box, above its centre).
#pragma once

#include <filesystem>
#include <string>

#include "panoscan/core/mesh.h"
#include "panoscan/scenes/scenes.h"

namespace panoscan {

// Throws Error naming the file (and the field) for a missing file, a file assimp cannot read (with
// assimp's message), a mesh without triangles, an unreadable texture, a missing or invalid
// positions file.
Scene load_scene_file(const std::filesystem::path& file);

// A built-in scene name ("living_room", "office"), built in `style`, or a path to a scene file.
// `style_given`: the caller set the style explicitly (scene.texture); a scene file keeps its own
// materials, so that is an Error naming the key rather than silently ignored.
Scene load_scene(const std::string& name_or_path, const scenes::SceneStyle& style = {}, bool style_given = false);

}  // namespace panoscan
