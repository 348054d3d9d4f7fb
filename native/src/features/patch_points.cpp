// What the feature stages see of the patches: their points (what a fit sees of a set of faces), the
// borders between them, and their features' face counts.
#include "features/patch_points.h"

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

std::vector<int> largest_first(const std::vector<FitData>& points, const std::vector<char>& which) {
  std::vector<int> order;
  for (size_t p = 0; p < which.size() && p < points.size(); ++p)
    if (which[p]) order.push_back(static_cast<int>(p));
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return points[x].points.rows() > points[y].points.rows(); });
  return order;
}

std::vector<int> vertex_labels(const TriangleMesh& mesh, const std::vector<int>& labels) {
  std::vector<int> out(mesh.num_vertices(), kNone);
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      int& v = out[mesh.F(f, c)];
      if (v == kNone) v = labels[f];
      else if (v != labels[f]) v = kSeveral;
    }
  return out;
}

std::vector<PatchPoints> patch_points(const TriangleMesh& mesh, const std::vector<int>& labels, int num_patches,
                                      int rim_rings) {
  // Faces bucketed by patch (counting sort).
  std::vector<int> offset(num_patches + 1, 0);
  for (int l : labels)
    if (l >= 0) ++offset[l + 1];
  for (int p = 0; p < num_patches; ++p) offset[p + 1] += offset[p];
  std::vector<int> faces(offset[num_patches]);
  {
    std::vector<int> next(offset.begin(), offset.end() - 1);
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (labels[f] >= 0) faces[next[labels[f]]++] = f;
  }
  std::vector<int> shared = vertex_labels(mesh, labels);
  for (int ring = 0; ring < rim_rings; ++ring) {
    std::vector<char> near_rim(mesh.num_faces(), 0);
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) near_rim[f] |= shared[mesh.F(f, c)] == kSeveral;
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (near_rim[f])
        for (int c = 0; c < 3; ++c) shared[mesh.F(f, c)] = kSeveral;
  }
  std::vector<int> slot(mesh.num_vertices(), -1);
  std::vector<PatchPoints> out(num_patches);
  for (int p = 0; p < num_patches; ++p)
    out[p] = face_points(mesh, faces.data() + offset[p], offset[p + 1] - offset[p], slot,
                         [&](int v) { return rim_rings >= 0 && shared[v] == p; });
  return out;
}

double facet_turn(const TriangleMesh& mesh, int f, int g) {
  const double turn = std::acos(std::clamp(face_normal(mesh, f).dot(face_normal(mesh, g)), -1.0, 1.0));
  return std::isfinite(turn) ? turn : M_PI;
}

std::map<std::pair<int, int>, double> boundary_turns(const TriangleMesh& mesh, const MeshTopology& topology,
                                                     const std::vector<int>& labels, bool inside) {
  std::map<std::pair<int, int>, double> turns;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < f || labels[f] < 0 || labels[g] < 0 || (labels[f] == labels[g] && !inside)) continue;
      double& t = turns[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}];
      t = std::max(t, facet_turn(mesh, f, g));
    }
  return turns;
}

std::vector<std::pair<int, int>> adjacent_pairs(const TriangleMesh& mesh, const MeshTopology& topology,
                                                const std::vector<int>& labels) {
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels)) pairs.push_back(pair);
  return pairs;
}

void compact_features(std::vector<int>& labels, std::vector<Feature>& features) {
  std::vector<int> used(features.size(), 0);
  for (int l : labels)
    if (l >= 0) used[l] = 1;
  std::vector<int> renumber(features.size(), kNone);
  std::vector<Feature> kept;
  for (size_t p = 0; p < features.size(); ++p)
    if (used[p]) {
      renumber[p] = static_cast<int>(kept.size());
      kept.push_back(features[p]);
      kept.back().id = renumber[p];
    }
  for (int& l : labels)
    if (l >= 0) l = renumber[l];
  features = std::move(kept);
}

void label_sums(const Eigen::VectorXd& area, const std::vector<int>& labels, int count, std::vector<double>& sums,
                std::vector<int>& triangles) {
  sums.assign(count, 0.0);
  triangles.assign(count, 0);
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] >= 0) {
      sums[labels[f]] += area[f];
      ++triangles[labels[f]];
    }
}

void count_faces(const Eigen::VectorXd& area, const std::vector<int>& labels, std::vector<Feature>& features) {
  std::vector<double> sums;
  std::vector<int> triangles;
  label_sums(area, labels, static_cast<int>(features.size()), sums, triangles);
  for (size_t p = 0; p < features.size(); ++p) {
    features[p].area = sums[p];
    features[p].triangles = triangles[p];
  }
}

}  // namespace idealize
