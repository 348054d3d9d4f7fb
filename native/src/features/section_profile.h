// Internals of the edge fillets and the profile splits: the cross-section in which features'
// surfaces are lines, and the mesh vertices whose profiles they fit. Not part of the core's API.
#pragma once

#include "core/mesh.h"

#include <cmath>
#include <vector>

namespace idealize {
namespace detail {

using Vector2 = Eigen::Vector2d;

// The plane of the cross-section in which two features' surfaces are lines meeting at a corner:
// across the line where two planes meet (`around_axis` false: a fillet is a cylinder along it), or
// through the axis of a cylinder or cone and a plane across it (a fillet is a torus about it).
struct Section {
  bool around_axis = false;
  Eigen::Vector3d origin, direction;  // a point of the planes' line and its direction; or of the axis
  Eigen::Vector3d e1, e2;             // the section's axes across the line; or a frame across the axis

  // Coordinates in the section: along e1 and e2; or distance from the axis and height along it.
  Vector2 profile(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - origin;
    if (!around_axis) return {q.dot(e1), q.dot(e2)};
    const double z = q.dot(direction);
    return {(q - z * direction).norm(), z};
  }
  // Where along the edge: the length along the line, or the angle about the axis.
  double position(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - origin;
    return around_axis ? std::atan2(q.dot(e2), q.dot(e1)) : q.dot(direction);
  }
};

// The vertices of `faces`, in order of first use; `seen` (#V, all 0) is left as it was.
std::vector<int> distinct_vertices(const TriangleMesh& mesh, const std::vector<int>& faces, std::vector<char>& seen);

// An even subsample of at most kSamplePoints of `points`.
std::vector<Vector2> even_sample(const std::vector<Vector2>& points);

}  // namespace detail
}  // namespace idealize
