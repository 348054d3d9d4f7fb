// A feature group as a decal (thesis 6.2, the texture idea): its triangles, their features and its
// border loops on host planes, ready to be placed in a mesh. Copying and moving a group lift it off
// its mesh (copy_features.cpp); a hole of another depth is made as one (hole_depth.cpp).
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <Eigen/Geometry>

#include <vector>

namespace idealize {

// A group lifted off its mesh and carried to its new place, or made afresh: what is placed.
struct Decal {
  TriangleMesh mesh;                    // the group's triangles (host rim triangles too), moved
  std::vector<int> labels;              // per decal face: its feature in the layer (a member)
  std::vector<std::vector<int>> loops;  // per border loop: decal vertices in order, the group on the left
  std::vector<int> hosts;               // per loop: its host plane
  std::vector<char> member;             // per feature of the layer: in the group
  Eigen::Isometry3d motion;             // what carried it
};

// `mesh` with `decal` placed (written to `out`, `out_labels`, `out_created`): for each loop, the
// host's faces under its outline and a ring around them open, and the ring between the gap's
// border and the outline is triangulated. Decal faces take the label label_of[their feature];
// `created` (#F of mesh, or empty) flags the faces an edit made, and out_created the placed mesh's
// (the ring's too, not the decal's); `own` marks the features whose place the decal must not reach
// (the original of a copy). Throws EditConflict naming what the new place conflicts with.
void place_decal(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<char>& created,
                 const std::vector<Surface>& surfaces, const Decal& decal, const std::vector<int>& label_of,
                 const std::vector<char>& own, TriangleMesh& out, std::vector<int>& out_labels,
                 std::vector<char>& out_created);

}  // namespace idealize
