// Making a user's triangle soup safe for geometry processing, without losing the mapping back.
//
// Degenerate triangles (repeated vertex, zero area) and exact duplicates are set aside; unused
// vertices are dropped. `face_origin` maps every working face to the user's face so results are
// reported per input triangle.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

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

// Scales refused by prepare_mesh (MeshError), measured on the vertices the triangles use. They
// refuse only what cannot be processed, whatever the unit: a 0.1 m part in metres, a 10 mm part in
// micrometres (1e4) or a 1e-6 m part pass.
// - Bounding-box diagonal below kMinDiagonal (or zero): every triangle collapsed to a point.
constexpr double kMinDiagonal = 1e-9;
// - A coordinate beyond kMaxCoordinate (or a diagonal that overflows): the fits multiply up to about
//   eight coordinates, which overflows double precision (1e308) around there.
constexpr double kMaxCoordinate = 1e30;
// - The largest |coordinate| above kMaxOffsetRatio times the diagonal: single precision (STL keeps
//   24 bits, 6e-8 relative) then spaces representable points more than half the part apart, and the
//   algebraic fits, which square coordinates, lose 1e-16 * ratio^2 = 1e-2 of the part's size.
constexpr double kMaxOffsetRatio = 1e7;

// Throws MeshError when nothing usable remains, coordinates are not finite or at an absurd scale
// (above); Cancelled when `progress` is cancelled.
PreparedMesh prepare_mesh(const TriangleMesh& input, const ProgressSpan& progress = {});

}  // namespace idealize
