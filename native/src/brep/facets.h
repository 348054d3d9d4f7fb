// Planar facets: the mesh's own triangles as B-rep faces, the face of last resort.
//
// A region whose surface gives no valid face (its analytic surface fails OpenCASCADE's checks, or a
// freeform region has no fitted B-spline) is made of its triangles, each a planar face. The facets,
// and the straight edges along the mesh's border between the region and its neighbours, share
// their vertices and edges through one FacetBuilder: the faceted region closes against its
// neighbours by construction, because its boundary is the mesh's own border (thesis 4.3.3: the
// boundary between features is an edge polyline of the mesh).
#pragma once

#include "core/mesh.h"

#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Vertex.hxx>

#include <Eigen/Dense>

#include <cstdint>
#include <optional>
#include <unordered_map>

namespace idealize {

class FacetBuilder {
 public:
  // `mesh`: the labelled mesh (#V x 3, #F x 3, counter-clockwise seen from outside); kept by
  // reference. Two repairs keep its facets a closed manifold shell where the mesh is one:
  // - an edge used by more than two triangles (two sheets touching along it) becomes one edge per
  //   pair of triangles that run along it in opposite directions;
  // - a triangle whose corners are collinear (no plane, height below OpenCASCADE's confusion
  //   distance) has no facet: the triangle across its longest side takes its middle corner, which
  //   lies on that side, as a vertex of its own facet.
  explicit FacetBuilder(const TriangleMesh& mesh);

  // Puts mesh vertex `v` at `p` instead of its mesh position (a boundary vertex moved onto the
  // neighbouring feature's surface). Only before the vertex is first used.
  void place(int v, const Eigen::Vector3d& p) { positions_[v] = p; }
  // Uses `vertex` (a corner that analytic edges end at too) for mesh vertex `v`, at its point.
  // Mesh vertices given one vertex (corners that the surfaces put at one point) are one vertex of
  // the facets too: their edges to a third vertex are one edge, and a triangle between them none.
  void share(int v, const TopoDS_Vertex& vertex);

  Eigen::Vector3d position(int v) const;
  TopoDS_Vertex vertex(int v);
  // The straight edges from mesh vertex a to mesh vertex b (more than one where collinear
  // triangles put vertices on the way), oriented from a to b and shared by every face that uses
  // them; none where both ends are one vertex. `sheet`: which pair of triangles along a
  // non-manifold edge (0 elsewhere).
  std::vector<TopoDS_Edge> path(int a, int b, int sheet = 0);
  // Triangle f as a planar face whose normal is the triangle's (counter-clockwise) normal, with
  // exact pcurves; none where its corners are collinear or coincide.
  std::optional<TopoDS_Face> facet(int f);

 private:
  const TriangleMesh& mesh_;
  std::unordered_map<int, Eigen::Vector3d> positions_;
  std::unordered_map<int, TopoDS_Vertex> vertices_;
  std::unordered_map<int, int> alias_;                       // mesh vertex -> the one standing for it
  std::unordered_map<const void*, int> shared_;              // shared vertex -> its first mesh vertex
  int alias(int v) const {
    const auto it = alias_.find(v);
    return it == alias_.end() ? v : it->second;
  }
  std::unordered_map<std::int64_t, TopoDS_Edge> edges_;  // by (smaller, larger) vertex, oriented so
  std::unordered_map<std::int64_t, int> sheet_;          // half-edge 3 f + c -> its pair on a non-manifold edge
  std::unordered_map<std::int64_t, int> middle_;         // (smaller, larger) -> the collinear vertex on it
  std::vector<char> flat_;                               // per triangle: collinear, no facet
  TopoDS_Edge edge(int a, int b, int sheet);
};

}  // namespace idealize
