// The fitted surfaces as OpenCASCADE's (surfaces.h).
#include "brep/surfaces.h"

#include <Geom_ConicalSurface.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <Geom_Plane.hxx>
#include <Geom_SphericalSurface.hxx>
#include <Geom_ToroidalSurface.hxx>
#include <TColStd_Array1OfInteger.hxx>
#include <TColStd_Array1OfReal.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <gp_Ax3.hxx>
#include <gp_Vec.hxx>

#include <algorithm>
#include <cmath>
#include <limits>

namespace idealize {

// A unit vector orthogonal to `axis`, pointing from the axis towards -mean of the points' radial
// directions: the parametric seam (u = 0) of a revolved surface then lies opposite to its face.
Vec3 seam_direction(const Vec3& axis, const Vec3& mean_radial) {
  Vec3 x = -(mean_radial - mean_radial.dot(axis) * axis);
  if (x.norm() < 1e-9) {
    Vec3 e2;
    orthonormal_frame(axis, x, e2);
  }
  return x.normalized();
}

// A unit vector orthogonal to `axis` that depends on the axis line only (not on its sense): the
// seam of every face that goes all round an axis. Coaxial bands then share their seams; healing
// splits each band's circles where its own seam crosses them, and the circle between two bands
// with different seams is cut differently on each side: sewing leaves it free (a cone between two
// tori on a scanned blended part).
Vec3 common_seam_direction(const Vec3& axis) {
  Eigen::Index least_aligned;
  axis.cwiseAbs().minCoeff(&least_aligned);
  const Vec3 unit = Vec3::Unit(least_aligned);
  return (unit - unit.dot(axis) * axis).normalized();
}


// The surface of feature `s` for a face through `points`; `round`: set when the face goes all round
// an axis.
Handle(Geom_Surface) make_surface(const Surface& s, const std::vector<Vec3>& points, const std::optional<RoundFace>& round) {
  Vec3 radial = Vec3::Zero();
  double height = 0.0;
  for (const Vec3& p : points) {
    const Vec3 q = p - s.point;
    const double h = q.dot(s.axis);
    height += h;
    const Vec3 r = q - h * s.axis;
    if (r.norm() > 0) radial += r.normalized();
  }
  if (!points.empty()) height /= static_cast<double>(points.size());
  const Vec3 seam = !s.has_direction() ? Vec3::Zero() : round ? round->seam : seam_direction(s.axis, radial);
  switch (s.type) {
    case SurfaceType::Plane: {
      Vec3 x, y;
      orthonormal_frame(s.axis, x, y);
      return new Geom_Plane(gp_Ax3(to_pnt(s.point), to_dir(s.axis), to_dir(x)));
    }
    case SurfaceType::Cylinder:
      return new Geom_CylindricalSurface(gp_Ax3(to_pnt(s.point), to_dir(s.axis), to_dir(seam)), s.radius);
    case SurfaceType::Cone: {
      // OCCT places a cone by a reference circle: take it at the face's mean height.
      const double h = std::max(height, 1e-6);
      return new Geom_ConicalSurface(gp_Ax3(to_pnt(s.point + h * s.axis), to_dir(s.axis), to_dir(seam)),
                                     s.half_angle, h * std::tan(s.half_angle));
    }
    case SurfaceType::Sphere: {
      // A band all round an axis: that axis is the polar one, so that its circles are parallels
      // (a circle that crosses the meridians has no exact curve in the parameter plane).
      if (round) return new Geom_SphericalSurface(gp_Ax3(to_pnt(s.point), to_dir(round->axis), to_dir(round->seam)), s.radius);
      // Otherwise poles away from the face: the polar axis orthogonal to the face's mean direction.
      Vec3 mean = Vec3::Zero();
      for (const Vec3& p : points) mean += (p - s.point).normalized();
      Vec3 x = mean.norm() > 1e-9 ? Vec3(-mean.normalized()) : Vec3::UnitX();
      Vec3 z, unused;
      orthonormal_frame(x, z, unused);
      return new Geom_SphericalSurface(gp_Ax3(to_pnt(s.point), to_dir(z), to_dir(x)), s.radius);
    }
    case SurfaceType::Torus:  // a lemon (radius < 0) is the part of a spindle torus about v = π
      return new Geom_ToroidalSurface(gp_Ax3(to_pnt(s.point), to_dir(s.axis), to_dir(seam)), std::abs(s.radius), s.minor);
    case SurfaceType::Freeform:
      break;
  }
  return nullptr;
}

bool same_surface(const Surface& a, const Surface& b, double tol) {
  if (a.type != b.type || a.type == SurfaceType::Freeform) return false;
  if (std::abs(a.radius - b.radius) > tol || std::abs(a.minor - b.minor) > tol) return false;
  if (std::abs(a.half_angle - b.half_angle) > 1e-9) return false;
  if (a.type == SurfaceType::Sphere) return (a.point - b.point).norm() <= tol;
  if (a.axis.cross(b.axis).norm() > 1e-9) return false;
  const Vec3 d = b.point - a.point;
  if (a.type == SurfaceType::Plane) return std::abs(d.dot(a.axis)) <= tol;
  if (a.type == SurfaceType::Cylinder) return (d - d.dot(a.axis) * a.axis).norm() <= tol;
  return d.norm() <= tol && a.axis.dot(b.axis) > 0;  // cone apex, torus centre
}

// A freeform feature's B-spline as OCCT's surface; u and v as in the fit (coordinates over its
// mean plane).
Handle(Geom_BSplineSurface) occt_bspline(const BSplineSurfaceFit& fit) {
  TColgp_Array2OfPnt poles(1, fit.count_u, 1, fit.count_v);
  for (int i = 0; i < fit.count_u; ++i)
    for (int j = 0; j < fit.count_v; ++j) poles.SetValue(i + 1, j + 1, to_pnt(fit.poles.row(i * fit.count_v + j).transpose()));
  auto knots = [&](const Eigen::VectorXd& k, TColStd_Array1OfReal& values, TColStd_Array1OfInteger& mults) {
    for (Eigen::Index i = 0; i < k.size(); ++i) {
      values.SetValue(static_cast<int>(i) + 1, k[i]);
      mults.SetValue(static_cast<int>(i) + 1, i == 0 || i + 1 == k.size() ? fit.degree + 1 : 1);
    }
  };
  const int ku = static_cast<int>(fit.knots_u.size()), kv = static_cast<int>(fit.knots_v.size());
  TColStd_Array1OfReal u_knots(1, ku), v_knots(1, kv);
  TColStd_Array1OfInteger u_mults(1, ku), v_mults(1, kv);
  knots(fit.knots_u, u_knots, u_mults);
  knots(fit.knots_v, v_knots, v_mults);
  return new Geom_BSplineSurface(poles, u_knots, v_knots, u_mults, v_mults, fit.degree, fit.degree);
}

Surface FreeformSurface::tangent_plane(const Vec3& p) const {
  double u = (p - origin).dot(u_direction), v = (p - origin).dot(v_direction);
  double u0, u1, v0, v1;
  surface->Bounds(u0, u1, v0, v1);
  if (extrusion) {
    constexpr int kSamples = 256;
    double nearest = std::numeric_limits<double>::infinity();
    const double along = std::clamp(v, v0, v1);
    for (int i = 0; i <= kSamples; ++i) {
      const double t = u0 + (u1 - u0) * i / kSamples;
      const double distance = (to_vec(surface->Value(t, along)) - p).squaredNorm();
      if (distance < nearest) {
        nearest = distance;
        u = t;
      }
    }
  }
  gp_Pnt at;
  gp_Vec du, dv;
  for (int iteration = 0; iteration < 6; ++iteration) {
    u = std::clamp(u, u0, u1);
    v = std::clamp(v, v0, v1);
    surface->D1(u, v, at, du, dv);
    const Vec3 r = p - to_vec(at), su(du.X(), du.Y(), du.Z()), sv(dv.X(), dv.Y(), dv.Z());
    Eigen::Matrix2d j;
    j << su.dot(su), su.dot(sv), su.dot(sv), sv.dot(sv);
    const Eigen::Vector2d step = j.ldlt().solve(Eigen::Vector2d(r.dot(su), r.dot(sv)));
    if (!step.allFinite()) break;
    u += step.x();
    v += step.y();
    if (step.norm() < 1e-12 * (u1 - u0 + v1 - v0)) break;
  }
  surface->D1(std::clamp(u, u0, u1), std::clamp(v, v0, v1), at, du, dv);
  Surface plane;
  plane.type = SurfaceType::Plane;
  plane.point = to_vec(at);
  const gp_Vec n = du.Crossed(dv);
  plane.axis = n.Magnitude() > 0 ? Vec3(n.X(), n.Y(), n.Z()).normalized() : Vec3(u_direction.cross(v_direction));
  return plane;
}

}  // namespace idealize
