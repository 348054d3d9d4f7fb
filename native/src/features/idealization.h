// Idealization of the feature table (thesis 4.3, part 1 and the relation-driven steps of part 2):
// the features' surfaces are made exactly parallel, perpendicular, coaxial, coplanar and of equal
// radius where the feature graph says they nearly are, and axes are snapped to the ideal
// directions of the part's own frame.
//
// The frame: the normal of the largest plane is Z; the largest feature whose direction is
// orthogonal to it (within the angle tolerance) gives X. A direction within the angle tolerance of
// a direction in a coordinate plane of that frame at 0, 10, 30, 45, 60 or 90 degrees (and their
// supplements) from a frame axis snaps to it; so does a cone's half-angle, about such a direction,
// where the ideal cone fits its points about as well, and coaxial cones that one cone fits (the
// corner pieces of a chamfered hexagon) take it. Tori whose tube radius or centre the relations
// share are fitted again about their axis with them (one tube and one centre per concentric group,
// each its own circle), together with the coaxial cylinders they touch. Cylinders tangent to
// planes parallel to their axis move to touch them (keeping their radius), and so do tori tangent
// to a plane across their axis or a coaxial cylinder or cone (keeping their tube radius). No
// constraint solver: groups are made consistent one relation kind at a time, in the order a
// designer fixes them (directions, then positions, then profiles about the fixed axes, then sizes,
// then tangency), so an answer always exists.
#pragma once

#include "features/feature_layer.h"

#include <vector>

namespace idealize {

struct IdealizationOptions {
  double angle_tolerance_degrees = 5.0;  // the thesis's alignment tolerance
  double distance_tolerance = 0.0;       // model units; must be set (the layer's tolerance)
  bool snap_to_frame = true;             // snap directions to the part's ideal directions
  std::vector<int> unsnapped;            // features (ids) whose directions stay as fitted
  // The points of each feature (by id; one set per feature, else idealize_features throws
  // std::invalid_argument), or null: then a cylinder or cone whose axis the directions
  // and coaxial groups moved keeps its fitted profile; with them its profile is fitted again about
  // the ideal axis (the thesis's semi-defined features, 4.3: a narrow chamfer cone's fitted
  // half-angle is off by as much as its tilt allows); related tori are refitted only with them.
  const std::vector<FitData>* points = nullptr;
  // Whether the profiles of cylinders and cones whose axis moved are fitted again (with `points`).
  bool refit_moved_profiles = true;
  // With `points`: an ideal cone (pieces joined, half-angle snapped) may fit its points by this
  // factor worse (RMS) than the fitted one.
  double residual_ratio = 1.5;
};

// Idealizes `features` in place using `relations` (from build_feature_graph). Freeform features
// are left alone. Returns the number of features whose surface changed.
int idealize_features(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                      const IdealizationOptions& options);

}  // namespace idealize
