// Checks of a prepared mesh before processing, and the one repair they make: orientation.
//
// What happens with each finding (README "Mesh checks and repairs"):
//   - NaN / infinite coordinates, absurd scales: rejected in prepare_mesh (MeshError);
//   - degenerate and duplicate triangles: set aside by prepare_mesh (counted here);
//   - non-manifold edges and vertices, open boundaries, several shells: counted, kept as they are
//     (curvature is estimated locally, the segmentation handles open meshes and several shells);
//   - inconsistent orientation: repaired on the working copy (each shell oriented consistently,
//     closed shells outward, open shells by their majority);
//   - self-intersections: counted (through a counter the caller supplies, CGAL in
//     remesh_cgal.cpp), not repaired.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

#include <vector>

namespace idealize {

// Counts pairs of triangles of `mesh` that intersect other than along a shared edge or vertex,
// stopping at `max_pairs`; reports into / polls `progress`.
using SelfIntersectionCounter = long long (*)(const TriangleMesh& mesh, long long max_pairs,
                                              const ProgressSpan& progress);

struct MeshCheckOptions {
  // Counting self-intersections needs CGAL, which stays out of the core library: the Python module
  // passes count_self_intersections (remesh_cgal.h). nullptr: not counted (reported as -1).
  SelfIntersectionCounter self_intersections = nullptr;
  // The count stops here: a mesh with this many crossing pairs is broken beyond counting them.
  long long max_self_intersecting_pairs = 100000;
  // Orient every shell consistently (see check_mesh).
  bool repair_orientation = true;
};

struct MeshCheck {
  // Set aside by prepare_mesh.
  int degenerate_removed = 0;        // input triangles with a repeated vertex or zero area
  int duplicate_removed = 0;         // input triangles repeating another's vertices
  int unused_vertices_removed = 0;   // vertices no kept triangle uses
  // Topology of the prepared mesh (kept as is).
  int shells = 0;                    // connected components through manifold edges
  int boundary_edges = 0;            // edges of one triangle
  int boundary_loops = 0;            // connected chains of boundary edges (holes and open rims)
  int largest_hole_edges = 0;        // boundary edges of the largest such chain
  int nonmanifold_edges = 0;         // edges of more than two triangles
  int nonmanifold_vertices = 0;      // vertices whose triangles form more than one fan
  // Orientation (repaired).
  int inconsistent_edges = 0;        // manifold edges whose two triangles run along it the same way
  int flipped_faces_repaired = 0;    // triangles turned over to orient their shells consistently
  int nonorientable_shells = 0;      // shells no orientation makes consistent (Moebius-like)
  int closed_shells_turned_outward = 0;  // closed shells whose orientation was inverted as a whole
  // Self-intersections (reported only); -1 when not counted.
  long long self_intersecting_pairs = -1;
  bool self_intersections_capped = false;  // the count stopped at max_self_intersecting_pairs

  // Per working face: turned over by the repair (empty when none is).
  std::vector<char> flipped;
};

// Checks `mesh` (a prepared mesh: no degenerate or duplicate triangles) whose adjacency is
// `topology`. With options.repair_orientation, `flipped` says which faces to turn over so that every
// shell is consistently oriented: a breadth-first walk over manifold edges from each shell's first
// face; a closed shell (no boundary edge) then gets the orientation with positive signed volume
// (outward normals), an open one the orientation most of its faces already have (ties: its first
// face's). Faces of a non-orientable shell keep the walk's choice. Throws Cancelled.
MeshCheck check_mesh(const TriangleMesh& mesh, const MeshTopology& topology, const MeshCheckOptions& options = {},
                     const ProgressSpan& progress = {});

// Turns over the faces check.flipped marks (swaps their last two corners).
void apply_orientation(TriangleMesh& mesh, const MeshCheck& check);

}  // namespace idealize
