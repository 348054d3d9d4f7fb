// Merging adjacent patches that one surface fits together.
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

// Whether the mesh vertices on the border between patches a and b lie, at the median, within
// `distance_a` of a's surface and `distance_b` of b's: two planes of a face that undulates meet
// where their patches meet, while the two levels of a step do not.
bool surfaces_meet_at_border(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                             int a, int b, const Surface& sa, const Surface& sb, double distance_a, double distance_b);

// Whether two features may be pieces of one surface by their parameters: one type, parallel axes,
// radii that relations would take for equal (cones: half-angles within the angle tolerance); or a
// zone of a torus between two parallels, which a cone or cylinder about its axis fits.
bool alike(const Feature& a, const Feature& b, double angle_tolerance, double distance_tolerance, double radius_tolerance);

// Merges adjacent patches whose union one surface fits as well as each part alone: a fillet or a
// cylinder that segmentation split along the facet folds of a coarse tessellation. Patches of one
// type are refitted together; a patch too small to have interior vertices may also join a
// neighbour of another type (a single facet of a fillet is planar). Plain RMS values decide
// here, not the robust spreads, which would not see a small foreign face in the union. Each patch
// merges at most once per call; `rejected` remembers the pairs that did not fit together until one
// of them grows. On an exact tessellation (`exact`) the merged surface must also explain every
// vertex to within `exact_distance` and every facet normal; on a noisy one each part must fit it
// about as well as its own surface, `noise` being the least RMS expected. Returns whether any pair
// merged.
bool merge_patches(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                   const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                   const FeatureOptions& options, double tolerance, bool exact, double exact_distance, double noise,
                   std::vector<Feature>& features, std::vector<int>& labels, std::set<std::pair<int, int>>& rejected, const ProgressSpan& progress);

}  // namespace idealize
