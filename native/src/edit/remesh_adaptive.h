// Adaptive remeshing of the region an edit moved (thesis 6.1.2): split long edges, collapse short
// ones, flip for valence and relax tangentially (Botsch & Kobbelt, "A remeshing approach to
// multiresolution modeling", SGP 2004, as CGAL::Polygon_mesh_processing::isotropic_remeshing
// implements it), with the borders between features constrained: they are split and collapsed
// but never flipped, and their vertices slide along them. Every vertex is projected onto its
// features' surfaces (a border vertex onto their intersection), and new triangles inherit the
// feature of the region they lie in.
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <set>
#include <utility>
#include <vector>

namespace idealize {

struct RemeshedLayer {
  TriangleMesh mesh;
  std::vector<int> labels;  // per face of `mesh`: its feature
};

// Remeshes the faces of `mesh` whose feature has a target edge length (`target_edge_length`, per
// feature; 0 leaves the feature as it is), one feature at a time, in `iterations` rounds each.
// `labels` (#F): each face's feature; `surfaces`: each feature's surface; `g1`: the tangent pairs
// of features (smaller id first). Corners where three or more features meet stay where they are
// during the remeshing, and are then projected onto the meeting point of their surfaces (an edit
// that moved them). With `keep_others`, the features that are not remeshed keep their triangles
// (but for splits of their borders' edges): the vertices they share with remeshed ones stay where
// they are (no relaxation along borders), and corners are not projected (an edit that kept the surfaces; there, two corners of a tessellation's facets along
// an edge may share that point).
// The mesh must be a consistently oriented manifold; throws MeshError otherwise.
RemeshedLayer remesh_adaptive(const TriangleMesh& mesh, const std::vector<int>& labels,
                              const std::vector<double>& target_edge_length, const std::vector<Surface>& surfaces,
                              const std::set<std::pair<int, int>>& g1, int iterations, bool keep_others = false);

}  // namespace idealize
