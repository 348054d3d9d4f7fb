// Edge curves of the B-rep: the intersection of two fitted surfaces in closed form (lines, circles
// and ellipses of the pairs an idealized prismatic part has), and curves fitted to a boundary chain
// of the mesh where no closed form follows it.
//
// Points are Eigen 3-vectors; a "chain" is the ordered mesh vertices of the border between two
// regions; `tol` is the distance below which geometry is equal (the layer's distance tolerance).
#pragma once

#include "fit/surface.h"
#include "brep/occt_util.h"

#include <Geom_Curve.hxx>

#include <functional>
#include <optional>
#include <vector>

namespace idealize {

// sin(5 degrees): directions this close count as parallel when an exact closed form is not found
// (the feature graph's default parallel tolerance; BrepOptions::angle_tolerance_degrees sets it).
inline constexpr double kNearlyParallel = 0.0872;
inline constexpr int kToleranceSamples = 64;  // points of a fitted edge measured against its two surfaces

// A line or circle in a plane: meridian (rho, h) of a surface of revolution, or cross-section of a
// surface along parallel axes.
struct Primitive2 {
  bool circle = false;
  Vec2 p = Vec2::Zero();  // point on the line, or centre
  Vec2 d = Vec2::UnitX(); // unit direction of a line
  double r = 0.0;
};

inline Primitive2 line2(const Vec2& p, const Vec2& d) { return {false, p, d.normalized(), 0.0}; }
inline Primitive2 circle2(const Vec2& c, double r) { return {true, c, Vec2::UnitX(), r}; }

// Intersection points of two primitives; primitives that touch within `tol` (missing each other
// or crossing with a sagitta below it) meet in one point of contact. With `crossings_too`,
// crossings within the touching zone come too (then the contact last).
std::vector<Vec2> intersect(const Primitive2& a, const Primitive2& b, double tol, bool crossings_too);

// The meridian of `s` about the axis through `o` along unit `a` when `s` is a surface of
// revolution about it (axes within `angle_eps`, centres within `tol`).
std::optional<Primitive2> meridian(const Surface& s, const Vec3& o, const Vec3& a, double angle_eps, double tol);

// The common axis (`o`, `axis`) of two surfaces that may be coaxial surfaces of revolution.
bool common_axis(const Surface& a, const Surface& b, Vec3& o, Vec3& axis);

// The point of both planes `a` and `b` nearest to `near` (their normals not parallel).
Vec3 point_on_both_planes(const Surface& a, const Surface& b, const Vec3& near);

// The intersection curve of `a` and `b` in closed form through the chain's `points`, or null.
// `ends`: the corner points of an open chain (none for a closed one), which choose the branch.
// Directions within `angle_eps` (a sine) are parallel; a plane cuts a cylinder in an ellipse only
// where it is oblique by more than `nearly_parallel` (a sine: nearer, the pass with that
// `angle_eps` makes a line or a circle).
Handle(Geom_Curve) closed_form_curve(const Surface& a, const Surface& b, const std::vector<Vec3>& points,
                                     const std::vector<Vec3>& ends, double angle_eps, double tol,
                                     double nearly_parallel = kNearlyParallel);

// The parameter of the point of `curve` closest to `p`; the nearer end of a bounded curve when `p`
// projects beyond it.
double curve_parameter(const Handle(Geom_Curve)& curve, const Vec3& p);

// The largest distance of (up to 17 of) `points` from `curve`; infinity where one does not project.
double max_distance_to_curve(const Handle(Geom_Curve)& curve, const std::vector<Vec3>& points);

// A B-spline through (up to 65 of) `points`, within `tol` of them; null when it cannot be made.
Handle(Geom_Curve) fitted_curve(const std::vector<Vec3>& points, double tol);

// The largest `off(p)` (a point's distance from the farther of an edge's two surfaces) along
// `curve` from `u0` to `u1`, at kToleranceSamples + 1 points.
double farthest_off(const Handle(Geom_Curve)& curve, double u0, double u1, const std::function<double(const Vec3&)>& off);

// The curve fitted to a chain's `points`, from the corners `start` and `end` where they are given
// (null: the chain's end), where the curve through them stays within `tol` of both surfaces (`off`).
Handle(Geom_Curve) fitted_between(const std::vector<Vec3>& points, const Vec3* start, const Vec3* end, double tol,
                                  const std::function<double(const Vec3&)>& off);

// A feature's surface near a point: the analytic surface itself, or for a freeform feature the
// tangent plane of its B-spline at the point's nearest point (so that closest_point, signed_distance
// and surface_normal near that point are those of the B-spline).
using LocalSurface = std::function<Surface(const Vec3&)>;

// The points of a chain moved onto the intersection of the two surfaces (alternating projections);
// onto `a` alone when `b` is null.
std::vector<Vec3> project_on_both(const std::vector<Vec3>& chain, const LocalSurface& a, const LocalSurface* b);

// Whether two surfaces meet tangentially along `curve`: the median angle between their normals at
// the points' nearest curve points is below `max_angle` (radians; the feature graph's G1 criterion,
// its angle tolerance).
bool tangent_along(const Handle(Geom_Curve)& curve, const Surface& a, const Surface& b, const std::vector<Vec3>& points,
                   double max_angle);

}  // namespace idealize
