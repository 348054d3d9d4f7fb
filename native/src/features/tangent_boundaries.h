// The border between two tangent features, moved to where their surfaces touch.
//
// Near the line where a fillet touches the plane beside it, both surfaces lie within the noise of
// the mesh over a band about sqrt(2 r σ) wide on each side (a radius-r fillet leaves its tangent
// plane by s²/2r at arc length s): there no fit decides, and the plane, the larger patch, ends up
// with a fifth of a narrow fillet on each side. The surfaces themselves say where the border is:
// the touching line (plane–cylinder), circle (plane–torus) or parallel (cylinder–sphere, cylinder–
// torus), thesis 4.3's tangency between adjacent ideal surfaces.
#pragma once

#include "features/feature_layer.h"

#include <vector>

namespace idealize {

// Moves faces across the border of each tangent pair (relations of kind "tangent" between features
// of the pairs named above) to the side of the touching curve their centroid lies on, starting at
// the border and spreading from the faces moved; a face moves only when the surface that takes it
// explains its centroid within three of that surface's spreads, and moves once. labels (#F) holds a
// feature id per face (-1: none). Returns the number of faces moved.
int settle_tangent_boundaries(const TriangleMesh& mesh, const MeshTopology& topology,
                              const std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                              std::vector<int>& labels);

}  // namespace idealize
