// The tables a feature layer keeps of its labelled mesh, in one linear pass over it: which features
// each vertex's faces have, which features share an edge, and each feature's area and triangle
// count. A local re-idealization (thesis ch. 7), which relabels a sculpted region of a large mesh,
// rebuilds them so instead of with whole-mesh array sorts.
#pragma once

#include "core/mesh.h"

#include <array>
#include <utility>
#include <vector>

namespace idealize {

struct FeatureTables {
  // The distinct (vertex, feature) pairs of the labelled faces, by feature, then by vertex.
  std::vector<std::array<int, 2>> vertex_features;
  // The pairs of features (a, b), a < b, that share a mesh edge, sorted.
  std::vector<std::pair<int, int>> adjacent;
  std::vector<double> area;   // per feature: the area of its faces
  std::vector<int> triangles; // per feature: the number of its faces
};

// The tables of `mesh` whose faces have the feature `labels` (#F; -1 for none, else below
// `num_features`). Throws MeshError for labels of another length or out of range.
FeatureTables feature_tables(const TriangleMesh& mesh, const std::vector<int>& labels, int num_features);

}  // namespace idealize
