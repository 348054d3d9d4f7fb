// Dynamic topology for sculpting (thesis ch. 5, "adaptive remeshing" as Freestyle and Sculptris do
// it): after each dab of a brush, the triangles round the moved vertices are remeshed towards a
// target edge length, so that they stay well shaped under large deformation. Isotropic remeshing
// (Botsch & Kobbelt, "A remeshing approach to multiresolution modeling", SGP 2004): split edges
// longer than 4/3 of the target, collapse those shorter than 4/5, flip towards valence 6 (4 on the
// border), and relax each vertex towards its neighbours' centroid in its tangent plane.
#pragma once

#include "sculpt/sculpt_mesh.h"

#include <vector>

namespace idealize {

struct DynamicTopologyOptions {
  // The edge length the triangles keep (> 0): the sculpted region's own, measured by the caller
  // before the stroke.
  double target_edge_length = 0.0;
  // Rounds of split, collapse, flip and relax per call. One round after each dab keeps up with a
  // brush that moves vertices by a fraction of the target each dab; two let it catch up with a grab.
  int rounds = 1;
};

// Remeshes the edges of `mesh` that have a vertex flagged in `active` (per vertex slot; vertices
// made by splits are flagged too, and `active` grows with the mesh). Only active vertices are
// removed or moved: the rest of the mesh keeps its vertices where they are, and faces the
// operations change are marked modified. A collapse or flip that would turn a face over, or make
// an edge longer than the split length, is skipped. Cost: linear in the active region's size.
void remesh_region(SculptMesh& mesh, std::vector<char>& active, const DynamicTopologyOptions& options);

}  // namespace idealize
