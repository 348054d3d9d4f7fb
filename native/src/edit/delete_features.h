// Deleting a feature group from a mesh (thesis 6.2.1, "delete"): the group's triangles are lifted
// off, the faces around each hole they leave erode into it until it is closed (erosion.h: one
// plane or cylinder closes over a group inside it; several meet along new edges across a group
// that sat across their edges, and identical ones join), and the new triangles are remeshed
// adaptively, so the mesh stays closed, manifold and well shaped.
#pragma once

#include "core/mesh.h"
#include "edit/edit.h"
#include "features/feature_layer.h"
#include "fit/surface.h"

#include <string>
#include <utility>
#include <vector>

namespace idealize {

struct DeleteResult {
  TriangleMesh mesh;              // the mesh without the group, its gaps closed
  std::vector<int> labels;        // per face of `mesh`: the feature's new id
  std::vector<int> kept;          // per remaining feature (new id): its id before the edit
  std::vector<int> hosts;         // the new ids of the features that closed over the gaps
  std::vector<char> created;      // per face of `mesh`: made to close a gap
  std::vector<std::pair<int, int>> merged;  // (old id, old id it joined): identical hosts a gap joined
  std::vector<std::pair<int, int>> edges;   // the new edges' features (new ids, smaller first)
  int new_edges = 0;                        // the new edges made across the gaps
  int corners = 0;                          // the new corners where new edges meet
  Eigen::VectorXd vertex_deviation;         // per vertex, as EditResult's
  std::vector<double> target_edge_lengths;  // per remaining feature: its remeshing target
  std::string remeshing_problem;            // as EditResult's
};

// Deletes `features` (ids into `surfaces`) from a layer: `mesh` its idealized mesh (vertices on
// their features, triangles oriented consistently), `labels` its #F feature ids, `surfaces` its
// features' surfaces, `adjacency` its feature graph. `options`: the distance tolerance, whether to
// remesh, the per-feature targets and rounds (EditOptions; relations are not used). Throws
// EditConflict, naming the features, when the faces around a gap cannot close it, std::invalid_argument for ids
// that name no feature or name them all. The features that remain keep their surfaces exactly.
DeleteResult delete_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                             const std::vector<Surface>& surfaces, const std::vector<FeatureAdjacency>& adjacency,
                             const std::vector<int>& features, const EditOptions& options);

}  // namespace idealize
