// A triangle mesh whose connectivity changes as it is sculpted (thesis ch. 5): a half-edge
// structure with the local operations of dynamic topology, edge split, edge collapse and edge flip
// (as pmp-library's SurfaceMesh has them; Botsch et al., "Polygon Mesh Processing", 2010, ch. 2).
//
// Half-edges come in pairs, h and h ^ 1 (its opposite). A face is three half-edges in a cycle,
// counter-clockwise seen from outside; a half-edge with no face lies on the mesh's border, and the
// border's half-edges form cycles of their own. Deleted elements stay in the arrays until
// `compacted` copies the mesh out. Per face, the mesh carries a label (the feature it belonged to)
// and whether sculpting changed it; new faces take their label from the face they came from.
#pragma once

#include "core/mesh.h"

#include <algorithm>
#include <vector>

namespace idealize {

class SculptMesh {
 public:
  // From a consistently oriented, manifold mesh (`labels`: #F, or empty for -1 everywhere). Throws
  // MeshError naming the problem for an edge with more than two faces, faces of opposite
  // orientation, or a vertex where separate fans of faces touch.
  SculptMesh(const TriangleMesh& mesh, const std::vector<int>& labels);

  // The mesh without deleted elements; per face of it, the label (`labels`) and whether sculpting
  // changed it (`modified`).
  TriangleMesh compacted(std::vector<int>& labels, std::vector<char>& modified) const;

  int vertex_slots() const { return static_cast<int>(position_.size()); }
  int halfedge_slots() const { return static_cast<int>(to_.size()); }
  int face_slots() const { return static_cast<int>(face_halfedge_.size()); }
  int num_faces() const { return live_faces_; }

  Eigen::Vector3d& position(int v) { return position_[v]; }
  const Eigen::Vector3d& position(int v) const { return position_[v]; }
  bool vertex_deleted(int v) const { return vertex_halfedge_[v] == kDeleted; }
  bool face_deleted(int f) const { return face_halfedge_[f] < 0; }
  bool edge_deleted(int h) const { return to_[h] < 0; }

  int halfedge(int v) const { return vertex_halfedge_[v]; }  // outgoing; a border one on the border
  int to(int h) const { return to_[h]; }
  int from(int h) const { return to_[h ^ 1]; }
  int next(int h) const { return next_[h]; }
  int prev(int h) const { return prev_[h]; }
  static int opposite(int h) { return h ^ 1; }
  int face(int h) const { return face_[h]; }
  int face_halfedge(int f) const { return face_halfedge_[f]; }
  bool border(int h) const { return face_[h] < 0; }
  bool border_vertex(int v) const { return border(vertex_halfedge_[v]); }
  // The outgoing half-edge after h round its origin (the whole fan, on the border too).
  int rotated(int h) const { return next_[h ^ 1]; }

  int& label(int f) { return label_[f]; }
  int label(int f) const { return label_[f]; }
  void mark(int f) { modified_[f] = 1; }
  void clear_marks() { std::fill(modified_.begin(), modified_.end(), 0); }
  bool modified(int f) const { return modified_[f] != 0; }

  int valence(int v) const;
  // The half-edge from a to b, or -1.
  int find_halfedge(int a, int b) const;
  Eigen::Vector3d face_normal(int f) const;    // unit
  Eigen::Vector3d vertex_normal(int v) const;  // unit, area-weighted
  Eigen::Vector3d neighbour_centroid(int v) const;  // the mean of v's neighbours (v itself if none)

  // Splits the edge of h at p: the new vertex, joined to the opposite corners (two faces become
  // four, one becomes two on the border). Returns the new vertex.
  int split(int h, const Eigen::Vector3d& p);
  // Whether collapsing h (its origin onto its end) keeps the mesh manifold (the link condition).
  bool collapse_ok(int h) const;
  // Collapses h: its origin goes, its end stays where it is. Call collapse_ok first.
  void collapse(int h);
  // Whether the edge of h can be flipped: not on the border, and the new edge not there already.
  bool flip_ok(int h) const;
  // Flips the edge of h to join the two opposite corners. Call flip_ok first.
  void flip(int h);

 private:
  static constexpr int kDeleted = -2;
  int new_vertex(const Eigen::Vector3d& p);
  int new_edge(int a, int b);  // the half-edge a -> b (its opposite b -> a)
  int new_face(int like);      // takes the label of face `like`, marked modified
  void link(int h, int n) {
    next_[h] = n;
    prev_[n] = h;
  }
  void border_outgoing(int v);  // a border vertex's outgoing half-edge: a border one
  void remove_edge(int h);
  void remove_loop(int h);

  std::vector<Eigen::Vector3d> position_;
  std::vector<int> vertex_halfedge_;  // -1 isolated, kDeleted
  std::vector<int> to_, next_, prev_, face_;
  std::vector<int> face_halfedge_;    // -1 deleted
  std::vector<int> label_;
  std::vector<char> modified_;
  int live_faces_ = 0;
};

// Where the ray from `origin` along `direction` (not zero) first meets a face of `mesh` (front or
// back; the smallest parameter t >= 0 of origin + t direction; core/ray.h): the picking of a view,
// on the mesh as it is being sculpted. False when it meets none.
bool first_hit(const SculptMesh& mesh, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
               Eigen::Vector3d& hit);

}  // namespace idealize
