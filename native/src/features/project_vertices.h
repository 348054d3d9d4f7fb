// Projection of the mesh onto its features' surfaces: the idealized mesh and its deviation.
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

// Moves every input vertex onto the surfaces of the features around it that explain it: onto the
// one surface inside a patch, onto the intersection of two or three along edges and at corners
// (alternating projections, which converge to the nearest common point of transversal surfaces).
void project_vertices(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                      const std::vector<Feature>& features, double tolerance, FeatureLayer& layer,
                      const ProgressSpan& progress);

}  // namespace idealize
