// Cutting and closing gaps in host faces (see gaps.h).
#include "edit/gaps.h"

#include "edit/edit.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <set>
#include <string>

namespace idealize {

namespace {

// Rounds of remeshing for triangles an edit made. They start as an ear-clipped fan or a Delaunay
// ring between fixed borders, not as a stretched mesh (EditOptions::remesh_iterations, 3): on the
// editing benchmark's deleted boss, 3 rounds left 98.95 % of them well shaped (smallest angle
// >= 20 deg), 5 rounds 99.13 %, 8 rounds no more.
constexpr int kClosingRounds = 5;


}  // namespace

std::string feature_list(const std::set<int>& features) {
  std::string s;
  for (int f : features) s += (s.empty() ? "" : ", ") + std::to_string(f);
  return s;
}

void take_rim_triangles(const TriangleMesh& mesh, int group, std::vector<int>& group_labels) {
  const MeshTopology topology(mesh);
  for (bool grew = true; grew;) {
    grew = false;
    std::vector<char> on_border(mesh.num_vertices(), 0);
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (group_labels[f] == group && g >= 0 && group_labels[g] != group)
          on_border[mesh.F(f, (c + 1) % 3)] = on_border[mesh.F(f, (c + 2) % 3)] = 1;
      }
    for (int f = 0; f < mesh.num_faces(); ++f) {
      if (group_labels[f] == group || group_labels[f] < 0) continue;
      bool touches = false, rim = true;
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        touches |= g >= 0 && group_labels[g] == group;
        rim &= on_border[mesh.F(f, c)] != 0;
      }
      if (touches && rim) {
        group_labels[f] = group;
        grew = true;
      }
    }
  }
}

std::vector<int> gap_hosts(const TriangleMesh& mesh, const std::vector<int>& group_labels, int group,
                           const std::vector<Surface>& surfaces, const std::vector<BorderLoop>& loops) {
  std::vector<std::vector<int>> faces_of(surfaces.size());
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (group_labels[f] >= 0 && group_labels[f] != group) faces_of[group_labels[f]].push_back(f);
  std::vector<int> hosts;
  for (const BorderLoop& loop : loops) {
    const std::set<int> across(loop.across.begin(), loop.across.end());
    if (across.count(-1))
      throw EditConflict("the group reaches the mesh's open border or a triangle set aside: there is no face to close it");
    if (across.size() > 1)
      throw EditConflict("the group's border runs along features " + feature_list(across) +
                         ", not around one face: only a group that one plane or cylinder surrounds travels as a decal");
    const int host = *across.begin();
    const Surface& s = surfaces[host];
    if (s.type != SurfaceType::Plane && s.type != SurfaceType::Cylinder)
      throw EditConflict("the group sits on feature " + std::to_string(host) + ", a " + surface_type_name(s.type) +
                         ": only a gap in a plane or a cylinder can be closed");
    // The host walks the loop the other way round, with itself on the left.
    const std::vector<int> reversed(loop.vertices.rbegin(), loop.vertices.rend());
    if (!is_inner_loop(mesh, reversed, faces_of[host], s))
      throw EditConflict("the group is not an island in feature " + std::to_string(host) +
                         ": its border there is not a hole in that face (it would take the face's outline with it)");
    hosts.push_back(host);
  }
  return hosts;
}

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Whether segments pq and rs cross or touch.
bool segments_meet(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r,
                   const Eigen::Vector2d& s) {
  const double d1 = cross2(p, q, r), d2 = cross2(p, q, s), d3 = cross2(r, s, p), d4 = cross2(r, s, q);
  if (((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0)) && d1 != 0 && d2 != 0 && d3 != 0 && d4 != 0) return true;
  auto within = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& x) {
    return x.x() >= std::min(a.x(), b.x()) && x.x() <= std::max(a.x(), b.x()) && x.y() >= std::min(a.y(), b.y()) &&
           x.y() <= std::max(a.y(), b.y());
  };
  return (d1 == 0 && within(p, q, r)) || (d2 == 0 && within(p, q, s)) || (d3 == 0 && within(r, s, p)) ||
         (d4 == 0 && within(r, s, q));
}

}  // namespace

// Segments are binned in a grid of cells as large as their mean length, and only segments that
// share a cell are tested: linear in the number of segments when they are spread about evenly, as
// a gap's border is.
bool simple_polygon(const std::vector<Eigen::Vector2d>& p) {
  const long n = static_cast<long>(p.size());
  if (n < 3) return false;
  Eigen::Vector2d low = p[0], high = p[0];
  double mean = 0.0;
  for (long i = 0; i < n; ++i) {
    low = low.cwiseMin(p[i]);
    high = high.cwiseMax(p[i]);
    mean += (p[(i + 1) % n] - p[i]).norm() / static_cast<double>(n);
  }
  if (!(mean > 0.0)) return false;
  // At most about 4n cells: a long thin polygon does not get a grid larger than its segments.
  const double cell = std::max(mean, std::sqrt((high - low).prod() / (4.0 * static_cast<double>(n))));
  std::map<std::pair<long, long>, std::vector<long>> grid;
  for (long i = 0; i < n; ++i) {
    const Eigen::Vector2d a = p[i], b = p[(i + 1) % n];
    const long x0 = static_cast<long>(std::floor((std::min(a.x(), b.x()) - low.x()) / cell));
    const long x1 = static_cast<long>(std::floor((std::max(a.x(), b.x()) - low.x()) / cell));
    const long y0 = static_cast<long>(std::floor((std::min(a.y(), b.y()) - low.y()) / cell));
    const long y1 = static_cast<long>(std::floor((std::max(a.y(), b.y()) - low.y()) / cell));
    for (long x = x0; x <= x1; ++x)
      for (long y = y0; y <= y1; ++y) grid[{x, y}].push_back(i);
  }
  for (const auto& [key, segments] : grid)
    for (size_t a = 0; a < segments.size(); ++a)
      for (size_t b = a + 1; b < segments.size(); ++b) {
        const long i = segments[a], j = segments[b];
        const long gap = std::abs(i - j);
        if (gap == 1 || gap == n - 1) {
          // Neighbours share a corner; they meet elsewhere only when they fold back onto each other.
          const long first = gap == 1 ? std::min(i, j) : std::max(i, j);
          const Eigen::Vector2d &u = p[first], &v = p[(first + 1) % n], &w = p[(first + 2) % n];
          if (cross2(u, v, w) == 0.0 && (v - u).dot(w - v) < 0.0) return false;
          continue;
        }
        if (segments_meet(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n])) return false;
      }
  return true;
}

namespace {

// A constrained Delaunay triangulation whose faces know how deep they lie inside the constraints
// (CGAL's polygon triangulation example, "mark_domains").
struct Nesting {
  int level = -1;
};
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<int, Kernel>;
using FaceBase = CGAL::Constrained_triangulation_face_base_2<Kernel, CGAL::Triangulation_face_base_with_info_2<Nesting, Kernel>>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>,
                                                       CGAL::Exact_predicates_tag>;

void mark_domains(Cdt& cdt) {
  for (Cdt::Face_handle f : cdt.all_face_handles()) f->info().level = -1;
  std::list<Cdt::Edge> border;
  auto flood = [&](Cdt::Face_handle start, int level) {
    std::list<Cdt::Face_handle> queue{start};
    while (!queue.empty()) {
      Cdt::Face_handle f = queue.front();
      queue.pop_front();
      if (f->info().level != -1) continue;
      f->info().level = level;
      for (int i = 0; i < 3; ++i) {
        Cdt::Face_handle next = f->neighbor(i);
        if (next->info().level != -1) continue;
        if (cdt.is_constrained(Cdt::Edge(f, i)))
          border.push_back(Cdt::Edge(f, i));
        else
          queue.push_back(next);
      }
    }
  };
  flood(cdt.infinite_face(), 0);
  while (!border.empty()) {
    const Cdt::Edge e = border.front();
    border.pop_front();
    Cdt::Face_handle next = e.first->neighbor(e.second);
    if (next->info().level == -1) flood(next, e.first->info().level + 1);
  }
}

}  // namespace

std::vector<std::array<int, 3>> fill_ring(const std::vector<Eigen::Vector2d>& outer,
                                          const std::vector<Eigen::Vector2d>& inner) {
  Cdt cdt;
  int index = 0;
  for (const std::vector<Eigen::Vector2d>* polygon : {&outer, &inner}) {
    std::vector<Cdt::Vertex_handle> handles;
    for (const Eigen::Vector2d& p : *polygon) {
      handles.push_back(cdt.insert(Cdt::Point(p.x(), p.y())));
      handles.back()->info() = index++;
    }
    for (size_t i = 0; i < handles.size(); ++i) cdt.insert_constraint(handles[i], handles[(i + 1) % handles.size()]);
  }
  // A point inserted twice, or constraints that cross (CGAL then adds their crossing point): the
  // polygons touch.
  if (static_cast<int>(cdt.number_of_vertices()) != index)
    throw EditConflict("the group's new outline touches or crosses the triangles around it: place it further from "
                       "the face's edges and from other features");
  mark_domains(cdt);
  std::vector<std::array<int, 3>> out;
  for (Cdt::Face_handle f : cdt.finite_face_handles())
    if (f->info().level == 1) out.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});
  return out;
}

void check_closed(const std::vector<std::array<int, 3>>& faces) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : faces)
    for (int c = 0; c < 3; ++c) ++uses[{std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])}];
  for (const auto& [edge, count] : uses)
    if (count != 2)
      throw EditConflict("closing the gap would not give a closed surface (the triangles around the gap fold into "
                         "it): delete fewer or more features");
}

bool is_closed(const TriangleMesh& mesh) {
  const MeshTopology topology(mesh);
  return topology.num_boundary_edges() == 0 && topology.num_nonmanifold_edges() == 0;
}

RemeshedLayer remesh_created(const TriangleMesh& mesh, const std::vector<int>& labels, std::vector<char>& created,
                             const std::vector<Surface>& surfaces, const std::vector<double>& targets,
                             const std::set<std::pair<int, int>>& g1) {
  const int n = static_cast<int>(surfaces.size());
  std::vector<int> stand_in(n, -1);  // per feature: the feature its created faces are remeshed as
  std::vector<Surface> all = surfaces;
  std::vector<double> all_targets(n, 0.0);
  std::vector<int> with = labels;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int l = labels[f];
    if (!created[f] || l < 0) continue;
    if (stand_in[l] < 0) {
      stand_in[l] = static_cast<int>(all.size());
      all.push_back(surfaces[l]);
      all_targets.push_back(targets[l]);
    }
    with[f] = stand_in[l];
  }
  // A stand-in is tangent to what its feature is tangent to.
  std::set<std::pair<int, int>> tangent = g1;
  auto either = [&](int f) { return std::vector<int>{f, stand_in[f]}; };
  for (const auto& [a, b] : g1)
    for (int x : either(a))
      for (int y : either(b))
        if (x >= 0 && y >= 0) tangent.insert({std::min(x, y), std::max(x, y)});
  RemeshedLayer out = remesh_adaptive(mesh, with, all_targets, all, tangent, kClosingRounds, true);
  std::vector<int> back(all.size());
  for (int l = 0; l < static_cast<int>(all.size()); ++l) back[l] = l;
  for (int l = 0; l < n; ++l)
    if (stand_in[l] >= 0) back[stand_in[l]] = l;
  created.assign(out.labels.size(), 0);
  for (size_t f = 0; f < out.labels.size(); ++f) {
    int& l = out.labels[f];
    if (l >= n) created[f] = 1;
    if (l >= 0) l = back[l];
  }
  return out;
}

std::set<std::pair<int, int>> tangent_pairs(const std::vector<FeatureAdjacency>& adjacency,
                                            const std::vector<int>& new_id) {
  std::set<std::pair<int, int>> g1;
  for (const FeatureAdjacency& a : adjacency) {
    if (a.continuity != Continuity::G1) continue;
    const int x = new_id[a.a], y = new_id[a.b];
    if (x >= 0 && y >= 0) g1.insert({std::min(x, y), std::max(x, y)});
  }
  return g1;
}

Eigen::VectorXd finish_created(TriangleMesh& mesh, std::vector<int>& labels, std::vector<char>& created,
                               const std::vector<Surface>& surfaces, const std::vector<double>& targets,
                               const std::set<std::pair<int, int>>& g1, bool remesh, std::string& problem) {
  if (remesh) {
    try {
      RemeshedLayer remeshed = remesh_created(mesh, labels, created, surfaces, targets, g1);
      mesh = std::move(remeshed.mesh);
      labels = std::move(remeshed.labels);
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  return vertex_deviation(mesh, labels, surfaces);
}

TriangleMesh compact_mesh(const MatrixX3d& V, const std::vector<std::array<int, 3>>& faces) {
  std::vector<int> vertex_id(V.rows(), -1);
  int next = 0;
  for (const auto& t : faces)
    for (int v : t)
      if (vertex_id[v] < 0) vertex_id[v] = next++;
  TriangleMesh out;
  out.V.resize(next, 3);
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (vertex_id[v] >= 0) out.V.row(vertex_id[v]) = V.row(v);
  out.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c) out.F(static_cast<Eigen::Index>(f), c) = vertex_id[faces[f][c]];
  return out;
}

}  // namespace idealize
