// Closing a gap whose border runs along several faces, by letting the faces around it erode into
// it (thesis 6.2.2, "edge extraction through the erosive technique"; Chen & Feng).
//
// A deleted group leaves a gap. Its border loop runs along host faces: along one face when the
// group sat inside it (a boss on a plate's top), along several when it sat across their edges (a
// notch in an edge, a boss against a wall, a rib between two walls). The thesis lets the hosts
// erode into the gap until only edges remain, and names three cases: a single point (one host
// closes over the gap), a new edge attached to old edges (the edge between two hosts runs on
// through the gap), and a new edge attached to new edges (new edges meet inside the gap; one
// between two identical features is false and removed).
//
// Here the erosion's result is built directly, from the loop alone:
//   - the loop splits into arcs, each along one host; hosts whose surfaces are identical (two
//     coplanar faces a rib had kept apart) count as one;
//   - each place where the loop passes from host a to host b (an old edge entering the gap) is
//     paired with a place where it passes back from b to a, innermost pairs first, and the new
//     edge between them runs along the intersection of a's and b's surfaces (case 2);
//   - three places left over, between hosts a, b and c in turn, meet at the corner of the three
//     surfaces (case 3: new edges attached to new edges);
//   - the new edges cut the gap into pieces, each bounded by arcs of one host and new edges, and
//     each is closed on its host's surface. A piece joins identical hosts into one feature: the
//     false edge between them is never made.
// A gap these rules do not close (a host would have to give up triangles, surfaces that do not
// meet inside the gap, another pattern of edges) is refused with a message naming the features.
#pragma once

#include "core/mesh.h"
#include "edit/feature_groups.h"
#include "fit/surface.h"

#include <array>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

struct ErodedGap {
  std::vector<Eigen::Vector3d> points;      // new vertices: points of the new edges and corners
  std::vector<std::array<int, 3>> faces;    // the triangles closing the gap (vertex ids: the mesh's,
                                            // then points from `first_point` on), oriented as the mesh
  std::vector<int> hosts;                   // per face: the host feature it belongs to
  std::vector<std::pair<int, int>> merged;  // (feature, feature it joins): identical hosts the fill
                                            // connects, the smaller id kept
  std::vector<std::pair<int, int>> edges;   // per new edge: the two hosts it lies between
  int corners = 0;                          // the new corners made (case 3)
  double edge_length = 0.0;                 // the new edges' total length
};

// Closes the gap inside `loop`, a border loop of a deleted group (walked with the group on its
// left), on the features across it. `labels`: #F feature ids (the group's faces under an id of
// their own); `surfaces`: the features' surfaces;
// `first_point`: the id the first new vertex gets (the mesh's vertex count, or more when several
// gaps add points); `tolerance`: the layer's distance tolerance (new edges must lie on both
// surfaces within it, identical surfaces agree within it); `g1`: the tangent pairs of features
// (smaller id first); `spacing`: the length of the new edges' segments. Throws EditConflict naming
// the features when the gap cannot be closed this way.
ErodedGap erode_gap(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                    const BorderLoop& loop, int first_point, double tolerance,
                    const std::set<std::pair<int, int>>& g1, double spacing);

}  // namespace idealize
