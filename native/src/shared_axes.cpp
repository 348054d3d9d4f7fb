#include "shared_axes.h"

#include <algorithm>
#include <cmath>

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

// The simpler of a cylinder and a cone about the axis that fits (by RMS, as identification
// chooses); invalid if neither does or the cone is really a cylinder or a plane.
SurfaceFit fit_about(const FitData& data, const Axis& axis, const SharedAxisOptions& options) {
  const SurfaceFit cylinder = fit_about_axis(SurfaceType::Cylinder, data, axis.origin, axis.direction);
  SurfaceFit cone = fit_about_axis(SurfaceType::Cone, data, axis.origin, axis.direction);
  const double half_angle = cone.surface.half_angle;
  if (half_angle < options.angle_tolerance || half_angle > 0.5 * M_PI - options.angle_tolerance) cone.valid = false;
  if (!cone.valid) return cylinder;
  if (!cylinder.valid) return cone;
  const double best = std::min(cylinder.rms, cone.rms);
  return cylinder.rms <= options.residual_ratio * best + options.distance_tolerance ? cylinder : cone;
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

}  // namespace

int fit_about_shared_axes(const std::vector<FitData>& points, const SharedAxisOptions& options,
                          std::vector<Feature>& features) {
  std::vector<Axis> axes;
  for (size_t f = 0; f < features.size(); ++f)
    if (determined_axis(features[f], points[f], options))
      axes.push_back({features[f].surface.point, features[f].surface.axis, static_cast<int>(f)});
  int changed = 0;
  for (size_t f = 0; f < features.size(); ++f) {
    Feature& feature = features[f];
    const FitData& data = points[f];
    const bool plane = feature.type == SurfaceType::Plane, sphere = feature.type == SurfaceType::Sphere;
    if (!plane && !sphere && feature.type != SurfaceType::Cylinder && feature.type != SurfaceType::Cone) continue;
    if (data.points.rows() < 2 * parameter_count(feature.type)) continue;
    // One of the part's axes already: idealization aligns it.
    if (!plane && !sphere && std::any_of(axes.begin(), axes.end(), [&](const Axis& a) { return same_axis(feature.surface, a, options); }))
      continue;
    // Candidates by RMS (cheap); the spreads decide for the best one.
    const double rms_limit = plane ? feature.rms : options.residual_ratio * feature.rms + options.distance_tolerance;
    SurfaceFit best;
    for (const Axis& axis : axes) {
      if (axis.source == static_cast<int>(f)) continue;
      const SurfaceFit fit = fit_about(data, axis, options);
      if (fit.valid && fit.rms < rms_limit && (!best.valid || fit.rms < best.rms)) best = fit;
    }
    if (!best.valid) continue;
    measure_spreads(data, best);
    const bool normals_fit =
        best.normal_spread <= options.residual_ratio * feature.normal_spread + options.normal_floor;
    const bool fits = normals_fit && (plane ? best.spread < feature.spread &&
                                                  turn_across(best.surface, data) > options.angle_tolerance
                                            : best.spread <= options.residual_ratio * feature.spread +
                                                                 options.distance_tolerance);
    if (!fits) continue;
    feature.set_fit(best);
    ++changed;
  }
  return changed;
}

}  // namespace idealize
