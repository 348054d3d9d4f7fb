#include "surface.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace idealize {

namespace {

Eigen::Vector3d unit_or(const Eigen::Vector3d& v, const Eigen::Vector3d& fallback) {
  const double n = v.norm();
  return n > 0.0 ? Eigen::Vector3d(v / n) : fallback;
}

// The height and distance of axial_coordinates without the radial direction, which distances
// alone do not need: model fitting evaluates them millions of times.
struct HeightDistance {
  double height, distance;
};

HeightDistance height_distance(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - origin;
  const double height = q.dot(axis);
  return {height, (q - height * axis).norm()};
}

}  // namespace

const char* surface_type_name(SurfaceType type) {
  switch (type) {
    case SurfaceType::Plane: return "plane";
    case SurfaceType::Cylinder: return "cylinder";
    case SurfaceType::Cone: return "cone";
    case SurfaceType::Sphere: return "sphere";
    case SurfaceType::Torus: return "torus";
    case SurfaceType::Freeform: return "freeform";
  }
  return "freeform";
}

int parameter_count(SurfaceType type) {
  switch (type) {
    case SurfaceType::Plane: return 3;
    case SurfaceType::Sphere: return 4;
    case SurfaceType::Cylinder: return 5;
    case SurfaceType::Cone: return 6;
    case SurfaceType::Torus: return 7;
    case SurfaceType::Freeform: return 0;
  }
  return 0;
}

void orthonormal_frame(const Eigen::Vector3d& axis, Eigen::Vector3d& e1, Eigen::Vector3d& e2) {
  // Cross with the coordinate axis least aligned with `axis`: never nearly parallel.
  Eigen::Index smallest;
  axis.cwiseAbs().minCoeff(&smallest);
  e1 = axis.cross(Eigen::Vector3d::Unit(smallest)).normalized();
  e2 = axis.cross(e1);
}

void signed_distances(const Surface& s, const Eigen::Vector3d* p, size_t n, double* out) {
  switch (s.type) {
    case SurfaceType::Plane:
      for (size_t i = 0; i < n; ++i) out[i] = (p[i] - s.point).dot(s.axis);
      return;
    case SurfaceType::Sphere:
      for (size_t i = 0; i < n; ++i) out[i] = (p[i] - s.point).norm() - s.radius;
      return;
    case SurfaceType::Cylinder:
      for (size_t i = 0; i < n; ++i) out[i] = height_distance(s.point, s.axis, p[i]).distance - s.radius;
      return;
    case SurfaceType::Cone: {
      const double cos_angle = std::cos(s.half_angle), sin_angle = std::sin(s.half_angle);
      for (size_t i = 0; i < n; ++i) {
        const HeightDistance c = height_distance(s.point, s.axis, p[i]);
        const double across = c.distance * cos_angle - c.height * sin_angle;
        const double along = c.distance * sin_angle + c.height * cos_angle;
        // Behind the apex the apex itself is closest.
        out[i] = along >= 0.0 ? across : std::copysign((p[i] - s.point).norm(), across);
      }
      return;
    }
    case SurfaceType::Torus:
      for (size_t i = 0; i < n; ++i) {
        const HeightDistance c = height_distance(s.point, s.axis, p[i]);
        const double radial = c.distance - s.radius;
        out[i] = std::sqrt(radial * radial + c.height * c.height) - s.minor;
      }
      return;
    case SurfaceType::Freeform:
      std::fill(out, out + n, 0.0);
      return;
  }
}

double signed_distance(const Surface& s, const Eigen::Vector3d& p) {
  double d;
  signed_distances(s, &p, 1, &d);
  return d;
}

Eigen::Vector3d surface_normal(const Surface& s, const Eigen::Vector3d& p) {
  switch (s.type) {
    case SurfaceType::Plane: return s.axis;
    case SurfaceType::Sphere: return unit_or(p - s.point, s.axis);
    case SurfaceType::Cylinder: return axial_coordinates(s.point, s.axis, p).radial;
    case SurfaceType::Cone: {
      const AxialCoordinates c = axial_coordinates(s.point, s.axis, p);
      return std::cos(s.half_angle) * c.radial - std::sin(s.half_angle) * s.axis;
    }
    case SurfaceType::Torus: {
      const AxialCoordinates c = axial_coordinates(s.point, s.axis, p);
      const Eigen::Vector3d tube_centre = s.point + s.radius * c.radial;
      return unit_or(p - tube_centre, c.radial);
    }
    case SurfaceType::Freeform: return Eigen::Vector3d::Zero();
  }
  return Eigen::Vector3d::Zero();
}

Eigen::Vector3d closest_point(const Surface& s, const Eigen::Vector3d& p) {
  switch (s.type) {
    case SurfaceType::Cone: {
      const AxialCoordinates c = axial_coordinates(s.point, s.axis, p);
      const Eigen::Vector3d generator = std::cos(s.half_angle) * s.axis + std::sin(s.half_angle) * c.radial;
      const double along = (p - s.point).dot(generator);
      return along > 0.0 ? Eigen::Vector3d(s.point + along * generator) : s.point;
    }
    case SurfaceType::Freeform: return p;
    default: return p - signed_distance(s, p) * surface_normal(s, p);
  }
}

}  // namespace idealize
