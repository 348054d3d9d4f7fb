#include "features/feature_tables.h"

#include "features/patch_points.h"

#include <algorithm>
#include <string>

namespace idealize {

FeatureTables feature_tables(const TriangleMesh& mesh, const std::vector<int>& labels, int num_features) {
  const int nf = mesh.num_faces();
  if (static_cast<int>(labels.size()) != nf)
    throw MeshError("one label per face is needed (" + std::to_string(nf) + " faces, " +
                    std::to_string(labels.size()) + " labels)");
  for (int l : labels)
    if (l < -1 || l >= num_features)
      throw MeshError("a face's feature " + std::to_string(l) + " is not one of the " +
                      std::to_string(num_features) + " features");
  const MeshTopology topology(mesh);
  FeatureTables tables;
  tables.adjacent = adjacent_pairs(mesh, topology, labels);

  label_sums(face_areas(mesh), labels, num_features, tables.area, tables.triangles);

  // Each vertex's distinct features, counted per feature, then placed by feature (a counting sort:
  // vertices come in order, so within a feature they stay sorted).
  std::vector<int> offsets(num_features + 1, 0);
  std::vector<int> mine;
  const auto features_of = [&](int v) {
    mine.clear();
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f)
      if (labels[*f] >= 0 && std::find(mine.begin(), mine.end(), labels[*f]) == mine.end()) mine.push_back(labels[*f]);
    return mine;
  };
  for (int v = 0; v < mesh.num_vertices(); ++v)
    for (int l : features_of(v)) ++offsets[l + 1];
  for (int l = 0; l < num_features; ++l) offsets[l + 1] += offsets[l];
  tables.vertex_features.resize(offsets.back());
  for (int v = 0; v < mesh.num_vertices(); ++v)
    for (int l : features_of(v)) tables.vertex_features[offsets[l]++] = {v, l};
  return tables;
}

}  // namespace idealize
