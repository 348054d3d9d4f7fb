// Copying a feature group to another place on its host planes or cylinders (thesis 6.2.2, "copy"; with
// delete_features, "move"). The group travels as a decal, the thesis's texture idea: its triangles
// and surfaces are carried rigidly, the host opens a gap of the group's outline at the new place,
// and the ring between that outline and the host's triangles around it is triangulated and
// remeshed. The original stays.
#pragma once

#include "core/mesh.h"
#include "edit/edit.h"
#include "features/feature_layer.h"
#include "fit/surface.h"

#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace idealize {

struct CopyResult {
  TriangleMesh mesh;              // the mesh with the copy in place
  std::vector<int> labels;        // per face of `mesh`: its feature (copies after the layer's)
  std::vector<Surface> surfaces;  // the layer's surfaces, then the copies'
  std::vector<int> copies;        // per feature given: its copy's id (a move: the feature's own)
  std::vector<int> hosts;         // the planes the copy sits on
  std::vector<char> created;      // per face of `mesh`: made to fill a gap (not the copy's own)
  Eigen::VectorXd vertex_deviation;         // per vertex, as EditResult's
  std::vector<double> target_edge_lengths;  // per feature (copies too): its remeshing target
  std::string remeshing_problem;            // as EditResult's
};

// Where a copy goes: turned by `rotation` (radians, counter-clockwise about the outward normal of
// the group's first host plane) about the line along that normal through the centroid of the
// group's vertices, then moved by `translation`, which must lie along the host planes. A group on
// a cylinder turns about the cylinder's axis instead, and moves along it.
//
// With `onto` (a plane feature), the group goes onto that face instead (a group on one host only):
// its host's outward normal turned onto that face's, its centre (on its host) onto the nearest
// point of that face's plane, then turned and moved along it as above.
struct Placement {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double rotation = 0.0;
  int onto = -1;
};

// Copies `features` (a group whose border loops each lie on one host plane or cylinder, as
// delete_features requires) to `placement`. `mesh`, `labels`, `surfaces`, `adjacency`, `options`: as
// delete_features. Throws EditConflict, naming the features, when the new place is off a host
// plane, reaches the host's edge or another feature, or overlaps the group itself;
// std::invalid_argument for ids that name no feature. The copy's surfaces are the originals
// moved rigidly; every other feature keeps its surface exactly.
CopyResult copy_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<int>& features,
                         const Placement& placement, const EditOptions& options);

// Moves `features` to `placement` as copy_features would copy them, the group deleted from its
// old place first (delete_features), so that the new place may overlap the old. The features keep
// their ids; the moved ones get their surfaces moved rigidly, the rest keep theirs exactly.
CopyResult move_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<int>& features,
                         const Placement& placement, const EditOptions& options);

}  // namespace idealize
