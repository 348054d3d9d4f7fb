#include "core/mesh.h"

#include <algorithm>
#include <limits>
#include <numeric>

namespace idealize {

void group_by_key(const int* keys, size_t count, int key_count, std::vector<int>& offsets, std::vector<int>& items) {
  offsets.assign(key_count + 1, 0);
  for (size_t i = 0; i < count; ++i)
    if (keys[i] >= 0) ++offsets[keys[i] + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  items.resize(offsets.back());
  std::vector<int> cursor(offsets.begin(), offsets.end() - 1);
  for (size_t i = 0; i < count; ++i)
    if (keys[i] >= 0) items[cursor[keys[i]]++] = static_cast<int>(i);
}

MeshTopology::MeshTopology(const TriangleMesh& mesh) {
  const MatrixX3i& F = mesh.F;
  const int nv = mesh.num_vertices();
  const int nf = mesh.num_faces();
  // The corners of each vertex (3 * face + corner, rows of F being row-major), then their faces.
  group_by_key(F.data(), 3 * static_cast<size_t>(nf), nv, vertex_face_offsets_, vertex_faces_);
  for (int& corner : vertex_faces_) corner /= 3;

  // Half-edges bucketed by their smaller vertex; within a bucket sorted by the larger one, so
  // equal keys are adjacent and become one edge. Linear apart from tiny per-vertex sorts.
  struct HalfEdge {
    int other;   // larger vertex
    int corner;  // 3 * face + corner opposite to the edge
  };
  std::vector<int> bucket_offsets(nv + 1, 0);
  for (int f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, (c + 1) % 3), b = F(f, (c + 2) % 3);
      ++bucket_offsets[std::min(a, b) + 1];
    }
  std::partial_sum(bucket_offsets.begin(), bucket_offsets.end(), bucket_offsets.begin());
  std::vector<HalfEdge> half_edges(bucket_offsets.back());
  {
    std::vector<int> cursor(bucket_offsets.begin(), bucket_offsets.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) {
        const int a = F(f, (c + 1) % 3), b = F(f, (c + 2) % 3);
        half_edges[cursor[std::min(a, b)]++] = {std::max(a, b), 3 * f + c};
      }
  }

  face_edges_.assign(3 * static_cast<size_t>(nf), -1);
  face_neighbors_.assign(3 * static_cast<size_t>(nf), -1);
  boundary_vertex_.assign(nv, 0);
  edge_vertices_.reserve(half_edges.size() / 2 + 1);
  for (int a = 0; a < nv; ++a) {
    auto first = half_edges.begin() + bucket_offsets[a];
    auto last = half_edges.begin() + bucket_offsets[a + 1];
    std::sort(first, last, [](const HalfEdge& x, const HalfEdge& y) {
      return x.other != y.other ? x.other < y.other : x.corner < y.corner;
    });
    for (auto run = first; run != last;) {
      auto run_end = run;
      while (run_end != last && run_end->other == run->other) ++run_end;
      const int e = static_cast<int>(edge_vertices_.size());
      const int count = static_cast<int>(run_end - run);
      edge_vertices_.push_back({a, run->other});
      edge_face_count_.push_back(count);
      for (auto h = run; h != run_end; ++h) face_edges_[h->corner] = e;
      if (count == 2) {
        face_neighbors_[run->corner] = (run + 1)->corner / 3;
        face_neighbors_[(run + 1)->corner] = run->corner / 3;
      } else {
        boundary_vertex_[a] = boundary_vertex_[run->other] = 1;
        (count == 1 ? num_boundary_edges_ : num_nonmanifold_edges_)++;
      }
      run = run_end;
    }
  }

  // One-ring vertex neighbours: the other two vertices of every incident face, deduplicated.
  vertex_neighbor_offsets_.assign(nv + 1, 0);
  std::vector<int> ring;
  vertex_neighbors_.reserve(vertex_faces_.size());
  for (int v = 0; v < nv; ++v) {
    ring.clear();
    for (const int* f = vertex_faces_begin(v); f != vertex_faces_end(v); ++f)
      for (int c = 0; c < 3; ++c)
        if (F(*f, c) != v) ring.push_back(F(*f, c));
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    vertex_neighbors_.insert(vertex_neighbors_.end(), ring.begin(), ring.end());
    vertex_neighbor_offsets_[v + 1] = static_cast<int>(vertex_neighbors_.size());
  }
}

int face_components(const MeshTopology& topology, const std::vector<int>& face_class,
                    std::vector<int>& component) {
  const int nf = static_cast<int>(face_class.size());
  component.assign(nf, -1);
  std::vector<int> stack;
  int count = 0;
  for (int seed = 0; seed < nf; ++seed) {
    if (face_class[seed] < 0 || component[seed] >= 0) continue;
    component[seed] = count;
    stack.push_back(seed);
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g >= 0 && component[g] < 0 && face_class[g] == face_class[f]) {
          component[g] = count;
          stack.push_back(g);
        }
      }
    }
    ++count;
  }
  return count;
}

Eigen::Vector3d face_normal(const TriangleMesh& mesh, int f) {
  const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  return (b - a).cross(c - a).normalized();
}

Eigen::Vector3d face_centroid(const TriangleMesh& mesh, int f) {
  return (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))).transpose() / 3.0;
}

Eigen::VectorXd face_areas(const TriangleMesh& mesh) {
  Eigen::VectorXd areas(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0));
    const Eigen::Vector3d b = mesh.V.row(mesh.F(f, 1));
    const Eigen::Vector3d c = mesh.V.row(mesh.F(f, 2));
    areas[f] = 0.5 * (b - a).cross(c - a).norm();
  }
  return areas;
}

double bounding_box_diagonal(const TriangleMesh& mesh) {
  if (mesh.V.rows() == 0) return 0.0;
  return (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
}

double coordinate_floor(const TriangleMesh& mesh) {
  if (mesh.V.rows() == 0) return 0.0;
  return std::max(1e-6 * bounding_box_diagonal(mesh), 2.0 * std::numeric_limits<float>::epsilon() * mesh.V.cwiseAbs().maxCoeff());
}

double median_edge_length(const TriangleMesh& mesh, const MeshTopology& topology) {
  std::vector<double> lengths(topology.num_edges());
  for (int e = 0; e < topology.num_edges(); ++e) {
    const auto& ev = topology.edge_vertices(e);
    lengths[e] = (mesh.V.row(ev[0]) - mesh.V.row(ev[1])).norm();
  }
  if (lengths.empty()) return 0.0;
  auto middle = lengths.begin() + lengths.size() / 2;
  std::nth_element(lengths.begin(), middle, lengths.end());
  return *middle;
}

}  // namespace idealize
