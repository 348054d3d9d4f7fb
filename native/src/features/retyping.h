// Rules that retype features or join them once the patches are settled.
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

// A small ball where fillets meet (thesis 4.3, case 2) fits a cylinder about as well as a sphere on
// a noisy mesh, and identification takes the simpler cylinder (a scan of blended boxes: a ball of
// r 0.1, 48 facets, between three fillets, fitted by a cylinder of r 0.12 across the corner). A
// cylinder beside two or more cylinders of one radius whose axes are not parallel and pass within
// the distance tolerance of one point is that ball, where the sphere about the point with their
// radius, which touches them all, fits its points as well as its cylinder (within the residual
// ratio; `points` by feature id, what their fits saw).
void make_balls_of_corner_cylinders(const TriangleMesh& mesh, const MeshTopology& topology, double angle_tolerance,
                                    double distance_tolerance, const FeatureOptions& options,
                                    const std::vector<int>& labels, const std::vector<PatchPoints>& points,
                                    std::vector<Feature>& features);

// A cylinder or cone beside a torus that explains its points about as well as its own surface does
// (spread and normal spread within `residual_ratio` times its own, as merging requires) is a piece of
// that torus (the half of a horn torus that touches no plane fitted a cone): its faces join the
// torus that explains it best. `beside`: pairs of adjacent features. Returns whether any joined.
bool join_torus_pieces(const std::vector<PatchPoints>& points, const std::vector<std::pair<int, int>>& beside,
                       double residual_ratio, double normal_floor, std::vector<Feature>& features,
                       std::vector<int>& labels);

// Freeform features that meet smoothly are pieces of one surface (the curvature histogram cuts a
// freeform surface where its curvature passes a valley): adjacent freeform features join where the
// border between them turns (the median turn between facets across it) no more sharply than the
// facets inside either at their sharpest. So does a feature too small for its fit to say anything
// (fewer than kInteriorPoints vertices: a CAD export's slivers where the freeform face meets its
// neighbours) that meets a freeform one so. Returns whether any feature joined.
bool join_freeform_features(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& labels,
                            std::vector<Feature>& features);

}  // namespace idealize
