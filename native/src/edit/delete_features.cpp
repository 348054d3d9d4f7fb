// Deleting a feature group: lift its triangles off, close each gap on its host, remesh the closing
// triangles (see delete_features.h).
#include "edit/delete_features.h"

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
  const std::vector<int> hosts = gap_hosts(mesh, group_labels, n, surfaces, loops);

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
      result.created.push_back(0);
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
    for (const std::array<int, 3>& t : close_polygon(chart)) {
      faces.push_back({loops[i].vertices[t[0]], loops[i].vertices[t[1]], loops[i].vertices[t[2]]});
      result.labels.push_back(new_id[host]);
      result.created.push_back(1);
    }
    host_set.insert(new_id[host]);
  }
  result.hosts.assign(host_set.begin(), host_set.end());
  if (is_closed(mesh)) check_closed(faces);
  result.mesh = compact_mesh(mesh.V, faces);

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
