// The feature graph: which features meet, how (sharp G0 or tangent G1), and the geometric
// relations a designer would have used (thesis 4.3).
#pragma once

#include "features/feature_layer.h"

namespace idealize {

// Fills `adjacency` (features sharing a mesh edge, sorted by (a, b)) and `relations`:
//   parallel, coplanar, coaxial, equal_radius, concentric: groups of two or more features
//     (directions are plane normals and axes; radii are those of cylinders and spheres and the
//     tube radius of tori, so a fillet's radius compares with the holes');
//   perpendicular, tangent: pairs of adjacent features.
// `angle_tolerance` in radians, `distance_tolerance` in model units; radii are equal within the
// larger of the distance tolerance and `radius_tolerance` times the radius (equal_radii), unless
// they differ by more than `radius_tolerance` times the radius and three standard errors of the
// difference (Feature::radius_error, measure_radius_errors).
void build_feature_graph(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                         const std::vector<Feature>& features, double angle_tolerance, double distance_tolerance,
                         double radius_tolerance, std::vector<FeatureAdjacency>& adjacency,
                         std::vector<FeatureRelation>& relations);

// Sets the radius_error of the features with a tube radius (cylinders, spheres, tori): the standard
// error of the radius fitted to `points` (by feature id: every vertex of the feature's triangles,
// FitData::points; tube_radius_error), with the part's `departure` from its surfaces
// (form_deviation), which moves each radius as a whole. Of fitted surfaces (ideal ones were moved
// off their points on purpose).
void measure_radius_errors(const std::vector<FitData>& points, double departure, std::vector<Feature>& features);

// How far a mesh departs from its features' surfaces other than by independent noise, as a
// sculpted part's undulation does (which moves a fillet's fitted radius as a whole, where noise
// averages out): the square root of the covariance of the deviations of neighbouring vertices from
// their feature's surface, deep inside the features (two rings from their borders, which a rim's
// misfit reaches), the median over the analytic features by their vertices. Noise does not
// correlate across an edge (the benchmark's scans: 0.00-0.05 of its variance, pooled over each
// part's planes), an undulation does (its sculpted parts: 0.71-0.98). Of fitted surfaces: ideal
// ones, turned or moved a little, leave trends that correlate too.
double form_deviation(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Feature>& features);

// Whether two features with radii (cylinders, spheres; tori by their tube) have one design radius:
// equal within the larger of the distance tolerance and `radius_tolerance` times the radius, plus
// the spread of the looser fit (a sculpted surface's undulation moves a fillet's points, and so its
// radius, by about as much as it scatters them).
bool equal_radii(const Feature& a, const Feature& b, double distance_tolerance, double radius_tolerance);

}  // namespace idealize
