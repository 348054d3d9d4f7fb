// Propagation of an edit through the feature graph (thesis 6.1.1): the edited features take their
// new surfaces, related features follow the relations the user keeps, and then, ring by ring from
// the edit, every feature whose tangent contact with a changed neighbour broke takes the pose that
// restores it (a fillet rolls along the planes it joins and keeps its radius; a slot's end, which
// cannot keep its radius between two planes that moved apart, takes the radius they leave).
#pragma once

#include "edit/edit.h"

#include <Eigen/Geometry>

#include <vector>

namespace idealize {

struct Propagation {
  std::vector<Surface> surfaces;             // per feature: after the edit
  std::vector<Eigen::Isometry3d> motions;    // per feature: the rigid part of its change
  std::vector<char> changed;                 // per feature: 1 where its surface changed
};

// The surfaces after `edit` (see edit_features for the arguments). Throws EditConflict naming the
// features when a contact cannot be kept within kExactFraction of the distance tolerance.
Propagation propagate_edit(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                           const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                           const FeatureEdit& edit, const EditOptions& options);

// +1 where the positive side of `surface` (its signed distances) faces away from the material of
// the feature `feature`, -1 where it faces into it, from the orientation of its triangles and of
// the whole mesh (a closed mesh's signed volume says whether they face out).
double outward_side(const TriangleMesh& mesh, const std::vector<int>& labels, int feature, const Surface& surface);

}  // namespace idealize
