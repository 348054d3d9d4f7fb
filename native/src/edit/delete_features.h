// Deleting a feature group from a mesh (thesis 6.2.1, "delete"): the group's triangles are lifted
// off, each hole they leave is closed on the face that surrounds it (a plane, or a cylinder), and
// the new triangles are remeshed adaptively, so the mesh stays closed, manifold and well shaped.
//
// The thesis lets the features around the gap erode into it until it is one boundary. Here the
// gap must already be one: each border loop of the group runs along a single plane or cylinder,
// which holds it as an inner loop (feature_groups.h). A group whose border runs along several
// features (a notch across an edge) is refused with a message naming them.
#pragma once

#include "core/mesh.h"
#include "edit/edit.h"
#include "features/feature_layer.h"
#include "fit/surface.h"

#include <string>
#include <vector>

namespace idealize {

struct DeleteResult {
  TriangleMesh mesh;              // the mesh without the group, its gaps closed
  std::vector<int> labels;        // per face of `mesh`: the feature's new id
  std::vector<int> kept;          // per remaining feature (new id): its id before the edit
  std::vector<int> hosts;         // the new ids of the features that closed over the gaps
  std::vector<char> created;      // per face of `mesh`: made to close a gap
  Eigen::VectorXd vertex_deviation;         // per vertex, as EditResult's
  std::vector<double> target_edge_lengths;  // per remaining feature: its remeshing target
  std::string remeshing_problem;            // as EditResult's
};

// Deletes `features` (ids into `surfaces`) from a layer: `mesh` its idealized mesh (vertices on
// their features, triangles oriented consistently), `labels` its #F feature ids, `surfaces` its
// features' surfaces, `adjacency` its feature graph. `options`: the distance tolerance, whether to
// remesh, the per-feature targets and rounds (EditOptions; relations are not used). Throws
// EditConflict when a gap is not closed by one plane or cylinder, std::invalid_argument for ids
// that name no feature or name them all. The features that remain keep their surfaces exactly.
DeleteResult delete_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                             const std::vector<Surface>& surfaces, const std::vector<FeatureAdjacency>& adjacency,
                             const std::vector<int>& features, const EditOptions& options);

}  // namespace idealize
