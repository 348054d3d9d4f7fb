// A hole's depth, through the part and back (thesis 6.2.3, genus changes): a blind hole deepened
// past the wall becomes a through hole, a through hole given a depth becomes blind again.
//
// The hole (a cylinder facing its axis, with a flat floor or none) is deleted as a group
// (delete_features), and a hole of the new depth is made afresh as a decal and placed where it was
// (decals.h): its wall a strip of the same cylinder from the entry face down to the floor, or to
// the face the axis leaves the part through, its floor a disc. Where the hole comes out, that face
// opens as a moved group's host does, so the mesh changes genus without any surgery of its own.
#pragma once

#include "core/mesh.h"
#include "edit/delete_features.h"
#include "edit/edit.h"
#include "fit/surface.h"

#include <vector>

namespace idealize {

struct HoleResult {
  TriangleMesh mesh;
  std::vector<int> labels;        // per face: the feature's new id
  std::vector<Surface> surfaces;  // per feature: its surface (the hole's after the others)
  std::vector<int> kept;          // per feature (new id): its id before the edit, -1 for the hole's
  int wall = -1, floor = -1;      // the hole's new features (floor -1: a through hole)
  bool through = false;
  double depth = 0.0;             // the depth made: the wall's thickness along the axis when through
  std::vector<int> hosts;         // the faces the hole opens (new ids)
  std::vector<char> created;      // per face: made by the edit
  Eigen::VectorXd vertex_deviation;
  std::vector<double> target_edge_lengths;
  std::string remeshing_problem;
};

// Gives hole `wall` (a cylinder whose region faces its axis, in a group with at most a flat floor
// perpendicular to the axis) the depth `depth`, measured along the axis from the entry face `entry`
// (a host plane of the hole; -1: a blind hole's one host, or a through hole's larger one). A depth
// at least the part's thickness there (within the distance tolerance) makes it a through hole. The
// other features keep their surfaces exactly. Throws EditConflict (naming the features) when the
// hole is not a plain hole, or the axis leaves the part through a face that is not a plane;
// std::invalid_argument for a depth that is not positive.
HoleResult set_hole_depth(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                          const std::vector<FeatureAdjacency>& adjacency, int wall, double depth, int entry,
                          const EditOptions& options);

}  // namespace idealize
