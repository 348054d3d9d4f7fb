// Identification of a patch's surface: the simplest type that fits about as well as the best one,
// how well a surface explains a face or every point, and the points that fix a fit.
#include "features/identify.h"
#include "fit/fits_as_well.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>

namespace idealize {

SurfaceType curvature_type(const PatchCurvature& c, const EffectiveZero& zero_h) {
  // K = k1 k2 with both principal curvatures inside the zero range of H.
  const double zero_k = std::pow(std::max(-zero_h.low, zero_h.high), 2);
  if (c.mean >= zero_h.low && c.mean <= zero_h.high && std::abs(c.gaussian) <= zero_k) return SurfaceType::Plane;
  if (std::abs(c.gaussian) <= zero_k) return SurfaceType::Cylinder;
  return c.gaussian > 0.0 ? SurfaceType::Sphere : SurfaceType::Torus;
}

Feature identify(const PatchPoints& pp, const PatchCurvature& curvature, const EffectiveZero& zero_h,
                 const FeatureOptions& options, double tolerance, bool curved_only) {
  Feature feature;
  feature.vertices = static_cast<int>(pp.points.rows());
  feature.curvature_type = curvature_type(curvature, zero_h);
  feature.curvature = curvature;
  const size_t first = curved_only ? 1 : 0;
  const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
  std::array<SurfaceFit, 5> fits;
  double best = std::numeric_limits<double>::infinity(), best_normal = best;
  // The first type accepted against the best fits so far. Later fits only lower the best, and so
  // the limits: a type that fails now fails for good, and one within the limits' floors (the
  // distance tolerance, the normal floor) is accepted for good. When the first type accepted so
  // far is of that kind, the more general types need not be fitted at all.
  auto first_accepted = [&](size_t fitted) {
    // Surfaces that deviate by less than the distance tolerance are as good as equal.
    const double accepted = accepted_residual(best, options.residual_ratio, tolerance);
    const double accepted_normal = accepted_residual(best_normal, options.residual_ratio, normal_floor);
    for (size_t t = first; t < fitted; ++t)
      if (fits[t].valid && fits[t].spread <= accepted && fits[t].normal_spread <= accepted_normal)
        return static_cast<int>(t);
    return -1;
  };
  size_t fitted = first;
  for (; fitted < kTypesByPreference.size(); ++fitted) {
    SurfaceFit& fit = fits[fitted];
    fit = fit_surface(kTypesByPreference[fitted], pp, options.fit);
    if (!fit.valid) continue;
    best = std::min(best, fit.spread);
    best_normal = std::min(best_normal, fit.normal_spread);
    const int leading = first_accepted(fitted + 1);
    if (leading >= 0 && fits[leading].spread <= tolerance && fits[leading].normal_spread <= normal_floor) {
      ++fitted;
      break;
    }
  }
  // The first accepted type: a more general surface always fits a little better.
  const int chosen = first_accepted(fitted);
  if (chosen < 0) return feature;  // no surface could be fitted at all
  feature.set_fit(fits[chosen]);
  return feature;
}

double face_misfit(const TriangleMesh& mesh, int f, const Surface& surface, double distance_unit, double angle_unit) {
  double worst = 0.0;
  for (int k = 0; k < 3; ++k)
    worst = std::max(worst, std::abs(signed_distance(surface, mesh.V.row(mesh.F(f, k)).transpose())) / distance_unit);
  const double cosine = std::abs(face_normal(mesh, f).dot(surface_normal(surface, face_centroid(mesh, f))));
  return std::max(worst, std::acos(std::min(cosine, 1.0)) / angle_unit);
}

double misfit(const TriangleMesh& mesh, int f, const Feature& feature, double floor, double normal_floor) {
  if (feature.type == SurfaceType::Freeform) return std::numeric_limits<double>::infinity();
  return face_misfit(mesh, f, feature.surface, 3.0 * feature.spread + floor, 3.0 * feature.normal_spread + normal_floor);
}

bool explains_every_point(const Surface& surface, const PatchPoints& data, double distance, double angle,
                          double largest_chord_turn) {
  for (Eigen::Index i = 0; i < data.points.rows(); ++i)
    if (std::abs(signed_distance(surface, data.points.row(i).transpose())) > distance) return false;
  for (Eigen::Index i = 0; i < data.sample_points.rows(); ++i) {
    if (!(data.sample_weights[i] > 0.0)) continue;
    const Eigen::Vector3d centroid = data.sample_points.row(i).transpose();
    const double sag = std::abs(signed_distance(surface, centroid));
    const double allowed = angle + std::min(4.0 * sag / std::sqrt(data.sample_weights[i]), largest_chord_turn);
    const Eigen::Vector3d n = surface_normal(surface, centroid);
    if (std::abs(n.dot(data.sample_normals.row(i).transpose())) < std::cos(std::min(allowed, 0.5 * M_PI))) return false;
  }
  return true;
}

int distinct_points(const PatchPoints& data) {
  std::set<std::array<double, 3>> seen;
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) seen.insert({data.points(i, 0), data.points(i, 1), data.points(i, 2)});
  return static_cast<int>(seen.size());
}

int distinct_parallels(const PatchPoints& data, const Surface& surface, double distance) {
  std::vector<double> heights(data.points.rows());
  for (Eigen::Index i = 0; i < data.points.rows(); ++i)
    heights[i] = (data.points.row(i).transpose() - surface.point).dot(surface.axis);
  std::sort(heights.begin(), heights.end());
  int count = heights.empty() ? 0 : 1;
  for (size_t i = 1; i < heights.size(); ++i) count += heights[i] - heights[i - 1] > distance;
  return count;
}

std::optional<SurfaceFit> fit_lemon(const PatchPoints& data, const FitOptions& options, double tolerance,
                                    double distance, const Surface* start) {
  FitOptions lemons = options;
  lemons.lemons = true;
  const SurfaceFit fit = fit_surface(SurfaceType::Torus, data, lemons, start);
  if (!fit.valid || fit.surface.radius >= -tolerance || (!start && distinct_parallels(data, fit.surface, distance) <= 3))
    return std::nullopt;
  return fit;
}

}  // namespace idealize
