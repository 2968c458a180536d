// PLY meshes: the ground-truth mesh of a scan (binary little-endian PLY with float vertices and
// int32 triangle faces). The reader accepts ASCII and binary PLY with float or double vertices
// and triangle (or polygon, fan-triangulated) faces, and validates indices and coordinates.
#pragma once

#include <filesystem>

#include "panoscan/core/mesh.h"

namespace panoscan {

void write_ply_mesh(const std::filesystem::path& path, const TriangleMesh& mesh);
TriangleMesh read_ply_mesh(const std::filesystem::path& path);

}  // namespace panoscan
