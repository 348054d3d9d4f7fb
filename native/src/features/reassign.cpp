// Reassignment of rim faces to the neighbour whose surface explains them.
#include "features/reassign.h"

#include "features/identify.h"
#include "features/pipeline.h"

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

std::vector<char> reassign_faces(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<Feature>& features,
                                 const FeatureOptions& options, double floor, std::vector<int>& labels,
                                 const ProgressSpan& progress) {
  const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
  std::vector<char> changed(features.size(), 0);
  std::vector<int> queue;
  for (int f = 0; f < mesh.num_faces(); ++f) queue.push_back(f);
  for (size_t head = 0; head < queue.size(); ++head) {
    progress.poll(static_cast<long long>(head));
    const int f = queue[head];
    const int p = labels[f];
    if (p < 0) continue;
    bool rim = false;
    for (int c = 0; c < 3 && !rim; ++c) {
      const int g = topology.face_neighbor(f, c);
      rim = g >= 0 && labels[g] >= 0 && labels[g] != p;
    }
    if (!rim) continue;
    int target = kNone;
    const double own = misfit(mesh, f, features[p], floor, normal_floor);
    // Noise alone rarely makes one surface four times better than another.
    double best = own > 1.0 ? 1.0 : own / 4.0;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] < 0 || labels[g] == p) continue;
      const double m = misfit(mesh, f, features[labels[g]], floor, normal_floor);
      if (m < best) {
        best = m;
        target = labels[g];
      }
    }
    if (target == kNone) continue;
    labels[f] = target;
    changed[p] = changed[target] = 1;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && labels[g] == p) queue.push_back(g);
    }
  }
  return changed;
}

void reassign_rims(FeatureState& s, const ProgressSpan& span) {
  // Move rim faces to the neighbour that explains them, refine the surfaces of the patches that
  // changed (same type, starting from the previous fit), and finally identify those afresh. Runs
  // again after merging, which brings surfaces that explain more of their neighbours' rims.
  // Rounds stop early when nothing moves: each round takes its share of the span.
  const int patches = static_cast<int>(s.layer.features.size());
  const std::vector<int> before = s.triangle_counts();
  const double share = 0.9 / std::max(s.options.reassignment_rounds, 1);
  for (int round = 0; round < s.options.reassignment_rounds; ++round) {
    const ProgressSpan this_round = span.sub(share * round, share * (round + 1));
    this_round.step(0.0);
    const std::vector<char> changed =
        reassign_faces(s.mesh, s.topology, s.layer.features, s.options, s.floor, s.layer.labels, this_round);
    if (std::find(changed.begin(), changed.end(), 1) == changed.end()) break;
    this_round.step(0.4);
    s.points = patch_points(s.mesh, s.layer.labels, patches);
    s.refit_changed(changed, this_round.sub(0.5, 1.0));
  }
  // A patch that lost or gained a good part of its faces may be of another type now (the rim of
  // a scan's patch changes by a few percent; a coarse CAD patch may lose half of its facets).
  const std::vector<int> after = s.triangle_counts();
  std::vector<char> reidentify(patches, 0);
  for (int p = 0; p < patches; ++p) reidentify[p] = std::abs(after[p] - before[p]) > before[p] / 4;
  s.identify_all(s.points, reidentify, span.sub(0.9, 1.0));
}

}  // namespace idealize
