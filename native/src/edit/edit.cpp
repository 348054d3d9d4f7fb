#include "edit/edit.h"

#include "edit/move_vertices.h"
#include "edit/propagate.h"
#include "edit/remesh_adaptive.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <string>

namespace idealize {
namespace {

// The most steps an edit that turns triangles over is split into (see edit_features).
constexpr int kMostSteps = 8;

}  // namespace

void check_layer(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                 const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations) {
  const int n = static_cast<int>(surfaces.size());
  if (static_cast<int>(labels.size()) != mesh.num_faces())
    throw std::invalid_argument("the layer has " + std::to_string(labels.size()) + " labels for " +
                                std::to_string(mesh.num_faces()) + " triangles");
  auto valid = [n](int f) { return f >= 0 && f < n; };
  // -1: a triangle the mesh check set aside (degenerate or duplicate); it belongs to no feature.
  if (!std::all_of(labels.begin(), labels.end(), [&](int f) { return f == -1 || valid(f); }))
    throw std::invalid_argument("a triangle's label names no feature of the layer");
  for (const FeatureAdjacency& a : adjacency)
    if (!valid(a.a) || !valid(a.b)) throw std::invalid_argument("an adjacency names no feature of the layer");
  for (const FeatureRelation& r : relations)
    if (!std::all_of(r.features.begin(), r.features.end(), valid))
      throw std::invalid_argument("a relation names no feature of the layer");
}

Eigen::VectorXd vertex_deviation(const TriangleMesh& mesh, const std::vector<int>& labels,
                                 const std::vector<Surface>& surfaces) {
  Eigen::VectorXd deviation = Eigen::VectorXd::Constant(mesh.num_vertices(), std::numeric_limits<double>::infinity());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0 || surfaces[labels[f]].type == SurfaceType::Freeform) continue;
    const Surface& s = surfaces[labels[f]];
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      deviation(v) = std::min(deviation(v), std::abs(signed_distance(s, mesh.V.row(v).transpose())));
    }
  }
  for (Eigen::Index v = 0; v < deviation.size(); ++v)
    if (std::isinf(deviation(v))) deviation(v) = std::numeric_limits<double>::quiet_NaN();
  return deviation;
}

namespace {

// The smallest radius of curvature of a surface over the points `at` (infinite for a plane).
double tightest_radius(const Surface& s, const TriangleMesh& mesh, const std::vector<int>& at) {
  switch (s.type) {
    case SurfaceType::Cylinder:
    case SurfaceType::Sphere: return s.radius;
    case SurfaceType::Torus: return s.minor;
    case SurfaceType::Cone: {
      double tightest = std::numeric_limits<double>::infinity();
      for (int v : at)
        tightest = std::min(tightest, axial_coordinates(s.point, s.axis, mesh.V.row(v).transpose()).distance /
                                          std::cos(s.half_angle));
      return tightest;
    }
    default: return std::numeric_limits<double>::infinity();
  }
}

}  // namespace

// Each feature's target edge length: the density it has, its own mean edge length, but no longer
// than keeps its chords as close to a curved surface as its own edges keep them, or a quarter of
// the distance tolerance, whichever is looser (an edge of length l across a radius r lies l^2 / 8r
// off it; isotropic remeshing leaves edges up to 4/3 of the target, which then lie (4/3)^2 / 4 =
// 0.44 of the tolerance off: still equal to the surface for the layer). A CAD export's holes,
// tessellated in slivers as fine across as a thousandth of the tolerance, would otherwise be
// remeshed into hundreds of thousands of triangles. `given` (per feature, or empty) wins where
// positive.
std::vector<double> remeshing_targets(const TriangleMesh& mesh, const std::vector<int>& labels,
                                      const std::vector<Surface>& surfaces, const std::vector<double>& given,
                                      double distance_tolerance) {
  const size_t n = surfaces.size();
  auto is_given = [&](size_t l) { return l < given.size() && given[l] > 0.0; };
  std::vector<std::vector<double>> edges(n);
  std::vector<double> sagitta(n, 0.0);
  std::vector<std::vector<int>> corners(n);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int l = labels[f];
    if (l < 0 || is_given(l)) continue;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d a = mesh.V.row(mesh.F(f, c)), b = mesh.V.row(mesh.F(f, (c + 1) % 3));
      edges[l].push_back((b - a).norm());
      sagitta[l] = std::max(sagitta[l], std::abs(signed_distance(surfaces[l], 0.5 * (a + b))));
      corners[l].push_back(mesh.F(f, c));
    }
  }
  std::vector<double> target(n, 0.0);
  for (size_t l = 0; l < n; ++l) {
    if (is_given(l)) target[l] = given[l];
    if (edges[l].empty()) continue;
    target[l] = std::accumulate(edges[l].begin(), edges[l].end(), 0.0) / static_cast<double>(edges[l].size());
    const double radius = tightest_radius(surfaces[l], mesh, corners[l]);
    const double off = std::max(sagitta[l], 0.25 * distance_tolerance);
    if (std::isfinite(radius) && off > 0.0) target[l] = std::min(target[l], 0.75 * std::sqrt(8.0 * radius * off));
  }
  return target;
}

namespace {

EditResult edit_once(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                     const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                     const FeatureEdit& edit, const EditOptions& options) {
  const Propagation propagation = propagate_edit(mesh, labels, surfaces, adjacency, relations, edit, options);
  MovedVertices moved = move_vertices(mesh, labels, adjacency, surfaces, propagation);
  const std::vector<double> sides = facing_sides(mesh, labels, surfaces);
  std::vector<char> edited(surfaces.size(), 0);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] >= 0) edited[labels[f]] |= moved.region[f] || propagation.changed[labels[f]];
  EditResult result;
  result.surfaces = propagation.surfaces;
  result.changed = propagation.changed;
  result.mesh.V = std::move(moved.V);
  result.mesh.F = mesh.F;
  result.labels = labels;
  result.target_edge_lengths =
      remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths, options.distance_tolerance);
  if (!options.remesh || std::none_of(moved.region.begin(), moved.region.end(), [](char r) { return r; })) {
    refuse_inverted(result.mesh, result.labels, result.surfaces, sides, edited, edit.features);
    result.vertex_deviation = vertex_deviation(result.mesh, result.labels, result.surfaces);
    return result;
  }
  std::vector<double> kept(surfaces.size(), 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (moved.region[f]) kept[labels[f]] = result.target_edge_lengths[labels[f]];
  std::set<std::pair<int, int>> g1;
  for (const FeatureAdjacency& a : adjacency)
    if (a.continuity == Continuity::G1) g1.insert({std::min(a.a, a.b), std::max(a.a, a.b)});
  // The remeshing relocates the few triangles a large change turns over near a border. When it
  // fails (CGAL refuses a configuration) or leaves triangles turned over, the moved mesh stands
  // if it is valid by itself: the edit degrades to stretched triangles instead of failing.
  try {
    RemeshedLayer remeshed = remesh_adaptive(result.mesh, result.labels, kept, result.surfaces, g1,
                                             options.remesh_iterations);
    const std::string inverted = inverted_triangles(remeshed.mesh, remeshed.labels, result.surfaces, sides, edited);
    if (inverted.empty()) {
      result.mesh = std::move(remeshed.mesh);
      result.labels = std::move(remeshed.labels);
    } else {
      result.remeshing_problem = "the remeshing turned " + inverted + " over";
    }
  } catch (const std::exception& e) {
    result.remeshing_problem = e.what();
  }
  if (!result.remeshing_problem.empty())
    refuse_inverted(result.mesh, result.labels, result.surfaces, sides, edited, edit.features);
  result.vertex_deviation = vertex_deviation(result.mesh, result.labels, result.surfaces);
  return result;
}

// The value of an absolute parameter of a surface (radius, tube radius, half-angle).
double parameter_value(const Surface& s, EditParameter parameter) {
  switch (parameter) {
    case EditParameter::Radius: return s.radius;
    case EditParameter::MinorRadius: return s.minor;
    case EditParameter::HalfAngle: return s.half_angle;
    default: return 0.0;
  }
}

// Step `i` of `steps` of `edit`, applied to the layer after step i - 1: a share of the offset, the
// parameter on its way from where it was, and the motion M(s) = (rotation by s times its angle,
// s times its translation) from s = (i - 1) / steps to i / steps.
FeatureEdit step_of(const FeatureEdit& edit, const std::vector<Surface>& original, int i, int steps) {
  FeatureEdit step = edit;
  const double s = static_cast<double>(i) / steps, r = static_cast<double>(i - 1) / steps;
  if (edit.parameter == EditParameter::Offset) {
    step.value = edit.value / steps;
  } else if (edit.parameter != EditParameter::None) {
    const double start = parameter_value(original[edit.features[0]], edit.parameter);
    step.value = start + s * (edit.value - start);
  }
  const Eigen::AngleAxisd turn(edit.motion.linear());
  auto along = [&](double share) {
    Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
    m.linear() = Eigen::AngleAxisd(share * turn.angle(), turn.axis()).toRotationMatrix();
    m.translation() = share * edit.motion.translation();
    return m;
  };
  step.motion = along(s) * along(r).inverse();
  return step;
}

EditResult edit_in_steps(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                         const FeatureEdit& edit, const EditOptions& options, int steps) {
  EditResult result{mesh, labels, surfaces, std::vector<char>(surfaces.size(), 0), {}, options.target_edge_lengths, ""};
  EditOptions each = options;
  for (int i = 1; i <= steps; ++i) {
    EditResult next =
        edit_once(result.mesh, result.labels, result.surfaces, adjacency, relations, step_of(edit, surfaces, i, steps), each);
    for (size_t f = 0; f < next.changed.size(); ++f) next.changed[f] |= result.changed[f];
    if (!result.remeshing_problem.empty() && next.remeshing_problem.empty()) next.remeshing_problem = result.remeshing_problem;
    each.target_edge_lengths = next.target_edge_lengths;  // the first step's density throughout
    result = std::move(next);
  }
  return result;
}

}  // namespace

EditResult edit_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                         const FeatureEdit& edit, const EditOptions& options) {
  check_layer(mesh, labels, surfaces, adjacency, relations);
  try {
    return edit_once(mesh, labels, surfaces, adjacency, relations, edit, options);
  } catch (const InvertedTriangles& whole) {
    // Too large a change for the mesh at once, or impossible: in 2, 4 and 8 steps, each remeshed
    // before the next, a border crosses a half, a quarter, an eighth as many triangles. Three
    // halvings bound the cost at 14 more runs; an impossible edit fails them all.
    const bool steps_apply = options.remesh && (edit.parameter == EditParameter::None ||
                                                edit.parameter == EditParameter::Offset || edit.features.size() == 1);
    for (int steps = 2; steps_apply && steps <= kMostSteps; steps *= 2) {
      try {
        return edit_in_steps(mesh, labels, surfaces, adjacency, relations, edit, options, steps);
      } catch (const InvertedTriangles&) {
      }
    }
    throw EditConflict(whole.what());
  }
}

}  // namespace idealize
