// Reassignment of rim faces to the neighbour whose surface explains them.
#pragma once

#include "features/feature_layer.h"
#include "features/patch_points.h"

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

// Moves faces on the rim of a patch to an edge-adjacent patch whose surface explains them when
// their own does not, or explains them several times better (segmentation leaves the first facets
// of a coarse fillet on the plane beside it, whose tolerances they may just meet). A moved face
// opens its neighbours to the same test, so a whole strip moves in one call. Returns which patches
// changed.
std::vector<char> reassign_faces(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<Feature>& features,
                                 const FeatureOptions& options, double floor, std::vector<int>& labels,
                                 const ProgressSpan& progress);

}  // namespace idealize
