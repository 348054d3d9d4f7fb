// Deleting a feature group: lift its triangles off, close each gap on its host, remesh the hosts
// (see delete_features.h).
#include "edit/delete_features.h"

#include "edit/feature_groups.h"
#include "edit/remesh_adaptive.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>

namespace idealize {

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Ear clipping of a simple polygon given counter-clockwise (`p`, its points in a chart): the
// triangles as indices into p, counter-clockwise. Each ear is the convex corner whose triangle
// holds no other corner; among the ears, the one of the largest smallest angle goes first, which
// keeps the fan from slivering before the remeshing. O(n^3) on an n-gon: gaps are loops of tens to
// a few hundred edges.
std::vector<std::array<int, 3>> ear_clipping(const std::vector<Eigen::Vector2d>& p) {
  std::vector<int> ring(p.size());
  for (size_t i = 0; i < p.size(); ++i) ring[i] = static_cast<int>(i);
  std::vector<std::array<int, 3>> out;
  auto smallest_angle = [&](int a, int b, int c) {
    const Eigen::Vector2d u = p[b] - p[a], v = p[c] - p[b], w = p[a] - p[c];
    auto angle = [](const Eigen::Vector2d& x, const Eigen::Vector2d& y) {
      return std::atan2(std::abs(x.x() * y.y() - x.y() * y.x()), -x.dot(y));
    };
    return std::min({angle(w, u), angle(u, v), angle(v, w)});
  };
  while (ring.size() > 3) {
    const size_t n = ring.size();
    int best = -1;
    double best_angle = -1.0;
    for (size_t i = 0; i < n; ++i) {
      const int a = ring[(i + n - 1) % n], b = ring[i], c = ring[(i + 1) % n];
      if (cross2(p[a], p[b], p[c]) <= 0.0) continue;  // reflex or flat: not an ear
      bool empty = true;
      for (size_t j = 0; j < n && empty; ++j) {
        const int x = ring[j];
        if (x == a || x == b || x == c) continue;
        empty = !(cross2(p[a], p[b], p[x]) >= 0.0 && cross2(p[b], p[c], p[x]) >= 0.0 && cross2(p[c], p[a], p[x]) >= 0.0);
      }
      if (!empty) continue;
      const double angle = smallest_angle(a, b, c);
      if (angle > best_angle) {
        best_angle = angle;
        best = static_cast<int>(i);
      }
    }
    // A polygon has two ears (Meisters); none found means rounding on nearly flat corners: the
    // most convex corner goes.
    if (best < 0) {
      double most = -std::numeric_limits<double>::infinity();
      for (size_t i = 0; i < n; ++i) {
        const double turn = cross2(p[ring[(i + n - 1) % n]], p[ring[i]], p[ring[(i + 1) % n]]);
        if (turn > most) {
          most = turn;
          best = static_cast<int>(i);
        }
      }
    }
    out.push_back({ring[(best + n - 1) % n], ring[best], ring[(best + 1) % n]});
    ring.erase(ring.begin() + best);
  }
  out.push_back({ring[0], ring[1], ring[2]});
  return out;
}

bool mesh_was_closed(const TriangleMesh& mesh) {
  const MeshTopology topology(mesh);
  return topology.num_boundary_edges() == 0 && topology.num_nonmanifold_edges() == 0;
}

std::string feature_list(const std::set<int>& features) {
  std::string s;
  for (int f : features) s += (s.empty() ? "" : ", ") + std::to_string(f);
  return s;
}

// The host of each border loop of the group (faces labelled `group`): the one plane or cylinder
// along it, holding it as an inner loop. Throws EditConflict otherwise.
std::vector<int> hosts_of(const TriangleMesh& mesh, const std::vector<int>& group_labels, int group,
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
                         ", not around one face: only a group that one plane or cylinder surrounds can be deleted");
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

// A triangle outside the group (labelled `group` in `group_labels`) that shares an edge with it and
// whose three corners all lie on its border belongs to the gap: a tessellation's triangle that
// straddles the edge where the group met its host, labelled with the host but lying inside the
// gap's outline (all three corners on the hole's rim). Left in, it would fold the host's closing
// triangles over it. Such triangles join the group until none is left.
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

// Throws EditConflict unless every edge of `faces` has exactly two triangles: a gap closed over a
// host whose triangles fold into its outline would not make a closed surface.
void check_closed(const std::vector<std::array<int, 3>>& faces) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : faces)
    for (int c = 0; c < 3; ++c) ++uses[{std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])}];
  for (const auto& [edge, count] : uses)
    if (count != 2)
      throw EditConflict("closing the gap would not give a closed surface (the triangles around the gap fold into "
                         "it): delete fewer or more features");
}

}  // namespace

DeleteResult delete_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                             const std::vector<Surface>& surfaces, const std::vector<FeatureAdjacency>& adjacency,
                             const std::vector<int>& features, const EditOptions& options) {
  check_layer(mesh, labels, surfaces, adjacency, {});
  const int n = static_cast<int>(surfaces.size());
  std::vector<char> deleted(n, 0);
  for (int f : features) {
    if (f < 0 || f >= n) throw std::invalid_argument("the layer has no feature " + std::to_string(f));
    deleted[f] = 1;
  }
  if (features.empty()) throw std::invalid_argument("no feature to delete");
  if (std::all_of(deleted.begin(), deleted.end(), [](char d) { return d != 0; }))
    throw std::invalid_argument("deleting every feature leaves nothing");
  // The group as one label, n, and its border loops.
  std::vector<int> group_labels = labels;
  for (int& l : group_labels)
    if (l >= 0 && deleted[l]) l = n;
  take_rim_triangles(mesh, n, group_labels);
  const std::vector<BorderLoop> loops = border_loops(mesh, group_labels, n);
  if (loops.empty()) throw std::invalid_argument("the features to delete have no triangles");
  const std::vector<int> hosts = hosts_of(mesh, group_labels, n, surfaces, loops);

  // The features that remain, renumbered in order.
  DeleteResult result;
  std::vector<int> new_id(n, -1);
  for (int f = 0; f < n; ++f)
    if (!deleted[f]) {
      new_id[f] = static_cast<int>(result.kept.size());
      result.kept.push_back(f);
    }
  std::vector<Surface> kept_surfaces;
  for (int f : result.kept) kept_surfaces.push_back(surfaces[f]);
  // Faces: those outside the group, then each gap closed on its host.
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (group_labels[f] != n) {
      faces.push_back({mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)});
      result.labels.push_back(labels[f] >= 0 ? new_id[labels[f]] : -1);
    }
  std::vector<std::vector<int>> host_faces(n);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (group_labels[f] >= 0 && group_labels[f] != n) host_faces[group_labels[f]].push_back(f);
  std::set<int> host_set;
  for (size_t i = 0; i < loops.size(); ++i) {
    const int host = hosts[i];
    bool winds = false;
    // Walked as the group's border, the loop is counter-clockwise about the host's outside.
    const std::vector<Eigen::Vector2d> chart = loop_chart(mesh, loops[i].vertices, host_faces[host], surfaces[host], winds);
    for (const std::array<int, 3>& t : ear_clipping(chart)) {
      faces.push_back({loops[i].vertices[t[0]], loops[i].vertices[t[1]], loops[i].vertices[t[2]]});
      result.labels.push_back(new_id[host]);
    }
    host_set.insert(new_id[host]);
  }
  result.hosts.assign(host_set.begin(), host_set.end());
  if (mesh_was_closed(mesh)) check_closed(faces);
  // Vertices only the group used go.
  std::vector<int> vertex_id(mesh.num_vertices(), -1);
  int next = 0;
  for (const auto& t : faces)
    for (int v : t)
      if (vertex_id[v] < 0) vertex_id[v] = next++;
  result.mesh.V.resize(next, 3);
  for (int v = 0; v < mesh.num_vertices(); ++v)
    if (vertex_id[v] >= 0) result.mesh.V.row(vertex_id[v]) = mesh.V.row(v);
  result.mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c) result.mesh.F(static_cast<Eigen::Index>(f), c) = vertex_id[faces[f][c]];

  // The hosts remeshed at their own density; the other features keep their triangles.
  const std::vector<double> before = remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths,
                                                       options.distance_tolerance);
  result.target_edge_lengths.resize(result.kept.size());
  for (size_t k = 0; k < result.kept.size(); ++k) result.target_edge_lengths[k] = before[result.kept[k]];
  if (options.remesh) {
    std::vector<double> targets(result.kept.size(), 0.0);
    for (int h : result.hosts) targets[h] = result.target_edge_lengths[h];
    std::set<std::pair<int, int>> g1;
    for (const FeatureAdjacency& a : adjacency)
      if (a.continuity == Continuity::G1 && !deleted[a.a] && !deleted[a.b])
        g1.insert({std::min(new_id[a.a], new_id[a.b]), std::max(new_id[a.a], new_id[a.b])});
    try {
      RemeshedLayer remeshed = remesh_adaptive(result.mesh, result.labels, targets, kept_surfaces, g1,
                                               options.remesh_iterations);
      result.mesh = std::move(remeshed.mesh);
      result.labels = std::move(remeshed.labels);
    } catch (const std::exception& e) {
      result.remeshing_problem = e.what();
    }
  }
  result.vertex_deviation = vertex_deviation(result.mesh, result.labels, kept_surfaces);
  return result;
}

}  // namespace idealize
