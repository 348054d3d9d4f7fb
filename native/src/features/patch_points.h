// What the feature stages see of the patches: their points (what a fit sees of a set of faces), the
// borders between them, and their features' face counts.
#pragma once

#include "features/feature_layer.h"

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

// What the fits see of a patch.
using PatchPoints = FitData;

// A vertex label: no patch, several patches.
constexpr int kNone = -1;
constexpr int kSeveral = -2;

// Fits use a patch's interior vertices when it has at least this many: enough for a torus (seven
// parameters) with noise.
constexpr int kInteriorPoints = 24;

// What a fit sees of a set of faces: their vertices (a third of the area of the faces around each)
// and the faces themselves (centroid, normal, area). When at least kInteriorPoints of the vertices
// are `interior`, only those are kept: on a scan the rim of a patch lies on the rounded-off edge,
// while a coarse CAD face may have no interior vertex and its rim lies on the surface. `slot` is a
// per-vertex scratch array of -1, left as it was found.
template <typename Interior>
PatchPoints face_points(const TriangleMesh& mesh, const int* faces, int count, std::vector<int>& slot,
                        const Interior& interior) {
  PatchPoints pp;
  pp.sample_points.resize(count, 3);
  pp.sample_normals.resize(count, 3);
  pp.sample_weights.resize(count);
  std::vector<int> vertices;
  std::vector<double> vertex_area;
  for (int i = 0; i < count; ++i) {
    const int f = faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double area = 0.5 * n.norm();
    pp.sample_points.row(i) = (a + b + c) / 3.0;
    pp.sample_normals.row(i) = area > 0.0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
    pp.sample_weights[i] = area;
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.F(f, k);
      if (slot[v] < 0) {
        slot[v] = static_cast<int>(vertices.size());
        vertices.push_back(v);
        vertex_area.push_back(0.0);
      }
      vertex_area[slot[v]] += area / 3.0;
    }
  }
  const auto interior_count = std::count_if(vertices.begin(), vertices.end(), interior);
  const bool interior_only = interior_count >= kInteriorPoints;
  pp.points.resize(interior_only ? interior_count : static_cast<Eigen::Index>(vertices.size()), 3);
  pp.weights.resize(pp.points.rows());
  Eigen::Index k = 0;
  for (size_t i = 0; i < vertices.size(); ++i) {
    const int v = vertices[i];
    slot[v] = -1;
    if (interior_only && !interior(v)) continue;
    pp.points.row(k) = mesh.V.row(v);
    pp.weights[k] = vertex_area[i];
    ++k;
  }
  return pp;
}

// The patches p with which[p] (#which <= #points), the largest (most points) first.
std::vector<int> largest_first(const std::vector<FitData>& points, const std::vector<char>& which);

// The label shared by all faces around each vertex, kNone if none, kSeveral if they differ.
std::vector<int> vertex_labels(const TriangleMesh& mesh, const std::vector<int>& labels);

// What the fits see of every patch (face_points, interior: the vertices only the patch touches,
// and with `rim_rings` > 0 not on that many rings of faces along its rim either; with `rim_rings`
// < 0 every vertex of the patch's faces).
std::vector<PatchPoints> patch_points(const TriangleMesh& mesh, const std::vector<int>& labels, int num_patches,
                                      int rim_rings = 0);

// The angle between the normals of faces f and g (π for a degenerate face).
double facet_turn(const TriangleMesh& mesh, int f, int g);

// The sharpest turn between the facets of each pair of adjacent patches, in radians, keyed (a, b)
// with a < b; with `inside`, also the sharpest turn inside each patch, keyed (p, p).
std::map<std::pair<int, int>, double> boundary_turns(const TriangleMesh& mesh, const MeshTopology& topology,
                                                     const std::vector<int>& labels, bool inside = false);

// The pairs of patches (a, b) with a < b that share a mesh edge.
std::vector<std::pair<int, int>> adjacent_pairs(const TriangleMesh& mesh, const MeshTopology& topology,
                                                const std::vector<int>& labels);

// Drops features left without faces and renumbers the rest in order.
void compact_features(std::vector<int>& labels, std::vector<Feature>& features);

// The area and triangle count of each of `count` labels (faces labelled -1 count for none), from
// each face's `area`.
void label_sums(const Eigen::VectorXd& area, const std::vector<int>& labels, int count, std::vector<double>& sums,
                std::vector<int>& triangles);

// Area and triangle count of each feature from the labels (label_sums).
void count_faces(const Eigen::VectorXd& area, const std::vector<int>& labels, std::vector<Feature>& features);

}  // namespace idealize
