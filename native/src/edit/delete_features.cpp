// Deleting a feature group: lift its triangles off, close each gap on the faces around it, remesh
// the closing triangles (see delete_features.h).
#include "edit/delete_features.h"

#include "edit/erosion.h"
#include "edit/feature_groups.h"
#include "edit/gaps.h"

#include <algorithm>
#include <array>
#include <set>
#include <string>

namespace idealize {

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

  // Each gap closed by the faces around it (erosion.h): its triangles and new vertices.
  std::vector<int> identity(n);
  for (int f = 0; f < n; ++f) identity[f] = f;
  const std::set<std::pair<int, int>> g1 = tangent_pairs(adjacency, identity);
  std::vector<ErodedGap> gaps;
  int first_point = mesh.num_vertices();
  std::vector<int> joined(n);  // union-find over the identical hosts a fill joins
  for (int f = 0; f < n; ++f) joined[f] = f;
  auto root = [&](int f) {
    while (joined[f] != f) f = joined[f] = joined[joined[f]];
    return f;
  };
  for (const BorderLoop& loop : loops) {
    // New edges are cut at the spacing of the loop's own edges.
    double length = 0.0;
    for (size_t i = 0; i < loop.vertices.size(); ++i)
      length += (mesh.V.row(loop.vertices[i]) - mesh.V.row(loop.vertices[(i + 1) % loop.vertices.size()])).norm();
    gaps.push_back(erode_gap(mesh, group_labels, surfaces, loop, first_point, options.distance_tolerance, g1,
                             length / static_cast<double>(loop.vertices.size())));
    first_point += static_cast<int>(gaps.back().points.size());
    for (const auto& [f, into] : gaps.back().merged) {
      const int a = root(f), b = root(into);
      if (a != b) joined[std::max(a, b)] = std::min(a, b);
    }
  }

  // The features that remain, renumbered in order; a host joined to an identical one goes.
  DeleteResult result;
  std::vector<int> new_id(n, -1);
  for (int f = 0; f < n; ++f)
    if (!deleted[f] && root(f) == f) {
      new_id[f] = static_cast<int>(result.kept.size());
      result.kept.push_back(f);
    }
  for (int f = 0; f < n; ++f)
    if (!deleted[f] && root(f) != f) {
      new_id[f] = new_id[root(f)];
      result.merged.emplace_back(f, root(f));
    }
  std::vector<Surface> kept_surfaces;
  for (int f : result.kept) kept_surfaces.push_back(surfaces[f]);
  // Faces: those outside the group, then each gap's.
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (group_labels[f] != n) {
      faces.push_back({mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)});
      result.labels.push_back(labels[f] >= 0 ? new_id[labels[f]] : -1);
      result.created.push_back(0);
    }
  MatrixX3d V(first_point, 3);
  V.topRows(mesh.num_vertices()) = mesh.V;
  std::set<int> host_set;
  std::set<std::pair<int, int>> edges;
  int row = mesh.num_vertices();
  for (const ErodedGap& gap : gaps) {
    for (const Eigen::Vector3d& p : gap.points) V.row(row++) = p.transpose();
    for (size_t t = 0; t < gap.faces.size(); ++t) {
      faces.push_back(gap.faces[t]);
      result.labels.push_back(new_id[gap.hosts[t]]);
      result.created.push_back(1);
      host_set.insert(new_id[gap.hosts[t]]);
    }
    for (const auto& [a, b] : gap.edges)
      if (new_id[a] != new_id[b]) edges.insert({std::min(new_id[a], new_id[b]), std::max(new_id[a], new_id[b])});
    result.new_edges += static_cast<int>(gap.edges.size());
    result.corners += gap.corners;
  }
  result.edges.assign(edges.begin(), edges.end());
  result.hosts.assign(host_set.begin(), host_set.end());
  if (is_closed(mesh)) check_closed(faces);
  result.mesh = compact_mesh(V, faces);

  // The closing triangles remeshed at their hosts' density; the other triangles stay.
  const std::vector<double> before = remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths,
                                                       options.distance_tolerance);
  result.target_edge_lengths.resize(result.kept.size());
  for (size_t k = 0; k < result.kept.size(); ++k) result.target_edge_lengths[k] = before[result.kept[k]];
  result.vertex_deviation = finish_created(result.mesh, result.labels, result.created, kept_surfaces,
                                           result.target_edge_lengths, tangent_pairs(adjacency, new_id),
                                           options.remesh, result.remeshing_problem);
  return result;
}

}  // namespace idealize
