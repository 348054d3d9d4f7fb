#include "brep_builder.h"

#include "brep/deviation.h"
#include "brep/facets.h"
#include "brep/solids.h"
#include "brep_topology.h"
#include "bspline_fitting.h"
#include "occt_signals.h"
#include "parallel.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BOPAlgo_ArgumentAnalyzer.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepCheck.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepCheck_ListIteratorOfListOfStatus.hxx>
#include <BRepCheck_Result.hxx>
#include <BRepGProp.hxx>
#include <BRepLib_CheckCurveOnSurface.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Poly_Triangulation.hxx>
#include <ElSLib.hxx>
#include <GProp_GProps.hxx>
#include <Geom2d_Curve.hxx>
#include <GeomAPI_IntSS.hxx>
#include <GeomAPI_PointsToBSpline.hxx>
#include <GeomAPI_ExtremaCurveCurve.hxx>
#include <GeomAPI_ProjectPointOnCurve.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_BSplineCurve.hxx>
#include <Geom_BSplineSurface.hxx>
#include <Geom_Circle.hxx>
#include <Geom_RectangularTrimmedSurface.hxx>
#include <Geom_ConicalSurface.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <Geom_Ellipse.hxx>
#include <Geom_Line.hxx>
#include <Geom_Plane.hxx>
#include <Geom_SphericalSurface.hxx>
#include <Geom_ToroidalSurface.hxx>
#include <Geom_TrimmedCurve.hxx>
#include <Precision.hxx>
#include <BRepTools_ReShape.hxx>
#include <ShapeBuild_ReShape.hxx>
#include <ShapeFix_Edge.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <ShapeFix_Face.hxx>
#include <ShapeFix_Solid.hxx>
#include <ShapeUpgrade_UnifySameDomain.hxx>
#include <Standard_Failure.hxx>
#include <TColStd_Array1OfInteger.hxx>
#include <TColStd_Array1OfReal.hxx>
#include <TColgp_Array1OfPnt.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Iterator.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <exception>
#include <functional>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <tuple>
#include <sstream>

namespace idealize {

namespace {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

gp_Pnt to_pnt(const Vec3& v) { return gp_Pnt(v.x(), v.y(), v.z()); }
gp_Dir to_dir(const Vec3& v) { return gp_Dir(v.x(), v.y(), v.z()); }
Vec3 to_vec(const gp_Pnt& p) { return Vec3(p.X(), p.Y(), p.Z()); }

std::string occt_message(const Standard_Failure& failure, const char* what) {
  const char* text = failure.GetMessageString();
  return std::string(what) + ((text && *text) ? std::string(": ") + text : std::string(" (OpenCASCADE failure)"));
}

// ---------------------------------------------------------------------------------------------
// Surfaces

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
// tori on as_customblend_05's scan).
Vec3 common_seam_direction(const Vec3& axis) {
  Eigen::Index least_aligned;
  axis.cwiseAbs().minCoeff(&least_aligned);
  const Vec3 unit = Vec3::Unit(least_aligned);
  return (unit - unit.dot(axis) * axis).normalized();
}

// How a face goes all round an axis: the axis (a sphere's polar one) and the direction of the seam.
struct RoundFace {
  Vec3 axis, seam;
  bool winds = false;  // a loop of several chains winds round the axis (else one is a closed chain)
  int split = -1;      // the chain of the winding loop that the seam crosses
};

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

// ---------------------------------------------------------------------------------------------
// Intersection curves in closed form

// A line or circle in a plane: meridian (rho, h) of a surface of revolution, or cross-section of a
// surface along parallel axes.
struct Primitive2 {
  bool circle = false;
  Vec2 p = Vec2::Zero();  // point on the line, or centre
  Vec2 d = Vec2::UnitX(); // unit direction of a line
  double r = 0.0;
};

Primitive2 line2(const Vec2& p, const Vec2& d) { return {false, p, d.normalized(), 0.0}; }
Primitive2 circle2(const Vec2& c, double r) { return {true, c, Vec2::UnitX(), r}; }

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

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

// sin(5 degrees): directions this close count as parallel when an exact closed form is not found
// (the feature graph's parallel tolerance).
constexpr double kNearlyParallel = 0.0872;
constexpr int kToleranceSamples = 64;  // points of a fitted edge measured against its two surfaces

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
                                     const std::vector<Vec3>& ends, double angle_eps, double tol) {
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
    if (other.type == SurfaceType::Plane && std::abs(cosine) > kNearlyParallel && n.cross(dir).norm() > kNearlyParallel) {
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

// A feature's surface near a point: the analytic surface itself, or for a freeform feature the
// tangent plane of its B-spline at the point's nearest point (so that closest_point, signed_distance
// and surface_normal near that point are those of the B-spline).
using LocalSurface = std::function<Surface(const Vec3&)>;

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

// Whether two surfaces meet tangentially along a curve of both (the median angle between their
// normals at the points' nearest curve points below 5 degrees, the feature graph's G1 criterion).
bool tangent_along(const Handle(Geom_Curve)& curve, const Surface& a, const Surface& b, const std::vector<Vec3>& points) {
  std::vector<double> angles;
  const size_t step = std::max<size_t>(1, points.size() / 16);
  for (size_t i = 0; i < points.size(); i += step) {
    const Vec3 p = to_vec(curve->Value(curve_parameter(curve, points[i])));
    const double c = std::abs(surface_normal(a, p).dot(surface_normal(b, p)));
    angles.push_back(std::acos(std::min(1.0, c)));
  }
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2] < 5.0 * M_PI / 180.0;
}

// ---------------------------------------------------------------------------------------------
// Corners

// The point closest (least squares) to all surfaces, starting from x0 (damped Gauss-Newton: the
// damping keeps the point near the mesh where tangent surfaces leave a direction free).
Vec3 corner_point(const std::vector<LocalSurface>& surfaces, const Vec3& x0, double tol) {
  Vec3 x = x0;
  const double damping = 1e-6;
  for (int iteration = 0; iteration < 30; ++iteration) {
    Eigen::Matrix3d normal = damping * Eigen::Matrix3d::Identity();
    Vec3 rhs = -damping * (x - x0);
    for (const LocalSurface& local : surfaces) {
      const Surface s = local(x);
      const Vec3 n = surface_normal(s, x);
      const double d = signed_distance(s, x);
      normal += n * n.transpose();
      rhs -= n * d;
    }
    const Vec3 step = normal.ldlt().solve(rhs);
    x += step;
    if (step.norm() < 1e-3 * tol) break;
  }
  return x;
}

// Where a line meets a surface near the parameter range [low, high]: its crossings, or, where it
// crosses nowhere there but passes within `tol`, the point where it touches (comes nearest).
std::vector<double> line_meets(const std::function<double(double)>& distance, double low, double high, double tol) {
  constexpr int kSamples = 256;
  std::vector<double> roots;
  double nearest = low, nearest_distance = std::abs(distance(low));
  double t_prev = low, d_prev = distance(low);
  for (int i = 1; i <= kSamples; ++i) {
    const double t = low + (high - low) * i / kSamples, d = distance(t);
    if (std::abs(d) < nearest_distance) nearest = t, nearest_distance = std::abs(d);
    if ((d_prev < 0.0) != (d < 0.0)) {
      double lo = t_prev, hi = t;  // bisection: distance(lo) has d_prev's sign
      for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        ((distance(mid) < 0.0) == (d_prev < 0.0) ? lo : hi) = mid;
      }
      roots.push_back(0.5 * (lo + hi));
    }
    t_prev = t;
    d_prev = d;
  }
  if (!roots.empty()) return roots;
  double lo = nearest - (high - low) / kSamples, hi = nearest + (high - low) / kSamples;
  for (int k = 0; k < 60; ++k) {  // golden-section search for the nearest point
    const double m1 = hi - 0.618 * (hi - lo), m2 = lo + 0.618 * (hi - lo);
    if (std::abs(distance(m1)) < std::abs(distance(m2))) hi = m2;
    else lo = m1;
  }
  const double t = 0.5 * (lo + hi);
  if (std::abs(distance(t)) <= tol) return {t};
  return {};
}

// The corners at both ends of a straight chain between two planes, each where the planes' line
// meets the third surface at that corner: the points nearest to the mesh's corners that keep the
// chain's order and have no crossing of either surface between them (the chain's edge runs on
// the planes alone; a crossing within `tol` of an end counts as that end's, as two pieces of one
// cone may cross it a little apart), a touching point standing for a crossing. A flat of a
// hexagon meets the chamfer cone round its corners at a shallow angle: its line crosses the
// chamfer's circle twice, close together, or touches it (a bolt's chamfer to the width across the
// flats); each corner alone, fitted from the mesh's rounded corner, may take either crossing, or
// its own point of a line that misses by less than the noise, and the face folds back. Null where
// no such pair is found.
std::optional<std::pair<Vec3, Vec3>> line_chain_ends(const Surface& a, const Surface& b,
                                                     const std::array<const Surface*, 2>& third,
                                                     const std::array<Vec3, 2>& mesh_corners,
                                                     const std::array<Vec3, 2>& fitted, double tol) {
  const Vec3 cross = a.axis.cross(b.axis);
  if (cross.norm() < kNearlyParallel) return std::nullopt;
  const Vec3 dir = cross.normalized();
  const Vec3 origin = point_on_both_planes(a, b, 0.5 * (mesh_corners[0] + mesh_corners[1]));
  const auto at = [&](double t) { return Vec3(origin + t * dir); };
  // Where to look: about the mesh's and the fitted corners, a chain's length beyond them.
  const std::array<double, 2> t_mesh = {(mesh_corners[0] - origin).dot(dir), (mesh_corners[1] - origin).dot(dir)};
  double low = std::min(t_mesh[0], t_mesh[1]), high = std::max(t_mesh[0], t_mesh[1]);
  for (const Vec3& p : fitted) {
    low = std::min(low, (p - origin).dot(dir));
    high = std::max(high, (p - origin).dot(dir));
  }
  const double reach = std::max(std::abs(t_mesh[1] - t_mesh[0]), tol);
  low -= reach;
  high += reach;
  std::array<std::vector<double>, 2> meets;
  for (int end = 0; end < 2; ++end)
    meets[end] = line_meets([&](double t) { return signed_distance(*third[end], at(t)); }, low, high, tol);
  const double sense = t_mesh[1] >= t_mesh[0] ? 1.0 : -1.0;
  auto crossed_between = [&](double x, double y) {  // (a crossing within tol of an end is that end's)
    for (const auto& ts : meets)
      for (double t : ts)
        if (t > std::min(x, y) + tol && t < std::max(x, y) - tol) return true;
    return false;
  };
  std::optional<std::pair<double, double>> best;
  double best_cost = 0.0;
  for (double p : meets[0])
    for (double q : meets[1]) {
      // One point for both only where one surface touches the line there.
      if (sense * (q - p) < 0.0 || (q == p && (third[0] != third[1] || meets[0].size() != 1)) || crossed_between(p, q)) continue;
      const double cost = std::abs(p - t_mesh[0]) + std::abs(q - t_mesh[1]);
      if (!best || cost < best_cost) best = std::make_pair(p, q), best_cost = cost;
    }
  if (!best) return std::nullopt;
  return std::make_pair(at(best->first), at(best->second));
}

// What fixes a corner: the surfaces that meet there, except that a cylinder tangent to a sphere (a
// fillet running into the ball where fillets meet, thesis 4.3 case 2) touches it along the circle in
// the plane through the centre normal to the axis, and that plane stands in for it. Tangent surfaces
// share their normal where they touch, so least squares could not tell where along the tangent
// plane two fillets and their ball meet; the planes cross the sphere there.
std::vector<Surface> corner_constraints(const std::vector<const Surface*>& surfaces, double tol) {
  std::vector<Surface> out;
  for (const Surface* s : surfaces) {
    Surface c = *s;
    if (s->type == SurfaceType::Cylinder) {
      for (const Surface* ball : surfaces) {
        if (ball->type != SurfaceType::Sphere || std::abs(ball->radius - s->radius) > tol ||
            axial_coordinates(s->point, s->axis, ball->point).distance > tol)
          continue;
        c.type = SurfaceType::Plane;
        c.point = ball->point;
        break;
      }
    }
    out.push_back(c);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The builder

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

// A freeform feature's fitted surface, and its tangent plane nearest a point: Gauss–Newton for the
// foot point from the point's place over the mean plane (the surface is a height field over it), or
// for an extruded profile from the nearest of a row of samples along the profile.
struct FreeformSurface {
  Handle(Geom_BSplineSurface) surface;
  Vec3 origin, u_direction, v_direction;
  bool extrusion = false;

  Surface tangent_plane(const Vec3& p) const {
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
};

class BrepBuilder {
 public:
  BrepBuilder(const TriangleMesh& mesh, const std::vector<Surface>& surfaces, const BrepOptions& options)
      : mesh_(mesh), surfaces_(surfaces), features_(static_cast<int>(surfaces.size())),
        progress_(options.progress, "topology") {
    diagonal_ = bounding_box_diagonal(mesh);
    tol_ = options.tolerance > 0 ? options.tolerance : 1e-3 * diagonal_;
    angle_eps_ = std::max(1e-9, tol_ / std::max(diagonal_, 1e-300));
  }

  BrepResult run(const std::vector<int>& labels, const BrepOptions& options);

 private:
  using Clock = std::chrono::steady_clock;
  void stage(BrepResult& result, const char* name, Clock::time_point& since) {
    const auto now = Clock::now();
    result.timings.emplace_back(name, std::chrono::duration<double>(now - since).count());
    since = now;
  }
  std::vector<int> merge_same_surfaces(const std::vector<int>& labels) const;
  std::optional<RoundFace> round_face(int region) const;
  bool split_at_seam(int chain, const Handle(Geom_Curve)& curve, double u0, double u1, const TopoDS_Vertex& v0,
                     const TopoDS_Vertex& v1, double tolerance);
  std::vector<int> dissolve_sampling_blends(const TriangleMesh& mesh, const MeshTopology& topology,
                                            std::vector<int> labels) const;
  void fit_freeform_surfaces(const TriangleMesh& mesh, const std::vector<int>& face_feature, BrepResult& result);
  LocalSurface local_surface(int feature) const;
  void make_vertices(const MeshTopology& topology);
  TopoDS_Vertex vertex_at_corner(int mesh_vertex) const { return vertices_.at(mesh_vertex); }
  struct ChainCurve {
    BrepEdge report;           // what the result says of the edge
    Handle(Geom_Curve) curve;  // null: no edge
    double u0 = 0, u1 = 0, tolerance = 0;
    Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero();  // its ends' points
    std::string problem;       // why it has none (empty: none to report)
  };
  ChainCurve chain_curve(size_t chain) const;
  void compute_curves();
  void make_edges(BrepResult& result);
  void make_faces(BrepResult& result);
  bool is_cap(size_t region) const;  // a cone or sphere bounded by one closed chain
  std::optional<TopoDS_Face> pole_cap(size_t region);
  // The healed, sewn and merged shape; `closed_faults`: closed_shell_faults of the solid returned
  // where merging had to judge its faces already, else empty.
  TopoDS_Shape assemble(BrepResult& result, const BrepOptions& options, std::vector<std::string>& closed_faults);
  TopoDS_Shape with_facets(const TopoDS_Shape& sewn, const BRepBuilderAPI_Sewing& sewing, ShapeBuild_ReShape& healed) const;
  // The region whose surface `face` lies on, -1 none.
  int region_of(const TopoDS_Face& face) const;

  const TriangleMesh& mesh_;
  std::vector<Surface> surfaces_;  // the layer's, and one freeform feature for what none explains
  int features_ = 0;               // the layer's
  // Shares of the whole run, as measured on a scan of a million triangles.
  const ProgressSpan progress_;
  double diagonal_ = 0, tol_ = 0, angle_eps_ = 0;
  BoundaryTopology topo_;
  std::map<int, FreeformSurface> freeform_;  // feature -> its fitted B-spline
  std::vector<Handle(Geom_Surface)> region_surfaces_;
  std::vector<double> region_sense_;  // +1 when the surface normal points out of the part
  std::vector<char> region_winds_;    // a loop of several chains winds round the surface's axis
  std::map<int, int> seam_splits_;    // chain -> the winding region whose seam crosses it
  std::map<int, std::array<TopoDS_Edge, 2>> split_edges_;  // such a chain's edge, in two at the seam
  std::vector<Vec3> region_centroid_;  // mean of the region's triangle centroids
  std::map<int, TopoDS_Vertex> vertices_;
  std::map<int, Vec3> corner_points_;
  std::vector<TopoDS_Edge> edges_;
  std::vector<char> edge_ok_;
  std::vector<char> collapsed_;  // chains whose two corners are one vertex: no edge
  std::vector<TopoDS_Face> faces_;
  std::vector<int> face_region_;
  std::vector<char> face_facet_;  // per face of faces_: a planar facet of a faceted region

  // Graceful degradation (build_round): regions made of their triangles, and the chains that run
  // as the mesh's polyline because a faceted region or a failed curve lies along them.
  TriangleMesh clean_;                      // the mesh without degenerate triangles
  std::vector<std::vector<int>> region_faces_;
  std::vector<ChainCurve> curves_;          // per chain, computed once
  std::vector<char> faceted_, bounded_, polyline_;
  std::vector<std::string> facet_reason_;   // per region: why it is faceted
  std::unique_ptr<FacetBuilder> facets_;
  std::map<int, std::vector<TopoDS_Edge>> chain_pieces_;  // polyline chain -> its edges, along it
  std::map<const Standard_Transient*, int> facet_region_;  // facet plane -> region
  std::vector<Handle(Geom_Surface)> facet_planes_;         // (keeps those keys alive)
  std::map<int, std::string> failed_;       // regions whose face failed this round -> why
  void fail(int region, const std::string& why) {
    if (region >= 0) failed_.try_emplace(region, why);
  }
  void place_polylines();
  std::vector<int> polyline_vertices(size_t chain) const;
  bool build_round(BrepResult& result, const BrepOptions& options);

  // Honest validity (deviation.h): how far each region's face may lie from its mesh.
  std::vector<double> region_fit_;  // per region: the sagitta of its triangles plus the noise's extent
  std::vector<double> region_noise_;  // per region: the noise's extent alone (sigma sqrt(2 ln n))
  std::vector<double> chain_gap_;   // per chain with a curve: largest distance of its vertices from it
  double mesh_volume_ = 0.0;        // enclosed by the clean mesh (0 when it is open)
  void measure_fits();
  std::vector<double> deviation_allowances(double deflection) const;
  bool follows_mesh(const TopoDS_Shape& shape, BrepResult& result, const ProgressSpan& progress);
};

// Whether a region goes all round the axis of its surface, and where its seam goes then. A loop of
// one closed chain goes round the axis of the surfaces on both sides (a sphere band takes the other
// side's as its polar axis); the seam goes along common_seam_direction. A loop of several chains
// that winds round the axis (a cone's rim cut by a slot) decides instead: its seam crosses the
// middle of the loop's longest chain, whose edge split_at_seam cuts there, so that healing joins
// the seam to vertices on both loops.
std::optional<RoundFace> BrepBuilder::round_face(int region) const {
  const Surface& s = surfaces_[topo_.region_feature[region]];
  if (s.type == SurfaceType::Freeform) return std::nullopt;
  std::optional<RoundFace> closed;  // from a closed chain; a winding loop beside it decides the seam
  for (const auto& loop : topo_.region_loops[region]) {
    const BoundaryChain& first = topo_.chains[loop.front().chain];
    if (loop.size() == 1 && first.closed) {
      const int across = first.left == region ? first.right : first.left;
      const Surface* other = across >= 0 ? &surfaces_[topo_.region_feature[across]] : nullptr;
      if (closed || (!s.has_direction() && !(other && other->has_direction()))) continue;
      const Vec3 axis = s.has_direction() ? s.axis : other->axis;
      closed = RoundFace{axis, common_seam_direction(axis)};
      continue;
    }
    // A band's loop (a single loop round the axis would bound a cap about a pole or apex).
    if (!s.has_direction() || s.type == SurfaceType::Plane || topo_.region_loops[region].size() < 2) continue;
    // The turn of the loop about the axis: ±2π when it winds round it.
    Vec3 e1, e2;
    orthonormal_frame(s.axis, e1, e2);
    double turn = 0.0, previous = 0.0;
    bool started = false;
    for (const ChainUse& use : loop) {
      const std::vector<int>& vertices = topo_.chains[use.chain].vertices;
      for (size_t i = 0; i < vertices.size(); ++i) {
        const Vec3 q = mesh_.V.row(vertices[use.forward ? i : vertices.size() - 1 - i]).transpose() - s.point;
        const double angle = std::atan2(q.dot(e2), q.dot(e1));
        if (started) turn += std::remainder(angle - previous, 2.0 * M_PI);
        previous = angle;
        started = true;
      }
    }
    if (std::abs(turn) < M_PI) continue;
    // The seam crosses the loop's longest chain at its middle: a seam through a corner would
    // run through the face above or below it wherever an edge there leans across (the walls of a
    // slot in a cone's rim narrow upwards).
    const auto longest = std::max_element(loop.begin(), loop.end(), [&](const ChainUse& x, const ChainUse& y) {
      return topo_.chains[x.chain].vertices.size() < topo_.chains[y.chain].vertices.size();
    });
    const std::vector<int>& vertices = topo_.chains[longest->chain].vertices;
    if (vertices.size() < 3) continue;
    const Vec3 q = mesh_.V.row(vertices[vertices.size() / 2]).transpose() - s.point;
    const Vec3 radial = q - q.dot(s.axis) * s.axis;
    if (radial.norm() > 1e-9 * diagonal_) return RoundFace{s.axis, radial.normalized(), true, longest->chain};
  }
  return closed;
}

// The edge of a chain that the seam of a winding face crosses (round_face), also made as two edges
// that meet on the seam, for the faces on both sides. Returns false if the seam misses it.
bool BrepBuilder::split_at_seam(int chain, const Handle(Geom_Curve)& curve, double u0, double u1,
                                const TopoDS_Vertex& v0, const TopoDS_Vertex& v1, double tolerance) {
  const auto splitting = seam_splits_.find(chain);
  if (splitting == seam_splits_.end()) return true;
  const Handle(Geom_Curve) seam = region_surfaces_[splitting->second]->UIso(0.0);
  GeomAPI_ExtremaCurveCurve crossing(new Geom_TrimmedCurve(curve, u0, u1), seam);
  if (crossing.NbExtrema() == 0 || crossing.LowerDistance() > 10 * tol_) return false;
  double t, unused;
  crossing.LowerDistanceParameters(t, unused);
  if (!(t > u0 && t < u1)) return false;
  BRep_Builder builder;
  TopoDS_Vertex middle;
  builder.MakeVertex(middle, curve->Value(t), std::max(tolerance, Precision::Confusion()));
  std::array<TopoDS_Edge, 2> parts;
  const std::array<std::array<double, 2>, 2> ranges = {{{u0, t}, {t, u1}}};
  const std::array<std::array<TopoDS_Vertex, 2>, 2> ends = {{{v0, middle}, {middle, v1}}};
  for (int i = 0; i < 2; ++i) {
    builder.MakeEdge(parts[i], curve, tolerance);
    builder.Add(parts[i], ends[i][0].Oriented(TopAbs_FORWARD));
    builder.Add(parts[i], ends[i][1].Oriented(TopAbs_REVERSED));
    builder.Range(parts[i], ranges[i][0], ranges[i][1]);
  }
  split_edges_[chain] = parts;
  return true;
}

std::vector<int> BrepBuilder::merge_same_surfaces(const std::vector<int>& labels) const {
  std::vector<int> representative(surfaces_.size());
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    representative[i] = static_cast<int>(i);
    for (size_t j = 0; j < i; ++j) {
      if (representative[j] == static_cast<int>(j) && same_surface(surfaces_[i], surfaces_[j], 1e-6 * diagonal_)) {
        representative[i] = static_cast<int>(j);
        break;
      }
    }
  }
  std::vector<int> merged(labels.size());
  for (size_t f = 0; f < labels.size(); ++f) merged[f] = labels[f] < 0 ? -1 : representative[labels[f]];
  return merged;
}

// A scanner samples a sharp edge as a rounded strip about one sample spacing wide, which fits a
// cylinder (or torus, sphere at corners) of about that radius: on a sampled (not exactly
// tessellated) mesh, round features with a radius below two median edge lengths that are less
// than one and a half wide (twice their area over their border's length) are such strips, and their
// triangles go back to the features on either side (the thesis folds transition strips into the
// neighbouring patches). A fillet of such a radius across several facets stays (occt_Pump_Nut's
// scan: r 1 on edges of 0.6, two edges wide). An exact CAD tessellation keeps every feature.
std::vector<int> BrepBuilder::dissolve_sampling_blends(const TriangleMesh& mesh, const MeshTopology& topology,
                                                       std::vector<int> labels) const {
  const int features = static_cast<int>(surfaces_.size());
  std::vector<double> squared(features, 0.0), count(features, 0.0);
  std::vector<double> edges, shortest(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    shortest[f] = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 3; ++c) {
      edges.push_back((mesh.V.row(mesh.F(f, c)) - mesh.V.row(mesh.F(f, (c + 1) % 3))).norm());
      shortest[f] = std::min(shortest[f], edges.back());
      if (labels[f] < 0 || surfaces_[labels[f]].type == SurfaceType::Freeform) continue;
      const double d = signed_distance(surfaces_[labels[f]], mesh.V.row(mesh.F(f, c)).transpose());
      squared[labels[f]] += d * d;
      count[labels[f]] += 1;
    }
  }
  if (edges.empty()) return labels;
  // Exact tessellation: half or more of the features fit exactly, as the feature layer decides it
  // (a CAD export's vertices may lie on a B-spline approximation of its tori, a few thousandths
  // of the tolerance off the ideal surface; or be rounded to single precision far from the origin).
  const double exact_rms = std::max(kExactFraction * tol_, 2.0 * coordinate_floor(mesh));
  int exact = 0, fitted = 0;
  for (int i = 0; i < features; ++i) {
    if (count[i] == 0) continue;
    ++fitted;
    exact += std::sqrt(squared[i] / count[i]) < exact_rms;
  }
  if (2 * exact >= fitted) return labels;
  std::nth_element(edges.begin(), edges.begin() + edges.size() / 2, edges.end());
  const double spacing = edges[edges.size() / 2];
  // A scanner samples about evenly in every direction (the benchmark's scans: a typical facet's
  // shortest edge is 0.85-0.95 of the median edge); facets many times longer than wide are a CAD export's,
  // noisy or not, whose rounds span facets however narrow (a plate's corner radii and hole of 5
  // and 8 on sides of 20, tessellated in slivers 0.4 wide, took the strips' rule and vanished).
  std::nth_element(shortest.begin(), shortest.begin() + shortest.size() / 2, shortest.end());
  if (shortest[shortest.size() / 2] < 0.25 * spacing) return labels;
  // Each feature's width: twice its area over the length of its border.
  std::vector<double> area(features, 0.0), border(features, 0.0);
  const Eigen::VectorXd face_area = face_areas(mesh);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0) continue;
    area[labels[f]] += face_area[f];
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] != labels[f])
        border[labels[f]] += (mesh.V.row(mesh.F(f, c)) - mesh.V.row(mesh.F(f, (c + 1) % 3))).norm();
    }
  }
  std::vector<char> strip(features, 0);
  for (int i = 0; i < features; ++i) {
    const Surface& s = surfaces_[i];
    const double radius = s.type == SurfaceType::Torus ? s.minor : s.radius;
    const bool narrow = border[i] > 0.0 && 2.0 * area[i] / border[i] < 1.5 * spacing;
    strip[i] = (s.type == SurfaceType::Cylinder || s.type == SurfaceType::Torus || s.type == SurfaceType::Sphere) &&
               radius < 2 * spacing && narrow;
  }
  for (int& l : labels) {
    if (l >= 0 && strip[l]) l = -1;
  }
  return labels;
}

// The B-spline of each freeform feature, fitted to the vertices of its faces (weighted by a third of
// each face's area) with the face normals checking that it is a height field.
void BrepBuilder::fit_freeform_surfaces(const TriangleMesh& mesh, const std::vector<int>& face_feature,
                                        BrepResult& result) {
  std::map<int, std::vector<int>> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (face_feature[f] >= 0 && surfaces_[face_feature[f]].type == SurfaceType::Freeform) faces[face_feature[f]].push_back(f);
  for (const auto& [feature, list] : faces) {
    std::map<int, double> vertex_weight;
    MatrixX3d normals(static_cast<Eigen::Index>(list.size()), 3);
    for (size_t i = 0; i < list.size(); ++i) {
      const Vec3 a = mesh.V.row(mesh.F(list[i], 0)), b = mesh.V.row(mesh.F(list[i], 1)), c = mesh.V.row(mesh.F(list[i], 2));
      const Vec3 area_normal = 0.5 * (b - a).cross(c - a);
      normals.row(static_cast<Eigen::Index>(i)) = area_normal.normalized().transpose();
      for (int k = 0; k < 3; ++k) vertex_weight[mesh.F(list[i], k)] += area_normal.norm() / 3.0;
    }
    MatrixX3d points(static_cast<Eigen::Index>(vertex_weight.size()), 3);
    Eigen::VectorXd weights(static_cast<Eigen::Index>(vertex_weight.size()));
    Eigen::Index row = 0;
    for (const auto& [v, w] : vertex_weight) {
      points.row(row) = mesh.V.row(v);
      weights[row++] = w;
    }
    const BSplineSurfaceFit fit = fit_bspline_surface(points, weights, normals);
    if (!fit.valid) {
      result.problems.push_back({feature, fit.problem});
      continue;
    }
    try {
      freeform_[feature] = {occt_bspline(fit), fit.origin, fit.u_direction, fit.v_direction, fit.extrusion};
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({feature, occt_message(failure, "the B-spline surface could not be made")});
    }
  }
}

LocalSurface BrepBuilder::local_surface(int feature) const {
  const auto spline = freeform_.find(feature);
  if (spline != freeform_.end()) {
    const FreeformSurface* f = &spline->second;
    return [f](const Vec3& p) { return f->tangent_plane(p); };
  }
  const Surface* s = &surfaces_[feature];
  return [s](const Vec3&) { return *s; };
}

// The plane that stands in for one of two surfaces touching along `contact` at a corner: the
// plane of a circle of contact, or the plane through a line of contact square to `a` there (their
// common tangent plane). With the other surface it fixes the curve the corner lies on, which the
// two surfaces alone leave free across the zone where they are close.
Surface contact_plane(const Handle(Geom_Curve)& contact, const Surface& a) {
  Surface plane;
  plane.type = SurfaceType::Plane;
  if (const Handle(Geom_Circle) circle = Handle(Geom_Circle)::DownCast(contact)) {
    plane.point = to_vec(circle->Location());
    const gp_Dir n = circle->Axis().Direction();
    plane.axis = Vec3(n.X(), n.Y(), n.Z());
  } else {
    const Handle(Geom_Line) line = Handle(Geom_Line)::DownCast(contact);
    plane.point = to_vec(line->Position().Location());
    const gp_Dir d = line->Position().Direction();
    plane.axis = Vec3(d.X(), d.Y(), d.Z()).cross(surface_normal(a, plane.point));
  }
  plane.axis.normalize();
  return plane;
}

void BrepBuilder::make_vertices(const MeshTopology& topology) {
  BRep_Builder builder;
  std::map<int, std::vector<int>> chains_at;  // corner -> the chains that end there
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    if (chain.closed || chain.right < 0) continue;
    chains_at[chain.vertices.front()].push_back(static_cast<int>(c));
    if (chain.vertices.back() != chain.vertices.front()) chains_at[chain.vertices.back()].push_back(static_cast<int>(c));
  }
  std::map<int, Handle(Geom_Curve)> contact_of;  // chain -> the curve its two surfaces touch along, or null
  std::map<int, std::vector<int>> plain_corners;  // corner -> its features, where their own surfaces fix it
  for (int v : topo_.corners) {
    std::vector<const Surface*> around;
    std::vector<int> around_features, freeform;
    std::set<int> seen;
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
      const int feature = topo_.region_feature[topo_.face_region[*f]];
      if (!seen.insert(feature).second) continue;
      if (freeform_.count(feature)) {
        freeform.push_back(feature);
      } else if (surfaces_[feature].type != SurfaceType::Freeform) {
        around.push_back(&surfaces_[feature]);
        around_features.push_back(feature);
      }
    }
    const Vec3 x0 = mesh_.V.row(v).transpose();
    std::vector<Surface> constraints = corner_constraints(around, tol_);
    // Two surfaces that touch along the chain between them (a fillet and the plane it runs into)
    // meet the corner on their curve of contact: a contact plane stands in for one of them.
    std::vector<char> replaced(constraints.size(), 0);
    for (size_t i = 0; i < constraints.size(); ++i) replaced[i] = constraints[i].type != around[i]->type;
    for (int c : chains_at[v]) {
      const BoundaryChain& chain = topo_.chains[c];
      const auto index = [&](int region) {
        return std::find(around_features.begin(), around_features.end(), topo_.region_feature[region]) - around_features.begin();
      };
      const size_t ia = static_cast<size_t>(index(chain.left)), ib = static_cast<size_t>(index(chain.right));
      if (ia >= around.size() || ib >= around.size() || ia == ib || replaced[ia] || replaced[ib]) continue;
      const Surface &a = *around[ia], &b = *around[ib];
      // Once per chain: both its corners ask.
      const auto [known, first] = contact_of.try_emplace(c);
      Handle(Geom_Curve)& contact = known->second;
      if (first) {
        std::vector<Vec3> raw;
        for (int u : chain.vertices) raw.push_back(mesh_.V.row(u).transpose());
        const LocalSurface local_a = [&a](const Vec3&) { return a; }, local_b = [&b](const Vec3&) { return b; };
        const std::vector<Vec3> points = project_on_both(raw, local_a, &local_b);
        contact = closed_form_curve(a, b, points, {}, angle_eps_, tol_);
        if (contact.IsNull()) contact = closed_form_curve(a, b, points, {}, kNearlyParallel, 5 * tol_);  // as make_edges
        if (contact && (!(contact->IsKind(STANDARD_TYPE(Geom_Circle)) || contact->IsKind(STANDARD_TYPE(Geom_Line))) ||
                        !tangent_along(contact, a, b, points)))
          contact.Nullify();
      }
      if (contact.IsNull()) continue;
      const size_t round = a.type == SurfaceType::Plane ? ib : ia;
      constraints[round] = contact_plane(contact, round == ia ? b : a);
      replaced[round] = 1;
    }
    std::vector<LocalSurface> meeting;
    for (const Surface& c : constraints) meeting.push_back([c](const Vec3&) { return c; });
    for (int feature : freeform) meeting.push_back(local_surface(feature));
    corner_points_[v] = meeting.empty() ? x0 : corner_point(meeting, x0, tol_);
    if (freeform.empty() && std::count(replaced.begin(), replaced.end(), 1) == 0) {
      std::sort(around_features.begin(), around_features.end());
      plain_corners[v] = around_features;
    }
  }
  // A straight chain between two planes whose corners each a third, round surface fixes: both
  // corners together (line_chain_ends).
  for (const BoundaryChain& chain : topo_.chains) {
    const int front = chain.vertices.front(), back = chain.vertices.back();
    if (chain.closed || chain.right < 0 || front == back) continue;
    const auto f = plain_corners.find(front), b = plain_corners.find(back);
    if (f == plain_corners.end() || b == plain_corners.end() || f->second.size() != 3 || b->second.size() != 3) continue;
    const int left = topo_.region_feature[chain.left], right = topo_.region_feature[chain.right];
    const Surface &a = surfaces_[left], &c = surfaces_[right];
    if (a.type != SurfaceType::Plane || c.type != SurfaceType::Plane) continue;
    const auto third = [&](const std::vector<int>& features) {  // the one besides the chain's two
      const bool both = std::count(features.begin(), features.end(), left) && std::count(features.begin(), features.end(), right);
      for (int f : features)
        if (both && f != left && f != right) return static_cast<const Surface*>(&surfaces_[f]);
      return static_cast<const Surface*>(nullptr);
    };
    const std::array<const Surface*, 2> thirds = {third(f->second), third(b->second)};
    if (!thirds[0] || !thirds[1] || thirds[0]->type == SurfaceType::Plane || thirds[1]->type == SurfaceType::Plane) continue;
    const auto ends = line_chain_ends(a, c, thirds, {mesh_.V.row(front).transpose(), mesh_.V.row(back).transpose()},
                                      {corner_points_[front], corner_points_[back]}, tol_);
    if (!ends) continue;
    corner_points_[front] = ends->first;
    corner_points_[back] = ends->second;
  }
  // Corners that the surfaces put at one point (four features meeting where the mesh shows two
  // corners joined by a short chain) are one vertex, and the chain between them no edge.
  std::map<int, int> parent;
  const std::function<int(int)> root = [&](int v) {
    auto it = parent.find(v);
    return it == parent.end() || it->second == v ? v : (it->second = root(it->second));
  };
  collapsed_.assign(topo_.chains.size(), 0);
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    const int front = chain.vertices.front(), back = chain.vertices.back();
    if (chain.closed || front == back || (corner_points_.at(front) - corner_points_.at(back)).norm() >= tol_) continue;
    collapsed_[c] = 1;
    const int a = root(front), b = root(back);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::map<int, std::pair<Vec3, int>> merged;  // root -> (sum of points, count)
  for (int v : topo_.corners) {
    auto& [sum, count] = merged.try_emplace(root(v), Vec3::Zero(), 0).first->second;
    sum += corner_points_[v];
    ++count;
  }
  std::map<int, TopoDS_Vertex> made;
  for (auto& [r, entry] : merged) {
    builder.MakeVertex(made[r], to_pnt(entry.first / entry.second), Precision::Confusion());
  }
  for (int v : topo_.corners) {
    vertices_[v] = made[root(v)];
    const auto& entry = merged[root(v)];
    corner_points_[v] = entry.first / entry.second;
  }
}

// One chain's edge, computed from the surfaces and the mesh alone (chains are independent: on two
// threads): its curve, range, ends and tolerance, or why it has none.
BrepBuilder::ChainCurve BrepBuilder::chain_curve(size_t c) const {
  ChainCurve out;
  const BoundaryChain& chain = topo_.chains[c];
  BrepEdge& report = out.report;
  report.a = topo_.region_feature[chain.left];
  report.b = chain.right >= 0 ? topo_.region_feature[chain.right] : -1;
  report.mesh_vertices = static_cast<int>(chain.vertices.size());
  report.closed = chain.closed;
  // A freeform feature's side is its B-spline. One that has none leaves the edge to the surface
  // on the other side alone (as on an open boundary), so that the face there is still made.
  const auto unfitted = [&](int feature) {
    return feature >= 0 && surfaces_[feature].type == SurfaceType::Freeform && !freeform_.count(feature);
  };
  const bool a_unfitted = unfitted(report.a), b_unfitted = unfitted(report.b);
  if (a_unfitted && (report.b < 0 || b_unfitted)) return out;
  const int feature_a = a_unfitted ? report.b : report.a;
  const int feature_b = a_unfitted || b_unfitted ? -1 : report.b;
  const Surface& a = surfaces_[feature_a];
  const Surface* b = feature_b >= 0 ? &surfaces_[feature_b] : nullptr;
  const bool analytic = a.type != SurfaceType::Freeform && (!b || b->type != SurfaceType::Freeform);
  const LocalSurface local_a = local_surface(feature_a);
  const LocalSurface local_b = b ? local_surface(feature_b) : LocalSurface();
  std::vector<Vec3> raw;
  for (int v : chain.vertices) raw.push_back(mesh_.V.row(v).transpose());
  const std::vector<Vec3> points = project_on_both(raw, local_a, b ? &local_b : nullptr);
  // A point's distance from the farther of the edge's surfaces.
  const auto off = [&](const Vec3& p) {
    return std::max(std::abs(signed_distance(local_a(p), p)), b ? std::abs(signed_distance(local_b(p), p)) : 0.0);
  };
  try {
    // A closed form is the exact answer when the chain lies near it; surfaces that touch
    // tangentially leave the mesh boundary anywhere in the zone where they are close. Surfaces
    // that are parallel or coaxial only nearly (idealization left them: a sculpted part) get
    // the closed form of the exact configuration when it stays near the chain: a line or circle
    // a little off one surface is a sound edge (its tolerance says by how much), the general
    // intersection of nearly tangent surfaces is not.
    Handle(Geom_Curve) curve;
    // The corners that an open chain's edge joins choose its branch in the exact configuration;
    // in the near one, whose touching zone is five times as wide, they lie off every branch.
    std::vector<Vec3> ends;
    if (!chain.closed) ends = {corner_points_.at(chain.vertices.front()), corner_points_.at(chain.vertices.back())};
    for (const auto& [angle_eps, gap, exact] :
         {std::tuple{angle_eps_, tol_, true}, std::tuple{kNearlyParallel, 5 * tol_, false}}) {
      if (b && analytic && curve.IsNull())
        curve = closed_form_curve(a, *b, points, exact ? ends : std::vector<Vec3>(), angle_eps, gap);
      if (curve && max_distance_to_curve(curve, points) > (tangent_along(curve, a, *b, points) ? 0.05 * diagonal_ : 5 * tol_))
        curve.Nullify();
    }
    report.curve = curve.IsNull() ? "" : "closed form";
    if (curve.IsNull() && b) {
      GeomAPI_IntSS intersection(region_surfaces_[chain.left], region_surfaces_[chain.right], 1e-3 * tol_);
      double best = 5 * tol_;
      if (intersection.IsDone()) {
        for (int i = 1; i <= intersection.NbLines(); ++i) {
          const double distance = max_distance_to_curve(intersection.Line(i), points);
          if (distance < best) {
            best = distance;
            curve = intersection.Line(i);
            report.curve = "intersection";
          }
        }
      }
    }
    if (curve.IsNull()) {
      // Through the corners that lie on both surfaces (points of the curve they meet on).
      const auto on_both = [&](const Vec3& corner) { return b && off(corner) <= tol_; };
      curve = chain.closed ? fitted_curve(points, tol_)
                           : fitted_between(points, on_both(ends[0]) ? &ends[0] : nullptr,
                                            on_both(ends[1]) ? &ends[1] : nullptr, tol_, off);
      report.curve = "fitted";
    }
    if (curve.IsNull()) {
      report.curve.clear();
      out.problem = "an edge of the feature could not be made";
      return out;
    }

    // Ends: the corners, or one new point on a closed chain (its vertex is made with the edge).
    const bool loop = chain.vertices.front() == chain.vertices.back();
    Vec3 p0, p1;
    if (chain.closed) {
      GeomAPI_ProjectPointOnCurve start(to_pnt(points.front()), curve);
      p0 = start.NbPoints() ? to_vec(start.NearestPoint()) : points.front();
      // A closed edge starts where it crosses the seam of the periodic face beside it: a full
      // band (a cylinder between two circles) is then bounded by circle, seam, circle, seam,
      // which healing does not have to split with gap-filling degenerate edges. A cap about a
      // pole or apex puts its seam through the vertex wherever it is. (Between two periodic
      // faces, whose seams differ, the mesh decides.)
      auto periodic = [&](int region) {
        return region >= 0 && !region_surfaces_[region].IsNull() && region_surfaces_[region]->IsUPeriodic() &&
               !is_cap(static_cast<size_t>(region));
      };
      // So does a circle beside a face that winds round its axis (whose seam its neighbour took).
      const bool winds = (chain.left >= 0 && region_winds_[chain.left]) || (chain.right >= 0 && region_winds_[chain.right]);
      if (periodic(chain.left) != periodic(chain.right) || (winds && periodic(chain.left) && periodic(chain.right))) {
        const int region = chain.left >= 0 && region_winds_[chain.left] ? chain.left
                           : chain.right >= 0 && region_winds_[chain.right] ? chain.right
                           : periodic(chain.left) ? chain.left : chain.right;
        const Handle(Geom_Curve) seam = region_surfaces_[region]->UIso(0.0);
        GeomAPI_ExtremaCurveCurve crossing(curve, seam);
        if (crossing.NbExtrema() > 0 && crossing.LowerDistance() <= 10 * tol_) {
          gp_Pnt on_curve, on_seam;
          crossing.NearestPoints(on_curve, on_seam);
          p0 = to_vec(on_curve);
        }
      }
      // A closed curve that is not periodic (an intersection loop of two cylinders) runs from
      // its first point round to it: the vertex goes there, not where the chain starts.
      if (!curve->IsPeriodic()) p0 = to_vec(curve->Value(curve->FirstParameter()));
      p1 = p0;
    } else {
      p0 = corner_points_.at(chain.vertices.front());
      p1 = corner_points_.at(chain.vertices.back());
    }
    const Vec3 probe = points[loop ? std::max<size_t>(1, points.size() / 4) : points.size() / 2];
    double u0 = 0, u1 = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
      const auto parameter = [&](const Vec3& p) { return curve_parameter(curve, p); };
      bool reverse = false;
      if (curve->IsPeriodic()) {
        const double period = curve->Period();
        const auto wrap = [&](double u) { return u - period * std::floor(u / period); };
        u0 = parameter(p0);
        const double span = loop ? period : wrap(parameter(p1) - u0);
        // A loop runs the way its mesh vertices do (from its first one, wherever the edge starts).
        reverse = loop ? wrap(parameter(probe) - parameter(points.front())) > 0.5 * period
                       : wrap(parameter(probe) - u0) > span;
        u1 = u0 + (span > 0 ? span : period);
      } else if (loop) {
        u0 = curve->FirstParameter();
        u1 = curve->LastParameter();
      } else {
        u0 = parameter(p0);
        u1 = parameter(p1);
        reverse = u1 < u0;
      }
      if (!reverse) break;
      if (attempt == 1) throw Standard_Failure("the edge's direction is ambiguous");
      curve = curve->Reversed();
    }
    // A fitted curve passes through the chain's points, which lie on both surfaces, and strays
    // from them in between by up to its fitting tolerance: its edge's tolerance says by how much.
    double edge_tolerance = Precision::Confusion();
    if (report.curve == "fitted") edge_tolerance = std::max(edge_tolerance, 1.01 * farthest_off(curve, u0, u1, off));
    out.curve = curve;
    out.u0 = u0, out.u1 = u1, out.tolerance = edge_tolerance;
    out.p0 = p0, out.p1 = p1;
  } catch (const Standard_Failure& failure) {
    out.report.curve.clear();
    out.problem = occt_message(failure, "an edge could not be made");
  }
  return out;
}

void BrepBuilder::compute_curves() {
  const size_t chains = topo_.chains.size();
  curves_.assign(chains, ChainCurve());
  std::vector<std::exception_ptr> errors(chains);  // raised after the threads, as the first chain's would be
  on_two_threads_as_free(static_cast<int>(chains), [&](int c) {
    try {
      if (!collapsed_[c]) curves_[c] = chain_curve(c);
    } catch (...) {
      errors[c] = std::current_exception();
    }
  });
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

// The mesh's own border between two regions, where one of them is faceted or their curve failed:
// its vertices move onto the surfaces of the analytic regions beside it (onto both, where both are),
// so that the straight edges between them bound those faces within the tolerance their pcurves
// measure. Corners stay the vertices that the analytic edges end at.
void BrepBuilder::place_polylines() {
  facets_ = std::make_unique<FacetBuilder>(clean_);
  facet_region_.clear();
  facet_planes_.clear();
  const auto analytic = [&](int r) { return r >= 0 && !faceted_[r] && !region_surfaces_[r].IsNull(); };
  // A corner where an analytic face meets is the vertex its edges end at; among facets alone it
  // stays the mesh's vertex (the surfaces may have put two corners at one point).
  std::vector<char> touches_analytic(clean_.num_vertices(), 0);
  for (int f = 0; f < clean_.num_faces(); ++f)
    if (analytic(topo_.face_region[f]))
      for (int k = 0; k < 3; ++k) touches_analytic[clean_.F(f, k)] = 1;
  for (const auto& [v, vertex] : vertices_)
    if (touches_analytic[v]) facets_->share(v, vertex);
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    if (!polyline_[c]) continue;
    const BoundaryChain& chain = topo_.chains[c];
    std::vector<LocalSurface> sides;
    for (int r : {chain.left, chain.right})
      if (analytic(r)) sides.push_back(local_surface(topo_.region_feature[r]));
    if (sides.empty()) continue;
    const size_t first = chain.closed ? 0 : 1, end = chain.closed ? chain.vertices.size() : chain.vertices.size() - 1;
    std::vector<Vec3> raw;
    for (size_t i = first; i < end; ++i) raw.push_back(clean_.V.row(chain.vertices[i]).transpose());
    const std::vector<Vec3> placed = project_on_both(raw, sides[0], sides.size() > 1 ? &sides[1] : nullptr);
    for (size_t i = first; i < end; ++i) facets_->place(chain.vertices[i], placed[i - first]);
  }
}

// The vertices of a polyline chain. Beside a facet, all of them (the facets use them). Between two
// analytic faces, those that advance along the chain once moved onto both surfaces, at least a
// tolerance apart: noisy border vertices projected onto the surfaces' intersection may step back
// along it, and the edge would cross itself.
std::vector<int> BrepBuilder::polyline_vertices(size_t c) const {
  const BoundaryChain& chain = topo_.chains[c];
  const bool facet_beside = faceted_[chain.left] || (chain.right >= 0 && faceted_[chain.right]);
  if (facet_beside || chain.vertices.size() < 3) return chain.vertices;
  std::vector<int> kept = {chain.vertices.front()};
  const size_t n = chain.vertices.size();
  const Vec3 end = facets_->position(chain.vertices.back());
  for (size_t i = 1; i + 1 < n; ++i) {
    const Vec3 last = facets_->position(kept.back()), p = facets_->position(chain.vertices[i]);
    const Vec3 along = chain.closed ? Vec3(clean_.V.row(chain.vertices[i + 1]) - clean_.V.row(chain.vertices[i - 1])).eval()
                                    : (end - last).eval();
    const bool advances = (p - last).dot(along) > 0.0 && (chain.closed || (end - p).norm() < (end - last).norm());
    if (advances && (p - last).norm() > tol_ && (chain.closed || (end - p).norm() > tol_)) kept.push_back(chain.vertices[i]);
  }
  kept.push_back(chain.vertices.back());
  return kept;
}

void BrepBuilder::make_edges(BrepResult& result) {
  BRep_Builder builder;
  const size_t chains = topo_.chains.size();
  edges_.assign(chains, TopoDS_Edge());
  edge_ok_.assign(chains, 0);
  split_edges_.clear();
  chain_pieces_.clear();
  const ProgressSpan progress = progress_.sub("edges", 0.55, 0.8);
  // The edges, their vertices' tolerances and the seam splits, in chain order.
  for (size_t c = 0; c < chains; ++c) {
    progress.step(static_cast<double>(c) / chains);
    const BoundaryChain& chain = topo_.chains[c];
    const ChainCurve& edge_curve = curves_[c];
    if (polyline_[c]) {
      std::vector<TopoDS_Edge>& pieces = chain_pieces_[c];
      const std::vector<int> kept = polyline_vertices(c);
      for (size_t i = 0; i + 1 < kept.size(); ++i)
        for (const TopoDS_Edge& piece : facets_->path(kept[i], kept[i + 1])) pieces.push_back(piece);
      edge_ok_[c] = 1;
      BrepEdge report = edge_curve.report;
      report.a = topo_.region_feature[chain.left];
      report.b = chain.right >= 0 ? topo_.region_feature[chain.right] : -1;
      report.mesh_vertices = static_cast<int>(chain.vertices.size());
      report.closed = chain.closed;
      report.curve = "polyline";
      result.edges.push_back(report);
      continue;
    }
    if (collapsed_[c]) {
      edge_ok_[c] = 1;
      continue;
    }
    result.edges.push_back(edge_curve.report);
    if (!edge_curve.problem.empty()) result.problems.push_back({topo_.region_feature[chain.left], edge_curve.problem});
    if (edge_curve.curve.IsNull()) continue;
    try {
      const Handle(Geom_Curve)& curve = edge_curve.curve;
      const double u0 = edge_curve.u0, u1 = edge_curve.u1;
      const Vec3 &p0 = edge_curve.p0, &p1 = edge_curve.p1;
      TopoDS_Vertex v0, v1;
      if (chain.closed) {
        builder.MakeVertex(v0, to_pnt(p0), Precision::Confusion());
        v1 = v0;
      } else {
        v0 = vertex_at_corner(chain.vertices.front());
        v1 = vertex_at_corner(chain.vertices.back());
      }
      TopoDS_Edge edge;
      builder.MakeEdge(edge, curve, edge_curve.tolerance);
      builder.Add(edge, v0.Oriented(TopAbs_FORWARD));
      builder.Add(edge, v1.Oriented(TopAbs_REVERSED));
      builder.Range(edge, u0, u1);
      // Vertex tolerance: the gap between the corner point and the curve's end.
      builder.UpdateVertex(v0, std::max(BRep_Tool::Tolerance(v0), 1.01 * (to_vec(curve->Value(u0)) - p0).norm()));
      builder.UpdateVertex(v1, std::max(BRep_Tool::Tolerance(v1), 1.01 * (to_vec(curve->Value(u1)) - p1).norm()));
      edges_[c] = edge;
      edge_ok_[c] = split_at_seam(c, curve, u0, u1, v0, v1, edge_curve.tolerance);
    } catch (const Standard_Failure& failure) {
      result.edges.back().curve.clear();
      result.problems.push_back({topo_.region_feature[chain.left], occt_message(failure, "an edge could not be made")});
    }
  }
}

// Whether an edge of `shape` spans no parameter range on a face it bounds. BRepTools_WireExplorer,
// which BRepCheck runs on every wire, steps along an edge's pcurve from its end by a thousandth of
// its range until it leaves the end's point: below the parameter's rounding the step adds nothing,
// and the check never returns (OCCT 7.6). Healing left such an edge, flagged degenerated, on a
// plane of a scan's sewn shell.
bool has_vanishing_edge(const TopoDS_Shape& shape) {
  for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next()) {
    const TopoDS_Face& face = TopoDS::Face(f.Current());
    for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) {
      double first, last;
      if (!BRep_Tool::CurveOnSurface(TopoDS::Edge(e.Current()), face, first, last).IsNull() &&
          !(last - first > Precision::PConfusion()))
        return true;
    }
  }
  return false;
}

// The pcurves of a wire that winds once round the axis of a u-periodic surface, made continuous in
// u from the vertex on the seam on (FixAddPCurve puts each in the period nearest the surface's):
// the loop then runs from the seam round to it, and healing closes the face along the seam. Were
// they left as they come, healing takes the stretch before the seam for a loop of its own.
void continue_pcurves(const TopoDS_Wire& wire, const TopoDS_Face& face) {
  if (has_vanishing_edge(face)) return;
  const double period = BRep_Tool::Surface(face)->UPeriod();
  struct Use {
    TopoDS_Edge edge;
    Handle(Geom2d_Curve) pcurve;
    gp_Pnt2d start, end;
  };
  std::vector<Use> uses;
  for (BRepTools_WireExplorer it(wire, face); it.More(); it.Next()) {
    double first, last;
    Use use{it.Current(), BRep_Tool::CurveOnSurface(it.Current(), face, first, last), {}, {}};
    if (use.pcurve.IsNull()) return;
    const bool reversed = use.edge.Orientation() == TopAbs_REVERSED;
    use.start = use.pcurve->Value(reversed ? last : first);
    use.end = use.pcurve->Value(reversed ? first : last);
    uses.push_back(use);
  }
  if (uses.empty()) return;
  auto off_seam = [&](double u) { return std::abs(std::remainder(u, period)); };
  const auto seam = std::min_element(uses.begin(), uses.end(),
                                     [&](const Use& x, const Use& y) { return off_seam(x.start.X()) < off_seam(y.start.X()); });
  std::rotate(uses.begin(), seam, uses.end());
  BRep_Builder builder;
  double u = uses.front().start.X() - std::remainder(uses.front().start.X(), period);  // the seam
  for (const Use& use : uses) {
    const double shift = period * std::round((u - use.start.X()) / period);
    if (shift != 0.0) {
      const Handle(Geom2d_Curve) moved = Handle(Geom2d_Curve)::DownCast(use.pcurve->Translated(gp_Vec2d(shift, 0.0)));
      builder.UpdateEdge(use.edge, moved, face, BRep_Tool::Tolerance(use.edge));
    }
    u = use.end.X() + shift;
  }
}

// A cone or sphere bounded by one whole circle is a cap about its apex (a drill point) or pole (a
// ball end): its face is the surface between the circle and that point, with the seam and the
// degenerate edge there that a face built from the circle alone lacks. The sphere is placed with
// its pole inside the cap. Sewing joins the cap's circle to the neighbour's.
bool BrepBuilder::is_cap(size_t region) const {
  const auto& loops = topo_.region_loops[region];
  const Handle(Geom_Surface)& surface = region_surfaces_[region];
  return loops.size() == 1 && loops[0].size() == 1 && topo_.chains[loops[0][0].chain].closed &&
         (surface->IsKind(STANDARD_TYPE(Geom_ConicalSurface)) || surface->IsKind(STANDARD_TYPE(Geom_SphericalSurface)));
}

std::optional<TopoDS_Face> BrepBuilder::pole_cap(size_t region) {
  if (!is_cap(region)) return std::nullopt;
  const auto& loops = topo_.region_loops[region];
  const TopoDS_Edge& edge = edges_[loops[0][0].chain];
  if (edge.IsNull()) return std::nullopt;  // a polyline: the face is bounded by its pieces
  double first, last;
  const Handle(Geom_Circle) circle = Handle(Geom_Circle)::DownCast(BRep_Tool::Curve(edge, first, last));
  if (circle.IsNull()) return std::nullopt;
  // The surface's seam through the edge's vertex: the cap's circle then starts where the edge does,
  // and sewing joins the two whole (it would cut both at each other's vertices).
  const gp_Pnt start = BRep_Tool::Pnt(TopExp::FirstVertex(edge));
  const gp_Dir seam = gp_Vec(circle->Location(), start);
  Handle(Geom_Surface) placed;
  double low, high;
  if (const Handle(Geom_ConicalSurface) cone = Handle(Geom_ConicalSurface)::DownCast(region_surfaces_[region]);
      !cone.IsNull()) {
    const Handle(Geom_ConicalSurface) turned = new Geom_ConicalSurface(
        gp_Ax3(cone->Location(), cone->Axis().Direction(), seam), cone->SemiAngle(), cone->RefRadius());
    double u, v;
    ElSLib::Parameters(turned->Cone(), start, u, v);
    const double apex = -turned->RefRadius() / std::sin(turned->SemiAngle());
    placed = turned;
    low = std::min(apex, v);
    high = std::max(apex, v);
  } else if (const Handle(Geom_SphericalSurface) sphere = Handle(Geom_SphericalSurface)::DownCast(region_surfaces_[region]);
             !sphere.IsNull()) {
    gp_Dir pole = circle->Axis().Direction();
    if (gp_Vec(circle->Location(), to_pnt(region_centroid_[region])).Dot(gp_Vec(pole)) < 0.0) pole.Reverse();
    const Handle(Geom_SphericalSurface) turned = new Geom_SphericalSurface(gp_Ax3(sphere->Location(), pole, seam), sphere->Radius());
    double u, v;
    ElSLib::Parameters(turned->Sphere(), start, u, v);
    placed = turned;
    low = v;
    high = 0.5 * M_PI;
  } else {
    return std::nullopt;
  }
  BRepBuilderAPI_MakeFace cap(placed, 0.0, 2.0 * M_PI, low, high, Precision::Confusion());
  if (!cap.IsDone()) return std::nullopt;
  region_surfaces_[region] = placed;  // faces map back to features by their surface
  return cap.Face();
}

void BrepBuilder::make_faces(BrepResult& result) {
  BRep_Builder builder;
  faces_.clear();
  face_region_.clear();
  face_facet_.clear();
  const ProgressSpan progress = progress_.sub("faces", 0.8, 0.83);
  for (size_t r = 0; r < topo_.region_loops.size(); ++r) {
    progress.step(static_cast<double>(r) / topo_.region_loops.size());
    const int feature = topo_.region_feature[r];
    if (faceted_[r]) {
      for (int f : region_faces_[r]) {
        const std::optional<TopoDS_Face> facet = facets_->facet(f);
        if (!facet) continue;  // no area: its neighbours' edges meet across it
        const Handle(Geom_Surface) plane = BRep_Tool::Surface(*facet);
        facet_region_[plane.get()] = static_cast<int>(r);
        facet_planes_.push_back(plane);
        faces_.push_back(*facet);
        face_region_.push_back(static_cast<int>(r));
        face_facet_.push_back(1);
      }
      continue;
    }
    bool complete = true;
    for (const auto& loop : topo_.region_loops[r]) {
      for (const ChainUse& use : loop) complete &= edge_ok_[use.chain] != 0;
    }
    if (!complete) {
      result.problems.push_back({feature, "the face has an edge that could not be made"});
      fail(static_cast<int>(r), "an edge of its face could not be made");
      continue;
    }
    const bool outward = region_sense_[r] > 0;
    if (const std::optional<TopoDS_Face> cap = pole_cap(r)) {
      faces_.push_back(outward ? *cap : TopoDS::Face(cap->Reversed()));
      face_region_.push_back(static_cast<int>(r));
      face_facet_.push_back(0);
      continue;
    }
    try {
      TopoDS_Face face;
      builder.MakeFace(face, region_surfaces_[r], Precision::Confusion());
      for (const auto& loop : topo_.region_loops[r]) {
        if (std::all_of(loop.begin(), loop.end(),
                        [&](const ChainUse& use) { return collapsed_[use.chain] != 0 && !polyline_[use.chain]; }))
          continue;
        TopoDS_Wire wire;
        builder.MakeWire(wire);
        // Loops run with the face on their left seen from outside; on a surface whose normal
        // points into the part the face is built reversed, with the loop reversed.
        const int n = static_cast<int>(loop.size());
        for (int i = 0; i < n; ++i) {
          const ChainUse& use = loop[outward ? i : n - 1 - i];
          const bool forward = use.forward == outward;
          if (const auto pieces = chain_pieces_.find(use.chain); pieces != chain_pieces_.end()) {
            const std::vector<TopoDS_Edge>& along = pieces->second;  // oriented along the chain
            for (size_t k = 0; k < along.size(); ++k)
              builder.Add(wire, forward ? along[k] : TopoDS::Edge(along[along.size() - 1 - k].Reversed()));
            continue;
          }
          if (collapsed_[use.chain]) continue;
          const auto split = split_edges_.find(use.chain);
          if (split == split_edges_.end()) {
            builder.Add(wire, edges_[use.chain].Oriented(forward ? TopAbs_FORWARD : TopAbs_REVERSED));
          } else {
            for (const TopoDS_Edge& part : split->second)
              builder.Add(wire, part.Oriented(forward ? TopAbs_FORWARD : TopAbs_REVERSED));
          }
        }
        wire.Closed(Standard_True);
        builder.Add(face, wire);
      }
      ShapeFix_Edge add_pcurves;
      for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) {
        add_pcurves.FixAddPCurve(TopoDS::Edge(e.Current()), face, Standard_False, tol_);
      }
      // (A polyline's pieces are projected one by one, each into the period nearest the surface's.)
      if (region_winds_[r] || (bounded_[r] && region_surfaces_[r]->IsUPeriodic()))
        for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) continue_pcurves(TopoDS::Wire(w.Current()), face);
      faces_.push_back(outward ? face : TopoDS::Face(face.Reversed()));
      face_region_.push_back(static_cast<int>(r));
      face_facet_.push_back(0);
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({feature, occt_message(failure, "the face could not be made")});
      fail(static_cast<int>(r), occt_message(failure, "its face could not be made"));
    }
  }
}

const char* occt_surface_name(const TopoDS_Face& face) {
  switch (BRepAdaptor_Surface(face).GetType()) {
    case GeomAbs_Plane: return "plane";
    case GeomAbs_Cylinder: return "cylinder";
    case GeomAbs_Cone: return "cone";
    case GeomAbs_Sphere: return "sphere";
    case GeomAbs_Torus: return "torus";
    case GeomAbs_BSplineSurface: return "bspline";
    default: return "other";
  }
}

// BRepCheck's verdict, invalid outright with an edge of no parameter range (which it cannot check).
bool is_valid(const TopoDS_Shape& shape, bool parallel = false) {
  return !has_vanishing_edge(shape) && BRepCheck_Analyzer(shape, Standard_True, parallel).IsValid();
}

// What BRepCheck finds wrong with an invalid face, first for the face itself, then for its wires,
// edges and vertices ("SelfIntersectingWire", "BadOrientationOfSubshape", ...).
std::string invalid_reason(const TopoDS_Shape& face) {
  if (has_vanishing_edge(face)) return "an edge of no length";
  const BRepCheck_Analyzer analyzer(face);
  for (const TopAbs_ShapeEnum type : {TopAbs_FACE, TopAbs_WIRE, TopAbs_EDGE, TopAbs_VERTEX}) {
    for (TopExp_Explorer e(face, type); e.More(); e.Next()) {
      const Handle(BRepCheck_Result) result = analyzer.Result(e.Current());
      if (result.IsNull()) continue;
      std::vector<const BRepCheck_ListOfStatus*> lists{&result->Status()};
      for (result->InitContextIterator(); result->MoreShapeInContext(); result->NextShapeInContext())
        lists.push_back(&result->StatusOnShape());
      for (const BRepCheck_ListOfStatus* list : lists)
        for (BRepCheck_ListIteratorOfListOfStatus it(*list); it.More(); it.Next())
          if (it.Value() != BRepCheck_NoError) {
            std::ostringstream name;
            BRepCheck::Print(it.Value(), name);
            std::string text = name.str();
            text.erase(std::remove(text.begin(), text.end(), '\n'), text.end());
            return text;
          }
    }
  }
  return "unknown";
}

// Why a face of a shell that did not close cannot be kept (empty: it can). Its edges may cross
// themselves or leave the surface, or its boundary run the wrong way round (the face would cover the
// rest of a torus: its area comes out negative), which BRepCheck passes but OpenCASCADE's mesher
// (and every modelling operation) chokes on: the mesher never returned on such a torus face. A
// vertex or edge whose tolerance exceeds `size` (the part's) is no geometry at all, and the
// self-intersection check never returned on one.
std::string shell_face_fault(const TopoDS_Shape& face, double size) {
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next())
    if (!(BRep_Tool::Tolerance(TopoDS::Edge(e.Current())) <= size)) return "an edge's tolerance exceeds the part";
  for (TopExp_Explorer v(face, TopAbs_VERTEX); v.More(); v.Next())
    if (!(BRep_Tool::Tolerance(TopoDS::Vertex(v.Current())) <= size)) return "a vertex's tolerance exceeds the part";
  if (!is_valid(face)) return invalid_reason(face);
  GProp_GProps area;
  BRepGProp::SurfaceProperties(face.Oriented(TopAbs_FORWARD), area);
  if (area.Mass() < 0.0) return "its boundary runs the wrong way round";
  // Whether the edges leave the surface first: it is the quick check, and the self-intersection
  // check of a face bounded by fitted curves that leave it takes up to half a second.
  for (const bool self_intersection : {false, true}) {
    BOPAlgo_ArgumentAnalyzer analyzer;
    analyzer.SetShape1(face);
    analyzer.ArgumentTypeMode() = Standard_False;
    analyzer.SelfInterMode() = self_intersection;
    analyzer.CurveOnSurfaceMode() = !self_intersection;
    analyzer.Perform();
    if (analyzer.HasFaulty()) return "its edges cross each other or leave its surface";
  }
  return "";
}

// Why each face of a closed shell fails where BRepCheck passes it ("" where it does not): bounded
// the wrong way round, or by a boundary that crosses itself (the end face of a scanned hex head,
// where the arcs of a narrow chamfer cone cut the flats' lines out of order), which the mesher
// leaves without triangles (at `deflection`) and FreeCAD's check rejects. Faces of less area than
// `tolerance` squared (slivers a CAD export keeps) are not judged. (The boolean operations' checks
// of shell_face_fault also reject sound faces whose arcs meet tangentially.)
std::vector<std::string> closed_shell_faults(const TopoDS_Shape& shape, double deflection, double tolerance,
                                             const std::function<bool(const TopoDS_Face&)>& sound = {}) {
  std::vector<std::string> faults;
  // (Faces sound by construction, planar facets, are neither meshed nor judged.)
  BRep_Builder builder;
  TopoDS_Compound judged;
  builder.MakeCompound(judged);
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next())
    if (!sound || !sound(TopoDS::Face(e.Current()))) builder.Add(judged, e.Current());
  BRepMesh_IncrementalMesh mesher(judged, deflection, Standard_False, 0.5, Standard_True);
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    if (sound && sound(face)) {
      faults.emplace_back();
      continue;
    }
    GProp_GProps area;
    BRepGProp::SurfaceProperties(face.Oriented(TopAbs_FORWARD), area);
    TopLoc_Location location;
    const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
    if (area.Mass() < 0.0)
      faults.push_back("its boundary runs the wrong way round");
    else if (area.Mass() > tolerance * tolerance && (triangulation.IsNull() || triangulation->NbTriangles() == 0))
      faults.push_back("its boundary crosses itself: no mesh covers it");
    else
      faults.emplace_back();
  }
  BRepTools::Clean(judged);  // (the mesh stays out of the shape, as in triangulate)
  return faults;
}

// A solid, or a compound of solids (a mesh of several bodies).
bool is_solid_shape(const TopoDS_Shape& shape) {
  if (shape.ShapeType() == TopAbs_SOLID) return true;
  if (shape.ShapeType() != TopAbs_COMPOUND) return false;
  bool any = false;
  for (TopoDS_Iterator it(shape); it.More(); it.Next()) {
    if (it.Value().ShapeType() != TopAbs_SOLID) return false;
    any = true;
  }
  return any;
}

bool no_faults(const std::vector<std::string>& faults) {
  return std::all_of(faults.begin(), faults.end(), [](const std::string& f) { return f.empty(); });
}

// Two edges of a wire that meet tangentially (a fillet's arc running into a larger arc) cross once
// more beside their common vertex wherever that vertex lies a little off their exact point of
// tangency, which BRepCheck takes for a self-intersecting wire unless the vertex's tolerance covers
// the crossing. Raises it to do so for crossings within `reach` of the vertex.
void cover_tangent_crossings(const TopoDS_Face& face, double reach) {
  if (has_vanishing_edge(face)) return;
  BRep_Builder builder;
  for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) {
    std::vector<TopoDS_Edge> edges;
    for (BRepTools_WireExplorer e(TopoDS::Wire(w.Current()), face); e.More(); e.Next()) edges.push_back(e.Current());
    for (size_t i = 0; i < edges.size() && edges.size() > 1; ++i) {
      const TopoDS_Edge &a = edges[i], &b = edges[(i + 1) % edges.size()];
      TopoDS_Vertex v;
      if (!TopExp::CommonVertex(a, b, v)) continue;
      double a0, a1, b0, b1;
      const Handle(Geom_Curve) ca = BRep_Tool::Curve(a, a0, a1), cb = BRep_Tool::Curve(b, b0, b1);
      if (ca.IsNull() || cb.IsNull()) continue;
      gp_Pnt pa, pb;
      gp_Vec ta, tb;
      ca->D1(BRep_Tool::Parameter(v, a), pa, ta);
      cb->D1(BRep_Tool::Parameter(v, b), pb, tb);
      if (ta.Magnitude() <= 0.0 || tb.Magnitude() <= 0.0 || ta.Crossed(tb).Magnitude() > 0.1 * ta.Magnitude() * tb.Magnitude())
        continue;  // not tangent (beyond about 6°): no second crossing near the vertex
      GeomAPI_ExtremaCurveCurve extrema(ca, cb, a0, a1, b0, b1);
      const gp_Pnt centre = BRep_Tool::Pnt(v);
      const double touching = BRep_Tool::Tolerance(a) + BRep_Tool::Tolerance(b);
      double cover = BRep_Tool::Tolerance(v);
      for (int n = 1; n <= extrema.NbExtrema(); ++n) {
        if (extrema.Distance(n) > touching) continue;
        gp_Pnt p, q;
        extrema.Points(n, p, q);
        const double away = std::max(centre.Distance(p), centre.Distance(q)) + touching;
        if (away <= reach) cover = std::max(cover, 1.01 * away);
      }
      if (cover > BRep_Tool::Tolerance(v)) builder.UpdateVertex(v, cover);
    }
  }
}

// An edge used by one face only (seams, used twice by their face, and degenerate edges aside).
bool has_free_edges(const TopoDS_Shape& shape) {
  TopTools_IndexedDataMapOfShapeListOfShape faces_of_edge;
  TopExp::MapShapesAndUniqueAncestors(shape, TopAbs_EDGE, TopAbs_FACE, faces_of_edge);
  for (int i = 1; i <= faces_of_edge.Extent(); ++i) {
    const TopoDS_Edge& edge = TopoDS::Edge(faces_of_edge.FindKey(i));
    const TopTools_ListOfShape& faces = faces_of_edge(i);
    if (BRep_Tool::Degenerated(edge) || faces.Extent() >= 2) continue;
    if (faces.Extent() == 0 || !BRep_Tool::IsClosed(edge, TopoDS::Face(faces.First()))) return true;
  }
  return false;
}

// Faces map back to features by their surface: the region's own, or for a face that healing or
// merging put on a copy (or a trimmed copy), the region's surface of that kind through points of
// the face's.
int BrepBuilder::region_of(const TopoDS_Face& face) const {
  Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  if (const auto facet = facet_region_.find(surface.get()); facet != facet_region_.end()) return facet->second;
  if (const Handle(Geom_RectangularTrimmedSurface) trimmed = Handle(Geom_RectangularTrimmedSurface)::DownCast(surface);
      !trimmed.IsNull())
    surface = trimmed->BasisSurface();  // merging bounds a periodic face's surface
  for (size_t r = 0; r < region_surfaces_.size(); ++r)
    if (region_surfaces_[r] == surface) return static_cast<int>(r);
  double u0, u1, v0, v1;
  BRepTools::UVBounds(face, u0, u1, v0, v1);
  const std::array<gp_Pnt, 3> points = {surface->Value(u0 + 0.25 * (u1 - u0), v0 + 0.25 * (v1 - v0)),
                                        surface->Value(u0 + 0.75 * (u1 - u0), v0 + 0.5 * (v1 - v0)),
                                        surface->Value(u0 + 0.5 * (u1 - u0), v0 + 0.75 * (v1 - v0))};
  for (size_t r = 0; r < region_surfaces_.size(); ++r) {
    if (region_surfaces_[r].IsNull() || region_surfaces_[r]->DynamicType() != surface->DynamicType()) continue;
    const bool on = std::all_of(points.begin(), points.end(), [&](const gp_Pnt& p) {
      GeomAPI_ProjectPointOnSurf projection(p, region_surfaces_[r]);
      return projection.NbPoints() > 0 && projection.LowerDistance() <= tol_;
    });
    if (on) return static_cast<int>(r);
  }
  return -1;
}

namespace {

// A fitted edge (a B-spline through the mesh's border between two features) whose 3D curve and
// pcurve lie this many tolerances apart bounds no face of its surface. (An exact circle on a
// sphere that is no parallel may have its approximated pcurve as far off: its tolerance covers it.)
constexpr double kStrayEdge = 10.0;

// The largest distance between a B-spline edge's 3D curve and its curve on `face`, at 33
// parameters: a lower bound of BRepLib_CheckCurveOnSurface's, at a small part of its cost. 0 for
// other edges and without the curves.
double sampled_pcurve_gap(const TopoDS_Edge& edge, const TopoDS_Face& face) {
  double first, last;
  const Handle(Geom_Curve) curve = BRep_Tool::Curve(edge, first, last);
  if (curve.IsNull() || !curve->IsKind(STANDARD_TYPE(Geom_BSplineCurve)) ||
      BRep_Tool::CurveOnSurface(edge, face, first, last).IsNull())
    return 0.0;
  const BRepAdaptor_Curve in_space(edge), on_face(edge, face);
  constexpr int kSamples = 32;
  double gap = 0.0;
  for (int i = 0; i <= kSamples; ++i) {
    const double t = first + (last - first) * i / kSamples;
    gap = std::max(gap, in_space.Value(t).Distance(on_face.Value(t)));
  }
  return gap;
}

}  // namespace

// The sewn analytic faces and the facets, whose edges and vertices are replaced by those that
// healing (`healed`) and then sewing made of them, grouped into connected shells.
TopoDS_Shape BrepBuilder::with_facets(const TopoDS_Shape& sewn, const BRepBuilderAPI_Sewing& sewing,
                                      ShapeBuild_ReShape& healed) const {
  BRepTools_ReShape replace;
  TopTools_IndexedMapOfShape parts;
  for (size_t i = 0; i < faces_.size(); ++i)
    if (face_facet_[i]) {
      TopExp::MapShapes(faces_[i], TopAbs_EDGE, parts);
      TopExp::MapShapes(faces_[i], TopAbs_VERTEX, parts);
    }
  bool any = false;
  for (int k = 1; k <= parts.Extent(); ++k) {
    const TopoDS_Shape& part = parts(k);
    TopoDS_Shape now = healed.Value(part);
    if (sewing.IsModifiedSubShape(now)) now = sewing.ModifiedSubShape(now);
    if (now.IsSame(part) && now.Orientation() == part.Orientation()) continue;
    replace.Replace(part, now);
    any = true;
  }
  // All facets at once: an edge they share is rebuilt once, with its new vertices.
  BRep_Builder builder;
  TopoDS_Compound facets;
  builder.MakeCompound(facets);
  for (size_t i = 0; i < faces_.size(); ++i)
    if (face_facet_[i]) builder.Add(facets, faces_[i]);
  std::vector<TopoDS_Face> faces;
  for (TopExp_Explorer e(sewn, TopAbs_FACE); e.More(); e.Next()) faces.push_back(TopoDS::Face(e.Current()));
  for (TopExp_Explorer e(any ? replace.Apply(facets) : TopoDS_Shape(facets), TopAbs_FACE); e.More(); e.Next())
    faces.push_back(TopoDS::Face(e.Current()));
  TopoDS_Compound shells;
  builder.MakeCompound(shells);
  for (const TopoDS_Shell& shell : connected_shells(faces)) builder.Add(shells, shell);
  return shells;
}

TopoDS_Shape BrepBuilder::assemble(BrepResult& result, const BrepOptions& options,
                                   std::vector<std::string>& closed_faults) {
  // Each face that needs it is healed on its own (pcurves shifted into one period, seams of
  // closed faces, degenerate edges at poles), then the faces are sewn: healing may replace an
  // edge in one face and not in its neighbour, and healing the whole shell at once
  // (ShapeFix_Shell) crashes on such shells in OCCT 7.6.
  if (faces_.empty()) {  // nothing to sew: an empty compound, no solid
    TopoDS_Compound nothing;
    BRep_Builder().MakeCompound(nothing);
    result.valid = true;
    result.closed = false;
    return nothing;
  }
  // An edge's tolerance must cover its pcurves too: a circle on a sphere that is no parallel (a
  // ball corner's rim) gets an approximated pcurve that strays from the circle by more than the
  // exact circle's tolerance, which BRepCheck accepts and the boolean operations' check does not.
  // The checks only read the faces (on two threads, edge by edge: a few B-spline edges of a scan
  // that does not close take most of the time); the tolerances are raised in face order.
  const int face_count = static_cast<int>(faces_.size());
  struct PcurveGap {
    int face;
    TopoDS_Edge edge;
    double gap = -1.0;   // none measured
    bool stray = false;  // its curves lie kStrayEdge tolerances apart or more
  };
  std::vector<PcurveGap> pcurve_gaps;
  for (int i = 0; i < face_count; ++i)  // (a facet's edges lie in its plane: their pcurves are exact)
    if (!face_facet_[i])
      for (TopExp_Explorer e(faces_[i], TopAbs_EDGE); e.More(); e.Next()) pcurve_gaps.push_back({i, TopoDS::Edge(e.Current())});
  on_two_threads_as_free(static_cast<int>(pcurve_gaps.size()), [&](int k) {
    PcurveGap& g = pcurve_gaps[k];
    try {
      OCC_CATCH_SIGNALS
      g.stray = sampled_pcurve_gap(g.edge, faces_[g.face]) >= kStrayEdge * tol_;
      if (g.stray) return;
      BRepLib_CheckCurveOnSurface check(g.edge, faces_[g.face]);
      check.Perform();
      // (A distance beyond the part's size is the check failing: no tolerance to take from it.)
      if (check.IsDone() && check.MaxDistance() <= diagonal_) g.gap = check.MaxDistance();
    } catch (const Standard_Failure&) {
    }
  });
  // A face whose boundary strays that far from its surface does not follow it: where the surfaces on
  // either side of an edge do not meet near the mesh's border between them (a scan that does not
  // close), the edge fitted to that border lies off them. It is left out, and said so.
  std::vector<char> stray(face_count, 0);
  for (const PcurveGap& g : pcurve_gaps) stray[g.face] |= g.stray;
  for (int i = 0; i < face_count; ++i)
    if (stray[i]) {
      const std::string why = "its face does not follow its boundary (an edge lies more than " +
                              std::to_string(static_cast<int>(kStrayEdge)) + " tolerances off its surface)";
      result.problems.push_back({topo_.region_feature[face_region_[i]], why + ": left out"});
      fail(face_region_[i], why);
    }
  BRep_Builder tolerances;
  for (const PcurveGap& g : pcurve_gaps) {
    if (!(g.gap > BRep_Tool::Tolerance(g.edge))) continue;
    const double tolerance = 1.01 * g.gap;
    tolerances.UpdateEdge(g.edge, tolerance);
    for (TopExp_Explorer v(g.edge, TopAbs_VERTEX); v.More(); v.Next())
      tolerances.UpdateVertex(TopoDS::Vertex(v.Current()), std::max(tolerance, BRep_Tool::Tolerance(TopoDS::Vertex(v.Current()))));
  }
  for (int i = 0; i < face_count; ++i) {
    if (face_facet_[i]) continue;
    try {
      OCC_CATCH_SIGNALS
      cover_tangent_crossings(faces_[i], tol_);
    } catch (const Standard_Failure&) {
    }
  }
  // Healing only where needed: invalid faces, and faces bounded by nothing (a whole sphere or torus
  // gets its natural bounds). Each face is judged as built (on two threads: a few faces of a scan
  // that does not close take most of the time), before healing touches its neighbours' edges.
  std::vector<char> sound(face_count, 0);
  on_two_threads_as_free(face_count, [&](int i) {
    if (face_facet_[i]) {  // valid by construction
      sound[i] = 1;
      return;
    }
    try {
      OCC_CATCH_SIGNALS
      sound[i] = TopExp_Explorer(faces_[i], TopAbs_WIRE).More() && is_valid(faces_[i]);
    } catch (const Standard_Failure&) {
    }
  });
  const ProgressSpan progress = progress_.sub("sewing", 0.83, 0.9);
  if (std::all_of(face_facet_.begin(), face_facet_.end(), [](char facet) { return facet != 0; })) {
    // Facets only: they share their edges already, and sewing thousands of them is slow.
    const std::vector<TopoDS_Shell> shells = connected_shells(faces_);
    result.closed = std::none_of(shells.begin(), shells.end(), [](const TopoDS_Shell& shell) { return has_free_edges(shell); });
    TopoDS_Shape shape;
    if (result.closed) {
      shape = solids_from_shells(shells);
    } else {
      BRep_Builder builder;
      TopoDS_Compound open;
      builder.MakeCompound(open);
      for (const TopoDS_Shell& shell : shells) builder.Add(open, shell);
      shape = open;
    }
    progress.step(1.0);
    result.valid = is_valid(shape, true);
    return shape;
  }
  // The analytic faces are sewn; the facets, which share their edges and vertices exactly, are not
  // (sewing thousands of them takes minutes): they take the edges and vertices that healing and
  // sewing put in place of theirs.
  // (Its analysis drops edges shorter than the tolerance, which a polyline along the mesh has
  // many of, and which the facets keep.)
  const bool with_facet = std::any_of(face_facet_.begin(), face_facet_.end(), [](char facet) { return facet != 0; });
  BRepBuilderAPI_Sewing sewing(tol_, Standard_True, !with_facet);
  const Handle(ShapeBuild_ReShape) healed = new ShapeBuild_ReShape;
  for (int i = 0; i < face_count; ++i) {
    progress.sub(0.0, 0.5).step(static_cast<double>(i) / face_count);
    if (stray[i] || face_facet_[i]) continue;
    if (sound[i]) {
      sewing.Add(faces_[i]);
      continue;
    }
    try {
      OCC_CATCH_SIGNALS
      ShapeFix_Face fix(faces_[i]);
      // Its periodic-degenerate check dereferences a null curve on some faces (OCCT 7.6); our
      // spheres and cones have their poles and apices away from the faces anyway.
      fix.FixPeriodicDegeneratedMode() = 0;
      fix.SetPrecision(Precision::Confusion());
      fix.SetMaxTolerance(tol_);
      fix.Perform();
      // The seam that healing adds to a band on a torus comes out flagged same-parameter when
      // its curves are not (BRepCheck_InvalidSameParameterFlag): set them so.
      ShapeFix_Edge same_parameter;
      for (TopExp_Explorer e(fix.Face(), TopAbs_EDGE); e.More(); e.Next())
        same_parameter.FixSameParameter(TopoDS::Edge(e.Current()));
      // What it replaced, for the facets that share those edges and vertices (its own record:
      // given one, it copies the edges it changes instead of changing them for both faces).
      const Handle(ShapeBuild_ReShape) context = fix.Context();
      for (const TopAbs_ShapeEnum type : {TopAbs_EDGE, TopAbs_VERTEX})
        if (!context.IsNull())
          for (TopExp_Explorer e(faces_[i], type); e.More(); e.Next())
            if (const TopoDS_Shape now = context->Value(e.Current()); !now.IsSame(e.Current())) healed->Replace(e.Current(), now);
      sewing.Add(fix.Face());
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({topo_.region_feature[face_region_[i]], occt_message(failure, "its face could not be healed")});
      fail(face_region_[i], occt_message(failure, "its face could not be healed"));
    }
  }
  progress.step(0.5);
  sewing.Perform();
  progress.step(0.8);
  TopoDS_Shape shape = sewing.SewedShape();
  if (with_facet) shape = with_facets(shape, sewing, *healed);
  if (shape.ShapeType() == TopAbs_FACE) {  // a single face (a whole sphere) is sewn to itself
    BRep_Builder builder;
    TopoDS_Shell shell;
    builder.MakeShell(shell);
    builder.Add(shell, shape);
    shape = shell;
  }

  // Closed shells become solids (one per body).
  std::vector<TopoDS_Shell> shells;
  int shell_faces = 0, faces = 0;
  for (TopExp_Explorer e(shape, TopAbs_SHELL); e.More(); e.Next()) {
    shells.push_back(TopoDS::Shell(e.Current()));
    for (TopExp_Explorer f(e.Current(), TopAbs_FACE); f.More(); f.Next()) ++shell_faces;
  }
  for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next()) ++faces;
  const bool closed = !shells.empty() && shell_faces == faces && !has_free_edges(shape);
  result.closed = closed;
  if (closed) shape = solids_from_shells(shells);
  // (Not with facets: merging thousands of them takes minutes.)
  if (options.unify && closed && !with_facet) {
    // Merging is a refinement: where OCCT's merging fails (it faults on some edges) or leaves an
    // invalid face (a circle cut where a sphere cap's seam met it, whose pcurve then wraps the
    // wrong way) of a valid solid, the faces stay as they are. Only on a closed solid: on an open
    // shell of many faces OCCT 7.6's merging ran for minutes (a fragmented CAD torus blend). The
    // merged shape is checked first: it is usually valid, and then the one check is all.
    try {
      OCC_CATCH_SIGNALS
      ShapeUpgrade_UnifySameDomain unify(shape, Standard_True, Standard_True, Standard_False);
      unify.SetLinearTolerance(tol_ * 1e-3);
      unify.Build();
      // (Merging may also leave faces that BRepCheck passes and no mesh covers: the sides of a
      // noisy rounded plate, merged with its corner cylinders, came out as planes bounded by their
      // whole outline.)
      std::vector<std::string> faults = closed_shell_faults(unify.Shape(), 0.01 * diagonal_, tol_);
      result.valid = is_valid(unify.Shape(), true) && no_faults(faults);
      if (result.valid) closed_faults = std::move(faults);
      if (result.valid || !is_valid(shape, true)) return unify.Shape();
    } catch (const Standard_Failure&) {
    }
  }
  result.valid = is_valid(shape, true);
  return shape;
}

// What the honest-validity check measures once: how far each region's mesh may lie from its
// surface where the surface explains it (the sagitta of its triangles and the extent of the
// mesh's noise), each curve's distance from its chain (a sharp edge laid over a rounded one), and
// the volume the mesh encloses.
void BrepBuilder::measure_fits() {
  const int regions = static_cast<int>(topo_.region_feature.size());
  region_fit_.assign(regions, 0.0);
  std::vector<double> residuals;  // of every vertex of a region with a surface, for the noise
  std::vector<int> counts(regions, 0);
  std::vector<char> seen(clean_.num_vertices(), 0);
  for (int r = 0; r < regions; ++r) {
    if (region_surfaces_[r].IsNull()) continue;
    const LocalSurface surface = local_surface(topo_.region_feature[r]);
    const auto distance = [&](const Vec3& p) { return std::abs(signed_distance(surface(p), p)); };
    for (int f : region_faces_[r]) {
      double corners = 0.0;
      for (int k = 0; k < 3; ++k) {
        const int v = clean_.F(f, k);
        const double d = distance(clean_.V.row(v).transpose());
        corners += d / 3.0;
        if (seen[v] != 1 + (r & 1)) {  // (each vertex once per region, near enough)
          seen[v] = static_cast<char>(1 + (r & 1));
          residuals.push_back(d);
          ++counts[r];
        }
      }
      // The sagitta: how far the triangle's middle lies from the surface beyond its corners (a
      // curved surface's chord; 0 on a plane).
      const Vec3 middle = face_centroid(clean_, f);
      region_fit_[r] = std::max(region_fit_[r], distance(middle) - corners);
    }
  }
  // The noise: the median residual of a Gaussian is 0.6745 sigma (1.4826 = 1 / 0.6745), robust to
  // the blurred edges and to a region its surface does not explain. The largest of n Gaussian
  // residuals is about sigma sqrt(2 ln n).
  double sigma = 0.0;
  if (!residuals.empty()) {
    std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
    sigma = 1.4826 * residuals[residuals.size() / 2];
  }
  region_noise_.assign(regions, 0.0);
  for (int r = 0; r < regions; ++r) {
    if (counts[r] > 1) region_noise_[r] = sigma * std::sqrt(2.0 * std::log(static_cast<double>(counts[r])));
    region_fit_[r] += region_noise_[r];
  }
  chain_gap_.assign(topo_.chains.size(), 0.0);
  on_two_threads_as_free(static_cast<int>(topo_.chains.size()), [&](int c) {
    const ChainCurve& curve = curves_[c];
    if (curve.curve.IsNull()) return;
    const std::vector<int>& chain = topo_.chains[c].vertices;
    // One vertex in 64 or more: the gap varies slowly along a chain (its surfaces' fits do).
    const size_t step = std::max<size_t>(1, chain.size() / 64);
    for (size_t i = 0; i < chain.size(); i += step) {
      GeomAPI_ProjectPointOnCurve projection(to_pnt(clean_.V.row(chain[i]).transpose()), curve.curve);
      if (projection.NbPoints() > 0) chain_gap_[c] = std::max(chain_gap_[c], projection.LowerDistance());
    }
  });
  const bool open_mesh = std::any_of(topo_.chains.begin(), topo_.chains.end(),
                                     [](const BoundaryChain& chain) { return chain.right < 0; });
  mesh_volume_ = open_mesh ? 0.0 : std::abs(enclosed_volume(clean_));
}

// Per region, the distance its face and its mesh may lie apart: the larger of its fit and of the
// gaps between its border and the edges and corners that replace it, plus the tolerance and the
// sampling's deflection. A region its surface does not explain (a strip of another feature's
// triangles in it) lies farther: its face fails. (A faceted region's fit is 0: its facets are its
// triangles.)
std::vector<double> BrepBuilder::deviation_allowances(double deflection) const {
  const int regions = static_cast<int>(topo_.region_feature.size());
  std::vector<double> allow(regions, 0.0);
  for (int r = 0; r < regions; ++r) allow[r] = faceted_[r] ? 0.0 : region_fit_[r];
  const auto raw = [&](int v) { return Vec3(clean_.V.row(v).transpose()); };
  std::vector<double> gaps(topo_.chains.size(), 0.0);
  std::map<int, double> corner_reach;  // corner -> the widest gap of the chains that end there
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    gaps[c] = polyline_[c] ? 0.0 : chain_gap_[c];
    if (polyline_[c] && facets_)
      for (int v : chain.vertices) gaps[c] = std::max(gaps[c], (facets_->position(v) - raw(v)).norm());
    if (!chain.closed)
      for (int v : {chain.vertices.front(), chain.vertices.back()}) corner_reach[v] = std::max(corner_reach[v], gaps[c]);
  }
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    double gap = gaps[c];
    // A corner lies off the mesh's as far as its edges let it: a ball-rounded corner of three square
    // faces lies 1.77 times as far from the sharp corner as its rounded edges from theirs
    // ((sqrt 3 - 1) / (sqrt 2 - 1)), so twice their widest gap. A corner farther off (surfaces
    // meeting nearly parallel put it anywhere along their near-intersection) is not the mesh's.
    if (!chain.closed)
      for (int v : {chain.vertices.front(), chain.vertices.back()})
        if (const auto corner = corner_points_.find(v); corner != corner_points_.end())
          gap = std::max(gap, std::min((corner->second - raw(v)).norm(), 2.0 * corner_reach[v]));
    for (int r : {chain.left, chain.right})
      if (r >= 0) allow[r] = std::max(allow[r], gap);
  }
  for (double& a : allow) a += tol_ + deflection;
  return allow;
}

// Whether a closed solid lies where its mesh does (deviation.h). A face farther from the mesh, or
// a region whose vertices lie farther from the solid, than its allowance fails its region; a volume
// that differs from the mesh's by more than the allowances over the regions' areas can account for
// fails the solid.
bool BrepBuilder::follows_mesh(const TopoDS_Shape& shape, BrepResult& result, const ProgressSpan& progress) {
  const double deflection = tol_;  // samples within the tolerance of the faces
  const std::vector<double> allow = deviation_allowances(deflection);
  const double widest = allow.empty() ? tol_ : *std::max_element(allow.begin(), allow.end());
  std::vector<TopoDS_Face> faces;
  std::vector<int> face_regions;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    if (facet_region_.count(BRep_Tool::Surface(face).get())) continue;
    faces.push_back(face);
    face_regions.push_back(region_of(face));
  }
  // (A faceted region's triangles stand for its facets, whose border vertices may have moved by up
  // to their gap onto the surfaces beside them: within the allowances.)
  std::vector<int> facet_triangles, query, query_index(clean_.num_vertices(), -1);
  for (int f = 0; f < clean_.num_faces(); ++f) {
    if (faceted_[topo_.face_region[f]]) {
      facet_triangles.push_back(f);
      continue;
    }
    for (int k = 0; k < 3; ++k)
      if (query_index[clean_.F(f, k)] < 0) {
        query_index[clean_.F(f, k)] = static_cast<int>(query.size());
        query.push_back(clean_.F(f, k));
      }
  }
  const ShapeMeshDistance distance = shape_mesh_distance(faces, clean_, facet_triangles, query, deflection, progress);
  bool follows = true;
  const auto fault = [&](int region, const char* what, double d, double allowed) {
    std::ostringstream message;
    message << what << d << ", beyond the " << allowed << " that its fit and its border allow";
    follows = false;
    fail(region, message.str());
    result.problems.push_back({region >= 0 ? topo_.region_feature[region] : -1, message.str()});
  };
  result.deviation_bound = widest;
  for (size_t i = 0; i < faces.size(); ++i) {
    const int r = face_regions[i];
    const double allowed = r >= 0 ? allow[r] : widest;
    result.shape_to_mesh = std::max(result.shape_to_mesh, distance.face_to_mesh[i]);
    if (distance.face_to_mesh[i] > allowed) fault(r, "its face lies off the mesh by ", distance.face_to_mesh[i], allowed);
  }
  std::vector<double> region_off(allow.size(), 0.0);
  std::vector<std::vector<double>> offs(allow.size());
  for (int f = 0; f < clean_.num_faces(); ++f) {
    const int r = topo_.face_region[f];
    if (faceted_[r]) continue;
    for (int k = 0; k < 3; ++k) {
      const double d = distance.vertex_to_shape[query_index[clean_.F(f, k)]];
      region_off[r] = std::max(region_off[r], d);
      offs[r].push_back(d);
    }
  }
  for (size_t r = 0; r < allow.size(); ++r) {
    result.mesh_to_shape = std::max(result.mesh_to_shape, region_off[r]);
    if (failed_.count(static_cast<int>(r)) || offs[r].empty()) continue;
    // Most of a region lies within the noise of its face: a face moved off its mesh as a whole
    // (its edges then follow it, and their gaps would excuse it) fails here.
    std::nth_element(offs[r].begin(), offs[r].begin() + offs[r].size() / 2, offs[r].end());
    const double median = offs[r][offs[r].size() / 2], noise = region_noise_[r] + tol_ + deflection;
    if (region_off[r] > allow[r])
      fault(static_cast<int>(r), "its mesh lies off the solid by ", region_off[r], allow[r]);
    else if (median > noise)
      fault(static_cast<int>(r), "half its mesh lies off the solid by more than ", median, noise);
  }
  if (follows && mesh_volume_ > 0) {
    // Two surfaces within distance d of each other over an area A enclose volumes at most A d apart.
    const Eigen::VectorXd areas = face_areas(clean_);
    double slack = 0.0;
    for (int f = 0; f < clean_.num_faces(); ++f) slack += areas[f] * allow[topo_.face_region[f]];
    result.mesh_volume = mesh_volume_;
    if (std::abs(result.volume - mesh_volume_) > slack) {
      std::ostringstream message;
      message << "the solid's volume " << result.volume << " differs from the mesh's " << mesh_volume_
              << " by more than its faces' allowances account for (" << slack << ")";
      result.problems.push_back({-1, message.str()});
      follows = false;
    }
  }
  return follows;
}

BrepResult BrepBuilder::run(const std::vector<int>& labels, const BrepOptions& options) {
  BrepResult result;
  progress_.step(0.0);  // a cancelled Progress stops here, before any work
  auto since = Clock::now();
  // Faces whose corners coincide carry no area and no topology.
  TriangleMesh& clean = clean_;
  std::vector<int> clean_labels;
  clean.V = mesh_.V;
  std::vector<int> kept;
  for (int f = 0; f < mesh_.num_faces(); ++f) {
    const int a = mesh_.F(f, 0), b = mesh_.F(f, 1), c = mesh_.F(f, 2);
    if (a != b && b != c && a != c) kept.push_back(f);
  }
  clean.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t i = 0; i < kept.size(); ++i) {
    clean.F.row(static_cast<Eigen::Index>(i)) = mesh_.F.row(kept[i]);
    clean_labels.push_back(labels[kept[i]]);
  }
  progress_.step(0.05);
  const MeshTopology topology(clean);
  progress_.step(0.15);
  const std::vector<int> merged = dissolve_sampling_blends(clean, topology, merge_same_surfaces(clean_labels));
  progress_.step(0.25);
  // A part of the mesh that no feature reaches is one more, freeform, feature: a B-spline fitted to
  // it, or its facets.
  const int unexplained = static_cast<int>(surfaces_.size());
  const std::vector<int> face_feature = complete_face_features(clean, topology, merged, surfaces_, 0.1, unexplained);
  if (std::count(face_feature.begin(), face_feature.end(), unexplained)) {
    Surface freeform;
    freeform.type = SurfaceType::Freeform;
    surfaces_.push_back(freeform);
  }
  progress_.step(0.35);
  topo_ = trace_boundaries(clean, topology, face_feature);
  region_faces_.assign(topo_.region_feature.size(), {});
  for (int f = 0; f < clean.num_faces(); ++f) region_faces_[topo_.face_region[f]].push_back(f);
  stage(result, "brep.topology", since);
  progress_.step(0.45);

  progress_.sub("vertices", 0.0, 1.0).step(0.5);
  fit_freeform_surfaces(clean, face_feature, result);
  make_vertices(topology);
  // One surface per region, oriented against the mesh normals.
  const int regions = static_cast<int>(topo_.region_feature.size());
  std::vector<std::vector<Vec3>> region_points(regions);
  region_sense_.assign(regions, 0.0);
  region_centroid_.assign(regions, Vec3::Zero());
  for (int f = 0; f < clean.num_faces(); ++f) {
    const int r = topo_.face_region[f];
    const Vec3 a = clean.V.row(clean.F(f, 0)), b = clean.V.row(clean.F(f, 1)), c = clean.V.row(clean.F(f, 2));
    const Vec3 centre = (a + b + c) / 3.0;
    const Vec3 area_normal = 0.5 * (b - a).cross(c - a);
    region_points[r].push_back(centre);
    const Surface& s = surfaces_[topo_.region_feature[r]];
    // OCCT's normal of a spindle torus turns inward on the lemon, beyond the axis, where the
    // parametrization's u direction reverses. (A lemon whose centre circle lies within the
    // tolerance of the axis is a sphere as much as the torus's other part, which OCCT then takes.)
    const double occt_sense = s.type == SurfaceType::Torus && s.radius < -tol_ ? -1.0 : 1.0;
    if (s.type != SurfaceType::Freeform) {
      region_sense_[r] += occt_sense * surface_normal(s, centre).dot(area_normal);
    } else if (const auto spline = freeform_.find(topo_.region_feature[r]); spline != freeform_.end()) {
      region_sense_[r] += spline->second.tangent_plane(centre).axis.dot(area_normal);
    }
  }
  region_surfaces_.resize(regions);
  region_winds_.assign(regions, 0);
  std::vector<std::optional<RoundFace>> rounds(regions);
  for (int r = 0; r < regions; ++r) {
    for (const Vec3& p : region_points[r]) region_centroid_[r] += p / static_cast<double>(region_points[r].size());
    rounds[r] = round_face(r);
    region_winds_[r] = rounds[r] && rounds[r]->winds;
    if (region_winds_[r]) seam_splits_[rounds[r]->split] = r;
  }
  for (int r = 0; r < regions; ++r) {
    // A band beside a face that winds round the same axis takes its seam: healing then joins the
    // two seams at the vertex of the circle between them.
    std::optional<RoundFace>& round = rounds[r];
    for (const auto& loop : topo_.region_loops[r]) {
      const BoundaryChain& chain = topo_.chains[loop.front().chain];
      const int across = chain.left == r ? chain.right : chain.left;
      if (round && !round->winds && loop.size() == 1 && chain.closed && across >= 0 && region_winds_[across] &&
          rounds[across]->axis.cross(round->axis).norm() <= angle_eps_)
        round->seam = rounds[across]->seam;
    }
    const auto spline = freeform_.find(topo_.region_feature[r]);
    region_surfaces_[r] = spline != freeform_.end() ? Handle(Geom_Surface)(spline->second.surface)
                                                    : make_surface(surfaces_[topo_.region_feature[r]], region_points[r], round);
  }
  compute_curves();
  measure_fits();
  stage(result, "brep.edges", since);
  // Graceful degradation, region by region. A region whose face fails (not made, not valid, or
  // where the shell does not close) is first bounded by the mesh's border between it and its
  // neighbours, moved onto their surfaces (its own surface stays); where it fails again, it is made
  // of its triangles. Each round degrades at least one more region; the last facets them all, which
  // closes whenever the mesh does.
  constexpr int kRounds = 5;  // attempts before every region is faceted (a time budget)
  faceted_.assign(regions, 0);
  bounded_.assign(regions, 0);
  facet_reason_.assign(regions, "");
  for (int r = 0; r < regions; ++r)
    if (region_surfaces_[r].IsNull()) {
      faceted_[r] = 1;
      facet_reason_[r] = "no surface explains it (a freeform region without a fitted B-spline)";
    }
  const BrepResult prepared = result;
  for (int round = 0;; ++round) {
    const bool all = std::all_of(faceted_.begin(), faceted_.end(), [](char f) { return f != 0; });
    result = prepared;
    failed_.clear();
    polyline_.assign(topo_.chains.size(), 0);
    for (size_t c = 0; c < topo_.chains.size(); ++c) {
      const BoundaryChain& chain = topo_.chains[c];
      polyline_[c] = faceted_[chain.left] || bounded_[chain.left] ||
                     (chain.right >= 0 && (faceted_[chain.right] || bounded_[chain.right])) ||
                     (!collapsed_[c] && curves_[c].curve.IsNull());
    }
    bool done = false;
    try {
      OCC_CATCH_SIGNALS
      place_polylines();
      done = build_round(result, options);
    } catch (const Standard_Failure& failure) {
      // A round that OpenCASCADE gives up on: every region left is faceted in the next.
      if (all) throw;
      for (int r = 0; r < regions; ++r)
        if (!faceted_[r]) {
          faceted_[r] = 1;
          facet_reason_[r] = occt_message(failure, "the construction failed");
        }
      continue;
    }
    if (done || all) break;
    // An open mesh does not close however its faces are made: only faces that fail degrade.
    const bool open_mesh = std::any_of(topo_.chains.begin(), topo_.chains.end(),
                                       [](const BoundaryChain& chain) { return chain.right < 0; });
    if (open_mesh && failed_.empty()) break;
    bool more = false;
    for (const auto& [r, why] : failed_) {
      if (faceted_[r]) continue;
      more = true;
      if (!bounded_[r] && !region_surfaces_[r].IsNull()) {
        bounded_[r] = 1;
        facet_reason_[r] = why;
        continue;
      }
      faceted_[r] = 1;
      facet_reason_[r] = facet_reason_[r].empty() ? why : facet_reason_[r] + "; bounded by the mesh's border: " + why;
    }
    if (!more || round + 1 >= kRounds)
      for (int r = 0; r < regions; ++r)
        if (!faceted_[r]) {
          faceted_[r] = 1;
          facet_reason_[r] = facet_reason_[r].empty() ? "the shell did not close with its analytic face"
                                                      : facet_reason_[r] + "; then the shell did not close";
        }
  }
  stage(result, "brep.faces", since);
  // What became of each region.
  const Eigen::VectorXd areas = face_areas(clean_);
  double total = 0.0, analytic = 0.0;
  for (int r = 0; r < regions; ++r) {
    BrepRegionFace face;
    face.feature = topo_.region_feature[r];
    for (int f : region_faces_[r]) face.area += areas[f];
    face.kind = faceted_[r] ? "faceted" : freeform_.count(face.feature) ? "bspline" : "analytic";
    face.reason = faceted_[r] ? facet_reason_[r] : "";
    total += face.area;
    if (face.kind == "analytic") analytic += face.area;
    result.regions.push_back(face);
  }
  result.analytic_area_fraction = total > 0 ? analytic / total : 0.0;
  // The feature added for what no feature explained is none of the layer's.
  const auto layer_feature = [&](int& feature) {
    if (feature >= features_) feature = -1;
  };
  for (BrepProblem& problem : result.problems) layer_feature(problem.feature);
  for (int& feature : result.face_features) layer_feature(feature);
  for (BrepRegionFace& face : result.regions) layer_feature(face.feature);
  for (BrepEdge& edge : result.edges) {
    layer_feature(edge.a);
    layer_feature(edge.b);
  }
  return result;
}

// One attempt with the regions faceted so far: edges, faces, the shell and its checks. Returns
// whether it gave a valid closed solid; the regions that failed are in failed_.
bool BrepBuilder::build_round(BrepResult& result, const BrepOptions& options) {
  auto since = Clock::now();
  make_edges(result);
  make_faces(result);
  stage(result, "brep.round.faces", since);
  std::vector<std::string> closed_faults;
  TopoDS_Shape shape = assemble(result, options, closed_faults);
  stage(result, "brep.sew", since);
  const ProgressSpan checking = progress_.sub("checking", 0.9, 1.0);
  checking.step(0.0);

  // Validated by assemble, a closed solid's faces by closed_shell_faults; an invalid result keeps
  // only its valid faces, as a shell (never an invalid solid).
  result.solid = result.valid && result.closed && is_solid_shape(shape);
  if (result.solid && closed_faults.empty()) {
    try {
      OCC_CATCH_SIGNALS
      closed_faults = closed_shell_faults(shape, 0.01 * diagonal_, tol_, [&](const TopoDS_Face& face) {
        return facet_region_.count(BRep_Tool::Surface(face).get()) != 0;
      });
    } catch (const Standard_Failure& failure) {
      result.problems.push_back({-1, occt_message(failure, "the solid's faces could not be meshed")});
      result.solid = false;  // (no face to blame: the boolean operations' checks decide what stays)
    }
  }
  result.solid = result.solid && no_faults(closed_faults);
  if (result.solid) {
    GProp_GProps properties;
    BRepGProp::VolumeProperties(shape, properties);
    result.volume = std::abs(properties.Mass());
    // Valid and closed is not enough: the solid must also lie where the mesh does.
    result.solid = follows_mesh(shape, result, checking.sub(0.0, 0.5));
    if (!result.solid) result.volume = 0.0;
  }
  if (!result.solid) {
    // Only the faces that pass the boolean operations' checks are kept (shell_face_fault, which
    // only reads them: on two threads).
    std::vector<TopoDS_Face> sewn_faces;
    for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) sewn_faces.push_back(TopoDS::Face(e.Current()));
    std::vector<std::string> faults(sewn_faces.size());
    on_two_threads_as_free(static_cast<int>(sewn_faces.size()), [&](int i) {
      if (static_cast<size_t>(i) < closed_faults.size() && !closed_faults[i].empty()) {
        faults[i] = closed_faults[i];
        return;
      }
      if (facet_region_.count(BRep_Tool::Surface(sewn_faces[i]).get())) return;  // valid by construction
      try {
        OCC_CATCH_SIGNALS
        faults[i] = shell_face_fault(sewn_faces[i], diagonal_);
      } catch (const Standard_Failure& failure) {
        faults[i] = occt_message(failure, "its check failed");
      }
    });
    BRep_Builder builder;
    TopoDS_Compound kept_faces;
    builder.MakeCompound(kept_faces);
    bool dropped = false;
    for (size_t i = 0; i < sewn_faces.size(); ++i) {
      const std::string& reason = faults[i];
      if (reason.empty()) {
        builder.Add(kept_faces, sewn_faces[i]);
      } else {
        dropped = true;
        const std::string message = "its face is not valid (" + reason + ")";
        const int region = region_of(sewn_faces[i]);
        // Never dropped silently, also where no feature is known.
        fail(region, message);
        if (region >= 0)
          result.problems.push_back({topo_.region_feature[region], message});
        else
          result.problems.push_back({-1, std::string("a ") + occt_surface_name(sewn_faces[i]) + " face: " + message.substr(4)});
      }
    }
    if (dropped || !result.valid) {  // the sewn shell when it is valid and every face is kept
      shape = kept_faces;
      result.valid = is_valid(shape, true);  // what is returned: the valid faces
      result.closed = result.closed && !dropped;
    }
  }
  if (!result.closed) {
    result.problems.push_back({-1, "the faces do not close into a solid (free edges remain)"});
  }
  const bool open_mesh = std::any_of(topo_.chains.begin(), topo_.chains.end(),
                                     [](const BoundaryChain& chain) { return chain.right < 0; });
  if (!result.closed && failed_.empty() && !open_mesh) {
    // No face failed on its own: the faces along the free edges.
    TopTools_IndexedDataMapOfShapeListOfShape faces_of_edge;
    TopExp::MapShapesAndUniqueAncestors(shape, TopAbs_EDGE, TopAbs_FACE, faces_of_edge);
    for (int i = 1; i <= faces_of_edge.Extent(); ++i) {
      const TopTools_ListOfShape& faces = faces_of_edge(i);
      if (BRep_Tool::Degenerated(TopoDS::Edge(faces_of_edge.FindKey(i))) || faces.Extent() != 1) continue;
      const TopoDS_Face& face = TopoDS::Face(faces.First());
      if (BRep_Tool::IsClosed(TopoDS::Edge(faces_of_edge.FindKey(i)), face)) continue;
      fail(region_of(face), "the shell does not close along its boundary");
    }
  }
  result.shape = shape;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    ++result.faces;
    const int region = region_of(face);
    ++result.surface_types[region >= 0 && faceted_[region] ? "facet" : occt_surface_name(face)];
    result.face_features.push_back(region < 0 ? -1 : topo_.region_feature[region]);
  }
  for (TopExp_Explorer e(shape, TopAbs_VERTEX); e.More(); e.Next())
    result.max_tolerance = std::max(result.max_tolerance, BRep_Tool::Tolerance(TopoDS::Vertex(e.Current())));
  for (TopExp_Explorer e(shape, TopAbs_EDGE); e.More(); e.Next())
    result.max_tolerance = std::max(result.max_tolerance, BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
  checking.step(0.6);
  stage(result, "brep.check", since);
  checking.step(1.0);
  return result.solid;
}

}  // namespace

BrepResult build_brep(const TriangleMesh& mesh, const std::vector<int>& labels,
                      const std::vector<Surface>& surfaces, const BrepOptions& options) {
  if (static_cast<int>(labels.size()) != mesh.num_faces()) {
    throw std::invalid_argument("build_brep: one label per triangle expected");
  }
  for (int l : labels) {
    if (l >= static_cast<int>(surfaces.size())) throw std::invalid_argument("build_brep: label without a surface");
  }
  // OpenCASCADE's healing and checking dereference null pointers on some inputs; with its signal
  // handlers installed for the duration of the call such a fault becomes an exception (thrown at
  // the nearest OCC_CATCH_SIGNALS) instead of taking the user's FreeCAD down.
  const OcctSignalHandlers handlers;
  try {
    OCC_CATCH_SIGNALS
    return BrepBuilder(mesh, surfaces, options).run(labels, options);
  } catch (const Standard_Failure& failure) {
    throw std::runtime_error(occt_message(failure, "B-rep construction failed"));
  }
}

}  // namespace idealize
