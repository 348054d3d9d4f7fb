// Isotropic remeshing of the active region of a sculpted mesh (see dynamic_topology.h).
#include "sculpt/dynamic_topology.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace idealize {

namespace {

// Botsch & Kobbelt's band: an edge longer than 4/3 L splits into two of at least 2/3 L, an edge
// shorter than 4/5 L collapses; within the band neither operation undoes the other.
constexpr double kSplitFactor = 4.0 / 3.0;
constexpr double kCollapseFactor = 4.0 / 5.0;

class RegionRemesher {
 public:
  RegionRemesher(SculptMesh& mesh, std::vector<char>& active, double target)
      : m_(mesh), active_(active), split_(kSplitFactor * target), collapse_(kCollapseFactor * target) {
    for (int v = 0; v < static_cast<int>(active.size()); ++v)
      if (active[v]) vertices_.push_back(v);
  }

  void round() {
    split_long_edges();
    collapse_short_edges();
    flip_edges();
    relax();
  }

 private:
  bool is_active(int v) const { return v < static_cast<int>(active_.size()) && active_[v]; }
  double length(int h) const { return (m_.position(m_.to(h)) - m_.position(m_.from(h))).norm(); }

  bool live(int v) const { return !m_.vertex_deleted(v) && m_.halfedge(v) >= 0; }

  // One half-edge per live edge with an active vertex (the even one of the pair), in order.
  std::vector<int> region_edges() const {
    std::vector<int> edges;
    for (int v : vertices_) {
      if (!live(v)) continue;
      const int start = m_.halfedge(v);
      int h = start;
      do {
        edges.push_back(h & ~1);
        h = m_.rotated(h);
      } while (h != start);
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    return edges;
  }

  void split_long_edges() {
    // The halves of a very long edge can still be long: repeat, as many passes as halvings bring
    // the longest edge into the band, and two more for the edges to the opposite corners.
    double longest = 0.0;
    for (int h : region_edges()) longest = std::max(longest, length(h));
    const int passes = longest > split_ ? 2 + static_cast<int>(std::ceil(std::log2(longest / split_))) : 0;
    for (int pass = 0, any = 1; pass < passes && any; ++pass) {
      any = 0;
      for (int h : region_edges()) {
        if (length(h) <= split_) continue;
        const int v = m_.split(h, 0.5 * (m_.position(m_.from(h)) + m_.position(m_.to(h))));
        if (v >= static_cast<int>(active_.size())) active_.resize(v + 1, 0);
        active_[v] = 1;
        vertices_.push_back(v);
        any = 1;
      }
    }
  }

  // Whether moving v onto `target` turns over none of v's faces, other than those that vanish (the
  // ones on the edge to `keep`).
  bool keeps_orientation(int v, int keep, const Eigen::Vector3d& target) const {
    const int start = m_.halfedge(v);
    int h = start;
    do {
      const int f = m_.face(h);
      if (f >= 0) {
        const int b = m_.to(h), c = m_.to(m_.next(h));
        if (b != keep && c != keep) {
          const Eigen::Vector3d before = (m_.position(b) - m_.position(v)).cross(m_.position(c) - m_.position(v));
          const Eigen::Vector3d after = (m_.position(b) - target).cross(m_.position(c) - target);
          if (before.dot(after) <= 0.0) return false;
        }
      }
      h = m_.rotated(h);
    } while (h != start);
    return true;
  }

  // Collapsing h (its origin onto its end) keeps every edge out of the end within the split length.
  bool stays_short(int h) const {
    const int v0 = m_.from(h), v1 = m_.to(h);
    const int start = m_.halfedge(v0);
    int g = start;
    do {
      if ((m_.position(m_.to(g)) - m_.position(v1)).norm() > split_) return false;
      g = m_.rotated(g);
    } while (g != start);
    return true;
  }

  bool try_collapse(int h) {
    const int v0 = m_.from(h), v1 = m_.to(h);
    if (!is_active(v0) || m_.border_vertex(v0) || !m_.collapse_ok(h) || !stays_short(h) ||
        !keeps_orientation(v0, v1, m_.position(v1)))
      return false;
    m_.collapse(h);
    return true;
  }

  void collapse_short_edges() {
    for (int h : region_edges()) {
      if (m_.edge_deleted(h) || length(h) >= collapse_) continue;
      if (!try_collapse(h)) try_collapse(h ^ 1);
    }
  }

  int target_valence(int v) const { return m_.border_vertex(v) ? 4 : 6; }

  void flip_edges() {
    for (int h : region_edges()) {
      if (m_.edge_deleted(h) || !is_active(m_.to(h)) || !is_active(m_.from(h)) || !m_.flip_ok(h)) continue;
      const int a = m_.from(h), b = m_.to(h), c = m_.to(m_.next(h)), d = m_.to(m_.next(h ^ 1));
      const int va = m_.valence(a), vb = m_.valence(b), vc = m_.valence(c), vd = m_.valence(d);
      auto deviation = [&](int x, int v) { return (v - target_valence(x)) * (v - target_valence(x)); };
      const int before = deviation(a, va) + deviation(b, vb) + deviation(c, vc) + deviation(d, vd);
      const int after = deviation(a, va - 1) + deviation(b, vb - 1) + deviation(c, vc + 1) + deviation(d, vd + 1);
      if (after >= before) continue;
      // The two new faces must face the way the two old ones did: no fold.
      const Eigen::Vector3d pa = m_.position(a), pb = m_.position(b), pc = m_.position(c), pd = m_.position(d);
      const Eigen::Vector3d n = (pb - pa).cross(pc - pa) + (pa - pb).cross(pd - pb);
      if ((pc - pd).cross(pa - pd).dot(n) <= 0.0 || (pd - pc).cross(pb - pc).dot(n) <= 0.0) continue;
      m_.flip(h);
    }
  }

  // Each active vertex off the border moves to its neighbours' centroid, along its tangent plane.
  void relax() {
    std::vector<std::pair<int, Eigen::Vector3d>> moves;
    for (int v : vertices_) {
      if (!live(v) || m_.border_vertex(v)) continue;
      const Eigen::Vector3d n = m_.vertex_normal(v);
      Eigen::Vector3d u = m_.neighbour_centroid(v) - m_.position(v);
      u -= n.dot(u) * n;
      const Eigen::Vector3d target = m_.position(v) + u;
      if (keeps_orientation(v, -1, target)) moves.emplace_back(v, target);
    }
    for (const auto& [v, p] : moves) {
      m_.position(v) = p;
      const int start = m_.halfedge(v);
      int h = start;
      do {
        if (m_.face(h) >= 0) m_.mark(m_.face(h));
        h = m_.rotated(h);
      } while (h != start);
    }
  }

  SculptMesh& m_;
  std::vector<char>& active_;
  std::vector<int> vertices_;  // the active vertices (some deleted by collapses since)
  const double split_, collapse_;
};

}  // namespace

void remesh_region(SculptMesh& mesh, std::vector<char>& active, const DynamicTopologyOptions& options) {
  if (!(options.target_edge_length > 0.0)) throw std::invalid_argument("remesh_region: the target edge length must be positive");
  RegionRemesher remesher(mesh, active, options.target_edge_length);
  for (int r = 0; r < options.rounds; ++r) remesher.round();
}

}  // namespace idealize
