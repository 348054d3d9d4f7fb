// Projection of the mesh onto its features' surfaces: the idealized mesh and its deviation.
#include "features/project_vertices.h"

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

void project_vertices(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                      const std::vector<Feature>& features, double tolerance, FeatureLayer& layer,
                      const ProgressSpan& progress) {
  layer.idealized_vertices = mesh.V;
  double sum = 0.0;
  int measured = 0;
  layer.max_deviation = 0.0;
  layer.vertex_deviation = Eigen::VectorXd::Constant(mesh.num_vertices(), std::numeric_limits<double>::quiet_NaN());
  // How far noise alone takes a vertex of patch p from its surface, in units of the fit's spread: a
  // false alarm in a hundred patches among its n vertices (a patch has about half as many vertices as
  // faces) at sqrt(2 ln(100 n)).
  std::vector<double> reach(features.size());
  for (size_t p = 0; p < features.size(); ++p)
    reach[p] = std::sqrt(2.0 * std::log(std::max(1.0, 50.0 * features[p].triangles)));
  std::vector<int> around;
  std::vector<double> offsets;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    progress.tick(v, mesh.num_vertices());
    around.clear();
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
      const int p = labels[*f];
      if (p >= 0 && features[p].type != SurfaceType::Freeform &&
          std::find(around.begin(), around.end(), p) == around.end())
        around.push_back(p);
    }
    if (around.empty()) continue;
    const Eigen::Vector3d original = mesh.V.row(v);
    double nearest = std::numeric_limits<double>::infinity();
    for (int p : around) nearest = std::min(nearest, std::abs(signed_distance(features[p].surface, original)));
    layer.vertex_deviation[v] = nearest;
    sum += nearest * nearest;
    ++measured;
    layer.max_deviation = std::max(layer.max_deviation, nearest);

    // A surface that does not explain the vertex does not move it: beyond 3 σ of its fit the vertex
    // lies in a part of the patch the feature does not describe (a fillet too narrow to be found),
    // unless the noise put it there: within the patch's reach, with neighbours in the patch whose
    // median distance is within 3 σ of the median of as many (those in an undescribed part are off
    // together; those across a sharp edge are another surface's: a scan's vertex on a sharp edge
    // goes to the edge, a small face that no feature took is cut back to its neighbours' edge). The
    // median, not the mean: one of a few hundred noise outliers has another among its neighbours,
    // which alone took the mean of five beyond its limit (a box's scan). Off on the vertex's side
    // only: an undescribed part moves the vertex and its neighbours off together, while neighbours
    // that the noise put on the other side (a plane's vertex 3.3 σ below it, its neighbours' median
    // 1.6 σ above) say nothing against the vertex's being noise.
    auto noise_outlier = [&](int p, double sigma, double side) {
      offsets.clear();
      for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
        if (labels[*f] != p) continue;
        for (int c = 0; c < 3; ++c)
          if (mesh.F(*f, c) != v)  // each neighbour twice on a closed fan
            offsets.push_back(signed_distance(features[p].surface, mesh.V.row(mesh.F(*f, c)).transpose()));
      }
      if (offsets.empty()) return false;
      std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
      // The median of k samples spreads by sqrt(pi / 2) σ / sqrt(k).
      const double median_spread = std::sqrt(0.5 * M_PI) * sigma / std::sqrt(0.5 * offsets.size());
      return side * offsets[offsets.size() / 2] <= 3.0 * median_spread;
    };
    around.erase(std::remove_if(around.begin(), around.end(), [&](int p) {
                   const double sigma = features[p].spread + kExactFraction * tolerance;
                   const double offset = signed_distance(features[p].surface, original), d = std::abs(offset);
                   return d > 3.0 * sigma && (d > reach[p] * sigma || !noise_outlier(p, sigma, offset < 0.0 ? -1.0 : 1.0));
                 }), around.end());
    if (around.empty()) continue;
    Eigen::Vector3d x = original;
    const int rounds = around.size() == 1 ? 1 : 50;
    for (int r = 0; r < rounds; ++r) {
      const Eigen::Vector3d before = x;
      for (int p : around) x = closest_point(features[p].surface, x);
      if ((x - before).norm() < 1e-6 * tolerance) break;
    }
    // Nearly tangent surfaces intersect far from where they touch: never move a vertex further
    // than its own patch allows.
    if ((x - original).norm() > std::max(nearest, tolerance) * 10.0) x = closest_point(features[around[0]].surface, original);
    layer.idealized_vertices.row(v) = x;
  }
  layer.rms_deviation = measured > 0 ? std::sqrt(sum / measured) : 0.0;
}

}  // namespace idealize
