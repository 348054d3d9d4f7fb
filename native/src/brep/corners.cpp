// Corner vertices of the B-rep (corners.h).
#include "brep/corners.h"

#include <algorithm>
#include <cmath>

namespace idealize {

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
                                                     const std::array<Vec3, 2>& fitted, double tol,
                                                     double nearly_parallel) {
  const Vec3 cross = a.axis.cross(b.axis);
  if (cross.norm() < nearly_parallel) return std::nullopt;
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

}  // namespace idealize
