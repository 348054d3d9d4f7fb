// The mesh update of an edit (thesis 6.1.2): vertices move onto their features' new surfaces, and
// boundary vertices onto the intersections of their features' new surfaces.
//
// Vertices of a changed feature follow its motion and land on its new surface. Features that did not
// change but border a changed one (a wall under a pushed face) stretch: their vertices take the
// harmonic interpolation of their borders' displacements (uniform Laplacian, Dirichlet on the
// moved and on the fixed borders) and are put back on their surfaces. Everything else stays.
#pragma once

#include "edit/propagate.h"

#include <set>
#include <string>
#include <utility>
#include <vector>

namespace idealize {

struct MovedVertices {
  MatrixX3d V;                  // the new positions (the input's triangles)
  // Per face: 1 on a stretched feature or one whose shape changed (what remeshing redoes); a
  // feature that only moved keeps its triangles.
  std::vector<char> region;
};

// The vertices of `mesh` after the propagated edit `propagation` (surfaces, motions, changed).
MovedVertices move_vertices(const TriangleMesh& mesh, const std::vector<int>& labels,
                            const std::vector<FeatureAdjacency>& adjacency, const std::vector<Surface>& before,
                            const Propagation& propagation);

// The point nearest to p on all of `features`' surfaces (their common edge or corner): a tangent
// pair through its contact point, the rest by Gauss-Newton steps of least norm, alternately.
// Freeform features impose nothing. `g1`: the tangent pairs of features (smaller id first).
Eigen::Vector3d onto_features(const std::vector<int>& features, const std::vector<Surface>& surfaces,
                              const std::set<std::pair<int, int>>& g1, Eigen::Vector3d p, double length);

// Per feature: +1 where its triangles face the positive side of its surface, -1 where they face
// the other (freeform features: +1).
std::vector<double> facing_sides(const TriangleMesh& mesh, const std::vector<int>& labels,
                                 const std::vector<Surface>& surfaces);

// How squarely the triangle (a, b, c) faces `surface`'s positive side: the cosine between its
// normal and the surface's normal at its centre; 0 for a degenerate triangle.
double facing_cosine(const Surface& surface, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                     const Eigen::Vector3d& c);

// An edit that turns triangles over: the change is too large for the mesh as it is (a border moved
// across more triangles than the remeshing can relocate), or impossible (a face pushed past the one
// behind it). Edits in smaller steps tell the two apart.
class InvertedTriangles : public EditConflict {
 public:
  using EditConflict::EditConflict;
};

// "N triangles of feature F (type)": the feature with the most triangles of an `edited` feature
// that face against its surface's side `sides`; empty when none does.
std::string inverted_triangles(const TriangleMesh& mesh, const std::vector<int>& labels,
                               const std::vector<Surface>& surfaces, const std::vector<double>& sides,
                               const std::vector<char>& edited);

// Throws InvertedTriangles naming the edited features `edit_of` and the feature with the most triangles
// turned over: triangles of an `edited` feature that face against its surface's side `sides` (a
// face pushed past the one behind it turns the walls between inside out).
void refuse_inverted(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                     const std::vector<double>& sides, const std::vector<char>& edited,
                     const std::vector<int>& edit_of);

}  // namespace idealize
