// The half-edge mesh of sculpting and its local operations (see sculpt_mesh.h). The operations
// follow pmp-library's SurfaceMesh (split, collapse with its two helpers, flip).
#include "sculpt/sculpt_mesh.h"

#include "core/ray.h"

#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

namespace idealize {

SculptMesh::SculptMesh(const TriangleMesh& mesh, const std::vector<int>& labels) {
  const int nv = mesh.num_vertices(), nf = mesh.num_faces();
  if (!labels.empty() && static_cast<int>(labels.size()) != nf)
    throw std::invalid_argument("SculptMesh: one label per face");
  position_.resize(nv);
  for (int v = 0; v < nv; ++v) position_[v] = mesh.V.row(v).transpose();
  vertex_halfedge_.assign(nv, -1);
  std::unordered_map<long long, int> edges;  // (smaller, larger) -> the half-edge smaller -> larger
  edges.reserve(3 * static_cast<size_t>(nf) / 2 + 1);
  std::vector<int> corner(3);
  for (int f = 0; f < nf; ++f) {
    const int face = new_face(-1);
    label_[face] = labels.empty() ? -1 : labels[f];
    modified_[face] = 0;
    for (int c = 0; c < 3; ++c) {
      const int a = mesh.F(f, c), b = mesh.F(f, (c + 1) % 3);
      if (a < 0 || b < 0 || a >= nv || b >= nv || a == b)
        throw MeshError("face " + std::to_string(f) + " has a repeated or invalid vertex index");
      const long long key = static_cast<long long>(std::min(a, b)) * nv + std::max(a, b);
      auto it = edges.find(key);
      int h;
      if (it == edges.end()) {
        h = new_edge(std::min(a, b), std::max(a, b));
        edges.emplace(key, h);
        if (a > b) h ^= 1;
      } else {
        h = a < b ? it->second : it->second ^ 1;
      }
      if (face_[h] >= 0)
        throw MeshError("the mesh is not a consistently oriented manifold: the edge between vertices " +
                        std::to_string(a) + " and " + std::to_string(b) +
                        " has more than two faces, or two faces of opposite orientation");
      face_[h] = face;
      corner[c] = h;
    }
    for (int c = 0; c < 3; ++c) link(corner[c], corner[(c + 1) % 3]);
    face_halfedge_[face] = corner[0];
    for (int c = 0; c < 3; ++c) vertex_halfedge_[from(corner[c])] = corner[c];
  }
  // Border half-edges: each starts where another ends; one per vertex, or the vertex is where
  // separate fans touch.
  std::vector<int> border_out(nv, -1);
  for (int h = 0; h < halfedge_slots(); ++h)
    if (face_[h] < 0) {
      if (border_out[from(h)] >= 0)
        throw MeshError("the mesh is not manifold at vertex " + std::to_string(from(h)) +
                        ": separate fans of faces touch there");
      border_out[from(h)] = h;
    }
  for (int h = 0; h < halfedge_slots(); ++h)
    if (face_[h] < 0) link(h, border_out[to(h)]);
  for (int v = 0; v < nv; ++v)
    if (border_out[v] >= 0) vertex_halfedge_[v] = border_out[v];
  // Every fan whole: the faces round each vertex, walked, are all its faces.
  std::vector<int> degree(nv, 0);
  for (int f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) ++degree[mesh.F(f, c)];
  for (int v = 0; v < nv; ++v) {
    if (vertex_halfedge_[v] < 0) continue;
    int faces = 0, h = vertex_halfedge_[v];
    do {
      faces += face_[h] >= 0;
      h = rotated(h);
    } while (h != vertex_halfedge_[v] && faces <= degree[v]);
    if (faces != degree[v])
      throw MeshError("the mesh is not manifold at vertex " + std::to_string(v) + ": separate fans of faces touch there");
  }
}

int SculptMesh::new_vertex(const Eigen::Vector3d& p) {
  position_.push_back(p);
  vertex_halfedge_.push_back(-1);
  return vertex_slots() - 1;
}

int SculptMesh::new_edge(int a, int b) {
  const int h = halfedge_slots();
  to_.insert(to_.end(), {b, a});
  next_.insert(next_.end(), {-1, -1});
  prev_.insert(prev_.end(), {-1, -1});
  face_.insert(face_.end(), {-1, -1});
  return h;
}

int SculptMesh::new_face(int like) {
  face_halfedge_.push_back(-1);
  label_.push_back(like >= 0 ? label_[like] : -1);
  modified_.push_back(1);
  ++live_faces_;
  return face_slots() - 1;
}

int SculptMesh::valence(int v) const {
  int count = 0, h = vertex_halfedge_[v];
  if (h < 0) return 0;
  do {
    ++count;
    h = rotated(h);
  } while (h != vertex_halfedge_[v]);
  return count;
}

int SculptMesh::find_halfedge(int a, int b) const {
  int h = vertex_halfedge_[a];
  if (h < 0) return -1;
  do {
    if (to_[h] == b) return h;
    h = rotated(h);
  } while (h != vertex_halfedge_[a]);
  return -1;
}

Eigen::Vector3d SculptMesh::face_normal(int f) const {
  const int h = face_halfedge_[f];
  const Eigen::Vector3d a = position_[from(h)], b = position_[to(h)], c = position_[to(next_[h])];
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double length = n.norm();
  return length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
}

Eigen::Vector3d SculptMesh::vertex_normal(int v) const {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  int h = vertex_halfedge_[v];
  if (h < 0) return n;
  do {
    if (face_[h] >= 0) {
      const Eigen::Vector3d a = position_[v], b = position_[to_[h]], c = position_[to_[next_[h]]];
      n += (b - a).cross(c - a);
    }
    h = rotated(h);
  } while (h != vertex_halfedge_[v]);
  const double length = n.norm();
  return length > 0.0 ? Eigen::Vector3d(n / length) : n;
}

Eigen::Vector3d SculptMesh::neighbour_centroid(int v) const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0, h = vertex_halfedge_[v];
  if (h < 0) return position_[v];
  do {
    sum += position_[to_[h]];
    ++count;
    h = rotated(h);
  } while (h != vertex_halfedge_[v]);
  return sum / count;
}

void SculptMesh::border_outgoing(int v) {
  int h = vertex_halfedge_[v];
  if (h < 0) return;
  do {
    if (face_[h] < 0) {
      vertex_halfedge_[v] = h;
      return;
    }
    h = rotated(h);
  } while (h != vertex_halfedge_[v]);
}

int SculptMesh::split(int h0, const Eigen::Vector3d& p) {
  const int v = new_vertex(p);
  const int o0 = h0 ^ 1;
  const int v2 = to_[o0];  // h0's origin
  const int e1 = new_edge(v, v2), t1 = e1 ^ 1;
  const int f0 = face_[h0], f3 = face_[o0];
  vertex_halfedge_[v] = h0;
  to_[o0] = v;
  if (f0 >= 0) {
    const int h1 = next_[h0], h2 = next_[h1];
    const int v1 = to_[h1];
    const int e0 = new_edge(v, v1), t0 = e0 ^ 1;
    const int f1 = new_face(f0);
    face_halfedge_[f0] = h0;
    face_halfedge_[f1] = h2;
    face_[h1] = face_[t0] = face_[h0] = f0;
    face_[h2] = face_[t1] = face_[e0] = f1;
    link(h0, h1);
    link(h1, t0);
    link(t0, h0);
    link(e0, h2);
    link(h2, t1);
    link(t1, e0);
    modified_[f0] = 1;
  } else {
    link(prev_[h0], t1);
    link(t1, h0);
  }
  if (f3 >= 0) {
    const int o1 = next_[o0], o2 = next_[o1];
    const int v3 = to_[o1];
    const int e2 = new_edge(v, v3), t2 = e2 ^ 1;
    const int f2 = new_face(f3);
    face_halfedge_[f2] = o1;
    face_halfedge_[f3] = o0;
    face_[o1] = face_[t2] = face_[e1] = f2;
    face_[o2] = face_[o0] = face_[e2] = f3;
    link(e1, o1);
    link(o1, t2);
    link(t2, e1);
    link(o0, e2);
    link(e2, o2);
    link(o2, o0);
    modified_[f3] = 1;
  } else {
    link(e1, next_[o0]);
    link(o0, e1);
    vertex_halfedge_[v] = e1;
  }
  if (vertex_halfedge_[v2] == h0) vertex_halfedge_[v2] = t1;
  return v;
}

bool SculptMesh::collapse_ok(int h) const {
  const int o = h ^ 1;
  const int v0 = to_[o], v1 = to_[h];
  int vl = -1, vr = -1;
  // The faces either side must not both have their other edges on the border.
  if (face_[h] >= 0) {
    const int h1 = next_[h], h2 = next_[h1];
    vl = to_[h1];
    if (face_[h1 ^ 1] < 0 && face_[h2 ^ 1] < 0) return false;
  }
  if (face_[o] >= 0) {
    const int o1 = next_[o], o2 = next_[o1];
    vr = to_[o1];
    if (face_[o1 ^ 1] < 0 && face_[o2 ^ 1] < 0) return false;
  }
  if (vl == vr) return false;
  // The opposite corners lose an edge each: one left with two (three on the border, where the
  // valence counts the border's edges) would hold two faces on the same three vertices, as on a
  // tetrahedron, which pmp-library's test lets through.
  for (int corner : {vl, vr})
    if (corner >= 0 && valence(corner) < (border_vertex(corner) ? 3 : 4)) return false;
  // An edge between two border vertices must be a border edge.
  if (border_vertex(v0) && border_vertex(v1) && face_[h] >= 0 && face_[o] >= 0) return false;
  // The link condition: v0's and v1's neighbours share only vl and vr.
  int g = vertex_halfedge_[v0];
  do {
    const int w = to_[g];
    if (w != v1 && w != vl && w != vr && find_halfedge(w, v1) >= 0) return false;
    g = rotated(g);
  } while (g != vertex_halfedge_[v0]);
  return true;
}

void SculptMesh::remove_edge(int h) {
  const int hn = next_[h], hp = prev_[h];
  const int o = h ^ 1, on = next_[o], op = prev_[o];
  const int fh = face_[h], fo = face_[o];
  const int vh = to_[h], vo = to_[o];
  // The half-edges into vo now end at vh.
  int g = vertex_halfedge_[vo];
  do {
    to_[g ^ 1] = vh;
    g = rotated(g);
  } while (g != vertex_halfedge_[vo]);
  link(hp, hn);
  link(op, on);
  if (fh >= 0) face_halfedge_[fh] = hn;
  if (fo >= 0) face_halfedge_[fo] = on;
  if (vertex_halfedge_[vh] == o) vertex_halfedge_[vh] = hn;
  border_outgoing(vh);
  vertex_halfedge_[vo] = kDeleted;
  to_[h] = to_[o] = -1;
}

void SculptMesh::remove_loop(int h0) {
  const int h1 = next_[h0];
  const int o0 = h0 ^ 1, o1 = h1 ^ 1;
  const int v0 = to_[h0], v1 = to_[h1];
  const int fh = face_[h0], fo = face_[o0];
  link(h1, next_[o0]);
  link(prev_[o0], h1);
  face_[h1] = fo;
  vertex_halfedge_[v0] = h1;
  border_outgoing(v0);
  vertex_halfedge_[v1] = o1;
  border_outgoing(v1);
  if (fo >= 0 && face_halfedge_[fo] == o0) face_halfedge_[fo] = h1;
  if (fh >= 0) {
    face_halfedge_[fh] = -1;
    --live_faces_;
  }
  if (fo >= 0) modified_[fo] = 1;
  to_[h0] = to_[o0] = -1;
}

void SculptMesh::collapse(int h) {
  const int h1 = prev_[h];
  const int o1 = next_[h ^ 1];
  // The faces round the end vertex change shape.
  for (int v : {to_[h], to_[h ^ 1]}) {
    int g = vertex_halfedge_[v];
    do {
      if (face_[g] >= 0) modified_[face_[g]] = 1;
      g = rotated(g);
    } while (g != vertex_halfedge_[v]);
  }
  remove_edge(h);
  if (next_[next_[h1]] == h1) remove_loop(h1);
  if (next_[next_[o1]] == o1) remove_loop(o1);
}

bool SculptMesh::flip_ok(int h) const {
  if (face_[h] < 0 || face_[h ^ 1] < 0) return false;
  const int v0 = to_[next_[h]], v1 = to_[next_[h ^ 1]];
  return v0 != v1 && find_halfedge(v0, v1) < 0;
}

void SculptMesh::flip(int a0) {
  const int b0 = a0 ^ 1;
  const int a1 = next_[a0], a2 = next_[a1];
  const int b1 = next_[b0], b2 = next_[b1];
  const int va0 = to_[a0], va1 = to_[a1];
  const int vb0 = to_[b0], vb1 = to_[b1];
  const int fa = face_[a0], fb = face_[b0];
  to_[a0] = va1;
  to_[b0] = vb1;
  link(a0, a2);
  link(a2, b1);
  link(b1, a0);
  link(b0, b2);
  link(b2, a1);
  link(a1, b0);
  face_[a1] = fb;
  face_[b1] = fa;
  face_halfedge_[fa] = a0;
  face_halfedge_[fb] = b0;
  if (vertex_halfedge_[va0] == b0) vertex_halfedge_[va0] = a1;
  if (vertex_halfedge_[vb0] == a0) vertex_halfedge_[vb0] = b1;
  modified_[fa] = modified_[fb] = 1;
}

TriangleMesh SculptMesh::compacted(std::vector<int>& labels, std::vector<char>& modified) const {
  std::vector<int> index(vertex_slots(), -1);
  int nv = 0;
  for (int v = 0; v < vertex_slots(); ++v)
    if (!vertex_deleted(v) && vertex_halfedge_[v] >= 0) index[v] = nv++;
  TriangleMesh out;
  out.V.resize(nv, 3);
  for (int v = 0; v < vertex_slots(); ++v)
    if (index[v] >= 0) out.V.row(index[v]) = position_[v].transpose();
  out.F.resize(live_faces_, 3);
  labels.clear();
  modified.clear();
  int row = 0;
  for (int f = 0; f < face_slots(); ++f) {
    if (face_deleted(f)) continue;
    const int h = face_halfedge_[f];
    out.F.row(row++) << index[from(h)], index[to_[h]], index[to_[next_[h]]];
    labels.push_back(label_[f]);
    modified.push_back(modified_[f]);
  }
  return out;
}

bool first_hit(const SculptMesh& mesh, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
               Eigen::Vector3d& hit) {
  double nearest = std::numeric_limits<double>::infinity();
  for (int f = 0; f < mesh.face_slots(); ++f) {
    if (mesh.face_deleted(f)) continue;
    const int h = mesh.face_halfedge(f);
    const double t = ray_triangle(origin, direction, mesh.position(mesh.from(h)), mesh.position(mesh.to(h)),
                                  mesh.position(mesh.to(mesh.next(h))));
    if (t >= 0.0 && t < nearest) nearest = t;
  }
  if (!std::isfinite(nearest)) return false;
  hit = origin + nearest * direction;
  return true;
}

}  // namespace idealize
