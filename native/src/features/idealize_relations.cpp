// The relations of the feature graph made exact (idealization.h), keeping the fitted surface
// where the ideal one no longer describes its patch.
#include "features/pipeline.h"

#include "features/edge_fillets.h"
#include "features/feature_graph.h"
#include "features/idealization.h"
#include "fit/fits_as_well.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace idealize {

void idealize_layer(FeatureState& s) {
  const double angle_tolerance = s.options.angle_tolerance_degrees * M_PI / 180.0;
  IdealizationOptions ideal;
  ideal.angle_tolerance_degrees = s.options.angle_tolerance_degrees;
  ideal.distance_tolerance = s.layer.distance_tolerance;
  const std::vector<Feature> fitted = s.layer.features;
  // On an exact tessellation, profiles are fitted again about the ideal axes (to every vertex, as
  // above). On a noisy mesh the fitted profiles stay (measured on the benchmark: refitted about
  // the ideal axes, the scans' median radius error grew from 0.38 % to 0.53 %).
  ideal.points = s.exact_mesh ? &s.whole : &s.points;
  ideal.refit_moved_profiles = s.exact_mesh;
  ideal.residual_ratio = s.options.residual_ratio;
  if (idealize_features(s.layer.features, s.layer.relations, ideal) > 0) {
    // An ideal surface must still describe its patch: where it fits clearly worse than the fitted
    // one (a direction that only looked ideal, radii that only looked equal), the fit stays. A
    // sculpted part's smooth undulation moves every fit a little (a fillet's axis by a degree or
    // two), which the ideal surface does not follow, and a fit that stays meets its tangent
    // neighbours nowhere: the more the mesh's residuals are correlated (the share of them that is
    // not independent noise), the more of the distance tolerance the ideal one may deviate by in
    // addition. (Measured on the benchmark's sculpted parts: 11 -> 12 of 23 solids with the true
    // surface types, and the scans' and CAD exports' solids unchanged.)
    const double share = s.exact_mesh ? 1.0 : independent_share(s.mesh, fitted, s.layer.labels);
    const double ideal_slack = (1.0 - share) * s.layer.distance_tolerance;
    auto rms_of = [&](size_t p, const Surface& surface) {
      double rms, max_error;
      fit_residuals(surface, s.points[p].points, s.points[p].weights, rms, max_error);
      return rms;
    };
    auto misfits = [&](size_t p, double rms) {
      // (The fit's spread: one σ of noise more; then the slack for correlated residuals.)
      return rms > accepted_residual(fitted[p].rms, s.options.residual_ratio, fitted[p].spread) + s.floor + ideal_slack;
    };
    auto misfit = [&](size_t p, const Surface& surface) { return misfits(p, rms_of(p, surface)); };
    // A direction that snapped to one of the part's ideal ones only by the angle tolerance (a face
    // designed at 25° snaps to 30°) moves the features tangent to it too: once more, with the
    // directions that alone (the fitted surface turned about its point nearest the patch's
    // centre) do not fit their patch as fitted, and that turned by more than three times the
    // part's median turn (a sculpted part's undulation tilts every fit a little), neither averaged
    // with their parallels nor snapped. (On an exact tessellation any turn misfits; the fits
    // that snapping spoils just stay, below.)
    auto turn = [&](size_t p) {
      return std::acos(std::min(1.0, std::abs(fitted[p].surface.axis.dot(s.layer.features[p].surface.axis))));
    };
    std::vector<double> turns;
    for (size_t p = 0; p < s.layer.features.size(); ++p)
      if (fitted[p].type != SurfaceType::Freeform && fitted[p].surface.has_direction()) turns.push_back(turn(p));
    double typical_turn = 0.0;
    if (!turns.empty()) {
      std::nth_element(turns.begin(), turns.begin() + turns.size() / 2, turns.end());
      typical_turn = turns[turns.size() / 2];
    }
    for (size_t p = 0; p < s.layer.features.size() && !s.exact_mesh; ++p) {
      if (fitted[p].type == SurfaceType::Freeform || !fitted[p].surface.has_direction() || turn(p) <= 3.0 * typical_turn)
        continue;
      // Turned about the point of its axis (or plane) nearest the patch's centre.
      Surface turned = fitted[p].surface;
      const Eigen::Vector3d centre = s.points[p].points.transpose() * s.points[p].weights / s.points[p].weights.sum();
      const Eigen::Vector3d& a = turned.axis;
      const double along = (centre - turned.point).dot(a);
      if (turned.type == SurfaceType::Plane) turned.point = centre - along * a;
      else if (turned.type != SurfaceType::Cone) turned.point += along * a;
      turned.axis = s.layer.features[p].surface.axis;
      // Beyond the misfit, a turn whose systematic deviation (RMS beyond the fit's) the noise
      // cannot explain: as much as the share of correlated residuals lets the whole face tilt,
      // and what its independent noise leaves of the fit's parameters. (A scanned face designed
      // at 11.6° fitted 11.5° about as well as 10° fits it by misfit's measure.)
      const double rms = rms_of(p, turned);
      const double excess = std::sqrt(std::max(0.0, rms * rms - fitted[p].rms * fitted[p].rms));
      const double sigma = fitted[p].spread, n = static_cast<double>(s.points[p].points.rows());
      const bool unexplained =
          excess > 3.0 * sigma * (std::sqrt(1.0 - share) + std::sqrt(3.0 / std::max(n, 1.0))) + ideal_slack;
      if (misfits(p, rms) || unexplained) ideal.unsnapped.push_back(static_cast<int>(p));
    }
    if (!ideal.unsnapped.empty()) {
      s.layer.features = fitted;
      idealize_features(s.layer.features, s.layer.relations, ideal);
    }
    // On a noisy mesh, planes whose turned direction misfits keep their fitted one, and the rest
    // is idealized once more about them: the features they define (a cylinder that touches a
    // plane) were placed against the turned plane, and misfit too. (A part whose faces meet at
    // 88° has its rounds' axes made parallel again, instead of all of them staying as fitted.)
    const size_t held = ideal.unsnapped.size();
    for (size_t p = 0; p < s.layer.features.size() && !s.exact_mesh; ++p)
      if (s.layer.features[p].type == SurfaceType::Plane && turn(p) > 0.0 && misfit(p, s.layer.features[p].surface))
        ideal.unsnapped.push_back(static_cast<int>(p));
    if (ideal.unsnapped.size() > held) {
      s.layer.features = fitted;
      idealize_features(s.layer.features, s.layer.relations, ideal);
    }
    for (size_t p = 0; p < s.layer.features.size(); ++p)
      if (s.layer.features[p].type != SurfaceType::Freeform && misfit(p, s.layer.features[p].surface)) s.layer.features[p] = fitted[p];
    build_feature_graph(s.mesh, s.topology, s.layer.labels, s.layer.features, angle_tolerance, s.layer.distance_tolerance,
                        s.options.radius_tolerance, s.layer.adjacency, s.layer.relations);  // the graph of the ideal surfaces
  }
}

}  // namespace idealize
