// CGAL's isotropic remeshing over the edited region, with feature borders constrained and vertices
// projected onto their features (see remesh_adaptive.h). Everything CGAL stays in this file.
#include "edit/remesh_adaptive.h"

#include "edit/move_vertices.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/boost/graph/Euler_operations.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <string>

namespace idealize {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VertexIndex = SurfaceMesh::Vertex_index;
using FaceIndex = SurfaceMesh::Face_index;

// The features of the faces around a vertex, sorted.
std::vector<int> features_at(const SurfaceMesh& sm, const SurfaceMesh::Property_map<FaceIndex, int>& patch,
                             VertexIndex v) {
  std::vector<int> around;
  for (FaceIndex f : CGAL::faces_around_target(sm.halfedge(v), sm))
    if (f != SurfaceMesh::null_face() && std::find(around.begin(), around.end(), patch[f]) == around.end())
      around.push_back(patch[f]);
  std::sort(around.begin(), around.end());
  return around;
}

// Projects a vertex that remeshing created or moved onto its features' surfaces.
struct OntoFeatures {
  const SurfaceMesh* sm;
  SurfaceMesh::Property_map<FaceIndex, int> patch;
  const std::vector<Surface>* surfaces;
  const std::set<std::pair<int, int>>* g1;
  double length;

  Point operator()(VertexIndex v) const {
    const Point& p = sm->point(v);
    const Eigen::Vector3d q =
        onto_features(features_at(*sm, patch, v), *surfaces, *g1, Eigen::Vector3d(p.x(), p.y(), p.z()), length);
    return Point(q.x(), q.y(), q.z());
  }
};

Eigen::Vector3d vec(const Point& p) { return Eigen::Vector3d(p.x(), p.y(), p.z()); }

// The corners of face `f`, in its order.
std::array<Eigen::Vector3d, 3> corners(const SurfaceMesh& sm, FaceIndex f) {
  const auto h = sm.halfedge(f);
  return {vec(sm.point(sm.source(h))), vec(sm.point(sm.target(h))), vec(sm.point(sm.target(sm.next(h))))};
}

// The cross product of the edges of face `f` (twice its area along its normal).
Eigen::Vector3d face_cross(const SurfaceMesh& sm, FaceIndex f) {
  const auto [a, b, c] = corners(sm, f);
  return (b - a).cross(c - a);
}

// How squarely the triangle `f` faces its feature's surface (facing_cosine) times the feature's side
// (`sides`, facing_sides); 1 for a triangle of no analytic feature.
double facing(const SurfaceMesh& sm, const SurfaceMesh::Property_map<FaceIndex, int>& patch,
              const std::vector<Surface>& surfaces, const std::vector<double>& sides, FaceIndex f) {
  const int l = patch[f];
  if (l < 0 || l >= static_cast<int>(surfaces.size()) || surfaces[l].type == SurfaceType::Freeform) return 1.0;
  const auto [a, b, c] = corners(sm, f);
  return sides[l] * facing_cosine(surfaces[l], a, b, c);
}

// What a relaxation move must keep of each triangle around the vertex: not degenerate, not turned
// against its normal before, and facing its surface at least half as squarely as before. The last
// catches a triangle laid flat across a border (its corners slid onto one border curve, at right
// angles to its surface), which neither turns over nor degenerates; half leaves room for any
// relocation along a surface, which tilts a triangle only as far as its chords sag.
struct StarFace {
  FaceIndex face;
  Eigen::Vector3d cross;
  double facing;
};

bool star_keeps_orientation(const SurfaceMesh& sm, const SurfaceMesh::Property_map<FaceIndex, int>& patch,
                            const std::vector<Surface>& surfaces, const std::vector<double>& sides,
                            const std::vector<StarFace>& before) {
  for (const StarFace& was : before) {
    const Eigen::Vector3d now = face_cross(sm, was.face);
    if (now.squaredNorm() == 0.0 || now.dot(was.cross) <= 0.0) return false;
    if (was.facing > 0.0 && facing(sm, patch, surfaces, sides, was.face) < 0.5 * was.facing) return false;
  }
  return true;
}

// Turns over, by an edge flip, the triangles of the features beside `faces` (the remeshed feature's)
// that face against their surface: where a split of the border between them was projected onto
// the border's curve, the neighbour's triangle across it may be left as an ear outside its own
// face (three consecutive border vertices, over the hole's opening of a bored plate). An edge of
// that triangle inside its feature is flipped when both triangles it makes then face their surface;
// one whose flip would not is flipped back.
void unfold_neighbours(SurfaceMesh& sm, const std::vector<FaceIndex>& faces, int feature,
                       const SurfaceMesh::Property_map<SurfaceMesh::Edge_index, bool>& constrained_edge,
                       const OntoFeatures& project, const std::vector<double>& sides) {
  std::vector<FaceIndex> nearby;
  for (FaceIndex f : faces)
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm))
      for (FaceIndex g : CGAL::faces_around_target(sm.halfedge(v), sm))
        if (g != SurfaceMesh::null_face() && project.patch[g] != feature) nearby.push_back(g);
  std::sort(nearby.begin(), nearby.end());
  nearby.erase(std::unique(nearby.begin(), nearby.end()), nearby.end());
  auto faces_out = [&](FaceIndex g) { return facing(sm, project.patch, *project.surfaces, sides, g) < 0.0; };
  for (FaceIndex g : nearby) {
    if (sm.is_removed(g) || !faces_out(g)) continue;
    for (auto h : CGAL::halfedges_around_face(sm.halfedge(g), sm)) {
      const auto o = sm.opposite(h);
      if (constrained_edge[sm.edge(h)] || sm.is_border(h) || sm.is_border(o)) continue;
      const VertexIndex a = sm.target(sm.next(h)), b = sm.target(sm.next(o));
      if (a == b || sm.halfedge(a, b) != SurfaceMesh::null_halfedge()) continue;  // the new edge exists
      CGAL::Euler::flip_edge(h, sm);
      if (!faces_out(sm.face(h)) && !faces_out(sm.face(sm.opposite(h))) &&
          face_cross(sm, sm.face(h)).squaredNorm() > 0.0 && face_cross(sm, sm.face(sm.opposite(h))).squaredNorm() > 0.0)
        break;
      CGAL::Euler::flip_edge(h, sm);  // back as it was
    }
  }
}

// Tangential relaxation of the vertices of `faces` (Botsch & Kobbelt 2004, section 4): an
// interior vertex moves to the mean of its neighbours, less the move along its normal; a vertex
// on one border between two features (two constrained edges meeting at more than 120 degrees: not a
// corner of the border) moves along it, halfway to the mean of its two border neighbours, when
// `along_borders`. Each vertex is then projected onto its features' surfaces. A move that would
// make a triangle around the vertex degenerate or turn it over is halved, up to five times, and
// otherwise not made (as CGAL's relaxation does). Vertices flagged in `fixed` stay.
//
// CGAL 5.5's own tangential_relaxation is not used: at a vertex whose triangles are all
// degenerate it looks up the edge of a null halfedge (check_normals in tangential_relaxation.h)
// and reads outside its arrays, a segmentation fault that killed FreeCAD on corner balls.
// Here every lookup is of an existing element, and degenerate triangles only refuse a move.
void relax_tangentially(SurfaceMesh& sm, const std::vector<FaceIndex>& faces,
                        const SurfaceMesh::Property_map<SurfaceMesh::Edge_index, bool>& constrained_edge,
                        const SurfaceMesh::Property_map<VertexIndex, bool>& fixed, const OntoFeatures& project,
                        const std::vector<double>& sides, bool along_borders) {
  std::vector<VertexIndex> vertices;
  for (FaceIndex f : faces)
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm)) vertices.push_back(v);
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  std::vector<std::pair<VertexIndex, Eigen::Vector3d>> moves;  // computed from the positions before any move
  for (VertexIndex v : vertices) {
    if (fixed[v] || sm.is_isolated(v)) continue;
    const Eigen::Vector3d p = vec(sm.point(v));
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> border;
    int neighbours = 0;
    for (auto h : CGAL::halfedges_around_target(sm.halfedge(v), sm)) {
      const Eigen::Vector3d u = vec(sm.point(sm.source(h)));
      if (constrained_edge[sm.edge(h)] || sm.is_border(sm.edge(h))) border.push_back(u);
      sum += u;
      ++neighbours;
      if (!sm.is_border(h)) normal += face_cross(sm, sm.face(h));
    }
    if (border.empty() && neighbours > 0 && normal.squaredNorm() > 0.0) {
      const Eigen::Vector3d mean = sum / neighbours, n = normal.normalized();
      moves.emplace_back(v, mean + (p - mean).dot(n) * n);
    } else if (along_borders && border.size() == 2) {
      const Eigen::Vector3d a = border[0] - p, b = border[1] - p;
      const double lengths = a.norm() * b.norm();
      // cos < -1/2: the border runs on through v (an angle over 120 degrees, CGAL's bound).
      if (lengths > 0.0 && a.dot(b) < -0.5 * lengths) moves.emplace_back(v, 0.5 * p + 0.25 * (border[0] + border[1]));
    }
  }
  std::vector<StarFace> before;
  for (const auto& [v, target] : moves) {
    before.clear();
    for (FaceIndex f : CGAL::faces_around_target(sm.halfedge(v), sm))
      if (f != SurfaceMesh::null_face())
        before.push_back({f, face_cross(sm, f), facing(sm, project.patch, *project.surfaces, sides, f)});
    const Point start = sm.point(v);
    const Eigen::Vector3d move = target - vec(start);
    bool moved = false;
    for (double share = 1.0; share > 0.03 && !moved; share *= 0.5) {  // 1, 1/2, ... 1/32: five halvings
      const Eigen::Vector3d to = vec(start) + share * move;
      sm.point(v) = Point(to.x(), to.y(), to.z());
      sm.point(v) = project(v);
      moved = star_keeps_orientation(sm, project.patch, *project.surfaces, sides, before);
    }
    if (!moved) sm.point(v) = start;
  }
}

SurfaceMesh to_surface_mesh(const TriangleMesh& mesh, const std::vector<int>& labels,
                            SurfaceMesh::Property_map<FaceIndex, int>& patch) {
  SurfaceMesh sm;
  for (int v = 0; v < mesh.num_vertices(); ++v) sm.add_vertex(Point(mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2)));
  patch = sm.add_property_map<FaceIndex, int>("f:feature", -1).first;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const FaceIndex face =
        sm.add_face(VertexIndex(mesh.F(f, 0)), VertexIndex(mesh.F(f, 1)), VertexIndex(mesh.F(f, 2)));
    if (face == SurfaceMesh::null_face())
      throw MeshError("the edited mesh is not a consistently oriented manifold at triangle " + std::to_string(f) +
                      "; it cannot be remeshed");
    patch[face] = labels[f];
  }
  return sm;
}

RemeshedLayer from_surface_mesh(const SurfaceMesh& sm, const SurfaceMesh::Property_map<FaceIndex, int>& patch) {
  RemeshedLayer out;
  std::vector<int> index(sm.num_vertices(), -1);
  out.mesh.V.resize(static_cast<Eigen::Index>(sm.number_of_vertices()), 3);
  int next = 0;
  for (VertexIndex v : sm.vertices()) {
    const Point& p = sm.point(v);
    out.mesh.V.row(next) << p.x(), p.y(), p.z();
    index[v] = next++;
  }
  out.mesh.F.resize(static_cast<Eigen::Index>(sm.number_of_faces()), 3);
  int f = 0;
  for (FaceIndex face : sm.faces()) {
    int c = 0;
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(face), sm))
      if (c < 3) out.mesh.F(f, c++) = index[v];
    out.labels.push_back(patch[face]);
    ++f;
  }
  return out;
}

}  // namespace

RemeshedLayer remesh_adaptive(const TriangleMesh& mesh, const std::vector<int>& labels,
                              const std::vector<double>& target_edge_length, const std::vector<Surface>& surfaces,
                              const std::set<std::pair<int, int>>& g1, int iterations, bool keep_others) {
  SurfaceMesh::Property_map<FaceIndex, int> patch;
  SurfaceMesh sm = to_surface_mesh(mesh, labels, patch);
  auto constrained_edge = sm.add_property_map<SurfaceMesh::Edge_index, bool>("e:border", false).first;
  auto constrained_vertex = sm.add_property_map<VertexIndex, bool>("v:corner", false).first;
  for (auto e : sm.edges()) {
    const auto h = sm.halfedge(e), o = sm.opposite(h);
    constrained_edge[e] = sm.is_border(h) || sm.is_border(o) || patch[sm.face(h)] != patch[sm.face(o)];
  }
  auto remeshed = [&](int feature) {
    return feature >= 0 && feature < static_cast<int>(target_edge_length.size()) && target_edge_length[feature] > 0.0;
  };
  for (VertexIndex v : sm.vertices()) {
    const std::vector<int> around = features_at(sm, patch, v);
    constrained_vertex[v] = around.size() >= 3 || sm.is_border(v) ||
                            (keep_others && !std::all_of(around.begin(), around.end(), remeshed));
  }
  const double length = bounding_box_diagonal(mesh);
  const OntoFeatures project{&sm, patch, &surfaces, &g1, length};
  const std::vector<double> sides = facing_sides(mesh, labels, surfaces);
  auto faces_of = [&](int feature) {
    std::vector<FaceIndex> faces;
    for (FaceIndex f : sm.faces())
      if (patch[f] == feature) faces.push_back(f);
    return faces;
  };
  for (size_t feature = 0; feature < target_edge_length.size(); ++feature) {
    if (!(target_edge_length[feature] > 0.0)) continue;
    std::vector<FaceIndex> faces = faces_of(static_cast<int>(feature));
    if (faces.empty()) continue;
    // A round: CGAL splits, collapses and flips, and projects onto the features; then the
    // relaxation here (CGAL's is off, see relax_tangentially).
    for (int round = 0; round < iterations; ++round) {
      try {
        PMP::isotropic_remeshing(faces, target_edge_length[feature], sm,
                                 CGAL::parameters::number_of_iterations(1)
                                     .number_of_relaxation_steps(0)
                                     .face_patch_map(patch)
                                     .edge_is_constrained_map(constrained_edge)
                                     .vertex_is_constrained_map(constrained_vertex)
                                     .protect_constraints(false)
                                     .projection_functor(project));
      } catch (const std::exception& e) {
        throw MeshError(std::string("the adaptive remeshing failed: ") + e.what());
      }
      faces = faces_of(static_cast<int>(feature));
      unfold_neighbours(sm, faces, static_cast<int>(feature), constrained_edge, project, sides);
      relax_tangentially(sm, faces, constrained_edge, constrained_vertex, project, sides, !keep_others);
    }
  }
  sm.collect_garbage();
  // The final positions: every vertex of an edited feature on its features' surfaces; with
  // keep_others, not the vertices kept where they were (a vertex that splitting a border's edge
  // made is not among them).
  std::set<std::array<double, 3>> kept;
  if (keep_others)
    for (int v = 0; v < mesh.num_vertices(); ++v) kept.insert({mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2)});
  std::vector<char> edited(surfaces.size(), 0);
  for (size_t f = 0; f < target_edge_length.size(); ++f) edited[f] = target_edge_length[f] > 0.0;
  for (VertexIndex v : sm.vertices()) {
    const std::vector<int> around = features_at(sm, patch, v);
    const Point& at = sm.point(v);
    if (keep_others && (around.size() >= 3 || !std::all_of(around.begin(), around.end(), remeshed)) &&
        kept.count({at.x(), at.y(), at.z()}))
      continue;
    if (std::any_of(around.begin(), around.end(), [&](int l) { return l >= 0 && edited[l]; })) sm.point(v) = project(v);
  }
  return from_surface_mesh(sm, patch);
}

}  // namespace idealize
