// Feature groups: the features that make one boss, pocket or hole, found from how the mesh's
// feature regions border each other (thesis 6.2, structure-altering editing).
//
// A group sits on host faces: a boss on the plate's top, a through hole in the plate's top and
// bottom. Each host's region has a hole where the group is, so the border between the group and
// the host is an inner loop of the host's region: a loop around which the host lies outside. That
// is read from the mesh's orientation alone, with no threshold: walked with its region on the
// left, a region's outer boundary turns counter-clockwise about the region's outward normal and its
// holes clockwise (on a cylinder, in its unrolled chart; a loop that winds round the axis, the end
// of a band, is never a hole). Only planes and cylinders host groups.
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <vector>

namespace idealize {

// One closed loop of a feature region's border, walked with the region on its left.
struct BorderLoop {
  std::vector<int> vertices;  // the loop's vertices in order (the last joins the first)
  std::vector<int> faces;     // per loop edge vertices[i] -> vertices[i + 1]: the region's face on it
  std::vector<int> across;    // per loop edge: the feature on the other side (-1: the mesh's border)
  // Per loop edge: how far the far corner of the triangle across lies above the plane of the
  // region's triangle, along its outward normal: positive at a concave edge, negative at a convex
  // one (0 on the mesh's border).
  std::vector<double> rise;
  // Whether the loop's edges are concave on the whole (their rises sum to more than zero).
  bool concave() const;
};

// The closed border loops of the faces labelled `feature` (labels: #F feature ids). At a vertex
// where the region touches itself, the loop turns to the first unused edge out of it.
std::vector<BorderLoop> border_loops(const TriangleMesh& mesh, const std::vector<int>& labels, int feature);

// Whether `loop`, a border loop of the faces `region_faces` (whose orientation says which side of
// `surface` is outside), is an inner loop of that region on `surface`: a hole in a plane's region,
// or a loop that does not wind round a cylinder's axis and is walked clockwise in its unrolled
// chart. False for any other surface type.
bool is_inner_loop(const TriangleMesh& mesh, const std::vector<int>& loop, const std::vector<int>& region_faces,
                   const Surface& surface);

// The side of `surface` (a plane or a cylinder) that the faces `region_faces` face, from their
// area-weighted normals summed: +1 along a plane's axis or away from a cylinder's axis, -1 the
// other way (a hole's wall).
double facing_side(const TriangleMesh& mesh, const std::vector<int>& region_faces, const Surface& surface);

// Whether the regions of faces `a` on surface `sa` and `b` on `sb` (planes or cylinders) lie on one
// surface: every vertex of each within `tolerance` of the other's surface, facing the same side.
// Two faces a feature kept apart (the floor either side of a rib) are identical.
bool identical_regions(const TriangleMesh& mesh, const std::vector<int>& a, const Surface& sa,
                       const std::vector<int>& b, const Surface& sb, double tolerance);

// The faces labelled `feature` (labels: #F feature ids).
std::vector<int> faces_labelled(const std::vector<int>& labels, int feature);

// The outward normal of plane `feature`: its axis turned the way its faces face.
Eigen::Vector3d outward_normal(const TriangleMesh& mesh, const std::vector<int>& labels, int feature,
                               const Surface& plane);

// The points of `loop` in a chart of `surface` (a plane or a cylinder) in which counter-clockwise
// is counter-clockwise about the outward normal of `region_faces`: a plane's (u, v); a cylinder's
// (radius × angle, height), the angle unwrapped along the loop. `winds` tells whether the loop
// turns round the cylinder's axis (always false on a plane).
std::vector<Eigen::Vector2d> loop_chart(const TriangleMesh& mesh, const std::vector<int>& loop,
                                        const std::vector<int>& region_faces, const Surface& surface, bool& winds);

// Every vertex of `mesh` in the chart loop_chart uses for `surface` and `region_faces`; on a
// cylinder, each angle taken within half a turn of `near` (radians, in that chart: a loop chart's
// u over the radius), so that the points near a loop agree with its chart.
std::vector<Eigen::Vector2d> points_chart(const TriangleMesh& mesh, const std::vector<int>& region_faces,
                                          const Surface& surface, double near);

struct FeatureGroup {
  std::vector<int> members;  // the group's features, sorted (the seed among them)
  std::vector<int> hosts;    // the planes and cylinders that carry it, sorted
  bool island = false;       // each border loop of the group runs along one host
};

// The group of feature `seed`: from the seed, the features across its border join the group,
// except those whose region holds the border on an inner loop, or whose outline the border dents
// along an edge, turning into the region by more than `tolerance` (the layer's distance
// tolerance) over its length (a host: the faces either side of a notch in an edge, or of a boss
// against a wall). A host sunk into the part
// (its outline concave throughout) that holds the group on its only inner loop, a convex one, is
// the floor the group goes down from, and joins it: the step of a counterbored hole, the floor of
// a pocket with a hole through it. When the group would take as much area as the rest of the
// part, the seed has no group of its own: the group is the seed alone, with the features around
// it as hosts where they are (a plane of the part's outside).
FeatureGroup feature_group(const TriangleMesh& mesh, const std::vector<int>& labels,
                           const std::vector<Surface>& surfaces, int seed, double tolerance);

}  // namespace idealize
