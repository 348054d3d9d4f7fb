// Where a ray meets a triangle (T. Möller, B. Trumbore, "Fast, minimum storage ray-triangle
// intersection", Journal of Graphics Tools 2(1), 1997): the one test of the picking on a sculpted
// mesh and of the hole depth's ray through a part.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <limits>

namespace idealize {

// The parameter t at which origin + t direction meets the triangle (a, b, c), from the front or the
// back, of any sign; infinity when the ray misses it or runs along its plane.
inline double ray_triangle(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, const Eigen::Vector3d& a,
                           const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  constexpr double kMiss = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d e1 = b - a, e2 = c - a, p = direction.cross(e2);
  const double det = e1.dot(p);
  if (det == 0.0) return kMiss;
  const Eigen::Vector3d s = origin - a;
  const double u = s.dot(p) / det;
  if (u < 0.0 || u > 1.0) return kMiss;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = direction.dot(q) / det;
  if (v < 0.0 || u + v > 1.0) return kMiss;
  return e2.dot(q) / det;
}

}  // namespace idealize
