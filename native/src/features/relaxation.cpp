#include "features/relaxation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <queue>
#include <tuple>

namespace idealize {

namespace {

double face_cost(const TriangleMesh& mesh, int f, const FloodSurface& fs) {
  const Surface& surface = *fs.surface;
  double squared = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d p = mesh.V.row(mesh.F(f, k)).transpose();
    const double d = signed_distance(surface, p) / fs.distance_unit;
    squared += d * d / 3.0;
    centroid += p / 3.0;
  }
  const double cosine = std::abs(face_normal(mesh, f).dot(surface_normal(surface, centroid)));
  const double angle = std::acos(std::min(cosine, 1.0)) / fs.angle_unit;
  // The negative log-likelihood of the face under the surface's Gaussian spreads.
  const double cost = 0.5 * (squared + angle * angle) + std::log(fs.distance_unit) + std::log(fs.angle_unit);
  return std::isnan(cost) ? std::numeric_limits<double>::infinity() : cost;  // a facet without a normal comes last
}

// The largest distance from `centre` to a corner of face f.
double radius_about(const TriangleMesh& mesh, int f, const Eigen::Vector3d& centre) {
  double r = 0.0;
  for (int c = 0; c < 3; ++c) r = std::max(r, (mesh.V.row(mesh.F(f, c)).transpose() - centre).norm());
  return r;
}

// Whether the surfaces of the patches `on` (repeats allowed) have a common point within `radius` of
// `centre`: alternating projections from `centre` converge to the nearest common point of
// transversal surfaces, and wander off where the surfaces do not meet.
bool meet_within(const std::vector<FloodSurface>& surfaces, const std::array<int, 3>& on, const Eigen::Vector3d& centre,
                 double radius) {
  if (on[0] == on[1] && on[1] == on[2]) return true;
  Eigen::Vector3d x = centre;
  for (int round = 0; round < 50; ++round)
    for (int q : on) x = closest_point(*surfaces[q].surface, x);
  for (int q : on)
    if (std::abs(signed_distance(*surfaces[q].surface, x)) > surfaces[q].distance_unit) return false;
  return (x - centre).norm() <= radius;
}

constexpr int kUnclaimed = -2;
using Candidate = std::tuple<double, int, int>;  // cost, face, patch: ties go to the lower index
using CandidateQueue = std::priority_queue<Candidate, std::vector<Candidate>, std::greater<Candidate>>;

// What a face costs a surface more than its own: where two surfaces fit about equally well (the
// tangent zone of a fillet), the border stays; where the noise alone decided it moves. Measured on
// the benchmark: 0 let fillets overreach into their planes and scattered their radii (scan: 83 %
// within 1 %), 2 kept half of the gain in faces (scan 345 instead of 356); 0.5 gave 87 %.
constexpr double kSwitchCost = 0.5;

// Offers the unclaimed neighbours of face f to patch p.
void push_neighbors(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<FloodSurface>& surfaces,
                    const std::vector<int>& labels, const std::vector<int>& claimed, int f, int p, CandidateQueue& queue) {
  for (int c = 0; c < 3; ++c) {
    const int g = topology.face_neighbor(f, c);
    if (g >= 0 && claimed[g] == kUnclaimed)
      queue.emplace(face_cost(mesh, g, surfaces[p]) + (labels[g] == p ? 0.0 : kSwitchCost), g, p);
  }
}

// Hands the unclaimed faces out, cheapest first, to the patches that reach them; then relabels the
// faces claimed by another patch than their own. Returns which patches lost or gained faces.
std::vector<char> flood_and_relabel(const TriangleMesh& mesh, const MeshTopology& topology,
                                    const std::vector<FloodSurface>& surfaces, std::vector<int>& claimed,
                                    CandidateQueue& queue, std::vector<int>& labels, const ProgressSpan& progress) {
  long long popped = 0;
  while (!queue.empty()) {
    progress.poll(++popped, 1 << 12);
    const auto [cost, f, p] = queue.top();
    queue.pop();
    if (claimed[f] != kUnclaimed) continue;
    claimed[f] = p;
    push_neighbors(mesh, topology, surfaces, labels, claimed, f, p, queue);
  }
  std::vector<char> changed(surfaces.size(), 0);
  for (size_t f = 0; f < labels.size(); ++f)
    if (claimed[f] != kUnclaimed && claimed[f] != labels[f]) {
      changed[labels[f]] = changed[claimed[f]] = 1;
      labels[f] = claimed[f];
    }
  return changed;
}

}  // namespace

std::vector<char> flood_labels(const TriangleMesh& mesh, const MeshTopology& topology,
                               const std::vector<FloodSurface>& surfaces, int band, std::vector<int>& labels,
                               const ProgressSpan& progress) {
  const int num_faces = mesh.num_faces();
  const int num_patches = static_cast<int>(surfaces.size());
  auto movable = [&](int f) { return labels[f] >= 0 && labels[f] < num_patches && surfaces[labels[f]].surface != nullptr; };
  // Edge steps from the nearest face of another label, up to `band`; farther faces keep theirs.
  std::vector<int> depth(num_faces, -1), front;
  for (int f = 0; f < num_faces; ++f) {
    if (!movable(f)) continue;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && labels[g] != labels[f]) {
        depth[f] = 0;
        front.push_back(f);
        break;
      }
    }
  }
  for (size_t head = 0; head < front.size(); ++head) {
    const int f = front[head];
    if (depth[f] >= band) continue;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && depth[g] < 0 && movable(g)) {
        depth[g] = depth[f] + 1;
        front.push_back(g);
      }
    }
  }
  std::vector<int> claimed(num_faces, kUnclaimed);
  std::vector<char> has_core(num_patches, 0);
  for (int f = 0; f < num_faces; ++f)
    if (!movable(f) || depth[f] < 0) {
      claimed[f] = labels[f];
      if (movable(f)) has_core[labels[f]] = 1;
    }
  CandidateQueue queue;
  for (int f = 0; f < num_faces; ++f)
    if (movable(f) && depth[f] < 0)  // from the patches' cores
      push_neighbors(mesh, topology, surfaces, labels, claimed, f, labels[f], queue);
  // A patch no wider than the band floods from its face that the surface fits best among those whose
  // neighbours all lie in the patch (a face on the rim may be half in the neighbour), any face when
  // none does.
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  std::vector<int> seed(num_patches, -1);
  std::vector<double> seed_cost(num_patches, kInfinity);
  std::vector<char> seed_inside(num_patches, 0);
  for (int f = 0; f < num_faces; ++f) {
    if (claimed[f] != kUnclaimed || has_core[labels[f]]) continue;
    const int p = labels[f];
    bool inside = true;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      inside = inside && g >= 0 && labels[g] == p;
    }
    if (seed_inside[p] && !inside) continue;
    const double cost = face_cost(mesh, f, surfaces[p]);
    if ((inside && !seed_inside[p]) || cost < seed_cost[p]) {
      seed[p] = f;
      seed_cost[p] = cost;
      seed_inside[p] = inside;
    }
  }
  for (int p = 0; p < num_patches; ++p)
    if (seed[p] >= 0) queue.emplace(seed_cost[p], seed[p], p);
  return flood_and_relabel(mesh, topology, surfaces, claimed, queue, labels, progress);
}

std::vector<char> dissolve_explained_patches(const TriangleMesh& mesh, const MeshTopology& topology,
                                             const std::vector<FloodSurface>& surfaces, std::vector<int>& labels,
                                             const ProgressSpan& progress) {
  const int num_faces = mesh.num_faces();
  const int num_patches = static_cast<int>(surfaces.size());
  std::vector<std::vector<int>> faces(num_patches);
  for (int f = 0; f < num_faces; ++f)
    if (labels[f] >= 0 && labels[f] < num_patches) faces[labels[f]].push_back(f);
  std::vector<int> order(num_patches);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return faces[a].size() < faces[b].size(); });
  // Smallest first, each explained by neighbours that stay: a strip between two strips is not
  // explained by surfaces that are about to go.
  std::vector<char> dissolved(num_patches, 0);
  std::vector<int> neighbours;
  std::vector<char> seen(mesh.num_vertices(), 0);
  for (int p : order) {
    progress.check();
    if (faces[p].empty()) continue;
    neighbours.clear();
    for (int f : faces[p])
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        const int q = g < 0 ? -1 : labels[g];
        if (q >= 0 && q < num_patches && q != p && !dissolved[q] && surfaces[q].surface != nullptr &&
            std::find(neighbours.begin(), neighbours.end(), q) == neighbours.end())
          neighbours.push_back(q);
      }
    if (neighbours.empty()) continue;
    // Each vertex lies on the neighbour nearest to it, in units of the neighbours' spreads; each face
    // straddles where the surfaces its vertices lie on meet (a wide face whose vertices all lie on
    // its rim, between two parallel planes, does not).
    double squares = 0.0;
    int count = 0;
    bool straddles = true;
    for (size_t i = 0; i < faces[p].size() && straddles; ++i) {
      const int f = faces[p][i];
      std::array<int, 3> on{};
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      for (int c = 0; c < 3; ++c) {
        const int v = mesh.F(f, c);
        const Eigen::Vector3d x = mesh.V.row(v).transpose();
        centroid += x / 3.0;
        double nearest = std::numeric_limits<double>::infinity();
        for (int q : neighbours) {
          const double d = signed_distance(*surfaces[q].surface, x) / surfaces[q].distance_unit;
          if (d * d < nearest) {
            nearest = d * d;
            on[c] = q;
          }
        }
        if (!seen[v]) {
          seen[v] = 1;
          squares += nearest;
          ++count;
        }
      }
      // Within the facet's diameter: a chamfered edge's strip is two facets wide, and on a facet
      // beside the edge the surfaces meet just beyond its corners.
      straddles = meet_within(surfaces, on, centroid, 2.0 * radius_about(mesh, f, centroid));
    }
    for (int f : faces[p])
      for (int c = 0; c < 3; ++c) seen[mesh.F(f, c)] = 0;
    // In units of their spreads the distances of points on the neighbours' surfaces have an RMS of
    // about 1, give or take 1/sqrt(2 n) over n points: 3 of those more are still noise.
    if (straddles && std::sqrt(squares / count) <= 1.0 + 3.0 / std::sqrt(2.0 * count)) dissolved[p] = 1;
  }
  std::vector<int> claimed(labels);
  for (int f = 0; f < num_faces; ++f)
    if (labels[f] >= 0 && labels[f] < num_patches && dissolved[labels[f]]) claimed[f] = kUnclaimed;
  CandidateQueue queue;
  for (int f = 0; f < num_faces; ++f) {
    const int p = claimed[f];
    if (p >= 0 && p < num_patches && surfaces[p].surface != nullptr)
      push_neighbors(mesh, topology, surfaces, labels, claimed, f, p, queue);
  }
  return flood_and_relabel(mesh, topology, surfaces, claimed, queue, labels, progress);
}

}  // namespace idealize
