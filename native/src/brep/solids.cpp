#include "brep/solids.h"

#include <BRepClass3d_SolidClassifier.hxx>
#include <BRepGProp.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <GProp_GProps.hxx>
#include <Precision.hxx>
#include <Message_ProgressRange.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_Vertex.hxx>

#include <algorithm>
#include <functional>
#include <numeric>

namespace idealize {

std::vector<TopoDS_Shell> connected_shells(const std::vector<TopoDS_Face>& faces) {
  BRep_Builder builder;
  TopoDS_Compound all;
  builder.MakeCompound(all);
  for (const TopoDS_Face& face : faces) builder.Add(all, face);
  TopTools_IndexedMapOfShape face_index;
  TopExp::MapShapes(all, TopAbs_FACE, face_index);
  TopTools_IndexedDataMapOfShapeListOfShape faces_of_edge;
  TopExp::MapShapesAndUniqueAncestors(all, TopAbs_EDGE, TopAbs_FACE, faces_of_edge);
  std::vector<int> parent(face_index.Extent());
  std::iota(parent.begin(), parent.end(), 0);
  const std::function<int(int)> root = [&](int i) { return parent[i] == i ? i : (parent[i] = root(parent[i])); };
  for (int e = 1; e <= faces_of_edge.Extent(); ++e) {
    const TopTools_ListOfShape& around = faces_of_edge(e);
    if (around.Extent() < 2) continue;
    const int first = root(face_index.FindIndex(around.First()) - 1);
    for (TopTools_ListOfShape::Iterator it(around); it.More(); it.Next()) {
      const int other = root(face_index.FindIndex(it.Value()) - 1);
      if (other != first) parent[std::max(first, other)] = std::min(first, other);
    }
  }
  std::vector<int> shell_of(parent.size(), -1);
  std::vector<TopoDS_Shell> shells;
  for (const TopoDS_Face& face : faces) {
    const int r = root(face_index.FindIndex(face) - 1);
    if (shell_of[r] < 0) {
      shell_of[r] = static_cast<int>(shells.size());
      shells.emplace_back();
      builder.MakeShell(shells.back());
    }
    builder.Add(shells[shell_of[r]], face);
  }
  for (TopoDS_Shell& shell : shells) shell.Closed(Standard_True);
  return shells;
}

TopoDS_Shape solids_from_shells(const std::vector<TopoDS_Shell>& shells) {
  // Each shell as a solid of its own, oriented outwards, largest first.
  struct Body {
    TopoDS_Solid solid;
    double volume = 0.0;
  };
  std::vector<Body> bodies;
  BRep_Builder builder;
  for (const TopoDS_Shell& shell : shells) {
    // Outwards where its volume comes out positive: the faces of a closed shell agree on their
    // orientation, so the sign of the volume they enclose tells. (Linear in the faces; classifying
    // a point against the shell, as ShapeFix_Solid does, took seconds on thousands of facets.)
    Body body;
    builder.MakeSolid(body.solid);
    builder.Add(body.solid, shell);
    GProp_GProps properties;
    BRepGProp::VolumeProperties(body.solid, properties);
    if (properties.Mass() < 0.0) {
      builder.MakeSolid(body.solid);
      builder.Add(body.solid, shell.Reversed());
    }
    body.volume = std::abs(properties.Mass());
    bodies.push_back(body);
  }
  std::stable_sort(bodies.begin(), bodies.end(), [](const Body& a, const Body& b) { return a.volume > b.volume; });
  if (bodies.size() == 1) return bodies.front().solid;
  // A shell inside a larger body (a point of it classified inside) is that body's void.
  std::vector<TopoDS_Solid> outer;
  std::vector<std::vector<TopoDS_Shell>> voids;
  for (const Body& body : bodies) {
    TopExp_Explorer vertex(body.solid, TopAbs_VERTEX);
    const gp_Pnt probe = vertex.More() ? BRep_Tool::Pnt(TopoDS::Vertex(vertex.Current())) : gp_Pnt();
    int host = -1;
    for (size_t i = 0; i < outer.size() && host < 0; ++i) {
      BRepClass3d_SolidClassifier inside(outer[i], probe, Precision::Confusion());
      if (inside.State() == TopAbs_IN) host = static_cast<int>(i);
    }
    TopExp_Explorer shell(body.solid, TopAbs_SHELL);
    if (host >= 0) {
      voids[host].push_back(TopoDS::Shell(shell.Current().Reversed()));
    } else {
      outer.push_back(body.solid);
      voids.emplace_back();
    }
  }
  TopoDS_Compound compound;
  builder.MakeCompound(compound);
  for (size_t i = 0; i < outer.size(); ++i) {
    TopoDS_Solid solid = outer[i];
    if (!voids[i].empty()) {
      builder.MakeSolid(solid);
      for (TopExp_Explorer shell(outer[i], TopAbs_SHELL); shell.More(); shell.Next()) builder.Add(solid, shell.Current());
      for (const TopoDS_Shell& hole : voids[i]) builder.Add(solid, hole);
    }
    if (outer.size() == 1) return solid;
    builder.Add(compound, solid);
  }
  return compound;
}

}  // namespace idealize
