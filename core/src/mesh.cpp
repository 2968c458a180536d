#include "panoscan/core/mesh.h"

#include <cmath>

#include "panoscan/core/error.h"

namespace panoscan {

void Scene::check(const std::string& origin) const {
  const std::size_t num_vertices = mesh.vertices.size();
  const std::size_t num_triangles = mesh.triangles.size();
  if (num_triangles == 0) throw make_error(origin, "triangles", "the scene has no triangles");
  for (std::size_t i = 0; i < num_vertices; ++i)
    if (!mesh.vertices[i].allFinite()) throw make_error(origin, "vertex " + std::to_string(i), "non-finite coordinate");
  for (std::size_t t = 0; t < num_triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const int index = mesh.triangles[t][k];
      if (index < 0 || std::size_t(index) >= num_vertices)
        throw make_error(
            origin, "triangle " + std::to_string(t),
            "vertex index " + std::to_string(index) + " out of range (" + std::to_string(num_vertices) + " vertices)");
    }
  if (!mesh.vertex_colours.empty()) {
    if (mesh.vertex_colours.size() != num_vertices)
      throw make_error(origin, "vertex colours",
                       "expected one per vertex (" + std::to_string(num_vertices) + "), got " +
                           std::to_string(mesh.vertex_colours.size()));
    for (std::size_t i = 0; i < num_vertices; ++i) {
      const Eigen::Vector3f& c = mesh.vertex_colours[i];
      if (!c.allFinite() || c.minCoeff() < 0.f || c.maxCoeff() > 1.f)
        throw make_error(origin, "vertex colour " + std::to_string(i), "expected components in [0, 1]");
    }
  }
  if (!mesh.corner_uvs.empty() && mesh.corner_uvs.size() != 3 * num_triangles)
    throw make_error(origin, "texture coordinates", "expected 3 per triangle");
  for (std::size_t i = 0; i < mesh.corner_uvs.size(); ++i)
    if (!mesh.corner_uvs[i].allFinite())
      throw make_error(origin, "texture coordinate " + std::to_string(i), "non-finite value");
  if (!mesh.triangle_material.empty()) {
    if (mesh.triangle_material.size() != num_triangles)
      throw make_error(origin, "materials", "expected one material index per triangle");
    for (std::size_t t = 0; t < num_triangles; ++t) {
      const int m = mesh.triangle_material[t];
      if (m < 0 || std::size_t(m) >= materials.size())
        throw make_error(origin, "triangle " + std::to_string(t),
                         "material index " + std::to_string(m) + " out of range");
    }
  }
  for (std::size_t m = 0; m < materials.size(); ++m) {
    const int tex = materials[m].texture;
    if (tex < -1 || tex >= int(textures.size()))
      throw make_error(origin, "material " + materials[m].name, "texture index out of range");
    if (!materials[m].albedo.allFinite())
      throw make_error(origin, "material " + materials[m].name, "non-finite albedo");
  }
  for (const Texture& texture : textures)
    if (texture.width <= 0 || texture.height <= 0 ||
        texture.rgb.size() != std::size_t(texture.width) * texture.height * 3)
      throw make_error(origin, "texture " + texture.name, "pixel buffer does not match its size");
  for (const ScanPosition& position : positions)
    if (!position.floor_point.allFinite() || !std::isfinite(position.start_heading_rad))
      throw make_error(origin, "position " + position.name, "non-finite coordinate");
}

}  // namespace panoscan
