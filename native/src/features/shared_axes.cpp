#include "features/shared_axes.h"

#include "core/parallel.h"
#include "fit/fits_as_well.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

namespace idealize {

namespace {

struct Axis {
  Eigen::Vector3d origin, direction;
  int source;
};

// Normals of a quarter circle average to a vector of length sin(π/4) / (π/4) = 0.9.
constexpr double kRightAngleMeanNormal = 0.9;

bool determined_axis(const Feature& feature, const FitData& data, const SharedAxisOptions& options) {
  const SurfaceType t = feature.type;
  if (t != SurfaceType::Cylinder && t != SurfaceType::Cone && t != SurfaceType::Torus) return false;
  if (data.points.rows() < options.determined_points || !(data.sample_weights.sum() > 0.0)) return false;
  const Eigen::Vector3d mean = data.sample_normals.transpose() * data.sample_weights / data.sample_weights.sum();
  return mean.norm() <= kRightAngleMeanNormal;
}

bool same_axis(const Surface& s, const Axis& axis, const SharedAxisOptions& options) {
  if (std::abs(s.axis.dot(axis.direction)) < std::cos(options.angle_tolerance)) return false;
  return axial_coordinates(axis.origin, axis.direction, s.point).distance <= options.distance_tolerance;
}

// Free parameters of a surface of the type about a given axis (its 4 fixed).
int parameters_about_axis(SurfaceType type) { return parameter_count(type) - 4; }

// Whether `a` (k_a parameters) explains n points better than `b` (k_b > k_a, or fewer) by the BIC,
// n log(rms²) + k log n.
bool bic_prefers(double rms_a, int k_a, double rms_b, int k_b, double n) {
  if (!(rms_a > 0.0) || !(rms_b > 0.0)) return rms_a <= rms_b;
  return n * std::log(rms_a * rms_a) + k_a * std::log(n) < n * std::log(rms_b * rms_b) + k_b * std::log(n);
}

// Whether the points go about the axis by a right angle or more (the mean of their directions from
// it is as short as a quarter circle's): a torus about an axis that a patch does not go round
// passes for any tube along it.
bool goes_round(const FitData& data, const Axis& axis) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < data.points.rows(); ++i)
    mean += data.weights[i] * axial_coordinates(axis.origin, axis.direction, data.points.row(i).transpose()).radial;
  return mean.norm() <= kRightAngleMeanNormal * data.weights.sum();
}

// The simpler of a cylinder and a cone about the axis that fits (by RMS, as identification
// chooses); invalid if neither does or the cone is really a cylinder or a plane. With `torus`, the
// torus about the axis where the BIC prefers it to that and the points go round the axis: a noisy
// dome revolved from a wide arc (a screw head) sags from its cone by less than the distance
// tolerance. (It is a sphere where its tube's centre lies on the axis.)
SurfaceFit fit_about(const FitData& data, const Axis& axis, const SharedAxisOptions& options, bool torus) {
  const SurfaceFit cylinder = fit_about_axis(SurfaceType::Cylinder, data, axis.origin, axis.direction);
  SurfaceFit cone = fit_about_axis(SurfaceType::Cone, data, axis.origin, axis.direction);
  const double half_angle = cone.surface.half_angle;
  if (half_angle < options.angle_tolerance || half_angle > 0.5 * M_PI - options.angle_tolerance) cone.valid = false;
  SurfaceFit simple = cone.valid ? cone : cylinder;
  if (cone.valid && cylinder.valid &&
      fits_as_well(cylinder.rms, std::min(cylinder.rms, cone.rms), options.residual_ratio, options.distance_tolerance))
    simple = cylinder;
  if (!torus || !goes_round(data, axis)) return simple;
  const SurfaceFit ring = fit_about_axis(SurfaceType::Torus, data, axis.origin, axis.direction);
  if (!ring.valid || std::abs(ring.surface.radius) <= options.distance_tolerance) return simple;
  const double n = static_cast<double>(data.points.rows());
  if (simple.valid && !bic_prefers(ring.rms, parameters_about_axis(SurfaceType::Torus), simple.rms,
                                   parameters_about_axis(simple.surface.type), n))
    return simple;
  return ring;
}

// The largest angle (radians) between the surface's normals at the samples of `data`.
double turn_across(const Surface& surface, const FitData& data) {
  std::vector<Eigen::Vector3d> normals;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < data.sample_points.rows(); ++i) {
    normals.push_back(surface_normal(surface, data.sample_points.row(i).transpose()));
    mean += normals.back();
  }
  if (!(mean.norm() > 0.0)) return M_PI;
  mean.normalize();
  double widest = 0.0;
  for (const Eigen::Vector3d& n : normals) widest = std::max(widest, std::acos(std::clamp(n.dot(mean), -1.0, 1.0)));
  return 2.0 * widest;
}

// The plane's normal pointing the way its patch's face normals do (out of the part).
Eigen::Vector3d outward_normal(const Surface& plane, const FitData& data) {
  const Eigen::Vector3d mean = data.sample_normals.transpose() * data.sample_weights;
  return mean.dot(plane.axis) >= 0.0 ? plane.axis : Eigen::Vector3d(-plane.axis);
}

// Where f is least on [low, high]: on a grid of 60 steps, then by golden section between the grid
// points beside its least value.
double least_on_interval(const std::function<double(double)>& f, double low, double high) {
  constexpr int kGrid = 60;
  int arg = 0;
  double least = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kGrid; ++i) {
    const double value = f(low + (high - low) * i / kGrid);
    if (value < least) least = value, arg = i;
  }
  double a = low + (high - low) * std::max(arg - 1, 0) / kGrid;
  double b = low + (high - low) * std::min(arg + 1, kGrid) / kGrid;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int i = 0; i < 40; ++i) {
    const double x1 = b - golden * (b - a), x2 = a + golden * (b - a);
    if (f(x1) < f(x2)) b = x2;
    else a = x1;
  }
  return 0.5 * (a + b);
}

// The cylinder tangent to the planes (outward normals n1, n2 through p1, p2) that fits `data` best:
// its axis runs parallel to their intersection line at distance r from both, inside the part (a
// rounded edge) or outside (a filleted inner corner). The weighted mean square distance is searched
// over log r, on a grid first and then by golden section; with `radius` > 0 only the side is chosen.
// Invalid for parallel planes.
SurfaceFit tangent_cylinder(const FitData& data, const Eigen::Vector3d& n1, const Eigen::Vector3d& p1,
                            const Eigen::Vector3d& n2, const Eigen::Vector3d& p2, double radius = 0.0) {
  SurfaceFit best;
  const Eigen::Vector3d direction = n1.cross(n2);
  if (direction.norm() < 1e-6) return best;
  Eigen::Matrix3d planes;
  planes << n1.transpose(), n2.transpose(), direction.normalized().transpose();
  const Eigen::Vector3d on_line = planes.colPivHouseholderQr().solve(Eigen::Vector3d(n1.dot(p1), n2.dot(p2), 0.0));
  const Eigen::Vector3d towards_axis = (n1 + n2) / (1.0 + n1.dot(n2));  // one unit from each plane
  const double extent = (data.points.colwise().maxCoeff() - data.points.colwise().minCoeff()).norm();
  if (!(extent > 0.0) || !(data.weights.sum() > 0.0)) return best;
  // The search runs on an even subsample of a large patch (as the fits' refinement does).
  const Eigen::Index step = std::max<Eigen::Index>(1, data.points.rows() / FitOptions().max_points);
  const Eigen::Index count = (data.points.rows() + step - 1) / step;
  const MatrixX3d sample = data.points(Eigen::seqN(0, count, step), Eigen::all);
  const Eigen::VectorXd sample_weights = data.weights(Eigen::seqN(0, count, step));
  for (double side : {-1.0, 1.0}) {
    Surface cylinder;
    cylinder.type = SurfaceType::Cylinder;
    cylinder.axis = direction.normalized();
    auto mean_square = [&](double log_r) {
      cylinder.radius = std::exp(log_r);
      cylinder.point = on_line + side * cylinder.radius * towards_axis;
      double rms, max_error;
      fit_residuals(cylinder, sample, sample_weights, rms, max_error);
      return rms * rms;
    };
    // From a thousandth of the strip's size to a hundred times it (a shallow blend of a wide radius).
    mean_square(radius > 0.0 ? std::log(radius) : least_on_interval(mean_square, std::log(1e-3 * extent), std::log(1e2 * extent)));
    const SurfaceFit fit = fit_of(cylinder, data);
    if (!best.valid || fit.rms < best.rms) best = fit;
  }
  return best;
}

// The torus tangent to the plane (across the wall's axis) and to the wall, a cylinder or a cone, about
// the wall's axis, that fits `data` best, on the sides of both where the points lie: the tube radius
// is searched over its logarithm, on a grid and then by golden section. Invalid where the points lie
// in the plane, or (unless `spindle`) where the best is a spindle torus, its tube crossing the axis
// (where fillets meet in a corner ball the tube's circle shrinks onto the axis).
SurfaceFit tangent_torus(const FitData& data, const Surface& wall, const Surface& plane, bool spindle) {
  const Eigen::Vector3d& o = wall.point;
  const Eigen::Vector3d& a = wall.axis;
  const double foot = (plane.point - o).dot(a);
  const double total = data.weights.sum();
  double height = 0.0, off_wall = 0.0;
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) {
    height += data.weights[i] * axial_coordinates(o, a, data.points.row(i).transpose()).height / total;
    off_wall += data.weights[i] * signed_distance(wall, data.points.row(i).transpose()) / total;
  }
  const double above = height >= foot ? 1.0 : -1.0;
  const double outside = off_wall >= 0.0 ? 1.0 : -1.0;
  Surface tangent;
  tangent.type = SurfaceType::Torus;
  tangent.axis = a;
  auto mean_square = [&](double log_r) {
    tangent.minor = std::exp(log_r);
    tangent.point = o + (foot + above * tangent.minor) * a;
    tangent.radius = touching_circle_radius(wall, foot + above * tangent.minor, tangent.minor, outside);
    double rms, max_error;
    fit_residuals(tangent, data.points, data.weights, rms, max_error);
    return rms * rms;
  };
  // From a hundredth of the points' distance from the plane to a hundred times it, inside the
  // wall less than its radius at the plane.
  const double reach = std::abs(height - foot);
  const double wall_radius = touching_circle_radius(wall, foot, 0.0, 1.0);
  const double largest = outside > 0.0 ? 1e2 * reach : std::min(1e2 * reach, 0.999 * wall_radius);
  if (!(largest > 1e-2 * reach)) return SurfaceFit();
  mean_square(least_on_interval(mean_square, std::log(1e-2 * reach), std::log(largest)));
  if (!spindle && tangent.radius < tangent.minor) return SurfaceFit();
  return fit_of(tangent, data);
}

// The points of a plane's patch that lie on the arc of a cylinder tangent to it, within `reach` of the
// cylinder: past the line where the cylinder touches the plane (`to_plane`, the unit direction from
// the axis to it), towards `other` (the same for the other plane the cylinder touches).
FitData flank(const FitData& plane, const Surface& cylinder, const Eigen::Vector3d& to_plane,
              const Eigen::Vector3d& other, double reach) {
  const Eigen::Vector3d into_arc = (other - other.dot(to_plane) * to_plane).normalized();
  auto on_arc = [&](const Eigen::Vector3d& x) {
    return (x - cylinder.point).dot(into_arc) > 0.0 && std::abs(signed_distance(cylinder, x)) <= reach;
  };
  FitData out;
  std::vector<Eigen::Index> keep, keep_samples;
  for (Eigen::Index i = 0; i < plane.points.rows(); ++i)
    if (on_arc(plane.points.row(i).transpose())) keep.push_back(i);
  for (Eigen::Index i = 0; i < plane.sample_points.rows(); ++i)
    if (on_arc(plane.sample_points.row(i).transpose())) keep_samples.push_back(i);
  out.points = plane.points(keep, Eigen::all);
  out.weights = plane.weights(keep);
  out.sample_points = plane.sample_points(keep_samples, Eigen::all);
  out.sample_normals = plane.sample_normals(keep_samples, Eigen::all);
  out.sample_weights = plane.sample_weights(keep_samples);
  return out;
}

}  // namespace

int fillets_between_planes(const std::vector<FitData>& points, const std::vector<std::pair<int, int>>& adjacent,
                           const SharedAxisOptions& options, std::vector<Feature>& features) {
  std::vector<std::vector<int>> planes_beside(features.size());
  for (const auto& [a, b] : adjacent)
    for (const auto& [x, y] : {std::pair(a, b), std::pair(b, a)})
      if (features[y].type == SurfaceType::Plane &&
          (features[x].type == SurfaceType::Plane || features[x].type == SurfaceType::Cylinder))
        planes_beside[x].push_back(y);
  auto angle = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return std::acos(std::clamp(x.dot(y), -1.0, 1.0)); };
  // Decided on the planes as they were: a strip that became a cylinder is no plane beside another.
  const std::vector<Feature> before = features;
  int changed = 0;
  for (size_t s = 0; s < features.size(); ++s) {
    const FitData& data = points[s];
    const bool strip = before[s].type == SurfaceType::Plane;
    if ((!strip && before[s].type != SurfaceType::Cylinder) ||
        data.points.rows() < 2 * parameter_count(SurfaceType::Cylinder))
      continue;
    SurfaceFit own = fit_of(before[s].surface, data);
    const Eigen::Vector3d n = strip ? outward_normal(own.surface, data) : Eigen::Vector3d::Zero();
    SurfaceFit best;
    const std::vector<int>& beside = planes_beside[s];
    std::array<Eigen::Vector3d, 4> best_planes;  // n1, p1, n2, p2
    std::array<int, 2> best_pair{};
    for (size_t i = 0; i < beside.size(); ++i)
      for (size_t j = i + 1; j < beside.size(); ++j) {
        const Feature &f1 = before[beside[i]], &f2 = before[beside[j]];
        const Eigen::Vector3d n1 = outward_normal(f1.surface, points[beside[i]]);
        const Eigen::Vector3d n2 = outward_normal(f2.surface, points[beside[j]]);
        const double turn = angle(n1, n2);
        if (turn < options.angle_tolerance || turn > M_PI - options.angle_tolerance) continue;
        if (strip && angle(n1, n) + angle(n, n2) > turn + options.angle_tolerance) continue;  // not between them
        // A cylinder's axis runs along both planes.
        if (!strip && std::abs(n1.cross(n2).normalized().dot(own.surface.axis)) < std::cos(options.angle_tolerance))
          continue;
        const SurfaceFit fit = tangent_cylinder(data, n1, f1.surface.point, n2, f2.surface.point);
        if (fit.valid && (!strip || fit.rms < own.rms) && (!best.valid || fit.rms < best.rms)) {
          best = fit;
          best_planes = {n1, f1.surface.point, n2, f2.surface.point};
          best_pair = {beside[i], beside[j]};
        }
      }
    if (!best.valid) continue;
    measure_spreads(data, best);
    measure_spreads(data, own);
    if (strip && (best.spread >= own.spread ||
                  !fits_as_well(best.normal_spread, own.normal_spread, options.residual_ratio, options.normal_floor)))
      continue;
    // The radius from the whole arc: the planes beside the strip still hold its flanks, which pull
    // the tangent cylinder's radius short by a few percent. Fitted freely to the strip and the
    // flanks, and placed against the planes again.
    const Surface& c = best.surface;
    auto touching = [&](const Eigen::Vector3d& outward, const Eigen::Vector3d& on_plane) {
      return (on_plane - c.point).dot(outward) >= 0.0 ? outward : Eigen::Vector3d(-outward);
    };
    const Eigen::Vector3d u1 = touching(best_planes[0], best_planes[1]), u2 = touching(best_planes[2], best_planes[3]);
    const double reach = 3.0 * best.spread;
    const FitData arc = concatenate(concatenate(data, flank(points[best_pair[0]], c, u1, u2, reach)),
                                    flank(points[best_pair[1]], c, u2, u1, reach));
    const SurfaceFit free = fit_surface(SurfaceType::Cylinder, arc, FitOptions(), &best.surface);
    SurfaceFit placed;
    if (free.valid)
      placed = tangent_cylinder(data, best_planes[0], best_planes[1], best_planes[2], best_planes[3], free.surface.radius);
    if (placed.valid) measure_spreads(data, placed);
    if (strip) {
      if (placed.valid && placed.spread < own.spread) best = placed;
    } else {
      // A cylinder keeps its own fit unless the placed one fits the whole arc better and its own
      // points about as well (a fillet whose flanks the planes took fits a short radius to what is left).
      if (!placed.valid || !fits_as_well(placed.spread, own.spread, options.residual_ratio) ||
          fit_of(placed.surface, arc).rms >= fit_of(own.surface, arc).rms)
        continue;
      best = placed;
    }
    features[s].set_fit(best);
    ++changed;
  }
  return changed;
}

int tori_between_planes_and_walls(const std::vector<FitData>& points, const std::vector<std::pair<int, int>>& adjacent,
                                  const SharedAxisOptions& options, std::vector<Feature>& features) {
  std::vector<std::vector<int>> beside(features.size());
  for (const auto& [a, b] : adjacent) {
    beside[a].push_back(b);
    beside[b].push_back(a);
  }
  int changed = 0;
  for (size_t t = 0; t < features.size(); ++t) {
    const FitData& data = points[t];
    const bool retype = features[t].type == SurfaceType::Cylinder || features[t].type == SurfaceType::Cone;
    if ((!retype && features[t].type != SurfaceType::Torus) || data.points.rows() < 2 * parameter_count(SurfaceType::Torus))
      continue;
    SurfaceFit best;
    // Every plane and wall (cylinder or cone) beside it that meet at a right angle to the wall's
    // axis (not the torus's own axis, which a quarter of a noisy tube tilts by degrees, and its
    // centre with it).
    for (int c : beside[t])
      for (int p : beside[t]) {
        const SurfaceType wall = features[c].type;
        if ((wall != SurfaceType::Cylinder && wall != SurfaceType::Cone) || features[p].type != SurfaceType::Plane ||
            std::abs(features[p].surface.axis.dot(features[c].surface.axis)) < std::cos(options.angle_tolerance))
          continue;
        const SurfaceFit fit = tangent_torus(data, features[c].surface, features[p].surface, !retype);
        if (fit.valid && (!best.valid || fit.rms < best.rms)) best = fit;
      }
    if (!best.valid) continue;
    measure_spreads(data, best);
    const Feature& own = features[t];
    if (!fits_as_well(best.spread, own.spread, retype ? 1.0 : options.residual_ratio) ||
        !fits_as_well(best.normal_spread, own.normal_spread, options.residual_ratio, options.normal_floor))
      continue;
    features[t].set_fit(best);
    ++changed;
  }
  return changed;
}

int planes_on_curved_surfaces(const std::vector<FitData>& points, const SharedAxisOptions& options,
                              std::vector<Feature>& features) {
  const std::vector<Feature> before = features;  // surfaces as fitted, not as taken over here
  int changed = 0;
  for (size_t p = 0; p < features.size(); ++p) {
    const FitData& data = points[p];
    if (before[p].type != SurfaceType::Plane || data.points.rows() < 2 * parameter_count(SurfaceType::Cone)) continue;
    SurfaceFit plane = fit_surface(SurfaceType::Plane, data);
    if (!plane.valid) continue;
    measure_spreads(data, plane);
    const Eigen::Vector3d centre = data.points.transpose() * data.weights / data.weights.sum();
    SurfaceFit best;
    for (size_t q = 0; q < features.size(); ++q) {
      const Feature& other = before[q];
      if (q == p || other.type == SurfaceType::Plane || other.type == SurfaceType::Freeform) continue;
      // Only a surface that passes through the patch (cheap: at its centre).
      if (std::abs(signed_distance(other.surface, centre)) > 3.0 * plane.rms + options.distance_tolerance) continue;
      const SurfaceFit fit = fit_of(other.surface, data);
      if (fit.rms < plane.rms && (!best.valid || fit.rms < best.rms)) best = fit;
    }
    if (!best.valid) continue;
    measure_spreads(data, best);
    if (!fits_as_well(best.normal_spread, plane.normal_spread, options.residual_ratio, options.normal_floor) ||
        turn_across(best.surface, data) <= options.angle_tolerance)
      continue;
    features[p].set_fit(best);
    ++changed;
  }
  return changed;
}

int fit_about_shared_axes(const std::vector<FitData>& points, const SharedAxisOptions& options,
                          std::vector<Feature>& features) {
  std::vector<Axis> axes;
  for (size_t f = 0; f < features.size(); ++f)
    if (determined_axis(features[f], points[f], options))
      axes.push_back({features[f].surface.point, features[f].surface.axis, static_cast<int>(f)});
  // Each feature reads the axes gathered above and changes only itself: on two threads.
  std::vector<char> changed(features.size(), 0);
  on_two_threads_as_free(static_cast<int>(features.size()), [&](int f) {
    Feature& feature = features[f];
    const FitData& data = points[f];
    const bool plane = feature.type == SurfaceType::Plane, sphere = feature.type == SurfaceType::Sphere;
    if (!plane && !sphere && feature.type != SurfaceType::Cylinder && feature.type != SurfaceType::Cone) return;
    if (data.points.rows() < 2 * parameter_count(feature.type)) return;
    // On another feature's axis already: idealization aligns it.
    if (!plane && !sphere && std::any_of(axes.begin(), axes.end(), [&](const Axis& a) {
          return a.source != f && same_axis(feature.surface, a, options);
        }))
      return;
    const bool determined = std::any_of(axes.begin(), axes.end(), [&](const Axis& a) { return a.source == f; });
    if (options.only_determined && !determined) return;
    // Candidates by RMS (cheap); the spreads decide for the best one.
    const double rms_limit =
        plane ? feature.rms : accepted_residual(feature.rms, options.residual_ratio, options.distance_tolerance);
    SurfaceFit best;
    for (const Axis& axis : axes) {
      if (axis.source == f) continue;
      const SurfaceFit fit = fit_about(data, axis, options, determined);
      if (fit.valid && fit.rms < rms_limit && (!best.valid || fit.rms < best.rms)) best = fit;
    }
    if (!best.valid) return;
    if (determined) {
      // Its own axis is one more axis of the part only where the data need it: the BIC for the four
      // parameters of an axis of its own (a narrow band of revolution tilts its fit by a degree
      // within the noise), and for the profile (the dome of a screw head fits a tilted cylinder).
      if (!bic_prefers(best.rms, parameters_about_axis(best.surface.type), feature.rms,
                       parameter_count(feature.type), static_cast<double>(data.points.rows())))
        return;
      feature.set_fit(best);
      changed[f] = 1;
      return;
    }
    measure_spreads(data, best);
    const bool normals_fit =
        fits_as_well(best.normal_spread, feature.normal_spread, options.residual_ratio, options.normal_floor);
    const bool fits = normals_fit && (plane ? best.spread < feature.spread &&
                                                  turn_across(best.surface, data) > options.angle_tolerance
                                            : fits_as_well(best.spread, feature.spread, options.residual_ratio,
                                                           options.distance_tolerance));
    if (!fits) return;
    feature.set_fit(best);
    changed[f] = 1;
  });
  return static_cast<int>(std::count(changed.begin(), changed.end(), 1));
}

}  // namespace idealize
