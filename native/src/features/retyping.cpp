// Rules that retype features or join them once the patches are settled.
#include "features/retyping.h"

#include "core/parallel.h"
#include "features/exact_fragments.h"
#include "features/feature_graph.h"
#include "features/identify.h"
#include "features/pipeline.h"
#include "features/split.h"
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

void make_balls_of_corner_cylinders(const TriangleMesh& mesh, const MeshTopology& topology, double angle_tolerance,
                                    double distance_tolerance, const FeatureOptions& options,
                                    const std::vector<int>& labels, const std::vector<PatchPoints>& points,
                                    std::vector<Feature>& features) {
  std::vector<std::vector<int>> beside(features.size());
  for (const auto& [a, b] : adjacent_pairs(mesh, topology, labels)) {
    beside[a].push_back(b);
    beside[b].push_back(a);
  }
  for (Feature& f : features) {
    if (f.type != SurfaceType::Cylinder) continue;
    std::vector<const Surface*> fillets;
    for (int n : beside[f.id])
      if (features[n].type == SurfaceType::Cylinder) fillets.push_back(&features[n].surface);
    if (fillets.size() < 2) continue;
    const AxesMeeting meeting = point_nearest_to_axes(fillets);
    if (!(meeting.fixed > 1.0 - std::cos(angle_tolerance))) continue;  // parallel within the tolerance
    const Eigen::Vector3d& centre = meeting.point;
    double radius = 0.0;
    for (const Surface* c : fillets) radius += c->radius / fillets.size();
    const double near = std::max(distance_tolerance, options.radius_tolerance * radius);
    if (!std::all_of(fillets.begin(), fillets.end(), [&](const Surface* c) {
          return axial_coordinates(c->point, c->axis, centre).distance <= near && std::abs(c->radius - radius) <= near;
        }))
      continue;
    Surface ball;
    ball.type = SurfaceType::Sphere;
    ball.point = centre;
    ball.radius = radius;
    SurfaceFit fit = fit_of(ball, points[f.id]);
    if (!fits_as_well(fit.rms, fit_of(f.surface, points[f.id]).rms, options.residual_ratio)) continue;
    measure_spreads(points[f.id], fit);
    f.set_fit(fit);
  }
}

bool join_torus_pieces(const std::vector<PatchPoints>& points, const std::vector<std::pair<int, int>>& beside,
                       double residual_ratio, double normal_floor, std::vector<Feature>& features,
                       std::vector<int>& labels) {
  std::vector<int> join(features.size(), kNone);
  std::vector<double> joined_spread(features.size(), 0.0);
  for (const auto& [x, y] : beside)
    for (const auto& [piece, torus] : {std::pair{x, y}, std::pair{y, x}}) {
      const Feature &p = features[piece], &t = features[torus];
      if (t.type != SurfaceType::Torus || (p.type != SurfaceType::Cylinder && p.type != SurfaceType::Cone)) continue;
      SurfaceFit fit = fit_of(t.surface, points[piece]);
      measure_spreads(points[piece], fit);
      if (!fits_as_well(fit.spread, p.spread, residual_ratio) ||
          !fits_as_well(fit.normal_spread, p.normal_spread, residual_ratio, normal_floor))
        continue;
      if (join[piece] == kNone || fit.spread < joined_spread[piece]) join[piece] = torus, joined_spread[piece] = fit.spread;
    }
  if (std::all_of(join.begin(), join.end(), [](int j) { return j == kNone; })) return false;
  for (int& l : labels)  // (a torus joins nothing: it stays what its pieces join)
    if (l >= 0 && join[l] != kNone) l = join[l];
  compact_features(labels, features);
  return true;
}

bool join_freeform_features(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& labels,
                            std::vector<Feature>& features) {
  const auto freeform = [&](int p) { return features[p].type == SurfaceType::Freeform; };
  const auto joins = [&](int p) { return freeform(p) || features[p].vertices < kInteriorPoints; };
  bool any = false;
  // Slivers lie in rows along a border: each pass takes the row beside the freeform feature.
  for (bool joined = true; joined;) {
    joined = false;
    std::vector<double> inside(features.size(), 0.0);
    std::map<std::pair<int, int>, std::vector<double>> across;
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < f || labels[f] < 0 || labels[g] < 0) continue;
        const int a = labels[f], b = labels[g];
        if (!joins(a) || !joins(b)) continue;
        const double turn = facet_turn(mesh, f, g);
        if (a == b) inside[a] = std::max(inside[a], turn);
        else if (freeform(a) || freeform(b)) across[{std::min(a, b), std::max(a, b)}].push_back(turn);
      }
    std::vector<int> parent(features.size());
    std::iota(parent.begin(), parent.end(), 0);
    const std::function<int(int)> root = [&](int p) { return parent[p] == p ? p : parent[p] = root(parent[p]); };
    for (auto& [pair, turns] : across) {
      const auto [a, b] = pair;
      std::nth_element(turns.begin(), turns.begin() + turns.size() / 2, turns.end());
      if (turns[turns.size() / 2] > std::max(inside[a], inside[b])) continue;
      const int ra = root(a), rb = root(b);
      if (ra == rb) continue;
      // The larger freeform feature stands for the group.
      const bool a_stands = freeform(ra) && (!freeform(rb) || features[ra].area >= features[rb].area);
      if (a_stands) parent[rb] = ra; else parent[ra] = rb;
      joined = any = true;
    }
    if (!joined) break;
    for (int& l : labels)
      if (l >= 0) l = root(l);
    compact_features(labels, features);
  }
  return any;
}

// On an exact tessellation, the single facets that merging left as pieces of their own (planes
// that no neighbour's surface explains), where they meet each other without a crease (a turn below
// the largest a face's own facets make), are facets of one surface that no analytic type explains:
// a B-spline face of the export. Each connected group of them becomes one freeform feature.
// (Pieces of two facets are not taken: a quad whose four corners are coplanar is a plane, and the
// CAD exports of the test data have large two-facet planes that meet at shallow angles.) Returns
// whether any group formed.
bool join_unplaced_facets(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& labels,
                          std::vector<Feature>& features) {
  const auto piece = [&](int p) { return features[p].type == SurfaceType::Plane && features[p].triangles == 1; };
  std::vector<int> parent(features.size());
  std::iota(parent.begin(), parent.end(), 0);
  const std::function<int(int)> root = [&](int p) { return parent[p] == p ? p : parent[p] = root(parent[p]); };
  bool any = false;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < f || labels[f] < 0 || labels[g] < 0 || labels[f] == labels[g]) continue;
      if (!piece(labels[f]) || !piece(labels[g]) || facet_turn(mesh, f, g) >= kLargestFacetTurn) continue;
      const int ra = root(labels[f]), rb = root(labels[g]);
      if (ra != rb) {
        parent[std::max(ra, rb)] = std::min(ra, rb);
        any = true;
      }
    }
  if (!any) return false;
  for (size_t p = 0; p < features.size(); ++p)
    if (root(static_cast<int>(p)) != static_cast<int>(p)) features[root(static_cast<int>(p))].type = SurfaceType::Freeform;
  for (int& l : labels)
    if (l >= 0) l = root(l);
  compact_features(labels, features);
  return true;
}

// Settles the patches after merging: splits of an exact tessellation that found nothing exact are
// undone, features without faces dropped and the rest renumbered, and on an exact tessellation
// the surfaces refitted to every vertex.
void settle_features(FeatureState& s) {
  const auto identify_points = [&](const PatchPoints& pp, const PatchCurvature& c) { return s.identify_points(pp, c); };
  s.progress.sub("classify", 0.975, 0.98).step(0.0);
  undo_inexact_splits(s.mesh, s.area, s.segment_labels, s.was_split, kExactFraction * s.layer.distance_tolerance, identify_points, s.curvature,
                      s.layer.features, s.layer.labels);
  // On an exact tessellation the reassignment may have left a facet of a piece that merging placed
  // (a long facet beside a fillet's tangent border, whose piece's other facets went to the fillet):
  // it joins the neighbour whose surface passes through its vertices exactly. (After the undoing,
  // which counts such facets as a sign of a freeform surface; and not within the tolerance, which
  // would give the small pieces of a freeform surface to the planes beside it.)
  if (s.exact_mesh)
    absorb_fragments(s.mesh, s.topology, patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size())),
                     s.exact_distance, s.layer.features, s.layer.labels);
  compact_features(s.layer.labels, s.layer.features);
  count_faces(s.area, s.layer.labels, s.layer.features);

  // On an exact tessellation the rim vertices lie on the surface as well: the surfaces are fitted
  // once more to every vertex, where that fits them better. (The interior vertices alone leave a
  // narrow band undetermined: those of a chamfer cone one facet row wide lie on one circle, which
  // a cone of any half-angle passes through.)
  if (s.exact_mesh) {
    const std::vector<PatchPoints> whole = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()), -1);
    std::vector<char> which(s.layer.features.size(), 0);
    for (size_t p = 0; p < which.size(); ++p) which[p] = s.layer.features[p].type != SurfaceType::Freeform;
    on_two_threads(
        largest_first(whole, which),
        [&](int p) {
          Feature& f = s.layer.features[p];
          const SurfaceFit fit = fit_surface(f.type, whole[p], s.options.fit, &f.surface);
          if (fit.valid && fit.rms < fit_of(f.surface, whole[p]).rms) f.set_fit(fit);
        },
        ProgressSpan());
  }
}

// Freeform features and the retyping rules that need the settled features.
void classify_features(FeatureState& s) {
  // On a noisy mesh, a cone whose radius changes across its patch by less than the distance
  // tolerance, and which a cylinder fits about as well (identification's rule), is a cylinder: the
  // undulation of a sculpted cylinder tilts its profile by a fraction of a degree, and merging or
  // the edge stages refit a cone as a cone.
  if (!s.exact_mesh && std::any_of(s.layer.features.begin(), s.layer.features.end(),
                                 [](const Feature& f) { return f.type == SurfaceType::Cone; })) {
    const std::vector<PatchPoints> cone_points = patch_points(s.mesh, s.layer.labels, static_cast<int>(s.layer.features.size()));
    const double normal_floor = s.options.normal_floor_degrees * M_PI / 180.0;
    for (size_t p = 0; p < s.layer.features.size(); ++p) {
      Feature& f = s.layer.features[p];
      if (f.type != SurfaceType::Cone) continue;
      const Eigen::VectorXd heights = (cone_points[p].points.rowwise() - f.surface.point.transpose()) * f.surface.axis;
      if (heights.size() == 0 ||
          (heights.maxCoeff() - heights.minCoeff()) * std::tan(f.surface.half_angle) > s.layer.distance_tolerance)
        continue;
      const SurfaceFit about = fit_about_axis(SurfaceType::Cylinder, cone_points[p], f.surface.point, f.surface.axis);
      if (!about.valid) continue;
      const SurfaceFit cylinder = fit_surface(SurfaceType::Cylinder, cone_points[p], s.options.fit, &about.surface);
      if (cylinder.valid && fits_as_well(cylinder.spread, f.spread, s.options.residual_ratio, s.layer.distance_tolerance) &&
          fits_as_well(cylinder.normal_spread, f.normal_spread, s.options.residual_ratio, normal_floor))
        f.set_fit(cylinder);
    }
  }

  // Freeform: the best fit is much worse than the typical patch of this mesh (which takes a few
  // patches to tell; with fewer, the tolerances alone decide).
  std::vector<double> residuals;
  for (const Feature& f : s.layer.features)
    if (f.type != SurfaceType::Freeform) residuals.push_back(f.spread);
  double typical = s.floor;
  if (residuals.size() >= 3) {
    std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
    typical = std::max(residuals[residuals.size() / 2], s.floor);
  }
  // An exact tessellation has neither noise nor undulation: beyond the tolerance, a surface is not
  // the patch's, however large the patch.
  for (Feature& f : s.layer.features)
    if (f.spread > s.options.freeform_ratio * typical && f.spread > (s.exact_mesh ? s.exact_distance : s.layer.distance_tolerance) &&
        (s.exact_mesh || f.spread > s.options.freeform_relative_size * std::sqrt(f.area)))
      f.type = SurfaceType::Freeform;
  if (join_freeform_features(s.mesh, s.topology, s.layer.labels, s.layer.features)) count_faces(s.area, s.layer.labels, s.layer.features);
  // (After the freeform features took their slivers: a group's facets turn by up to the largest
  // facet turn, and would take every plane of few vertices beside it.)
  if (s.exact_mesh && join_unplaced_facets(s.mesh, s.topology, s.layer.labels, s.layer.features))
    count_faces(s.area, s.layer.labels, s.layer.features);
  // After the freeform features took their slivers: the planes tangent to a swept face's ends may be
  // as small in the export.
  if (s.exact_mesh && join_sampled_extrusions(s.mesh, s.topology, s.layer.distance_tolerance, s.exact_distance, s.floor,
                                             s.options.angle_tolerance_degrees * M_PI / 180.0, s.layer.labels, s.layer.features))
    count_faces(s.area, s.layer.labels, s.layer.features);
}

// The feature graph and its relations, with the rules that need them: each feature's points are
// fixed from here on.
void relate_features(FeatureState& s) {
  s.progress.sub("relations", 0.98, 0.99).step(0.0);

  const double angle_tolerance = s.options.angle_tolerance_degrees * M_PI / 180.0;
  // The labels stay as they are from here on: each feature's interior points (what its fit saw) and
  // every vertex of its faces serve the steps below and idealization.
  const int feature_count = static_cast<int>(s.layer.features.size());
  s.points = patch_points(s.mesh, s.layer.labels, feature_count);
  s.whole = patch_points(s.mesh, s.layer.labels, feature_count, -1);
  make_balls_of_corner_cylinders(s.mesh, s.topology, angle_tolerance, s.layer.distance_tolerance, s.options, s.layer.labels,
                                 s.points, s.layer.features);
  s.layer.form_deviation = form_deviation(s.mesh, s.layer.labels, s.layer.features);
  measure_radius_errors(s.whole, s.layer.form_deviation, s.layer.features);
  build_feature_graph(s.mesh, s.topology, s.layer.labels, s.layer.features, angle_tolerance, s.layer.distance_tolerance,
                      s.options.radius_tolerance, s.layer.adjacency, s.layer.relations);
  // On an exact tessellation a sphere band one facet row wide is a cone as much: any two coaxial
  // circles lie on both, and identification prefers the sphere. A chamfer meets its neighbours at
  // creases, while a sphere zone of a design (a ball between fillets, a rounded corner) is tangent
  // to some: a sphere that meets every neighbour at a crease, and that a cone explains as exactly,
  // is a cone (a screw's point).
  if (s.exact_mesh) {
    std::vector<char> tangent(s.layer.features.size(), 0), creased(s.layer.features.size(), 0);
    for (const FeatureAdjacency& a : s.layer.adjacency)
      for (int id : {a.a, a.b}) (a.continuity == Continuity::G1 ? tangent : creased)[id] = 1;
    const double normal_floor = s.options.normal_floor_degrees * M_PI / 180.0;
    bool retyped = false;
    for (Feature& f : s.layer.features) {
      if (f.type != SurfaceType::Sphere || tangent[f.id] || !creased[f.id]) continue;
      const SurfaceFit cone = fit_surface(SurfaceType::Cone, s.whole[f.id], s.options.fit);
      if (!cone.valid || !explains_every_point(cone.surface, s.whole[f.id], s.exact_distance,
                                               3.0 * f.normal_spread + normal_floor, kLargestFacetTurn))
        continue;
      f.set_fit(cone);
      retyped = true;
    }
    if (retyped)
      build_feature_graph(s.mesh, s.topology, s.layer.labels, s.layer.features, angle_tolerance, s.layer.distance_tolerance,
                          s.options.radius_tolerance, s.layer.adjacency, s.layer.relations);
  }
}

}  // namespace idealize
