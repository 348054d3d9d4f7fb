// CGAL's isotropic remeshing over the edited region, with feature borders constrained and vertices
// projected onto their features (see remesh_adaptive.h). Everything CGAL stays in this file.
#include "edit/remesh_adaptive.h"

#include "edit/move_vertices.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
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
  for (size_t feature = 0; feature < target_edge_length.size(); ++feature) {
    if (!(target_edge_length[feature] > 0.0)) continue;
    std::vector<FaceIndex> faces;
    for (FaceIndex f : sm.faces())
      if (patch[f] == static_cast<int>(feature)) faces.push_back(f);
    if (faces.empty()) continue;
    try {
      PMP::isotropic_remeshing(faces, target_edge_length[feature], sm,
                               CGAL::parameters::number_of_iterations(static_cast<unsigned int>(iterations))
                                   .face_patch_map(patch)
                                   .edge_is_constrained_map(constrained_edge)
                                   .vertex_is_constrained_map(constrained_vertex)
                                   .protect_constraints(false)
                                   .relax_constraints(!keep_others)
                                   .projection_functor(project));
    } catch (const std::exception& e) {
      throw MeshError(std::string("the adaptive remeshing failed: ") + e.what());
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
