// Indexed triangle mesh and its adjacency.
//
// Conventions follow libigl: V is #V x 3 double, F is #F x 3 int, both row-major so that numpy
// arrays pass without copies. Per-element data shared between algorithms lives in plain arrays
// indexed by vertex or face (named like pmp-library properties in the comments: "v:mean_curvature").
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace idealize {

using MatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using MatrixX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Any problem with the user's mesh: the message names the problem in words a user understands.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TriangleMesh {
  MatrixX3d V;  // #V x 3 vertex positions
  MatrixX3i F;  // #F x 3 vertex indices, counter-clockwise seen from outside

  int num_vertices() const { return static_cast<int>(V.rows()); }
  int num_faces() const { return static_cast<int>(F.rows()); }
};

// Edge-based adjacency of a mesh whose faces have three distinct vertices.
// Edges shared by more than two faces (non-manifold) are kept but have no "opposite" face.
class MeshTopology {
 public:
  explicit MeshTopology(const TriangleMesh& mesh);

  int num_edges() const { return static_cast<int>(edge_vertices_.size()); }
  // Two vertex indices (smaller first) of edge e.
  const std::array<int, 2>& edge_vertices(int e) const { return edge_vertices_[e]; }
  // Edge opposite to corner c (0..2) of face f: the edge (F(f,c+1), F(f,c+2)).
  int face_edge(int f, int c) const { return face_edges_[3 * f + c]; }
  // Face across edge opposite to corner c of face f; -1 on a boundary or non-manifold edge.
  int face_neighbor(int f, int c) const { return face_neighbors_[3 * f + c]; }
  // Number of faces using edge e (1 = boundary, 2 = manifold, >2 = non-manifold).
  int edge_face_count(int e) const { return edge_face_count_[e]; }
  // Faces incident to vertex v, as a range in a compressed array.
  const int* vertex_faces_begin(int v) const { return vertex_faces_.data() + vertex_face_offsets_[v]; }
  const int* vertex_faces_end(int v) const { return vertex_faces_.data() + vertex_face_offsets_[v + 1]; }
  int vertex_face_count(int v) const { return vertex_face_offsets_[v + 1] - vertex_face_offsets_[v]; }
  // Neighbouring vertices of v (one ring), as a range in a compressed array, sorted.
  const int* vertex_neighbors_begin(int v) const { return vertex_neighbors_.data() + vertex_neighbor_offsets_[v]; }
  const int* vertex_neighbors_end(int v) const { return vertex_neighbors_.data() + vertex_neighbor_offsets_[v + 1]; }
  // True for vertices on a boundary or non-manifold edge.
  bool is_boundary_vertex(int v) const { return boundary_vertex_[v] != 0; }

  int num_boundary_edges() const { return num_boundary_edges_; }
  int num_nonmanifold_edges() const { return num_nonmanifold_edges_; }

 private:
  std::vector<std::array<int, 2>> edge_vertices_;
  std::vector<int> edge_face_count_;
  std::vector<int> face_edges_;
  std::vector<int> face_neighbors_;
  std::vector<int> vertex_face_offsets_, vertex_faces_;
  std::vector<int> vertex_neighbor_offsets_, vertex_neighbors_;
  std::vector<char> boundary_vertex_;
  int num_boundary_edges_ = 0;
  int num_nonmanifold_edges_ = 0;
};

// Items 0 .. count-1 grouped by their key (0 <= keys[i] < key_count; items of negative key are left
// out), in item order within a group (a stable counting sort): group k is
// items[offsets[k] .. offsets[k + 1]).
void group_by_key(const int* keys, size_t count, int key_count, std::vector<int>& offsets, std::vector<int>& items);

// Connected components, through manifold edges, of faces of equal class; faces of negative class
// belong to none (-1). Returns the number of components and writes one id per face. A class
// vector of zeros gives the shells of the mesh.
int face_components(const MeshTopology& topology, const std::vector<int>& face_class,
                    std::vector<int>& component);

// Area of every face ("f:area").
Eigen::VectorXd face_areas(const TriangleMesh& mesh);

// Unit normal of face f (NaN for a degenerate face).
Eigen::Vector3d face_normal(const TriangleMesh& mesh, int f);

// Centroid of face f.
Eigen::Vector3d face_centroid(const TriangleMesh& mesh, int f);

// Length of the bounding-box diagonal (0 for an empty mesh).
double bounding_box_diagonal(const TriangleMesh& mesh);

// The least distance that tells two points of the mesh apart: the rounding of single-precision
// (STL) coordinates, with margin, whose spacing grows with the distance from the origin (which a
// part far out in its assembly's frame shows); at least a millionth of the diagonal.
double coordinate_floor(const TriangleMesh& mesh);

// Median length of the mesh's edges (0 for a mesh without edges).
double median_edge_length(const TriangleMesh& mesh, const MeshTopology& topology);

// What a mesh is: an exact tessellation (its vertices lie on their faces, as a CAD export's do) or
// a measured surface (a scan, a sculpted or remeshed surface: noise, undulation).
enum class MeshKind { ExactTessellation, MeasuredSurface };

}  // namespace idealize
