// The boundary topology of a labelled mesh: the faces, edges and vertices a B-rep needs.
//
// Every triangle belongs to one region (a connected set of triangles of one feature). Region
// boundaries are traced on the mesh as loops of half-edges with the region on the left (the mesh is
// counter-clockwise seen from outside), cut at corners (vertices where three or more regions meet)
// into chains, each chain separating two regions and becoming one B-rep edge used by both.
// Pure C++ on the mesh: the geometry (surfaces, curves) is the builder's (builder.h).
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <vector>

namespace idealize {

// One chain of mesh vertices between two corners (or a closed loop without corners, whose first
// and last vertex are the same). `left` has the chain on its boundary in chain direction, `right`
// in reverse; right = -1 where the chain runs along an open boundary of the mesh.
struct BoundaryChain {
  std::vector<int> vertices;  // mesh vertex indices, in chain direction
  int left = -1, right = -1;  // region ids
  bool closed = false;        // no corner on it: first vertex == last vertex
};

// A chain as used by one loop: in its own direction (forward) or reversed.
struct ChainUse {
  int chain = 0;
  bool forward = true;
};

struct BoundaryTopology {
  std::vector<int> face_region;                       // #F: region of every triangle
  std::vector<int> region_feature;                    // per region: the feature it lies on
  std::vector<std::vector<std::vector<ChainUse>>> region_loops;  // per region: its boundary loops
  std::vector<BoundaryChain> chains;
  std::vector<int> corners;                           // mesh vertices where chains end
};

// Gives every face a feature: unlabelled faces (< 0, transition strips) join the neighbouring
// feature whose surface passes closest to them, growing inwards from labelled faces; then every
// connected piece of a feature other than its largest that is smaller than `island_fraction` of
// the largest joins the neighbour it shares the longest boundary with (rims a reassignment left
// behind would otherwise become sliver faces); a piece within `tolerance` of its own surface
// joins only a neighbour whose surface passes its vertices within twice that. `surfaces` are
// indexed by feature. Faces that no feature reaches (a connected part of the mesh without any
// label) get `unexplained`; with the default -1 they raise MeshError instead.
std::vector<int> complete_face_features(const TriangleMesh& mesh, const MeshTopology& topology,
                                        const std::vector<int>& labels,
                                        const std::vector<Surface>& surfaces, double tolerance,
                                        double island_fraction = 0.1, int unexplained = -1);

// Traces the region boundaries of `mesh` (consistently oriented, every face labelled by
// `face_feature` >= 0). Throws MeshError when the mesh is not consistently oriented along a region
// boundary or has non-manifold edges there.
BoundaryTopology trace_boundaries(const TriangleMesh& mesh, const MeshTopology& topology,
                                  const std::vector<int>& face_feature);

}  // namespace idealize
