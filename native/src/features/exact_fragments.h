// The small pieces an exact tessellation's split leaves: merged into surfaces, absorbed by a
// neighbour, shattered into facets, or joined as one swept freeform face.
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

// On an exact tessellation, a small curved face (a chamfer cone cut by a hexagon) may fall apart
// into single facets of which no pair determines its surface. From each small piece, its nearest
// small neighbours are gathered until they have three distinct vertices more than a surface type
// has parameters; the simplest type that explains every vertex and facet normal of them exactly
// then grows over the adjacent small pieces it explains, and all of them merge into one patch.
// Returns whether any piece merged.
bool merge_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                     const FeatureOptions& options, double exact_distance, std::vector<Feature>& features,
                     std::vector<int>& labels);

// On an exact tessellation, the small pieces that no surface explains exactly once merging has
// finished join the large neighbour they meet without a crease whose surface comes nearest to their
// vertices, if within `tolerance`: the facets along the trimmed rim of a torus band that the
// tessellation cut with a single chord across (its other facets lie on a cone). Returns whether any
// piece joined.
bool absorb_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                      double tolerance, const std::vector<Feature>& features, std::vector<int>& labels);

// On an exact tessellation, the small pieces that nothing placed once merging has finished may hold
// facets of two faces that the planar split took for one (the first, narrow facet of a tangent
// fillet beside a facet of the cylinder it rounds, turned by a fraction of a degree): each of their
// facets becomes a piece of its own, for merging to place them one by one. A facet takes the id of
// a patch that merging emptied, and a plane through it. Returns whether any piece fell apart.
bool shatter_fragments(const TriangleMesh& mesh, const std::vector<PatchPoints>& points, const FeatureOptions& options,
                       std::vector<Feature>& features, std::vector<int>& labels);

// On an exact tessellation, a freeform face swept from a profile (a sketched spline pulled
// straight) falls apart into the surfaces that each fit a few of its facet strips exactly: cylinders
// of different radii about parallel axes, tangent to each other, and planes of one strip between
// them. Three or more such pieces meeting without a crease, each of fewer than kInteriorPoints
// vertices and too few to tell its surface from a spline's (a cylinder's on fewer rulings than a
// circle's parameters and three, as identification asks of an exact fit, or off it by more than
// the coordinates' rounding `floor`), through all of whose vertices one B-spline surface passes
// within the distance `tolerance`, are that face: they join as one freeform feature. (Not within
// the exact distance: a least-squares spline over a few dozen profile points leaves a few times
// that.) Returns whether any joined.
bool join_sampled_extrusions(const TriangleMesh& mesh, const MeshTopology& topology, double tolerance,
                             double exact_distance, double floor, double angle_tolerance, std::vector<int>& labels,
                             std::vector<Feature>& features);

}  // namespace idealize
