#include "fit/surface.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace idealize {

namespace {

Eigen::Vector3d unit_or(const Eigen::Vector3d& v, const Eigen::Vector3d& fallback) {
  const double n = v.norm();
  return n > 0.0 ? Eigen::Vector3d(v / n) : fallback;
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

double touching_circle_radius(const Surface& wall, double height, double tube, double side) {
  if (wall.type == SurfaceType::Cylinder) return wall.radius + side * tube;
  // A cone's generator through the apex, (height, distance) = t (cos a, sin a): the tube's centre
  // lies `tube` from it along its normal (-sin a, cos a).
  return (side * tube + height * std::sin(wall.half_angle)) / std::cos(wall.half_angle);
}

void orthonormal_frame(const Eigen::Vector3d& axis, Eigen::Vector3d& e1, Eigen::Vector3d& e2) {
  // Cross with the coordinate axis least aligned with `axis`: never nearly parallel.
  Eigen::Index smallest;
  axis.cwiseAbs().minCoeff(&smallest);
  e1 = axis.cross(Eigen::Vector3d::Unit(smallest)).normalized();
  e2 = axis.cross(e1);
}

namespace {

// Signed distances of a point (x, y, z) relative to the surface's point, the operations in the order
// Eigen's expressions use (results equal to the bit: the fits are chaotic enough to need that).
struct Distances {
  explicit Distances(const Surface& s)
      : ax(s.axis.x()), ay(s.axis.y()), az(s.axis.z()), radius(s.radius), minor(s.minor),
        cos_angle(std::cos(s.half_angle)), sin_angle(std::sin(s.half_angle)) {}

  double height(double x, double y, double z) const { return (x * ax + y * ay) + z * az; }
  // Distance from the axis, given the height along it.
  double off_axis(double x, double y, double z, double h) const {
    const double rx = x - h * ax, ry = y - h * ay, rz = z - h * az;
    return std::sqrt((rx * rx + ry * ry) + rz * rz);
  }
  static double length(double x, double y, double z) { return std::sqrt((x * x + y * y) + z * z); }

  double sphere(double x, double y, double z) const { return length(x, y, z) - radius; }
  double cylinder(double x, double y, double z) const { return off_axis(x, y, z, height(x, y, z)) - radius; }
  double torus(double x, double y, double z) const {
    const double h = height(x, y, z);
    const double radial = off_axis(x, y, z, h) - radius;
    return std::sqrt(radial * radial + h * h) - minor;
  }
  // The distance across a cone's generators, and `along` them from the apex.
  double cone_across(double x, double y, double z, double& along) const {
    const double h = height(x, y, z);
    const double d = off_axis(x, y, z, h);
    along = d * sin_angle + h * cos_angle;
    return d * cos_angle - h * sin_angle;
  }
  // Behind the apex (or nowhere along, NaN) the apex itself is closest.
  static bool behind_apex(double along) { return !(along >= 0.0); }
  static double to_apex(double x, double y, double z, double across) { return std::copysign(length(x, y, z), across); }
  double cone(double x, double y, double z) const {
    double along;
    const double across = cone_across(x, y, z, along);
    return behind_apex(along) ? to_apex(x, y, z, across) : across;
  }

  double ax, ay, az, radius, minor, cos_angle, sin_angle;
};

// Over arrays of x, y and z the compiler computes two distances per instruction: points go through
// in chunks of this many.
constexpr size_t kChunk = 256;

struct Chunk {
  double x[kChunk], y[kChunk], z[kChunk];
};

template <class Kernel>
void in_chunks(const Eigen::Vector3d& origin, const Eigen::Vector3d* p, size_t n, double* out, Kernel kernel) {
  Chunk c;
  for (size_t start = 0; start < n; start += kChunk) {
    const size_t m = std::min(kChunk, n - start);
    for (size_t i = 0; i < m; ++i) {
      c.x[i] = p[start + i].x() - origin.x();
      c.y[i] = p[start + i].y() - origin.y();
      c.z[i] = p[start + i].z() - origin.z();
    }
    kernel(c, m, out + start);
  }
}

}  // namespace

void signed_distances(const Surface& s, const Eigen::Vector3d* p, size_t n, double* out) {
  const Distances d(s);
  switch (s.type) {
    case SurfaceType::Plane:
      for (size_t i = 0; i < n; ++i) out[i] = (p[i] - s.point).dot(s.axis);  // no square root: as fast in place
      return;
    case SurfaceType::Sphere:
      in_chunks(s.point, p, n, out, [&](const Chunk& c, size_t m, double* o) {
        for (size_t i = 0; i < m; ++i) o[i] = d.sphere(c.x[i], c.y[i], c.z[i]);
      });
      return;
    case SurfaceType::Cylinder:
      in_chunks(s.point, p, n, out, [&](const Chunk& c, size_t m, double* o) {
        for (size_t i = 0; i < m; ++i) o[i] = d.cylinder(c.x[i], c.y[i], c.z[i]);
      });
      return;
    case SurfaceType::Cone: {
      double along[kChunk];
      in_chunks(s.point, p, n, out, [&](const Chunk& c, size_t m, double* o) {
        for (size_t i = 0; i < m; ++i) o[i] = d.cone_across(c.x[i], c.y[i], c.z[i], along[i]);
        for (size_t i = 0; i < m; ++i)  // (apart: the square root only where needed)
          if (Distances::behind_apex(along[i])) o[i] = Distances::to_apex(c.x[i], c.y[i], c.z[i], o[i]);
      });
      return;
    }
    case SurfaceType::Torus:
      in_chunks(s.point, p, n, out, [&](const Chunk& c, size_t m, double* o) {
        for (size_t i = 0; i < m; ++i) o[i] = d.torus(c.x[i], c.y[i], c.z[i]);
      });
      return;
    case SurfaceType::Freeform:
      std::fill(out, out + n, 0.0);
      return;
  }
}

double signed_distance(const Surface& s, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - s.point;
  switch (s.type) {
    case SurfaceType::Plane: return q.dot(s.axis);
    case SurfaceType::Sphere: return Distances(s).sphere(q.x(), q.y(), q.z());
    case SurfaceType::Cylinder: return Distances(s).cylinder(q.x(), q.y(), q.z());
    case SurfaceType::Cone: return Distances(s).cone(q.x(), q.y(), q.z());
    case SurfaceType::Torus: return Distances(s).torus(q.x(), q.y(), q.z());
    case SurfaceType::Freeform: return 0.0;
  }
  return 0.0;
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

AxesMeeting point_nearest_to_axes(const std::vector<const Surface*>& surfaces) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const Surface* s : surfaces) {
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - s->axis * s->axis.transpose();
    normal += across;
    rhs += across * s->point;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(normal);
  AxesMeeting out;
  out.fixed = solver.eigenvalues()[0];
  if (out.fixed > 0.0)
    out.point = solver.eigenvectors() * solver.eigenvalues().cwiseInverse().asDiagonal() *
                solver.eigenvectors().transpose() * rhs;
  return out;
}

std::array<double, 3> surface_color(SurfaceType type) {
  switch (type) {
    case SurfaceType::Plane: return {0.56, 0.93, 0.56};
    case SurfaceType::Cylinder: return {1.0, 1.0, 0.0};
    case SurfaceType::Cone: return {0.68, 0.85, 0.90};
    case SurfaceType::Sphere: return {0.0, 0.39, 0.0};
    case SurfaceType::Torus: return {0.55, 0.0, 0.0};
    default: return {0.60, 0.60, 0.60};
  }
}

}  // namespace idealize
