// Mesh surgery delegated to CGAL's Polygon Mesh Processing package (GPL-3+), kept in one
// translation unit because its templates are heavy to compile.
//
// Isotropic remeshing: Botsch & Kobbelt, "A remeshing approach to multiresolution modeling",
// SGP 2004, as implemented by CGAL::Polygon_mesh_processing::isotropic_remeshing.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

#include <vector>

namespace idealize {

// Uniform re-tessellation to `target_edge_length` (> 0) in `iterations` (>= 1) rounds, with
// vertices projected back onto the input surface. No edge is protected, so sharp edges are
// sampled like a scanner samples them (chamfered). Input must be a manifold triangle mesh;
// throws MeshError otherwise.
TriangleMesh remesh_isotropic(const TriangleMesh& mesh, double target_edge_length, int iterations);

// Index of the face of `mesh` closest to each row of `points` (#P x 3), via an AABB tree; with
// `distances`, also the distance of each point from the mesh. Reports into `progress` and throws
// Cancelled when it is cancelled.
// Pairs of triangles of `mesh` that intersect other than along a shared edge or at a shared vertex
// (the test of CGAL::Polygon_mesh_processing::self_intersections, on the indexed triangles so that
// non-manifold meshes work too; triangles sharing two vertices intersect only when coplanar and
// overlapping). Counting stops at `max_pairs`. Candidate pairs come from CGAL's box intersection
// (bounding boxes of the triangles); `progress` is polled among them (throws Cancelled). The
// triangles must have three distinct vertices and finite coordinates (a prepared mesh);
// collinear ones are skipped. Fits MeshCheckOptions::self_intersections.
long long count_self_intersections(const TriangleMesh& mesh, long long max_pairs, const ProgressSpan& progress = {});

std::vector<int> closest_faces(const TriangleMesh& mesh, const MatrixX3d& points,
                               std::vector<double>* distances = nullptr, const ProgressSpan& progress = {});

}  // namespace idealize
