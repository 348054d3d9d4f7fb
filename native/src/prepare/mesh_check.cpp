#include "prepare/mesh_check.h"

#include <algorithm>
#include <numeric>
#include <utility>

namespace idealize {

namespace {

// Union-find over a dense index range, with path halving (no recursion).
struct DisjointSets {
  std::vector<int> parent;
  explicit DisjointSets(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  bool unite(int a, int b) {
    a = find(a), b = find(b);
    if (a == b) return false;
    if (a > b) std::swap(a, b);
    parent[b] = a;
    return true;
  }
};

// The corner of face g whose opposite edge is e.
int corner_of_edge(const MeshTopology& topology, int g, int e) {
  for (int c = 0; c < 3; ++c)
    if (topology.face_edge(g, c) == e) return c;
  return -1;
}

// Boundary loops: connected chains of boundary edges (chains touching at a vertex count as one).
void count_boundary_loops(const TriangleMesh& mesh, const MeshTopology& topology, MeshCheck& out,
                          const ProgressSpan& progress) {
  if (topology.num_boundary_edges() == 0) return;
  DisjointSets sets(mesh.num_vertices());
  const int ne = topology.num_edges();
  for (int e = 0; e < ne; ++e) {
    progress.poll(e);
    if (topology.edge_face_count(e) == 1) sets.unite(topology.edge_vertices(e)[0], topology.edge_vertices(e)[1]);
  }
  std::vector<int> edges_per_root(mesh.num_vertices(), 0);
  for (int e = 0; e < ne; ++e)
    if (topology.edge_face_count(e) == 1) ++edges_per_root[sets.find(topology.edge_vertices(e)[0])];
  for (int count : edges_per_root)
    if (count > 0) {
      ++out.boundary_loops;
      out.largest_hole_edges = std::max(out.largest_hole_edges, count);
    }
}

// Vertices whose faces form more than one fan: faces around v are joined when they share an edge
// at v (of any number of faces), and more than one group means separate sheets meet at v.
int count_nonmanifold_vertices(const TriangleMesh& mesh, const MeshTopology& topology, const ProgressSpan& progress) {
  int count = 0;
  std::vector<std::pair<int, int>> edge_face;  // (edge at v, index of the face in v's ring)
  std::vector<int> parent;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    progress.poll(v);
    const int* begin = topology.vertex_faces_begin(v);
    const int n = topology.vertex_face_count(v);
    if (n <= 1) continue;
    if (!topology.is_boundary_vertex(v)) {
      // Only manifold edges at v: walk once around from the first face; a single fan comes back
      // after visiting all n faces.
      const int f0 = begin[0];
      auto corner = [&](int f) { return mesh.F(f, 0) == v ? 0 : mesh.F(f, 1) == v ? 1 : 2; };
      int c = (corner(f0) + 1) % 3;
      int e = topology.face_edge(f0, c);
      int f = topology.face_neighbor(f0, c);
      int visited = 1;
      while (f != f0 && f >= 0 && visited <= n) {
        ++visited;
        const int cv = corner(f);
        c = topology.face_edge(f, (cv + 1) % 3) == e ? (cv + 2) % 3 : (cv + 1) % 3;
        e = topology.face_edge(f, c);
        f = topology.face_neighbor(f, c);
      }
      if (f == f0 && visited == n) continue;
      if (f == f0 && visited < n) {
        ++count;  // the walk closed before seeing every face: more than one fan
        continue;
      }
      // (otherwise fall through to the general count)
    }
    edge_face.clear();
    for (int i = 0; i < n; ++i) {
      const int f = begin[i];
      const int cv = mesh.F(f, 0) == v ? 0 : mesh.F(f, 1) == v ? 1 : 2;
      edge_face.emplace_back(topology.face_edge(f, (cv + 1) % 3), i);
      edge_face.emplace_back(topology.face_edge(f, (cv + 2) % 3), i);
    }
    std::sort(edge_face.begin(), edge_face.end());
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    int groups = n;
    for (size_t k = 1; k < edge_face.size(); ++k)
      if (edge_face[k].first == edge_face[k - 1].first) {
        const int a = find(edge_face[k].second), b = find(edge_face[k - 1].second);
        if (a != b) {
          parent[std::max(a, b)] = std::min(a, b);
          --groups;
        }
      }
    if (groups > 1) ++count;
  }
  return count;
}

// Six times the signed volume enclosed by `faces` (turned over where `flipped`), about `origin`.
double signed_volume6(const TriangleMesh& mesh, const int* faces, int count, const std::vector<char>& flipped,
                      const Eigen::Vector3d& origin) {
  double sum = 0.0;
  for (int i = 0; i < count; ++i) {
    const int f = faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)).transpose() - origin;
    Eigen::Vector3d b = mesh.V.row(mesh.F(f, 1)).transpose() - origin;
    Eigen::Vector3d c = mesh.V.row(mesh.F(f, 2)).transpose() - origin;
    if (flipped[f]) std::swap(b, c);
    sum += a.dot(b.cross(c));
  }
  return sum;
}

}  // namespace

MeshCheck check_mesh(const TriangleMesh& mesh, const MeshTopology& topology, const MeshCheckOptions& options,
                     const ProgressSpan& progress) {
  MeshCheck out;
  const int nf = mesh.num_faces();
  out.boundary_edges = topology.num_boundary_edges();
  out.nonmanifold_edges = topology.num_nonmanifold_edges();
  progress.step(0.0);

  // Shells, orientation consistency and the orientation that makes each shell consistent: a
  // breadth-first walk over manifold edges. `flip` is relative to each shell's first face.
  std::vector<char> flip(nf, 0), visited(nf, 0);
  std::vector<int> order;  // faces shell by shell, in walk order
  order.reserve(nf);
  std::vector<int> shell_start;
  const ProgressSpan walk = progress.sub(0.0, 0.3);
  for (int seed = 0; seed < nf; ++seed) {
    if (visited[seed]) continue;
    walk.tick(static_cast<long long>(order.size()), nf, 1 << 12);
    const int start = static_cast<int>(order.size());
    shell_start.push_back(start);
    visited[seed] = 1;
    order.push_back(seed);
    bool orientable = true, open = false;
    for (size_t head = start; head < order.size(); ++head) {
      walk.poll(static_cast<long long>(head));
      const int f = order[head];
      for (int c = 0; c < 3; ++c) {
        const int e = topology.face_edge(f, c);
        if (topology.edge_face_count(e) == 1) open = true;
        const int g = topology.face_neighbor(f, c);
        if (g < 0) continue;
        const int cg = corner_of_edge(topology, g, e);
        // f runs along the edge from F(f, c+1) to F(f, c+2); g consistently runs the other way.
        const bool same_direction = mesh.F(g, (cg + 1) % 3) == mesh.F(f, (c + 1) % 3);
        if (same_direction && f < g) ++out.inconsistent_edges;
        const char wanted = static_cast<char>(flip[f] ^ (same_direction ? 1 : 0));
        if (!visited[g]) {
          visited[g] = 1;
          flip[g] = wanted;
          order.push_back(g);
        } else if (flip[g] != wanted) {
          orientable = false;
        }
      }
    }
    const int count = static_cast<int>(order.size()) - start;
    if (!orientable) ++out.nonorientable_shells;
    if (!options.repair_orientation) continue;
    // Which of the two consistent orientations: outward for a closed orientable shell, else the
    // majority's (ties: the first face's).
    const int* faces = order.data() + start;
    bool invert = false;
    double volume = 0.0;
    if (!open && orientable) {
      const Eigen::Vector3d origin = mesh.V.row(mesh.F(seed, 0)).transpose();
      volume = signed_volume6(mesh, faces, count, flip, origin);
    }
    if (volume != 0.0) {
      invert = volume < 0.0;
    } else {
      int flipped = 0;
      for (int i = 0; i < count; ++i) flipped += flip[faces[i]];
      invert = 2 * flipped > count;
    }
    if (invert) {
      for (int i = 0; i < count; ++i) flip[faces[i]] ^= 1;
      if (!open && orientable) {
        int turned = 0;  // a shell that was inside out as a whole has every face turned
        for (int i = 0; i < count; ++i) turned += flip[faces[i]];
        if (turned == count) ++out.closed_shells_turned_outward;
      }
    }
  }
  out.shells = static_cast<int>(shell_start.size());
  if (options.repair_orientation) {
    out.flipped_faces_repaired = static_cast<int>(std::count(flip.begin(), flip.end(), 1));
    if (out.flipped_faces_repaired > 0) out.flipped = std::move(flip);
  }
  progress.step(0.3);

  count_boundary_loops(mesh, topology, out, progress.sub(0.3, 0.4));
  progress.step(0.4);
  out.nonmanifold_vertices = count_nonmanifold_vertices(mesh, topology, progress.sub(0.4, 0.5));
  progress.step(0.5);

  if (options.self_intersections) {
    out.self_intersecting_pairs =
        options.self_intersections(mesh, options.max_self_intersecting_pairs, progress.sub(0.5, 1.0));
    out.self_intersections_capped = out.self_intersecting_pairs >= options.max_self_intersecting_pairs;
  }
  progress.step(1.0);
  return out;
}

void apply_orientation(TriangleMesh& mesh, const MeshCheck& check) {
  if (check.flipped.empty()) return;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (check.flipped[f]) std::swap(mesh.F(f, 1), mesh.F(f, 2));
}

}  // namespace idealize
