// Making a user's triangle soup safe for geometry processing, without losing the mapping back.
//
// Degenerate triangles (repeated vertex, zero area) and exact duplicates are set aside; unused
// vertices are dropped. `face_origin` maps every working face to the user's face so results are
// reported per input triangle.
#pragma once

#include "mesh.h"
#include "progress.h"

#include <vector>

namespace idealize {

struct PreparedMesh {
  TriangleMesh mesh;             // the working mesh
  std::vector<int> face_origin;  // working face -> input face
  std::vector<int> input_face;   // input face -> working face (a duplicate maps to the face it repeats; -1 if degenerate)
  int removed_degenerate = 0;    // input faces with a repeated vertex or zero area
  int removed_duplicate = 0;     // input faces that repeat another face's vertices
  int removed_unused_vertices = 0;
};

// Throws MeshError when nothing usable remains or coordinates are not finite; Cancelled when
// `progress` is cancelled.
PreparedMesh prepare_mesh(const TriangleMesh& input, const ProgressSpan& progress = {});

}  // namespace idealize
