#include "panoscan/sim/scene_loader.h"

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <unistd.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/scenes/scenes.h"

namespace fs = std::filesystem;

namespace panoscan {

namespace {

std::string builtin_list() {
  std::string list;
  for (const std::string& name : scenes::builtin_scene_names()) list += (list.empty() ? "" : ", ") + name;
  return list;
}

Texture texture_from_image(const ImageU8& image, const std::string& name) {
  Texture texture;
  texture.name = name;
  texture.width = image.width;
  texture.height = image.height;
  texture.rgb.assign(image.data.begin(), image.data.end());
  return texture;
}

// An embedded texture (glTF/GLB, FBX): compressed bytes go through a temporary file so that one
// decoder (read_rgb) handles every image; raw BGRA texels are copied directly.
Texture embedded_texture(const aiTexture& embedded, const std::string& name, const std::string& model_file,
                         const std::string& field) {
  if (embedded.mHeight > 0) {
    Texture texture;
    texture.name = name;
    texture.width = static_cast<int>(embedded.mWidth);
    texture.height = static_cast<int>(embedded.mHeight);
    texture.rgb.resize(static_cast<std::size_t>(texture.width) * texture.height * 3);
    for (std::size_t i = 0; i < static_cast<std::size_t>(texture.width) * texture.height; ++i) {
      texture.rgb[3 * i + 0] = embedded.pcData[i].r;
      texture.rgb[3 * i + 1] = embedded.pcData[i].g;
      texture.rgb[3 * i + 2] = embedded.pcData[i].b;
    }
    return texture;
  }
  static std::atomic<unsigned> counter{0};
  std::string hint = embedded.achFormatHint;
  if (hint.empty() || hint.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789") != std::string::npos) hint = "png";
  const fs::path temp = fs::temp_directory_path() / ("panoscan-embedded-" + std::to_string(::getpid()) + "-" +
                                                     std::to_string(counter.fetch_add(1)) + "." + hint);
  {
    std::ofstream out(temp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(embedded.pcData), static_cast<std::streamsize>(embedded.mWidth));
    if (!out) throw make_error(model_file, field, "cannot unpack the embedded texture to " + temp.string());
  }
  try {
    Texture texture = texture_from_image(read_rgb(temp), name);
    std::error_code ignored;
    fs::remove(temp, ignored);
    return texture;
  } catch (const Error& e) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw make_error(model_file, field, std::string("embedded texture is not a readable image: ") + e.what());
  }
}

}  // namespace

Scene load_scene_file(const fs::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw make_error(file, "", "scene file not found");

  // Positions first: a model without them cannot be scanned, and this check is cheap.
  const fs::path folder = path.parent_path();
  const fs::path beside = folder / (path.stem().string() + ".positions.json");
  const fs::path shared = folder / "positions.json";
  const fs::path positions_file = fs::is_regular_file(beside, ec) ? beside : shared;
  if (!fs::is_regular_file(positions_file, ec))
    throw make_error(file, "positions",
                     "no positions file: expected " + beside.string() + " (or " + shared.string() + ")");

  Assimp::Importer importer;
  // Points and lines carry no surface: drop them after triangulation.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices | aiProcess_SortByPType;
  const aiScene* imported = importer.ReadFile(file, flags);
  if (!imported) throw make_error(file, "", std::string("assimp cannot read it: ") + importer.GetErrorString());
  // Shared vertices are joined, except in meshes coloured per vertex: assimp 5.2's
  // JoinIdenticalVertices ignores colours and would merge corners of differently coloured faces
  // (fixed upstream in assimp PR #4872, 2023). The renderer needs no shared vertices.
  bool coloured_meshes = false;
  for (unsigned m = 0; m < imported->mNumMeshes; ++m)
    coloured_meshes = coloured_meshes || imported->mMeshes[m]->HasVertexColors(0);
  if (!coloured_meshes) {
    imported = importer.ApplyPostProcessing(aiProcess_JoinIdenticalVertices);
    if (!imported) throw make_error(file, "", std::string("assimp cannot read it: ") + importer.GetErrorString());
  }

  Scene scene;
  scene.name = path.stem().string();
  TriangleMesh& mesh = scene.mesh;

  // Materials actually used by a mesh, in assimp's order (OBJ: the order of the MTL file; the
  // unused default material assimp adds is left out).
  std::vector<bool> used(imported->mNumMaterials, false);
  for (unsigned m = 0; m < imported->mNumMeshes; ++m)
    if (imported->mMeshes[m]->mMaterialIndex < imported->mNumMaterials && imported->mMeshes[m]->mNumFaces > 0)
      used[imported->mMeshes[m]->mMaterialIndex] = true;
  std::vector<int> material_of(imported->mNumMaterials, -1);
  std::map<std::string, int> texture_of_path;
  for (unsigned m = 0; m < imported->mNumMaterials; ++m) {
    if (!used[m]) continue;
    const aiMaterial& source = *imported->mMaterials[m];
    Material material;
    aiString name;
    material.name = source.Get(AI_MATKEY_NAME, name) == AI_SUCCESS ? name.C_Str() : "material_" + std::to_string(m);
    const std::string field = "material " + material.name;
    aiColor3D diffuse;
    if (source.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) == AI_SUCCESS)
      material.albedo = Eigen::Vector3f(diffuse.r, diffuse.g, diffuse.b);
    aiString texture_path;
    bool has_texture = source.GetTextureCount(aiTextureType_DIFFUSE) > 0 &&
                       source.GetTexture(aiTextureType_DIFFUSE, 0, &texture_path) == AI_SUCCESS;
    if (!has_texture)
      has_texture = source.GetTextureCount(aiTextureType_BASE_COLOR) > 0 &&
                    source.GetTexture(aiTextureType_BASE_COLOR, 0, &texture_path) == AI_SUCCESS;
    if (has_texture && texture_path.length > 0) {
      std::string reference = texture_path.C_Str();
      const aiTexture* embedded = imported->GetEmbeddedTexture(reference.c_str());
      std::string key = reference;
      fs::path resolved;
      if (!embedded) {
        std::replace(reference.begin(), reference.end(), '\\', '/');
        resolved = fs::path(reference);
        if (resolved.is_relative()) resolved = folder / resolved;
        key = resolved.lexically_normal().string();
      }
      auto found = texture_of_path.find(key);
      if (found != texture_of_path.end()) {
        material.texture = found->second;
      } else {
        Texture texture;
        if (embedded) {
          texture = embedded_texture(*embedded, "embedded_" + std::to_string(texture_of_path.size()), file, field);
        } else {
          try {
            texture = texture_from_image(read_rgb(resolved), resolved.stem().string());
          } catch (const Error& e) {
            throw make_error(file, field, std::string("bad texture: ") + e.what());
          }
        }
        scene.textures.push_back(std::move(texture));
        material.texture = static_cast<int>(scene.textures.size()) - 1;
        texture_of_path.emplace(key, material.texture);
      }
      // A texture without a diffuse colour in the file is shown as it is.
      if (source.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) != AI_SUCCESS) material.albedo = Eigen::Vector3f::Ones();
    }
    material_of[m] = static_cast<int>(scene.materials.size());
    scene.materials.push_back(material);
  }

  // Geometry: node transforms are already applied (PreTransformVertices). Per-vertex colours
  // (channel 0) replace the material's albedo (TriangleMesh::vertex_colours); if only some meshes
  // of the file have them, the others' vertices take their material's albedo, which renders them
  // exactly as without vertex colours.
  bool any_vertex_colours = false;
  for (unsigned m = 0; m < imported->mNumMeshes; ++m)
    any_vertex_colours = any_vertex_colours || imported->mMeshes[m]->HasVertexColors(0);
  for (unsigned m = 0; m < imported->mNumMeshes; ++m) {
    const aiMesh& source = *imported->mMeshes[m];
    const int first = static_cast<int>(mesh.vertices.size());
    for (unsigned v = 0; v < source.mNumVertices; ++v)
      mesh.vertices.emplace_back(source.mVertices[v].x, source.mVertices[v].y, source.mVertices[v].z);
    const bool has_uvs = source.HasTextureCoords(0);
    const int material = source.mMaterialIndex < material_of.size() ? material_of[source.mMaterialIndex] : -1;
    if (any_vertex_colours) {
      const Eigen::Vector3f fallback =
          material >= 0 ? scene.materials[static_cast<std::size_t>(material)].albedo : Material().albedo;
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        Eigen::Vector3f colour = fallback;
        if (source.HasVertexColors(0)) {
          const aiColor4D& c = source.mColors[0][v];
          colour = Eigen::Vector3f(c.r, c.g, c.b);
          if (!colour.allFinite())
            throw make_error(file, "vertex colour " + std::to_string(first + static_cast<int>(v)), "not finite");
          colour = colour.cwiseMax(0.f).cwiseMin(1.f);
        }
        mesh.vertex_colours.push_back(colour);
      }
    }
    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      if (face.mNumIndices != 3) continue;
      mesh.triangles.emplace_back(first + static_cast<int>(face.mIndices[0]),
                                  first + static_cast<int>(face.mIndices[1]),
                                  first + static_cast<int>(face.mIndices[2]));
      for (int k = 0; k < 3; ++k) {
        if (has_uvs) {
          const aiVector3D& uv = source.mTextureCoords[0][face.mIndices[k]];
          mesh.corner_uvs.emplace_back(uv.x, uv.y);
        } else {
          mesh.corner_uvs.emplace_back(0.f, 0.f);
        }
      }
      mesh.triangle_material.push_back(material);
    }
  }
  if (mesh.triangles.empty()) throw make_error(file, "triangles", "the model has no triangles");
  // Faces without a material (possible in PLY) get a plain grey one.
  if (std::any_of(mesh.triangle_material.begin(), mesh.triangle_material.end(), [](int m) { return m < 0; })) {
    Material grey;
    grey.name = "default_grey";
    scene.materials.push_back(grey);
    for (int& m : mesh.triangle_material)
      if (m < 0) m = static_cast<int>(scene.materials.size()) - 1;
  }

  scenes::read_positions_file(positions_file, scene);
  if (scene.lights.empty()) {
    Eigen::Vector3f lo = mesh.vertices[0], hi = mesh.vertices[0];
    for (const Eigen::Vector3f& v : mesh.vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    PointLight light;
    light.position = Eigen::Vector3f(0.5f * (lo.x() + hi.x()), 0.5f * (lo.y() + hi.y()), hi.z() - 0.3f);
    scene.lights.push_back(light);
  }
  scene.check(file);
  return scene;
}

Scene load_scene(const std::string& name_or_path, const scenes::SceneStyle& style, bool style_given) {
  if (scenes::is_builtin_scene(name_or_path)) return scenes::make_builtin_scene(name_or_path, style);
  if (style_given)
    throw make_error(name_or_path, "scene.texture",
                     "applies to the built-in scenes only: a scene file is rendered with its own materials (a "
                     "generated room's density is chosen when generating it: scene generate --texture)");
  std::error_code ec;
  if (!fs::exists(fs::path(name_or_path), ec))
    throw make_error(name_or_path, "scene",
                     "no such scene file, and not a built-in scene (built-in: " + builtin_list() + ")");
  return load_scene_file(name_or_path);
}

}  // namespace panoscan
