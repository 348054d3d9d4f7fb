// Feature-based editing of a mesh through its feature layer, without changing its structure
// (thesis 6.1; Chen & Feng's hybrid CAD modeller): offset a plane, change a radius or a cone's
// angle, move or rotate features. The edit propagates through the feature graph ring by ring,
// the mesh's vertices move onto the new surfaces, and adaptive remeshing restores the triangles.
//
// The input is never modified: every function returns a new mesh, labels and surfaces.
#pragma once

#include "core/mesh.h"
#include "features/feature_layer.h"
#include "fit/surface.h"

#include <Eigen/Geometry>

#include <stdexcept>
#include <string>
#include <vector>

namespace idealize {

// An edit that no ideal configuration satisfies (a fillet larger than its wall, a face pushed
// through the one behind it). The message names the features in conflict; nothing was changed.
class EditConflict : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What the user changes of a feature's shape besides its position.
enum class EditParameter {
  None,
  Offset,       // the face moves by `value` along its normal, away from the material if positive
                // (a plane's offset, a round surface's radius grown or shrunk)
  Radius,       // a cylinder's or sphere's radius, a torus's major radius
  MinorRadius,  // a torus's tube radius
  HalfAngle,    // a cone's half-angle, radians
};

struct FeatureEdit {
  std::vector<int> features;                              // the edited features
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();  // moves them rigidly (move, rotate)
  EditParameter parameter = EditParameter::None;          // then this changes (each of them)
  double value = 0.0;
};

// Which relations of the layer an edit keeps (thesis 6.1.1); a relation not kept may break.
struct KeepRelations {
  bool tangent = true;       // tangent (G1) neighbours follow: fillets roll along their walls
  bool coplanar = true;      // coplanar planes offset together
  bool coaxial = true;       // coaxial features move with a moved axis
  bool concentric = true;    // concentric spheres and tori move with a moved centre
  bool equal_radius = true;  // equal radii change together
};

struct EditOptions {
  KeepRelations keep;
  // The layer's distance tolerance. A contact or intersection that misses by more than
  // kExactFraction of it (what the layer calls an exact fit) makes the edit a conflict.
  double distance_tolerance = 0.0;
  // Adaptive remeshing of the faces the edit moved (Botsch & Kobbelt 2004, CGAL's isotropic
  // remeshing with the feature borders constrained).
  bool remesh = true;
  // Per feature: the target edge length of its remeshing; empty (or 0 for a feature): its own
  // mean edge length before the edit, no longer than keeps its chords as close to its surface as
  // they were. Successive edits pass on the targets of the first (EditResult::target_edge_lengths),
  // so that the density does not drift (isotropic remeshing leaves edges a little shorter than
  // its target on average).
  std::vector<double> target_edge_lengths;
  // Rounds of split, collapse, flip and relocation: 3 is where CGAL's own examples stop, and
  // further rounds changed the minimum angles of a stretched wall by under 1° in our tests.
  int remesh_iterations = 3;
};

struct EditResult {
  TriangleMesh mesh;              // the edited mesh (new vertices and triangles)
  std::vector<int> labels;        // per face of `mesh`: feature id (new triangles inherit theirs)
  std::vector<Surface> surfaces;  // per feature: its surface after the edit
  std::vector<char> changed;      // per feature: 1 where the edit changed its surface
  // Per vertex of `mesh`: distance from the nearest surface of the analytic features around it
  // (NaN where only freeform features touch it), as the layer's vertex_deviation.
  Eigen::VectorXd vertex_deviation;
  std::vector<double> target_edge_lengths;  // per feature: the remeshing targets used (or derived)
  // Empty when the remeshing ran (or was not asked for); else why it failed: the mesh is then the
  // one with its vertices moved, valid but with the stretched triangles as they came.
  std::string remeshing_problem;
};

// Applies `edit` to a layer: `mesh` its idealized mesh (vertices on their features' surfaces,
// triangles oriented consistently), `labels` its #F feature ids, `surfaces` its features' surfaces
// (Freeform for a freeform feature), `adjacency` and `relations` its feature graph. Throws
// EditConflict when no ideal configuration satisfies the edit, std::invalid_argument for an edit
// that does not apply (a radius on a plane, a negative radius). Cost: the propagation is
// O(#contacts); the vertex update solves one sparse system over the stretched features' vertices.
EditResult edit_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                         const FeatureEdit& edit, const EditOptions& options);

// What the edits share.

// Throws std::invalid_argument unless `labels` (#F, -1 for a triangle set aside) and the graph name
// features of `surfaces` only.
void check_layer(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                 const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations);

// Per vertex: the distance from the nearest surface of the analytic features around it (NaN where
// only freeform features touch it).
Eigen::VectorXd vertex_deviation(const TriangleMesh& mesh, const std::vector<int>& labels,
                                 const std::vector<Surface>& surfaces);

// Per feature: the target edge length of its remeshing (EditOptions::target_edge_lengths): `given`
// where positive, else its own mean edge length, no longer than keeps its chords as close to a
// curved surface as its edges keep them now, or a quarter of `distance_tolerance`.
std::vector<double> remeshing_targets(const TriangleMesh& mesh, const std::vector<int>& labels,
                                      const std::vector<Surface>& surfaces, const std::vector<double>& given,
                                      double distance_tolerance);

}  // namespace idealize
