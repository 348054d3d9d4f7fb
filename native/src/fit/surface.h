// The analytic surfaces a prismatic feature can lie on, and their point-surface geometry.
#pragma once

#include <array>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace idealize {

enum class SurfaceType { Plane, Cylinder, Cone, Sphere, Torus, Freeform };

// A fit is exact when its residual is below this fraction of the distance tolerance: the vertices of
// a CAD tessellation lie on their faces (up to the file's float precision).
constexpr double kExactFraction = 0.01;

// Name used in reports: "plane", "cylinder", "cone", "sphere", "torus", "freeform".
const char* surface_type_name(SurfaceType type);

// The colour of each surface type, red, green, blue in 0..1: the thesis's feature colours (plane
// light green, cylinder yellow, cone light blue, sphere dark green, torus dark red) and grey for
// freeform surfaces, which the thesis does not have. The one table the STEP export, the feature
// layer's colouring and the workbench read.
std::array<double, 3> surface_color(SurfaceType type);

// Degrees of freedom of a surface of the type (0 for freeform).
int parameter_count(SurfaceType type);

// One analytic surface. Which members are used depends on the type:
//   plane     point on the plane, axis = unit normal
//   cylinder  point on the axis, axis = unit direction, radius
//   cone      point = apex, axis = unit direction towards the opening, half_angle (radians)
//   sphere    point = centre, radius
//   torus     point = centre, axis = unit direction, radius = major, minor
struct Surface {
  SurfaceType type = SurfaceType::Freeform;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double radius = 0.0;
  double minor = 0.0;
  double half_angle = 0.0;

  // Whether the surface has an axis (cylinder, cone, torus) or a normal direction (plane).
  bool has_direction() const { return type != SurfaceType::Sphere && type != SurfaceType::Freeform; }
};

// Signed distance of p from the surface (positive on the side away from the axis or centre, and
// along the normal of a plane). Freeform surfaces have none: returns 0.
double signed_distance(const Surface& surface, const Eigen::Vector3d& p);

// Signed distances of the n points p[0..n) into out[0..n): the same as signed_distance, faster.
void signed_distances(const Surface& surface, const Eigen::Vector3d* p, size_t n, double* out);

// The closest point of the surface to p (p itself for a freeform surface).
Eigen::Vector3d closest_point(const Surface& surface, const Eigen::Vector3d& p);

// Unit surface normal at the point of the surface closest to p, pointing to positive distances.
Eigen::Vector3d surface_normal(const Surface& surface, const Eigen::Vector3d& p);

// The radius of the circle that the centre of a tube of radius `tube` follows to touch the cylinder
// or cone `wall` about the wall's axis, the centre at `height` along the axis from the wall's point
// (a cone's apex), on the side `side` of the wall (+1 away from the axis, -1 towards it): the
// meridian of a fillet between a wall and a face across its axis.
double touching_circle_radius(const Surface& wall, double height, double tube, double side);

// Two unit vectors completing `axis` (unit) to a right-handed orthonormal frame, chosen
// deterministically from the axis alone.
void orthonormal_frame(const Eigen::Vector3d& axis, Eigen::Vector3d& e1, Eigen::Vector3d& e2);

// Position of p relative to an axis through `origin` along `axis` (unit): height along it, distance
// from it and the unit direction away from it (any perpendicular direction on the axis itself).
struct AxialCoordinates {
  double height, distance;
  Eigen::Vector3d radial;
};

inline AxialCoordinates axial_coordinates(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis,
                                          const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - origin;
  AxialCoordinates c;
  c.height = q.dot(axis);
  const Eigen::Vector3d r = q - c.height * axis;
  c.distance = r.norm();
  if (c.distance > 0.0) {
    c.radial = r / c.distance;
  } else {
    Eigen::Vector3d e2;
    orthonormal_frame(axis, c.radial, e2);
  }
  return c;
}

// The point nearest, in least squares, to the axes of `surfaces` (where fillets' axes meet, about
// which the ball between them is centred), and how well they fix it: the smallest eigenvalue of the
// normal matrix, the sum of (I - a a^T), which is 1 - cos t for two axes at an angle t and 0 for
// parallel axes (then `point` is not defined).
struct AxesMeeting {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double fixed = 0.0;
};
AxesMeeting point_nearest_to_axes(const std::vector<const Surface*>& surfaces);

}  // namespace idealize
