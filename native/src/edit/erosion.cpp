// Closing a gap on the faces around it, the erosion's result built from the loop (see erosion.h).
#include "edit/erosion.h"

#include "edit/edit.h"
#include "edit/gaps.h"
#include "edit/move_vertices.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <limits>
#include <numeric>
#include <optional>
#include <string>

namespace idealize {

namespace {

int find(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

void unite(std::vector<int>& parent, int a, int b) {
  a = find(parent, a);
  b = find(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the smaller id stays
}

double signed_area(const std::vector<Eigen::Vector2d>& p) {
  double twice = 0.0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d &a = p[i], &b = p[(i + 1) % p.size()];
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * twice;
}

// The loop split into arcs along one host class each.
struct Arc {
  int host = -1;      // the class (its smallest feature)
  int first = 0;      // its first edge in the loop
  int count = 0;      // its number of edges
  std::set<int> features;  // the features across it
};

// Triangulations of the polygon with vertices 0..m-1 (each a list of triangles, vertices in
// order): the planar ways new edges can meet at corners, one corner per triangle (its three hosts'
// common point) and one new edge per side or diagonal.
std::vector<std::vector<std::array<int, 3>>> triangulations(int i, int j) {
  if (j - i < 2) return {{}};
  std::vector<std::vector<std::array<int, 3>>> out;
  for (int k = i + 1; k < j; ++k)
    for (const auto& left : triangulations(i, k))
      for (const auto& right : triangulations(k, j)) {
        std::vector<std::array<int, 3>> t{{i, k, j}};
        t.insert(t.end(), left.begin(), left.end());
        t.insert(t.end(), right.begin(), right.end());
        out.push_back(std::move(t));
      }
  return out;
}

// The most transitions left unpaired that are tried: their polygon's triangulations, Catalan(m - 2),
// are 132 for 8. A gap across more unpaired edges than that (8 faces meeting round it) is refused.
constexpr int kMostUnpaired = 8;

class GapCloser {
 public:
  GapCloser(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
            const BorderLoop& loop, int first_point, double tolerance, const std::set<std::pair<int, int>>& g1,
            double spacing)
      : mesh_(mesh), labels_(labels), surfaces_(surfaces), loop_(loop), first_point_(first_point),
        tolerance_(tolerance), g1_(g1), spacing_(spacing) {
    length_ = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
    // Corners lie among the gap's border: within its bounding box, to the tolerance.
    low_ = high_ = mesh.V.row(loop.vertices[0]).transpose();
    for (int v : loop.vertices) {
      low_ = low_.cwiseMin(mesh.V.row(v).transpose());
      high_ = high_.cwiseMax(mesh.V.row(v).transpose());
    }
    low_.array() -= tolerance;
    high_.array() += tolerance;
  }

  // The gap closed: with the transitions left unpaired (none, or three and more) meeting at
  // corners in the way whose new edges are shortest among those that close it.
  ErodedGap run() {
    classify();
    split_into_arcs();
    pair_transitions();
    const int m = static_cast<int>(open_.size());
    if (m == 0) return attempt({});
    std::set<int> involved;
    for (int a : open_) involved.insert({arcs_[a].host, arcs_[next(a)].host});
    if (m < 3 || m > kMostUnpaired)
      throw EditConflict("the gap's border passes between features " + feature_list(involved) +
                         " in a way their edges cannot close: the edges entering it do not pair up");
    std::optional<ErodedGap> best;
    double shortest = std::numeric_limits<double>::infinity();
    std::string first_problem;
    for (const auto& triangles : triangulations(0, m - 1)) {
      try {
        ErodedGap gap = attempt(triangles);
        if (gap.edge_length < shortest) {
          shortest = gap.edge_length;
          best = std::move(gap);
        }
      } catch (const EditConflict& e) {
        if (first_problem.empty()) first_problem = e.what();
      }
    }
    if (!best) throw EditConflict(first_problem);
    return std::move(*best);
  }

 private:
  // Classes of hosts: the features across the loop, identical ones joined.
  void classify() {
    std::set<int> across(loop_.across.begin(), loop_.across.end());
    if (across.count(-1))
      throw EditConflict("the group reaches the mesh's open border or a triangle set aside: there is no face to close it");
    for (int f : across)
      if (surfaces_[f].type != SurfaceType::Plane && surfaces_[f].type != SurfaceType::Cylinder)
        throw EditConflict("the group's border runs along feature " + std::to_string(f) + ", a " +
                           surface_type_name(surfaces_[f].type) + ": only planes and cylinders close over a gap");
    class_.resize(surfaces_.size());
    std::iota(class_.begin(), class_.end(), 0);
    const std::vector<int> hosts(across.begin(), across.end());
    for (int f : hosts) faces_[f] = faces_labelled(labels_, f);
    for (size_t i = 0; i < hosts.size(); ++i)
      for (size_t j = i + 1; j < hosts.size(); ++j)
        if (identical_regions(mesh_, faces_[hosts[i]], surfaces_[hosts[i]], faces_[hosts[j]], surfaces_[hosts[j]], tolerance_))
          unite(class_, hosts[i], hosts[j]);
  }

  int class_of_edge(int e) { return find(class_, loop_.across[e]); }

  void split_into_arcs() {
    const int n = static_cast<int>(loop_.vertices.size());
    int start = 0;  // an edge that begins an arc (any, when one class holds the whole loop)
    for (int e = 0; e < n; ++e)
      if (class_of_edge(e) != class_of_edge((e + n - 1) % n)) {
        start = e;
        break;
      }
    for (int k = 0; k < n; ++k) {
      const int e = (start + k) % n;
      if (arcs_.empty() || class_of_edge(e) != arcs_.back().host) arcs_.push_back({class_of_edge(e), e, 0, {}});
      arcs_.back().count++;
      arcs_.back().features.insert(loop_.across[e]);
    }
    partner_.assign(arcs_.size(), -1);
  }

  // The loop's vertex where arc a ends (and arc a + 1 begins).
  int transition(int a) const {
    const int n = static_cast<int>(loop_.vertices.size());
    return loop_.vertices[(arcs_[a].first + arcs_[a].count) % n];
  }
  int next(int a) const { return (a + 1) % static_cast<int>(arcs_.size()); }

  // Transition a (from arc a's host to arc a + 1's) pairs with one from the second back to the
  // first: neighbours in the cyclic order of those still open, innermost first, until none pairs.
  void pair_transitions() {
    if (arcs_.size() < 2) return;
    open_.resize(arcs_.size());
    std::iota(open_.begin(), open_.end(), 0);
    auto reverse_of = [&](int a, int b) {
      return arcs_[a].host == arcs_[next(b)].host && arcs_[next(a)].host == arcs_[b].host;
    };
    for (bool paired = true; paired && open_.size() >= 2;) {
      paired = false;
      for (size_t i = 0; i < open_.size() && !paired; ++i) {
        const size_t j = (i + 1) % open_.size();
        if (!reverse_of(open_[i], open_[j])) continue;
        partner_[open_[i]] = open_[j];
        partner_[open_[j]] = open_[i];
        open_.erase(open_.begin() + static_cast<long>(std::max(i, j)));
        open_.erase(open_.begin() + static_cast<long>(std::min(i, j)));
        paired = true;
      }
    }
  }

  // One way of closing the gap: the unpaired transitions' regions (region i lies before
  // open_[i], between open_[i - 1] and open_[i]) meeting at the corners of `triangles`.
  ErodedGap attempt(const std::vector<std::array<int, 3>>& triangles) {
    Attempt a(*this, triangles);
    return a.run();
  }

  struct Attempt {
    Attempt(GapCloser& closer, const std::vector<std::array<int, 3>>& corners) : g(closer), triangles(corners) {}
    GapCloser& g;
    const std::vector<std::array<int, 3>>& triangles;
    ErodedGap out;
    std::vector<std::vector<int>> paired;           // per transition: new vertices to its partner
    std::vector<std::vector<int>> side;             // per unpaired transition i: to its triangle's corner
    std::map<std::pair<int, int>, std::vector<int>> diagonal;  // (triangle, triangle): between their corners
    std::vector<int> corner;                        // per triangle: its corner's vertex id
    std::map<std::pair<int, int>, std::vector<int>> triangles_of;  // (region, region), smaller first
    std::vector<char> visited;
    std::vector<int> piece_host;                    // per arc: the feature its piece closes on
    TriangleMesh extended;                          // the mesh's vertices, then the new points

    int m() const { return static_cast<int>(g.open_.size()); }
    int region(int i) const { return g.arcs_[g.open_[(i + m()) % m()]].host; }

    ErodedGap run() {
      const int arcs = static_cast<int>(g.arcs_.size());
      paired.assign(arcs, {});
      side.assign(m(), {});
      visited.assign(arcs, 0);
      piece_host.assign(arcs, -1);
      make_edges();
      // The mesh's vertices and the new points under their ids, for the pieces' charts.
      extended = TriangleMesh{MatrixX3d::Zero(g.first_point_ + static_cast<int>(out.points.size()), 3), g.mesh_.F};
      extended.V.topRows(g.mesh_.num_vertices()) = g.mesh_.V;
      for (size_t i = 0; i < out.points.size(); ++i) extended.V.row(g.first_point_ + static_cast<int>(i)) = out.points[i];
      for (int a = 0; a < arcs; ++a)
        if (!visited[a]) close_piece(a);
      // The new edges, between the features of the pieces on either side.
      for (int a = 0; a < arcs; ++a)
        if (g.partner_[a] > a) out.edges.emplace_back(piece_host[a], piece_host[g.next(a)]);
      for (int i = 0; i < m(); ++i)
        out.edges.emplace_back(piece_host[g.open_[i]], piece_host[g.next(g.open_[i])]);
      for (const auto& [pair, tris] : triangles_of)
        if (tris.size() == 2 && pair.first < pair.second)
          out.edges.emplace_back(piece_host[g.open_[pair.first]], piece_host[g.open_[pair.second]]);
      return std::move(out);
    }

    Eigen::Vector3d position(int id) const {
      return id < g.first_point_ ? Eigen::Vector3d(g.mesh_.V.row(id).transpose()) : out.points[id - g.first_point_];
    }

    // A point on all of `hosts`' surfaces near p, or a conflict naming them.
    // A corner (`corner`) must also lie among the gap's border, within its bounding box: three
    // nearly parallel planes meet far away.
    Eigen::Vector3d on_all(const std::vector<int>& hosts, const Eigen::Vector3d& p, bool corner = false) {
      const Eigen::Vector3d q = onto_features(hosts, g.surfaces_, g.g1_, p, g.length_);
      bool on = !corner || (((q - g.low_).array() >= 0.0).all() && ((g.high_ - q).array() >= 0.0).all());
      for (int h : hosts) on &= std::abs(signed_distance(g.surfaces_[h], q)) <= g.tolerance_;
      if (!on)
        throw EditConflict("the surfaces of features " + feature_list(std::set<int>(hosts.begin(), hosts.end())) +
                           " do not meet inside the gap: no edge between them closes it");
      return q;
    }

    int add_point(const Eigen::Vector3d& p) {
      out.points.push_back(p);
      return g.first_point_ + static_cast<int>(out.points.size()) - 1;
    }

    // New vertices strictly between the placed vertices a and b, on both hosts.
    std::vector<int> edge_points(int a, int b, int host_a, int host_b) {
      const Eigen::Vector3d pa = position(a), pb = position(b);
      out.edge_length += (pb - pa).norm();
      const int segments = std::max(1, static_cast<int>(std::lround((pb - pa).norm() / g.spacing_)));
      std::vector<int> ids;
      for (int s = 1; s < segments; ++s) {
        const double t = static_cast<double>(s) / segments;
        ids.push_back(add_point(on_all({host_a, host_b}, (1.0 - t) * pa + t * pb)));
      }
      return ids;
    }

    void make_edges() {
      // Case 2: the old edge entering the gap runs on to where it leaves.
      for (int a = 0; a < static_cast<int>(g.arcs_.size()); ++a) {
        const int b = g.partner_[a];
        if (b < a) continue;
        const int ha = g.arcs_[a].host, hb = g.arcs_[g.next(a)].host;
        on_all({ha, hb}, position(g.transition(a)));  // the old edges end on both surfaces
        on_all({ha, hb}, position(g.transition(b)));
        paired[a] = edge_points(g.transition(a), g.transition(b), ha, hb);
        paired[b].assign(paired[a].rbegin(), paired[a].rend());
      }
      if (triangles.empty()) return;
      // Case 3: new edges meet at corners, one per triangle of regions.
      for (size_t t = 0; t < triangles.size(); ++t) {
        const std::array<int, 3>& tri = triangles[t];
        std::set<int> hosts{region(tri[0]), region(tri[1]), region(tri[2])};
        if (hosts.size() < 3)
          throw EditConflict("features " + feature_list(hosts) + " cannot meet at a corner inside the gap");
        Eigen::Vector3d start = Eigen::Vector3d::Zero();  // near the transitions of its regions
        int count = 0;
        for (int i = 0; i < m(); ++i)
          if (hosts.count(region(i)) && hosts.count(region(i + 1))) {
            start += position(g.transition(g.open_[i]));
            ++count;
          }
        if (count == 0)
          for (int i = 0; i < m(); ++i) start += position(g.transition(g.open_[i])) / m();
        else
          start /= count;
        corner.push_back(add_point(on_all(std::vector<int>(hosts.begin(), hosts.end()), start, true)));
        for (int k = 0; k < 3; ++k) {
          const int x = tri[k], y = tri[(k + 1) % 3];
          triangles_of[{std::min(x, y), std::max(x, y)}].push_back(static_cast<int>(t));
        }
        ++out.corners;
      }
      for (int i = 0; i < m(); ++i) {  // side (i, i + 1): transition open_[i] to its corner
        const int t = triangles_of.at({std::min(i, (i + 1) % m()), std::max(i, (i + 1) % m())}).front();
        const int u = g.transition(g.open_[i]);
        on_all({region(i), region(i + 1)}, position(u));
        side[i] = edge_points(u, corner[t], region(i), region(i + 1));
      }
      for (const auto& [pair, tris] : triangles_of) {
        if (tris.size() != 2) continue;
        if (region(pair.first) == region(pair.second))
          throw EditConflict("a new edge would part feature " + std::to_string(region(pair.first)) + " from itself");
        diagonal[{tris[0], tris[1]}] = edge_points(corner[tris[0]], corner[tris[1]], region(pair.first), region(pair.second));
        diagonal[{tris[1], tris[0]}].assign(diagonal[{tris[0], tris[1]}].rbegin(), diagonal[{tris[0], tris[1]}].rend());
      }
    }

    // From the corner of triangle t, reached along its edge to region `from`, round region r to the
    // next transition into r: appends the way to `polygon` and returns that transition's arc.
    int round_corners(int r, int t, int from, std::vector<int>& polygon) {
      for (;;) {
        polygon.push_back(corner[t]);
        const std::array<int, 3>& tri = triangles[t];
        int y = -1;
        for (int v : tri)
          if (v != r && v != from) y = v;
        if ((y + 1) % m() == r) {  // the side (y, r): the transition from region y into r
          polygon.insert(polygon.end(), side[y].rbegin(), side[y].rend());
          return g.open_[y];
        }
        const std::vector<int>& across = triangles_of.at({std::min(r, y), std::max(r, y)});
        const int other = across[0] == t ? across[1] : across[0];
        const std::vector<int>& way = diagonal.at({t, other});
        polygon.insert(polygon.end(), way.begin(), way.end());
        t = other;
        from = y;
      }
    }

    // The piece that starts with arc `a`: its arcs and new edges in turn, closed on its host.
    void close_piece(int a) {
      const int n = static_cast<int>(g.loop_.vertices.size());
      std::vector<int> polygon, arcs;
      std::set<int> features;
      for (int arc = a;;) {
        visited[arc] = 1;
        arcs.push_back(arc);
        features.insert(g.arcs_[arc].features.begin(), g.arcs_[arc].features.end());
        for (int k = 0; k < g.arcs_[arc].count; ++k) polygon.push_back(g.loop_.vertices[(g.arcs_[arc].first + k) % n]);
        int resume = g.next(arc);  // one class round the whole loop: it closes on itself
        if (g.partner_[arc] >= 0) {
          polygon.push_back(g.transition(arc));
          polygon.insert(polygon.end(), paired[arc].begin(), paired[arc].end());
          resume = g.next(g.partner_[arc]);
        } else if (!triangles.empty()) {
          const int i = static_cast<int>(std::find(g.open_.begin(), g.open_.end(), arc) - g.open_.begin());
          polygon.push_back(g.transition(arc));
          polygon.insert(polygon.end(), side[i].begin(), side[i].end());
          const int next_region = (i + 1) % m();
          const int t = triangles_of.at({std::min(i, next_region), std::max(i, next_region)}).front();
          resume = g.next(round_corners(i, t, next_region, polygon));
        }
        if (resume == a) break;
        arc = resume;
      }
      check_and_fill(polygon, features, arcs);
    }

    // The piece in its host's chart, walked as the gap's border: counter-clockwise about the
    // host's outside and simple, or the host cannot close over it. The piece joins its features;
    // the smallest id stays.
    void check_and_fill(const std::vector<int>& polygon, const std::set<int>& features, const std::vector<int>& arcs) {
      const int host = *features.begin();
      for (int arc : arcs) piece_host[arc] = host;
      std::vector<int> region_faces;
      for (int f : features) region_faces.insert(region_faces.end(), g.faces_[f].begin(), g.faces_[f].end());
      bool winds = false;
      const std::vector<Eigen::Vector2d> chart = loop_chart(extended, polygon, region_faces, g.surfaces_[host], winds);
      // A constrained Delaunay triangulation of the piece (gaps.h), once it is known to be simple
      // (CGAL would insert the crossings of constraints that cross).
      std::vector<std::array<int, 3>> triangles;
      if (!winds && signed_area(chart) > 0.0 && simple_polygon(chart)) try {
          triangles = fill_ring(chart, {});
        } catch (const EditConflict&) {
          triangles.clear();
        }
      if (triangles.empty())
        throw EditConflict(
            "feature" + std::string(features.size() > 1 ? "s " : " ") + feature_list(features) + " cannot close over the gap: " +
            (winds ? "it would go round the cylinder"
                   : "its border there is not a hole in that face (it would take the face's outline with it)"));
      for (const std::array<int, 3>& t : triangles) {
        out.faces.push_back({polygon[t[0]], polygon[t[1]], polygon[t[2]]});
        out.hosts.push_back(host);
      }
      for (int f : features)
        if (f != host) out.merged.emplace_back(f, host);
    }
  };

  const TriangleMesh& mesh_;
  const std::vector<int>& labels_;
  const std::vector<Surface>& surfaces_;
  const BorderLoop& loop_;
  const int first_point_;
  const double tolerance_;
  const std::set<std::pair<int, int>>& g1_;
  const double spacing_;
  double length_ = 0.0;
  Eigen::Vector3d low_, high_;             // the gap border's bounding box, grown by the tolerance
  std::vector<int> class_;                 // per feature: union-find parent over identical hosts
  std::map<int, std::vector<int>> faces_;  // per feature across the loop: its faces
  std::vector<Arc> arcs_;
  std::vector<int> partner_;               // per transition (arc's end): the one it pairs with, or -1
  std::vector<int> open_;                  // the transitions left unpaired, in the loop's order
};

}  // namespace

ErodedGap erode_gap(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                    const BorderLoop& loop, int first_point, double tolerance,
                    const std::set<std::pair<int, int>>& g1, double spacing) {
  if (loop.vertices.size() < 3) throw EditConflict("the group's border has fewer than three vertices");
  if (!(spacing > 0.0)) throw std::invalid_argument("erode_gap: the spacing must be positive");
  return GapCloser(mesh, labels, surfaces, loop, first_point, tolerance, g1, spacing).run();
}

}  // namespace idealize
