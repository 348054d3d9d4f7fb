// The small pieces an exact tessellation's split leaves: merged into surfaces, absorbed by a
// neighbour, shattered into facets, or joined as one swept freeform face.
#include "features/exact_fragments.h"

#include "features/identify.h"
#include "fit/bspline_fitting.h"

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

bool merge_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                     const FeatureOptions& options, double exact_distance, std::vector<Feature>& features,
                     std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<char> small(num, 0);
  for (int p = 0; p < num; ++p) small[p] = points[p].points.rows() > 0 && points[p].points.rows() < kInteriorPoints;
  // Small pieces meeting without a crease (in order of id).
  std::vector<std::vector<int>> neighbours(num);
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels))
    if (small[pair.first] && small[pair.second] && turn <= kLargestFacetTurn) {
      neighbours[pair.first].push_back(pair.second);
      neighbours[pair.second].push_back(pair.first);
    }
  for (std::vector<int>& n : neighbours) std::sort(n.begin(), n.end());
  const double angle = options.normal_floor_degrees * M_PI / 180.0;
  std::vector<int> into(num);
  for (int p = 0; p < num; ++p) into[p] = p;
  std::vector<char> taken(num, 0), in_group(num, 0);
  bool any = false;
  for (int seed = 0; seed < num; ++seed) {
    if (!small[seed] || taken[seed] || neighbours[seed].empty()) continue;
    for (SurfaceType type : kTypesByPreference) {
      // The seed's nearest untaken small neighbours, breadth first, until the type is determined.
      std::vector<int> group{seed};
      in_group[seed] = 1;
      PatchPoints data = points[seed];
      for (size_t head = 0; head < group.size() && distinct_points(data) < parameter_count(type) + 3; ++head)
        for (int q : neighbours[group[head]])
          if (!taken[q] && !in_group[q] && distinct_points(data) < parameter_count(type) + 3) {
            in_group[q] = 1;
            group.push_back(q);
            data = concatenate(data, points[q]);
          }
      SurfaceFit fit;
      bool exact = distinct_points(data) >= parameter_count(type) + 3;
      if (exact) {
        fit = fit_surface(type, data, options.fit);
        exact = fit.valid && explains_every_point(fit.surface, data, exact_distance, angle, kFewPointsChordTurn);
      }
      const size_t gathered = group.size();  // their points are in `data` already
      if (exact) {  // grow over the small pieces the surface explains
        for (size_t head = 0; head < group.size(); ++head)
          for (int q : neighbours[group[head]])
            if (!taken[q] && !in_group[q] && explains_every_point(fit.surface, points[q], exact_distance, angle, kFewPointsChordTurn)) {
              in_group[q] = 1;
              group.push_back(q);
            }
      }
      for (int q : group) in_group[q] = 0;
      if (!exact) continue;
      const int id = features[seed].id;
      for (size_t i = gathered; i < group.size(); ++i) data = concatenate(data, points[group[i]]);
      const SurfaceFit refit = fit_surface(type, data, options.fit, &fit.surface);
      features[seed].set_fit(refit.valid && refit.rms <= fit.rms + exact_distance ? refit : fit);
      features[seed].id = id;
      for (int q : group) {
        into[q] = seed;
        taken[q] = 1;
      }
      any = true;
      break;
    }
  }
  for (int& l : labels)
    if (l >= 0) l = into[l];
  return any;
}

bool absorb_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                      double tolerance, const std::vector<Feature>& features, std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<int> into(num, kNone);
  std::vector<double> nearest(num, tolerance);
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels)) {
    if (turn > kLargestFacetTurn) continue;
    for (const auto& [piece, large] : {pair, std::make_pair(pair.second, pair.first)}) {
      if (points[piece].points.rows() >= kInteriorPoints || points[large].points.rows() < kInteriorPoints ||
          features[large].type == SurfaceType::Freeform)
        continue;
      double worst = 0.0;
      for (Eigen::Index i = 0; i < points[piece].points.rows(); ++i)
        worst = std::max(worst, std::abs(signed_distance(features[large].surface, points[piece].points.row(i).transpose())));
      if (worst < nearest[piece]) {
        nearest[piece] = worst;
        into[piece] = large;
      }
    }
  }
  bool any = false;
  for (int& l : labels)
    if (l >= 0 && into[l] != kNone) {
      l = into[l];
      any = true;
    }
  return any;
}

bool shatter_fragments(const TriangleMesh& mesh, const std::vector<PatchPoints>& points, const FeatureOptions& options,
                       std::vector<Feature>& features, std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<std::vector<int>> facets(num);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] >= 0 && points[labels[f]].points.rows() < kInteriorPoints) facets[labels[f]].push_back(f);
  std::vector<int> free_ids;
  for (int p = num - 1; p >= 0; --p)
    if (points[p].points.rows() == 0) free_ids.push_back(p);
  std::vector<int> slot(mesh.num_vertices(), -1);
  bool any = false;
  for (int p = 0; p < num; ++p) {
    if (facets[p].size() < 2 || facets[p].size() - 1 > free_ids.size()) continue;
    const Feature piece = features[p];
    for (size_t i = 0; i < facets[p].size(); ++i) {
      const int f = facets[p][i];
      const SurfaceFit plane =
          fit_surface(SurfaceType::Plane, face_points(mesh, &f, 1, slot, [](int) { return false; }), options.fit);
      if (!plane.valid) continue;  // a degenerate facet stays with the piece
      const int id = i == 0 ? p : free_ids.back();  // the first facet keeps the piece's id
      if (id != p) free_ids.pop_back();
      features[id] = piece;
      features[id].id = id;
      features[id].set_fit(plane);
      labels[f] = id;
      any |= id != p;
    }
  }
  return any;
}

bool join_sampled_extrusions(const TriangleMesh& mesh, const MeshTopology& topology, double tolerance,
                             double exact_distance, double floor, double angle_tolerance, std::vector<int>& labels,
                             std::vector<Feature>& features) {
  const std::vector<PatchPoints> points = patch_points(mesh, labels, static_cast<int>(features.size()), -1);
  // The rulings of a cylinder: its vertices across the axis, those within the exact distance as one.
  const auto rulings = [&](int p) {
    const Surface& c = features[p].surface;
    std::vector<Eigen::Vector3d> distinct;
    for (Eigen::Index i = 0; i < points[p].points.rows(); ++i) {
      const Eigen::Vector3d v = points[p].points.row(i).transpose() - c.point;
      const Eigen::Vector3d across = v - v.dot(c.axis) * c.axis;
      const auto near = [&](const Eigen::Vector3d& q) { return (q - across).norm() <= exact_distance; };
      if (std::none_of(distinct.begin(), distinct.end(), near)) distinct.push_back(across);
    }
    return static_cast<int>(distinct.size());
  };
  std::vector<char> small(features.size(), 0);
  for (size_t p = 0; p < features.size(); ++p) {
    const Feature& f = features[p];
    if (points[p].points.rows() >= kInteriorPoints) continue;
    if (f.type == SurfaceType::Plane) small[p] = 1;
    else if (f.type == SurfaceType::Cylinder) small[p] = f.rms > 2.0 * floor || rulings(static_cast<int>(p)) < 3 + 3;
  }
  const std::map<std::pair<int, int>, double> turns = boundary_turns(mesh, topology, labels);
  std::vector<int> parent(features.size());
  const std::function<int(int)> root = [&](int p) { return parent[p] == p ? p : parent[p] = root(parent[p]); };
  // The small pieces that meet without a crease, in groups.
  const auto grouped = [&] {
    std::iota(parent.begin(), parent.end(), 0);
    for (const auto& [pair, turn] : turns)
      if (small[pair.first] && small[pair.second] && turn <= kLargestFacetTurn) parent[root(pair.first)] = root(pair.second);
    std::map<int, std::vector<int>> groups;
    for (size_t p = 0; p < features.size(); ++p)
      if (small[p]) groups[root(static_cast<int>(p))].push_back(static_cast<int>(p));
    return groups;
  };
  // One direction: the axis of the group's widest cylinder (-1: none).
  const auto widest_cylinder = [&](const std::vector<int>& members) {
    int widest = -1;
    for (int m : members)
      if (features[m].type == SurfaceType::Cylinder && (widest < 0 || features[m].area > features[widest].area)) widest = m;
    return widest;
  };
  // How far a piece reaches across the direction: the diameter of its vertices seen along it.
  const auto reach_across = [&](int p, const Eigen::Vector3d& direction) {
    double widest = 0.0;
    const MatrixX3d& v = points[p].points;
    for (Eigen::Index i = 0; i < v.rows(); ++i)
      for (Eigen::Index j = i + 1; j < v.rows(); ++j) {
        const Eigen::Vector3d d = (v.row(i) - v.row(j)).transpose();
        widest = std::max(widest, (d - d.dot(direction) * direction).norm());
      }
    return widest;
  };
  // A plane of the profile is a chord of it, no wider across the direction than its cylinders'
  // pieces; a plane tangent to the profile's end (as small a piece where the export gives it two
  // facets) reaches far beyond.
  for (const auto& [group_root, members] : grouped()) {
    const int widest = widest_cylinder(members);
    if (widest < 0) continue;
    const Eigen::Vector3d direction = features[widest].surface.axis;
    double reach = 0.0;
    for (int m : members)
      if (features[m].type == SurfaceType::Cylinder) reach = std::max(reach, reach_across(m, direction));
    for (int m : members)
      if (features[m].type == SurfaceType::Plane && reach_across(m, direction) > reach) small[m] = 0;
  }
  std::vector<int> faces;
  std::vector<int> slot(mesh.num_vertices(), -1);
  bool any = false;
  for (const auto& [group_root, members] : grouped()) {
    const int widest = widest_cylinder(members);
    const auto cylinders = std::count_if(members.begin(), members.end(),
                                         [&](int m) { return features[m].type == SurfaceType::Cylinder; });
    if (members.size() < 3 || cylinders < 2) continue;
    // The axis of every cylinder along the direction, every plane's normal across it.
    const Eigen::Vector3d direction = features[widest].surface.axis;
    const bool swept = std::all_of(members.begin(), members.end(), [&](int m) {
      const double along = std::abs(features[m].surface.axis.dot(direction));
      return features[m].type == SurfaceType::Cylinder ? along >= std::cos(angle_tolerance) : along <= std::sin(angle_tolerance);
    });
    if (!swept) continue;
    faces.clear();
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (labels[f] >= 0 && small[labels[f]] && root(labels[f]) == group_root) faces.push_back(f);
    const PatchPoints union_points = face_points(mesh, faces.data(), static_cast<int>(faces.size()), slot, [](int) { return true; });
    const BSplineSurfaceFit fit = fit_bspline_surface(union_points.points, union_points.weights, union_points.sample_normals);
    if (!fit.valid || !(fit.max_error <= tolerance)) continue;
    int largest = members.front();
    for (int m : members)
      if (features[m].area > features[largest].area) largest = m;
    for (int f : faces) labels[f] = largest;
    features[largest].type = SurfaceType::Freeform;
    any = true;
  }
  if (any) compact_features(labels, features);
  return any;
}

}  // namespace idealize
