// Cutting and closing gaps in a host face: what deleting, copying and moving a feature group share
// (thesis 6.2). A group's gap is bounded by its border loops (feature_groups.h), each on one host
// plane or cylinder; closing a gap triangulates the loop in the host's chart, and placing a group
// opens a gap of the group's outline in the host and fills the ring between it and the host.
#pragma once

#include "core/mesh.h"
#include "edit/edit.h"
#include "edit/feature_groups.h"
#include "edit/remesh_adaptive.h"
#include "fit/surface.h"

#include <array>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace idealize {

// The ids of `features`, comma separated, for messages.
std::string feature_list(const std::set<int>& features);

// A host triangle that shares an edge with the group (faces labelled `group` in `labels`) and has
// all three corners on its border lies inside the group's outline: a tessellation's triangle that
// straddles the edge where the group meets its host, labelled with the host. Such triangles join
// the group (their label becomes `group`) until none is left, so that the gap's loops are simple.
void take_rim_triangles(const TriangleMesh& mesh, int group, std::vector<int>& labels);

// The host of each of `loops` (the border loops of the faces labelled `group` in `labels`): the
// one plane or cylinder along it, holding it as an inner loop, which a decal of the group needs. Throws EditConflict naming the
// features otherwise: a loop along several features, along the mesh's border, on another type of
// surface, or on the outline of its host.
std::vector<int> gap_hosts(const TriangleMesh& mesh, const std::vector<int>& labels, int group,
                           const std::vector<Surface>& surfaces, const std::vector<BorderLoop>& loops);

// Whether the closed polygon `p` (points in a chart) is simple: no two of its edges meet except
// neighbours at their shared corner, and none folds back onto the one before it.
bool simple_polygon(const std::vector<Eigen::Vector2d>& p);

// The triangles between an outer polygon (counter-clockwise) and an inner one (clockwise) inside
// it, both given by their points in a chart (a constrained Delaunay triangulation of the ring; an
// empty inner polygon: of the outer one's inside); indices into outer followed by inner,
// counter-clockwise. Throws EditConflict when the polygons touch or cross (themselves or each other).
std::vector<std::array<int, 3>> fill_ring(const std::vector<Eigen::Vector2d>& outer,
                                          const std::vector<Eigen::Vector2d>& inner);

// Throws EditConflict unless every edge of `faces` has exactly two triangles.
void check_closed(const std::vector<std::array<int, 3>>& faces);

// The mesh of `faces` (indices into the rows of V), without the vertices no face uses.
TriangleMesh compact_mesh(const MatrixX3d& V, const std::vector<std::array<int, 3>>& faces);

// Remeshes the faces flagged in `created` (#F: the triangles an edit made to close or fill a gap),
// each at `targets` of its feature, and leaves the others exactly as they are (their vertices on
// the border with created faces stay; its edges may be split). The created faces of a feature are
// remeshed as a feature of their own on its surface, so that its old triangles stay. `g1`: the
// tangent pairs of features (remesh_adaptive). Corners stay where they are. `created` becomes the
// flags of the remeshed mesh's faces.
RemeshedLayer remesh_created(const TriangleMesh& mesh, const std::vector<int>& labels, std::vector<char>& created,
                             const std::vector<Surface>& surfaces, const std::vector<double>& targets,
                             const std::set<std::pair<int, int>>& g1);

// The tangent (G1) pairs of `adjacency` under new ids (new_id[old], -1 for a feature gone), smaller
// id first.
std::set<std::pair<int, int>> tangent_pairs(const std::vector<FeatureAdjacency>& adjacency,
                                            const std::vector<int>& new_id);

// What every structure-altering edit ends with: when `remesh`, the created faces remeshed
// (remesh_created; a failure is recorded in `problem` and the mesh stays as made), then each
// vertex's deviation from its features (vertex_deviation), returned.
Eigen::VectorXd finish_created(TriangleMesh& mesh, std::vector<int>& labels, std::vector<char>& created,
                               const std::vector<Surface>& surfaces, const std::vector<double>& targets,
                               const std::set<std::pair<int, int>>& g1, bool remesh, std::string& problem);

// Whether the mesh is closed and manifold (no edge with one or more than two triangles).
bool is_closed(const TriangleMesh& mesh);

}  // namespace idealize
