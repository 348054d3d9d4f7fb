// Narrow fillets that segmentation gave to the features beside them.
//
// A rounded edge a facet or two wide sags across the edge by a few times a scan's noise: no
// curvature histogram sees a patch there, and the two features take half of it each (on the NIST
// test parts, most fillets of radius 0.8-1.5 edge lengths). Where two planes meet, a plane meets a
// cylinder or cone across its axis, or a cone meets a cylinder or cone about its axis, the two
// surfaces are lines in a cross-section (across the planes' line; through the axis). There the
// vertices near the edge fit either the sharp wedge or the wedge rounded by the circle tangent to
// both lines, which adds one parameter, its radius (J. S.-S. Chen, "Hybrid CAD modeler", 4.3: a
// fillet is defined by the surfaces it is tangent to and its radius): a cylinder along the planes'
// line, or a torus about the axis. The rounding is kept
// where the Bayesian information criterion prefers it (counting correlated residuals, a sculpted
// part's, as fewer independent ones), the band fits it about as well as the planes fit their own
// patches, and its arc is longer than a mesh edge (a rounding that narrow is what uniform
// re-tessellation, or displacement along averaged vertex normals, makes of a sharp edge);
// the faces between its tangent lines become a cylinder or torus feature. At this resolution a
// chamfer of the same width fits the rounded wedge as well (no fit tells them apart): it becomes a
// fillet too.
#pragma once

#include "features/feature_layer.h"

#include <vector>

namespace idealize {

struct EdgeFilletOptions {
  // Surfaces closer than this to parallel in the section (radians) have no edge between them; a
  // plane's normal within it of an axis is across it.
  double angle_tolerance = 5.0 * 3.14159265358979323846 / 180.0;
  // The band fitted on each side of the edge, in median edge lengths: fillets whose tangent lines
  // lie within half of it are found (larger ones are patches of their own).
  double band_edges = 10.0;
  // The band must fit the rounded wedge with a spread of at most this many times the planes' own
  // (as identification accepts a surface: FeatureOptions::residual_ratio).
  double residual_ratio = 1.5;
  // Radii within this fraction of each other are one design radius (FeatureOptions::radius_tolerance).
  double radius_tolerance = 0.05;
  // The shortest arc (in median edge lengths) that is a fillet: uniform re-tessellation cuts a sharp
  // edge with a strip of facets up to an edge wide, and a sculpted mesh's displacement along vertex
  // normals (averaged across the edge) rounds it over as much. Measured on the benchmark: the
  // roundings fitted at sharp edges spanned at most 1.03 edges, the narrowest true fillets 1.25-1.3.
  double shortest_arc = 1.15;
};

// The share of a mesh's residuals that counts as independent evidence, (1 - rho) / (1 + rho), rho
// being the correlation of the plane features' residuals at the ends of their mesh edges (labels:
// feature per face, -1 none): rho is about 0 for a scan's independent noise, near 1 for a sculpted
// part's smooth undulation (measured on the benchmark: 0.02-0.27 on the scans, 0.74-0.87 sculpted).
double independent_share(const TriangleMesh& mesh, const std::vector<Feature>& features,
                         const std::vector<int>& labels);

// Finds the rounded edges between adjacent features of a noisy mesh (two planes; a plane and a
// cylinder or cone across its axis; a cone and a coaxial cylinder or cone) and appends a cylinder or
// torus feature for each (type, surface; its residuals are left to the caller), relabelling the
// faces between its tangent lines. labels
// (#F): feature id per face (-1: none); features: indexed by id, with their spreads. Returns, per
// feature after the call, whether it changed (a new fillet, or a feature that gave it faces).
std::vector<char> round_edges(const TriangleMesh& mesh, const MeshTopology& topology,
                                    const EdgeFilletOptions& options, std::vector<Feature>& features,
                                    std::vector<int>& labels);

}  // namespace idealize
