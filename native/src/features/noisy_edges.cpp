// The features along a noisy mesh's edges, once the patches are settled: axes shared with related
// features, fillets too narrow for a patch of their own, the pieces that one surface fits merged
// again, and tori between planes and walls.
#include "features/pipeline.h"

#include "core/parallel.h"
#include "features/edge_fillets.h"
#include "features/identify.h"
#include "features/merge.h"
#include "features/profile_splits.h"
#include "features/retyping.h"
#include "features/shared_axes.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

void fit_noisy_edges(FeatureState& s) {
  const auto identify_points = [&](const PatchPoints& pp, const PatchCurvature& c) { return s.identify_points(pp, c); };
  // On a noisy mesh, features whose own points cannot fix an axis take a related feature's.
  SharedAxisOptions shared;
  shared.determined_points = 4 * kInteriorPoints;
  shared.angle_tolerance = s.options.angle_tolerance_degrees * M_PI / 180.0;
  shared.distance_tolerance = s.layer.distance_tolerance;
  shared.residual_ratio = s.options.residual_ratio;
  shared.normal_floor = s.options.normal_floor_degrees * M_PI / 180.0;
  const std::vector<PatchPoints> feature_points = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()));
  fit_about_shared_axes(feature_points, shared, s.layer.features);
  fillets_between_planes(feature_points, adjacent_pairs(s.mesh, s.topology, s.layer.labels), shared, s.layer.features);
  // Fillets too narrow for a patch of their own, which the features beside them took; cylinders and
  // planes that a torus took with it. The new features keep the surface the fit of the edge's
  // band or the torus's profile fixed, the others are refitted without the faces they gave.
  EdgeFilletOptions edges;
  edges.angle_tolerance = shared.angle_tolerance;
  edges.residual_ratio = s.options.residual_ratio;
  edges.radius_tolerance = s.options.radius_tolerance;
  // Features that a finder split into pieces (a fillet found on an edge takes faces from two
  // features that meet at an angle, which never merge again anyway: a cone that gave a fillet at
  // each end stays free to rejoin its other piece).
  std::vector<char> touched;
  for (auto find : {round_edges, split_tangent_continuations, split_cornered_tori, split_coaxial_steps}) {
    const size_t existing = s.layer.features.size();
    const std::vector<char> changed = find(s.mesh, s.topology, edges, s.layer.features, s.layer.labels);
    touched.resize(changed.size(), 0);
    if (find != round_edges)
      for (size_t p = 0; p < changed.size(); ++p) touched[p] |= changed[p];
    if (std::find(changed.begin(), changed.end(), 1) == changed.end()) continue;
    const std::vector<PatchPoints> now = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()));
    on_two_threads(
        largest_first(now, changed),
        [&](int p) {
          Feature& f = s.layer.features[p];
          SurfaceFit fit;
          if (static_cast<size_t>(p) < existing) fit = fit_surface(f.type, now[p], s.options.fit, &f.surface);
          if (!fit.valid) {
            fit = fit_of(f.surface, now[p]);
            measure_spreads(now[p], fit);
          }
          f.set_fit(fit);
          f.vertices = static_cast<int>(now[p].points.rows());
        },
        ProgressSpan());
    count_faces(s.area, s.layer.labels, s.layer.features);
  }
  // A surface that the stages between merging and here left in two pieces (a sculpted cylinder
  // whose pieces' fits differ by its undulation, a narrow piece whose rim went to a neighbour)
  // merges now where one surface fits both as merging requires. Only alike pieces are tried (one
  // type, parallel, radii that relations would take for equal), and not two that the finders
  // above just split apart.
  // The points and neighbours of the features, for the remerge and the tangent tori after it.
  std::vector<PatchPoints> settled = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()));
  std::vector<std::pair<int, int>> beside = adjacent_pairs(s.mesh, s.topology, s.layer.labels);
  {
    std::set<std::pair<int, int>> apart;
    touched.resize(s.layer.features.size(), 0);
    const double angle_tolerance = s.options.angle_tolerance_degrees * M_PI / 180.0;
    for (const auto& pair : beside)
      if ((touched[pair.first] && touched[pair.second]) ||
          !alike(s.layer.features[pair.first], s.layer.features[pair.second], angle_tolerance, s.layer.distance_tolerance,
                 s.options.radius_tolerance))
        apart.insert(pair);
    if (merge_patches(s.mesh, s.topology, settled, identify_points, s.options, s.layer.distance_tolerance, false, s.exact_distance,
                      s.noise, s.layer.features, s.layer.labels, apart, s.progress.sub("remerge", 0.98, 0.98))) {
      compact_features(s.layer.labels, s.layer.features);
      count_faces(s.area, s.layer.labels, s.layer.features);
      settled = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()));
      beside = adjacent_pairs(s.mesh, s.topology, s.layer.labels);
    }
  }
  // The features that the edge stages refitted freely (without the faces they gave a fillet, a
  // narrow band whose own axis tilts by a degree) take the part's axes again.
  SharedAxisOptions determined = shared;
  determined.only_determined = true;
  fit_about_shared_axes(settled, determined, s.layer.features);
  // The tori that the edge stages found or left, now that their neighbours are settled.
  tori_between_planes_and_walls(settled, beside, shared, s.layer.features);
  if (join_torus_pieces(settled, beside, s.options.residual_ratio, shared.normal_floor, s.layer.features, s.layer.labels))
    count_faces(s.area, s.layer.labels, s.layer.features);
  planes_on_curved_surfaces(patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()), -1), shared,
                            s.layer.features);
}

}  // namespace idealize
