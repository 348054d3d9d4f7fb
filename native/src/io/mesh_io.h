// Reading triangle meshes: binary and ASCII STL, OBJ, OFF, PLY (ASCII and binary).
//
// Every reader keeps the triangles in file order (polygons are fan-triangulated in order) so that
// per-triangle results map one-to-one onto the user's file. STL vertices are welded where their
// coordinates are bit-identical. Nothing is repaired here; mesh_preparation.h does that.
#pragma once

#include "core/mesh.h"

#include <string>

namespace idealize {

struct MeshReadInfo {
  std::string format;          // "stl-binary", "stl-ascii", "obj", "off", "ply-ascii", "ply-binary"
  long long file_triangles = 0;  // triangles in the file (after fan triangulation of polygons)
  long long file_vertices = 0;   // vertices in the file (STL: 3 per triangle, before welding)
};

// Reads a mesh, choosing the reader by content (binary STL sniffing) and by extension.
// Throws MeshError naming the problem: missing/empty file, unknown format, truncated data,
// bad indices, NaN/inf coordinates, no triangles.
TriangleMesh read_mesh(const std::string& path, MeshReadInfo* info = nullptr);

// The same from bytes already in memory; `name_hint` supplies the extension (".stl", ".obj" …).
TriangleMesh read_mesh_from_memory(const std::string& bytes, const std::string& name_hint,
                                   MeshReadInfo* info = nullptr);

}  // namespace idealize
