// Edge curves: intersections of two surfaces in closed form, and curves fitted to a chain
// (curves.h).
#include "brep/curves.h"

#include "brep/surfaces.h"

#include <GeomAPI_PointsToBSpline.hxx>
#include <Geom_BSplineCurve.hxx>
#include <GeomAPI_ProjectPointOnCurve.hxx>
#include <Geom_Circle.hxx>
#include <Geom_Ellipse.hxx>
#include <Geom_Line.hxx>
#include <TColgp_Array1OfPnt.hxx>
#include <gp_Ax2.hxx>
#include <Precision.hxx>

#include <algorithm>
#include <cmath>
#include <limits>

namespace idealize {

namespace {

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

// Intersection points; primitives that touch within `tol` (missing each other or crossing with a
// sagitta below it) meet in one point of contact: nearly tangent surfaces that idealization did not
// make tangent (a fillet whose patch took some of the cone beside it) get the circle where they
// touch, not one of two close crossings that the mesh's boundary does not follow. With
// `crossings_too`, crossings within the touching zone come too, for corners to choose from.
std::vector<Vec2> intersect(const Primitive2& a, const Primitive2& b, double tol, bool crossings_too) {
  if (a.circle && !b.circle) return intersect(b, a, tol, crossings_too);
  if (!a.circle && !b.circle) {
    const double det = cross2(a.d, b.d);
    if (std::abs(det) < 1e-12) return {};
    const double t = cross2(b.p - a.p, b.d) / det;
    return {a.p + t * a.d};
  }
  if (!a.circle) {  // line a, circle b
    const Vec2 foot = a.p + (b.p - a.p).dot(a.d) * a.d;
    const double dist = (b.p - foot).norm();
    if (dist > b.r + tol) return {};
    if (dist >= b.r) return {foot};  // missing by less than tol
    const double h = std::sqrt(b.r * b.r - dist * dist);
    if (dist < b.r - tol) return {foot + h * a.d, foot - h * a.d};
    if (!crossings_too) return {foot};
    return {foot + h * a.d, foot - h * a.d, foot};
  }
  const Vec2 between = b.p - a.p;
  const double d = between.norm();
  if (d < 1e-12 || d > a.r + b.r + tol || d < std::abs(a.r - b.r) - tol) return {};
  const Vec2 u = between / d;
  const double along = (a.r * a.r - b.r * b.r + d * d) / (2 * d);
  const double h2 = a.r * a.r - along * along;
  const bool touching = std::abs(d - (a.r + b.r)) <= tol || std::abs(d - std::abs(a.r - b.r)) <= tol;
  const Vec2 contact = a.p + along * u;
  if ((touching && !crossings_too) || h2 <= 1e-18 * std::max(1.0, a.r * a.r)) return {contact};
  const double h = std::sqrt(h2);
  const Vec2 n(-u.y(), u.x());
  if (!touching) return {contact + h * n, contact - h * n};
  return {contact + h * n, contact - h * n, contact};
}

// The meridian of `s` about the axis (o, a) when `s` is a surface of revolution about it.
std::optional<Primitive2> meridian(const Surface& s, const Vec3& o, const Vec3& a, double angle_eps, double tol) {
  const Vec3 d = s.point - o;
  const double h = d.dot(a);
  const double off_axis = (d - h * a).norm();
  const bool parallel = s.has_direction() && s.axis.cross(a).norm() <= angle_eps;
  switch (s.type) {
    case SurfaceType::Plane:
      if (parallel) return line2(Vec2(0, h), Vec2(1, 0));
      break;
    case SurfaceType::Cylinder:
      if (parallel && off_axis <= tol) return line2(Vec2(s.radius, 0), Vec2(0, 1));
      break;
    case SurfaceType::Cone:
      if (parallel && off_axis <= tol) {
        const double sense = s.axis.dot(a) > 0 ? 1.0 : -1.0;
        return line2(Vec2(0, h), Vec2(std::sin(s.half_angle), sense * std::cos(s.half_angle)));
      }
      break;
    case SurfaceType::Sphere:
      if (off_axis <= tol) return circle2(Vec2(0, h), s.radius);
      break;
    case SurfaceType::Torus:
      if (parallel && off_axis <= tol) return circle2(Vec2(s.radius, h), s.minor);
      break;
    case SurfaceType::Freeform:
      break;
  }
  return std::nullopt;
}

// The common axis of two surfaces that may be coaxial surfaces of revolution.
bool common_axis(const Surface& a, const Surface& b, Vec3& o, Vec3& axis) {
  const bool a_round = a.type != SurfaceType::Plane, b_round = b.type != SurfaceType::Plane;
  if (!a_round && !b_round) return false;
  const Surface& round = a_round ? a : b;
  const Surface& other = a_round ? b : a;
  o = round.point;
  if (round.type != SurfaceType::Sphere) {
    axis = round.axis;
  } else if (other.type == SurfaceType::Sphere) {
    axis = other.point - round.point;
    if (axis.norm() < 1e-12) return false;
    axis.normalize();
  } else {
    axis = other.axis;  // plane normal, or the other surface's axis through the centre
  }
  return true;
}

namespace {

// Median of the points' coordinates in a 2D map (robust reference for choosing a branch).
template <class Map>
Vec2 median_2d(const std::vector<Vec3>& points, Map map) {
  std::vector<double> xs, ys;
  for (const Vec3& p : points) {
    const Vec2 q = map(p);
    xs.push_back(q.x());
    ys.push_back(q.y());
  }
  std::nth_element(xs.begin(), xs.begin() + xs.size() / 2, xs.end());
  std::nth_element(ys.begin(), ys.begin() + ys.size() / 2, ys.end());
  return Vec2(xs[xs.size() / 2], ys[ys.size() / 2]);
}

Vec2 nearest(const std::vector<Vec2>& candidates, const Vec2& reference) {
  return *std::min_element(candidates.begin(), candidates.end(), [&](const Vec2& x, const Vec2& y) {
    return (x - reference).squaredNorm() < (y - reference).squaredNorm();
  });
}

// The branch of an edge among the intersections of two primitives in a 2D map (`hits` with the
// crossings in touching zones, `contacts` without; both non-empty): the one through the corners
// at its `ends` where one is within `tol` of them, otherwise the one nearest the chain's points.
template <class Map>
Vec2 edge_branch(const std::vector<Vec2>& hits, const std::vector<Vec2>& contacts, const std::vector<Vec3>& points,
                 const std::vector<Vec3>& ends, Map map, double tol) {
  if (!ends.empty()) {
    const Vec2 corners = median_2d(ends, map), hit = nearest(hits, corners);
    if ((hit - corners).norm() <= tol) return hit;
  }
  return nearest(contacts, median_2d(points, map));
}


}  // namespace

// The point of both planes `a` and `b` nearest to `near` (their normals not parallel).
Vec3 point_on_both_planes(const Surface& a, const Surface& b, const Vec3& near) {
  Eigen::Matrix2d m;
  m << a.axis.dot(a.axis), a.axis.dot(b.axis), b.axis.dot(a.axis), b.axis.dot(b.axis);
  const Vec2 ab = m.ldlt().solve(Vec2(a.axis.dot(a.point - near), b.axis.dot(b.point - near)));
  return near + ab.x() * a.axis + ab.y() * b.axis;
}

// The intersection curve of `a` and `b` in closed form, or null; `ends`: the corner points of an
// open chain (none for a closed one), which choose the branch (edge_branch).
Handle(Geom_Curve) closed_form_curve(const Surface& a, const Surface& b, const std::vector<Vec3>& points,
                                     const std::vector<Vec3>& ends, double angle_eps, double tol,
                                     double nearly_parallel) {
  if (a.type == SurfaceType::Plane && b.type == SurfaceType::Plane) {
    const Vec3 dir = a.axis.cross(b.axis);
    if (dir.norm() < angle_eps) return nullptr;
    // Through the point of both planes nearest to the chain's centre.
    Vec3 centre = Vec3::Zero();
    for (const Vec3& p : points) centre += p;
    centre /= static_cast<double>(points.size());
    return new Geom_Line(to_pnt(point_on_both_planes(a, b, centre)), to_dir(dir));
  }
  Vec3 o, axis;
  if (common_axis(a, b, o, axis)) {
    const auto ma = meridian(a, o, axis, angle_eps, tol), mb = meridian(b, o, axis, angle_eps, tol);
    if (ma && mb) {
      const auto rho_h = [&](const Vec3& p) {
        const double h = (p - o).dot(axis);
        return Vec2((p - o - h * axis).norm(), h);
      };
      const auto off_axis = [&](bool crossings_too) {
        std::vector<Vec2> hits = intersect(*ma, *mb, tol, crossings_too);
        hits.erase(std::remove_if(hits.begin(), hits.end(), [&](const Vec2& q) { return q.x() <= tol; }), hits.end());
        return hits;
      };
      const std::vector<Vec2> contacts = off_axis(false);
      if (contacts.empty()) return nullptr;
      const Vec2 hit = edge_branch(off_axis(true), contacts, points, ends, rho_h, tol);
      Vec3 x = Vec3::Zero();
      for (const Vec3& p : points) x += p - o - (p - o).dot(axis) * axis;
      return new Geom_Circle(gp_Ax2(to_pnt(o + hit.y() * axis), to_dir(axis), to_dir(seam_direction(axis, x))), hit.x());
    }
  }
  const bool a_cyl = a.type == SurfaceType::Cylinder, b_cyl = b.type == SurfaceType::Cylinder;
  // A straight tube running into a bend: a cylinder of the tube's radius whose axis touches the
  // torus's centre circle touches the torus along the meridian circle through that point.
  if ((a_cyl && b.type == SurfaceType::Torus) || (b_cyl && a.type == SurfaceType::Torus)) {
    const Surface& cyl = a_cyl ? a : b;
    const Surface& torus = a_cyl ? b : a;
    const Vec3 foot = cyl.point + (torus.point - cyl.point).dot(cyl.axis) * cyl.axis;  // of the centre on the axis
    const double height = (foot - torus.point).dot(torus.axis);
    const Vec3 out = foot - torus.point - height * torus.axis;
    if (std::abs(cyl.axis.dot(torus.axis)) <= angle_eps && std::abs(cyl.radius - torus.minor) <= tol &&
        std::abs(height) <= tol && std::abs(out.norm() - torus.radius) <= tol && torus.radius > tol) {
      const Vec3 centre = torus.point + torus.radius * out.normalized();
      return new Geom_Circle(gp_Ax2(to_pnt(centre), to_dir(cyl.axis), to_dir(torus.axis)), cyl.radius);
    }
  }
  // Surfaces along parallel axes (a plane parallel to a cylinder's axis, two parallel cylinders)
  // meet in lines along the axis.
  if ((a_cyl && (b_cyl || b.type == SurfaceType::Plane)) || (b_cyl && a.type == SurfaceType::Plane)) {
    const Surface& cyl = a_cyl ? a : b;
    const Surface& other = a_cyl ? b : a;
    const Vec3 dir = cyl.axis;
    const Vec3& n = other.axis;
    const double cosine = n.dot(dir);
    const bool parallel = other.type == SurfaceType::Plane ? std::abs(cosine) <= angle_eps : n.cross(dir).norm() <= angle_eps;
    if (other.type == SurfaceType::Plane && std::abs(cosine) > nearly_parallel && n.cross(dir).norm() > nearly_parallel) {
      // An oblique plane cuts the cylinder in an ellipse about the point where the axis crosses it:
      // the radius across the tilt, stretched by the tilt along it. (A plane nearly parallel to
      // the axis touches it along a line, one nearly square to it cuts a circle: the second pass's
      // closed forms.)
      const Vec3 centre = cyl.point + (n.dot(other.point - cyl.point) / cosine) * dir;
      const Vec3 across = dir.cross(n).normalized(), along = n.cross(across);
      return new Geom_Ellipse(gp_Ax2(to_pnt(centre), to_dir(n), to_dir(along)), cyl.radius / std::abs(cosine), cyl.radius);
    }
    if (!parallel) return nullptr;
    Vec3 e1, e2;
    orthonormal_frame(dir, e1, e2);
    const Vec3 o2 = cyl.point;
    const auto section = [&](const Vec3& p) { return Vec2((p - o2).dot(e1), (p - o2).dot(e2)); };
    Primitive2 second;
    if (other.type == SurfaceType::Plane) {
      const Vec2 n(other.axis.dot(e1), other.axis.dot(e2));
      const double offset = other.axis.dot(other.point - o2);
      second = line2(offset * n / n.squaredNorm(), Vec2(-n.y(), n.x()));
    } else {
      second = circle2(section(other.point), other.radius);
    }
    const Primitive2 round = circle2(Vec2::Zero(), cyl.radius);
    const std::vector<Vec2> contacts = intersect(round, second, tol, false);
    if (contacts.empty()) return nullptr;
    const Vec2 hit = edge_branch(intersect(round, second, tol, true), contacts, points, ends, section, tol);
    return new Geom_Line(to_pnt(o2 + hit.x() * e1 + hit.y() * e2), to_dir(dir));
  }
  return nullptr;
}

// The parameter of the point of `curve` closest to p; the nearer end of a bounded curve when p
// projects beyond it.
double curve_parameter(const Handle(Geom_Curve)& curve, const Vec3& p) {
  GeomAPI_ProjectPointOnCurve projection(to_pnt(p), curve);
  const double first = curve->FirstParameter(), last = curve->LastParameter();
  double best = std::numeric_limits<double>::infinity(), parameter = first;
  if (projection.NbPoints() > 0) {
    best = projection.LowerDistance();
    parameter = projection.LowerDistanceParameter();
  }
  for (double end : {first, last}) {
    if (Precision::IsInfinite(end)) continue;
    const double distance = (to_vec(curve->Value(end)) - p).norm();
    if (distance < best) {
      best = distance;
      parameter = end;
    }
  }
  return parameter;
}

double max_distance_to_curve(const Handle(Geom_Curve)& curve, const std::vector<Vec3>& points) {
  double worst = 0.0;
  const size_t step = std::max<size_t>(1, points.size() / 16);
  for (size_t i = 0; i < points.size(); i += step) {
    GeomAPI_ProjectPointOnCurve projection(to_pnt(points[i]), curve);
    if (projection.NbPoints() == 0) return std::numeric_limits<double>::infinity();
    worst = std::max(worst, projection.LowerDistance());
  }
  return worst;
}

Handle(Geom_Curve) fitted_curve(const std::vector<Vec3>& points, double tol) {
  std::vector<Vec3> kept;
  const size_t step = std::max<size_t>(1, points.size() / 64);
  for (size_t i = 0; i < points.size(); i += step) {
    if (kept.empty() || (points[i] - kept.back()).norm() > 0.1 * tol) kept.push_back(points[i]);
  }
  if ((points.back() - kept.back()).norm() > 0.1 * tol) kept.push_back(points.back());
  else kept.back() = points.back();
  if (kept.size() < 2) return nullptr;
  if (kept.size() == 2) return new Geom_Line(to_pnt(kept[0]), to_dir((kept[1] - kept[0]).normalized()));
  TColgp_Array1OfPnt array(1, static_cast<int>(kept.size()));
  for (size_t i = 0; i < kept.size(); ++i) array.SetValue(static_cast<int>(i) + 1, to_pnt(kept[i]));
  GeomAPI_PointsToBSpline fit(array, 3, 8, GeomAbs_C2, tol);
  if (!fit.IsDone()) return nullptr;
  return Handle(Geom_Curve)(fit.Curve());
}

// The largest `off` (a point's distance from the farther of an edge's two surfaces) along `curve`
// from u0 to u1, at kToleranceSamples + 1 points.
double farthest_off(const Handle(Geom_Curve)& curve, double u0, double u1, const std::function<double(const Vec3&)>& off) {
  double farthest = 0.0;
  for (int i = 0; i <= kToleranceSamples; ++i)
    farthest = std::max(farthest, off(to_vec(curve->Value(u0 + (u1 - u0) * i / kToleranceSamples))));
  return farthest;
}

// The curve fitted to a chain's points, from the corners `start` and `end` where they are given: the
// chain's own end vertices lie off the corners (by the width of the mesh's chamfer), and an edge
// that stopped there would leave gaps for its vertices' tolerance to bridge (a screw's slot walls
// met its domed head 0.3 mm from their corners). Points beyond a given corner along the curve are
// left out.
Handle(Geom_Curve) fitted_between(const std::vector<Vec3>& points, const Vec3* start, const Vec3* end, double tol,
                                  const std::function<double(const Vec3&)>& off) {
  const Handle(Geom_Curve) first = fitted_curve(points, tol);
  if (first.IsNull() || (!start && !end)) return first;
  // Parameters measured the way the chain runs.
  const double sense = curve_parameter(first, points.front()) <= curve_parameter(first, points.back()) ? 1.0 : -1.0;
  const auto along = [&](const Vec3& p) { return sense * curve_parameter(first, p); };
  const double from = start ? along(*start) : -std::numeric_limits<double>::infinity();
  const double to = end ? along(*end) : std::numeric_limits<double>::infinity();
  std::vector<Vec3> kept;
  if (start) kept.push_back(*start);
  for (const Vec3& p : points) {
    const double u = along(p);
    const bool at_corner = (start && (p - *start).norm() <= 0.1 * tol) || (end && (p - *end).norm() <= 0.1 * tol);
    if (u > from && u < to && !at_corner) kept.push_back(p);
  }
  if (end) kept.push_back(*end);
  // Only where the curve through them stays on both surfaces: a corner may lie on another branch of
  // their intersection.
  const Handle(Geom_Curve) pinned = fitted_curve(kept, tol);
  if (pinned.IsNull() || farthest_off(pinned, pinned->FirstParameter(), pinned->LastParameter(), off) > tol) return first;
  return pinned;
}


// The points of a chain moved onto the intersection of the two surfaces (alternating projections).
std::vector<Vec3> project_on_both(const std::vector<Vec3>& chain, const LocalSurface& a, const LocalSurface* b) {
  std::vector<Vec3> result(chain);
  for (Vec3& p : result) {
    for (int i = 0; i < (b ? 12 : 1); ++i) {
      p = closest_point(a(p), p);
      if (b) p = closest_point((*b)(p), p);
    }
  }
  return result;
}

bool tangent_along(const Handle(Geom_Curve)& curve, const Surface& a, const Surface& b, const std::vector<Vec3>& points,
                   double max_angle) {
  std::vector<double> angles;
  const size_t step = std::max<size_t>(1, points.size() / 16);
  for (size_t i = 0; i < points.size(); i += step) {
    const Vec3 p = to_vec(curve->Value(curve_parameter(curve, points[i])));
    const double c = std::abs(surface_normal(a, p).dot(surface_normal(b, p)));
    angles.push_back(std::acos(std::min(1.0, c)));
  }
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2] < max_angle;
}

}  // namespace idealize
