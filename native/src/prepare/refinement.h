// Internal refinement of long, thin triangles (typical of CAD-exported STL) so that discrete
// curvature has interior vertices to live on. Every new vertex lies on the input surface: long
// edges are split at their midpoints (longest first), then edges inside one input triangle are
// flipped to Delaunay. Sharp edges and facet folds therefore stay exactly where they were, and each
// refined face remembers the input face it lies in, so results map back one-to-one.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

#include <vector>

namespace idealize {

struct RefinementOptions {
  // Target edge length; 0 derives it from the data: the median input edge length (or, where that is
  // under half of it, the edge of an even sampling with the input's triangle count: a CAD
  // tessellation's fans of slivers), but no coarser than a sampling of about `min_samples` triangles
  // over the whole surface and no finer than `max_triangles` in total.
  double target_edge_length = 0.0;
  int min_samples = 20000;        // the thesis's meshes had 60–75k triangles; a third of that resolves
                                  // every feature wider than a few triangles
  int max_triangles = 2000000;    // memory bound for the refined mesh
  // The share of a whole part's surface that the mesh is: `min_samples` counts for the whole part,
  // and a region of it re-idealized alone is sampled as densely as the part would be (1: the mesh is
  // the whole part).
  double part_share = 1.0;
  // Splitting stops at this many times the triangles that an even sampling of the surface at the
  // target edge length needs (or the input's count if larger): a fan of slivers that no split can
  // mend multiplies instead (a degenerate input of a few needles reached 1.6 million faces). Of the
  // benchmark's 61 CAD tessellations, ten need 5 to 9.3 times (fans of slivers on caps and around
  // holes), and the densest fans of one are stopped here.
  double max_oversampling = 12.0;
};

struct RefinedMesh {
  TriangleMesh mesh;
  std::vector<int> face_origin;  // refined face -> input face (the pieces of each input face consecutive,
                                 // in the input's face order; new vertices after the input's)
  double target_edge_length = 0.0;
};

// Refines `mesh` (vertices of the input keep their indices). Edges shared by more than two faces or
// by two faces of opposite orientation are never split, so the refined mesh stays conforming.
// Reports into `progress` and throws Cancelled when it is cancelled.
RefinedMesh refine_long_triangles(const TriangleMesh& mesh, const MeshTopology& topology,
                                  const RefinementOptions& options = {}, const ProgressSpan& progress = {});

}  // namespace idealize
