// The feature graph: which features meet, how (sharp G0 or tangent G1), and the geometric
// relations a designer would have used (thesis 4.3).
#pragma once

#include "feature_layer.h"

namespace idealize {

// Fills `adjacency` (features sharing a mesh edge, sorted by (a, b)) and `relations`:
//   parallel, coplanar, coaxial, equal_radius, concentric: groups of two or more features
//     (directions are plane normals and axes; radii are those of cylinders and spheres and the
//     tube radius of tori, so a fillet's radius compares with the holes');
//   perpendicular, tangent: pairs of adjacent features.
// `angle_tolerance` in radians, `distance_tolerance` in model units; radii are equal within the
// larger of the distance tolerance and `radius_tolerance` times the radius.
void build_feature_graph(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                         const std::vector<Feature>& features, double angle_tolerance, double distance_tolerance,
                         double radius_tolerance, std::vector<FeatureAdjacency>& adjacency,
                         std::vector<FeatureRelation>& relations);

// Whether two features with radii (cylinders, spheres; tori by their tube) have one design radius:
// equal within the larger of the distance tolerance and `radius_tolerance` times the radius, plus
// the spread of the looser fit (a sculpted surface's undulation moves a fillet's points, and so its
// radius, by about as much as it scatters them).
bool equal_radii(const Feature& a, const Feature& b, double distance_tolerance, double radius_tolerance);

}  // namespace idealize
