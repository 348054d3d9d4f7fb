#include "brep/facets.h"

#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <ElSLib.hxx>
#include <Geom2d_Line.hxx>
#include <Geom_Line.hxx>
#include <Geom_Plane.hxx>
#include <Precision.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Wire.hxx>
#include <gp_Pln.hxx>

#include <algorithm>
#include <array>

namespace idealize {

namespace {

gp_Pnt to_pnt(const Eigen::Vector3d& v) { return gp_Pnt(v.x(), v.y(), v.z()); }

std::int64_t edge_key(int a, int b) {
  return (static_cast<std::int64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
}

// Mixes which sheet of a non-manifold edge into its key (vertex indices stay below 2^31).
std::int64_t sheet_key(std::int64_t key, int sheet) { return key ^ (static_cast<std::int64_t>(sheet) << 62); }

}  // namespace

FacetBuilder::FacetBuilder(const TriangleMesh& mesh) : mesh_(mesh), flat_(mesh.num_faces(), 0) {
  // The half-edges of every edge; where more than two, the k-th that runs from the smaller vertex
  // pairs with the k-th that runs towards it.
  std::unordered_map<std::int64_t, std::vector<int>> uses;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) uses[edge_key(mesh.F(f, c), mesh.F(f, (c + 1) % 3))].push_back(3 * f + c);
  for (const auto& [key, halves] : uses) {
    if (halves.size() <= 2) continue;
    int up = 0, down = 0;
    for (int h : halves) {
      const bool rising = mesh.F(h / 3, h % 3) < mesh.F(h / 3, (h % 3 + 1) % 3);
      sheet_[h] = 1 + (rising ? up++ : down++);
    }
  }
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const std::array<double, 3> side = {(c - b).norm(), (a - c).norm(), (b - a).norm()};  // opposite each corner
    const int longest = static_cast<int>(std::max_element(side.begin(), side.end()) - side.begin());
    if (!(side[longest] > 0.0)) continue;
    const double height = (b - a).cross(c - a).norm() / side[longest];
    if (height > Precision::Confusion()) continue;
    flat_[f] = 1;
    middle_[edge_key(mesh.F(f, (longest + 1) % 3), mesh.F(f, (longest + 2) % 3))] = mesh.F(f, longest);
  }
}

void FacetBuilder::share(int v, const TopoDS_Vertex& vertex) {
  const auto [first, added] = shared_.try_emplace(vertex.TShape().get(), v);
  if (!added) alias_[v] = first->second;
  vertices_[v] = vertex;
  const gp_Pnt p = BRep_Tool::Pnt(vertex);
  positions_[v] = Eigen::Vector3d(p.X(), p.Y(), p.Z());
}

Eigen::Vector3d FacetBuilder::position(int v) const {
  const auto placed = positions_.find(v);
  return placed != positions_.end() ? placed->second : Eigen::Vector3d(mesh_.V.row(v).transpose());
}

TopoDS_Vertex FacetBuilder::vertex(int v) {
  const auto [it, made] = vertices_.try_emplace(v);
  if (made) BRep_Builder().MakeVertex(it->second, to_pnt(position(v)), Precision::Confusion());
  return it->second;
}

TopoDS_Edge FacetBuilder::edge(int a, int b, int sheet) {
  const int low = std::min(a, b), high = std::max(a, b);
  auto [it, made] = edges_.try_emplace(sheet_key(edge_key(a, b), sheet));
  if (made) {
    const TopoDS_Vertex v0 = vertex(low), v1 = vertex(high);
    const Eigen::Vector3d p0 = position(low), p1 = position(high);
    const double length = (p1 - p0).norm();
    if (v0.IsSame(v1) || !(length > Precision::Confusion())) return it->second;  // null: no edge
    BRep_Builder builder;
    builder.MakeEdge(it->second, new Geom_Line(to_pnt(p0), gp_Dir(gp_Vec(to_pnt(p0), to_pnt(p1)))),
                     Precision::Confusion());
    builder.Add(it->second, v0.Oriented(TopAbs_FORWARD));
    builder.Add(it->second, v1.Oriented(TopAbs_REVERSED));
    builder.Range(it->second, 0.0, length);
  }
  if (it->second.IsNull()) return it->second;
  return TopoDS::Edge(a == low ? it->second : it->second.Reversed());
}

std::vector<TopoDS_Edge> FacetBuilder::path(int a, int b, int sheet) {
  std::vector<TopoDS_Edge> out;
  a = alias(a);
  b = alias(b);
  if (a == b) return out;
  if (const auto middle = middle_.find(edge_key(a, b)); middle != middle_.end() && sheet == 0) {
    for (int end : {middle->second, b}) {
      const std::vector<TopoDS_Edge> part = path(a, end);
      out.insert(out.end(), part.begin(), part.end());
      a = end;
    }
    return out;
  }
  const TopoDS_Edge e = edge(a, b, sheet);
  if (!e.IsNull()) out.push_back(e);
  return out;
}

std::optional<TopoDS_Face> FacetBuilder::facet(int f) {
  if (flat_[f]) return std::nullopt;
  const std::array<int, 3> corner = {alias(mesh_.F(f, 0)), alias(mesh_.F(f, 1)), alias(mesh_.F(f, 2))};
  if (corner[0] == corner[1] || corner[1] == corner[2] || corner[2] == corner[0]) return std::nullopt;
  const Eigen::Vector3d a = position(corner[0]), b = position(corner[1]), c = position(corner[2]);
  const Eigen::Vector3d normal = (b - a).cross(c - a);
  // Collinear within rounding: the plane would be undefined.
  if (!(normal.norm() > Precision::Confusion() * std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()})))
    return std::nullopt;
  const gp_Pln plane(gp_Ax3(to_pnt(a), gp_Dir(normal.x(), normal.y(), normal.z()), gp_Dir(gp_Vec(to_pnt(a), to_pnt(b)))));
  BRep_Builder builder;
  TopoDS_Face face;
  builder.MakeFace(face, new Geom_Plane(plane), Precision::Confusion());
  TopoDS_Wire wire;
  builder.MakeWire(wire);
  int edges = 0;
  for (int i = 0; i < 3; ++i) {
    const auto sheet = sheet_.find(3 * f + i);
    for (const TopoDS_Edge& e : path(corner[i], corner[(i + 1) % 3], sheet == sheet_.end() ? 0 : sheet->second)) {
      // The pcurve: the edge's line in the plane's (isometric) parameters, over the same range.
      const TopoDS_Edge forward = TopoDS::Edge(e.Oriented(TopAbs_FORWARD));
      double first, last;
      const Handle(Geom_Curve) line = BRep_Tool::Curve(forward, first, last);
      double u0, v0, u1, v1;
      ElSLib::Parameters(plane, line->Value(first), u0, v0);
      ElSLib::Parameters(plane, line->Value(last), u1, v1);
      const gp_Vec2d along(u1 - u0, v1 - v0);
      if (!(along.Magnitude() > 0.0)) return std::nullopt;
      builder.UpdateEdge(forward, new Geom2d_Line(gp_Pnt2d(u0, v0), gp_Dir2d(along)), face, Precision::Confusion());
      builder.Add(wire, e);
      ++edges;
    }
  }
  if (edges < 3) return std::nullopt;
  wire.Closed(Standard_True);
  builder.Add(face, wire);
  return face;
}

}  // namespace idealize
