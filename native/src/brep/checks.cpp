// Checks of faces, shells and solids beyond and around OpenCASCADE's checker (checks.h).
#include "brep/checks.h"

#include "brep/occt_progress.h"

#include <BOPAlgo_ArgumentAnalyzer.hxx>
#include <BRepAdaptor_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BRepCheck.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepCheck_ListIteratorOfListOfStatus.hxx>
#include <BRepCheck_Result.hxx>
#include <BRepGProp.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <GProp_GProps.hxx>
#include <GeomAPI_ExtremaCurveCurve.hxx>
#include <Geom2d_Curve.hxx>
#include <Geom_BSplineCurve.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Iterator.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>

#include <algorithm>
#include <cmath>

namespace idealize {

// Whether an edge of `shape` spans no parameter range on a face it bounds. BRepTools_WireExplorer,
// which BRepCheck runs on every wire, steps along an edge's pcurve from its end by a thousandth of
// its range until it leaves the end's point: below the parameter's rounding the step adds nothing,
// and the check never returns (OCCT 7.6). Healing left such an edge, flagged degenerated, on a
// plane of a scan's sewn shell.
bool has_vanishing_edge(const TopoDS_Shape& shape) {
  for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next()) {
    const TopoDS_Face& face = TopoDS::Face(f.Current());
    for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) {
      double first, last;
      if (!BRep_Tool::CurveOnSurface(TopoDS::Edge(e.Current()), face, first, last).IsNull() &&
          !(last - first > Precision::PConfusion()))
        return true;
    }
  }
  return false;
}

const char* occt_surface_name(const TopoDS_Face& face) {
  switch (BRepAdaptor_Surface(face).GetType()) {
    case GeomAbs_Plane: return "plane";
    case GeomAbs_Cylinder: return "cylinder";
    case GeomAbs_Cone: return "cone";
    case GeomAbs_Sphere: return "sphere";
    case GeomAbs_Torus: return "torus";
    case GeomAbs_BSplineSurface: return "bspline";
    default: return "other";
  }
}

// BRepCheck's verdict, invalid outright with an edge of no parameter range (which it cannot check).
bool is_valid(const TopoDS_Shape& shape, bool parallel) {
  return !has_vanishing_edge(shape) && BRepCheck_Analyzer(shape, Standard_True, parallel).IsValid();
}

// What BRepCheck finds wrong with an invalid face, first for the face itself, then for its wires,
// edges and vertices ("SelfIntersectingWire", "BadOrientationOfSubshape", ...).
std::string invalid_reason(const TopoDS_Shape& face) {
  if (has_vanishing_edge(face)) return "an edge of no length";
  const BRepCheck_Analyzer analyzer(face);
  for (const TopAbs_ShapeEnum type : {TopAbs_FACE, TopAbs_WIRE, TopAbs_EDGE, TopAbs_VERTEX}) {
    for (TopExp_Explorer e(face, type); e.More(); e.Next()) {
      const Handle(BRepCheck_Result) result = analyzer.Result(e.Current());
      if (result.IsNull()) continue;
      std::vector<const BRepCheck_ListOfStatus*> lists{&result->Status()};
      for (result->InitContextIterator(); result->MoreShapeInContext(); result->NextShapeInContext())
        lists.push_back(&result->StatusOnShape());
      for (const BRepCheck_ListOfStatus* list : lists)
        for (BRepCheck_ListIteratorOfListOfStatus it(*list); it.More(); it.Next())
          if (it.Value() != BRepCheck_NoError) {
            std::ostringstream name;
            BRepCheck::Print(it.Value(), name);
            std::string text = name.str();
            text.erase(std::remove(text.begin(), text.end(), '\n'), text.end());
            return text;
          }
    }
  }
  return "unknown";
}

// Why a face of a shell that did not close cannot be kept (empty: it can). Its edges may cross
// themselves or leave the surface, or its boundary run the wrong way round (the face would cover the
// rest of a torus: its area comes out negative), which BRepCheck passes but OpenCASCADE's mesher
// (and every modelling operation) chokes on: the mesher never returned on such a torus face. A
// vertex or edge whose tolerance exceeds `size` (the part's) is no geometry at all, and the
// self-intersection check never returned on one.
std::string shell_face_fault(const TopoDS_Shape& face, double size) {
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next())
    if (!(BRep_Tool::Tolerance(TopoDS::Edge(e.Current())) <= size)) return "an edge's tolerance exceeds the part";
  for (TopExp_Explorer v(face, TopAbs_VERTEX); v.More(); v.Next())
    if (!(BRep_Tool::Tolerance(TopoDS::Vertex(v.Current())) <= size)) return "a vertex's tolerance exceeds the part";
  if (!is_valid(face)) return invalid_reason(face);
  GProp_GProps area;
  BRepGProp::SurfaceProperties(face.Oriented(TopAbs_FORWARD), area);
  if (area.Mass() < 0.0) return "its boundary runs the wrong way round";
  // Whether the edges leave the surface first: it is the quick check, and the self-intersection
  // check of a face bounded by fitted curves that leave it takes up to half a second.
  for (const bool self_intersection : {false, true}) {
    BOPAlgo_ArgumentAnalyzer analyzer;
    analyzer.SetShape1(face);
    analyzer.ArgumentTypeMode() = Standard_False;
    analyzer.SelfInterMode() = self_intersection;
    analyzer.CurveOnSurfaceMode() = !self_intersection;
    analyzer.Perform();
    if (analyzer.HasFaulty()) return "its edges cross each other or leave its surface";
  }
  return "";
}

// Why each face of a closed shell fails where BRepCheck passes it ("" where it does not): bounded
// the wrong way round, or by a boundary that crosses itself (the end face of a scanned hex head,
// where the arcs of a narrow chamfer cone cut the flats' lines out of order), which the mesher
// leaves without triangles (at `deflection`) and FreeCAD's check rejects. Faces of less area than
// `tolerance` squared (slivers a CAD export keeps) are not judged. (The boolean operations' checks
// of shell_face_fault also reject sound faces whose arcs meet tangentially.)
std::vector<std::string> closed_shell_faults(const TopoDS_Shape& shape, double deflection, double tolerance,
                                             const std::function<bool(const TopoDS_Face&)>& sound,
                                             const ProgressSpan& progress) {
  std::vector<std::string> faults;
  // (Faces sound by construction, planar facets, are neither meshed nor judged.)
  BRep_Builder builder;
  TopoDS_Compound judged;
  builder.MakeCompound(judged);
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next())
    if (!sound || !sound(TopoDS::Face(e.Current()))) builder.Add(judged, e.Current());
  IMeshTools_Parameters parameters;  // as BRepMesh_IncrementalMesh(judged, deflection, false, 0.5, true) sets them
  parameters.Deflection = deflection;
  parameters.Angle = 0.5;
  parameters.Relative = Standard_False;
  parameters.InParallel = Standard_True;
  Handle(OcctProgress) indicator = new OcctProgress(progress);
  BRepMesh_IncrementalMesh mesher(judged, parameters, indicator->Start());
  progress.check();  // the mesher stops early when cancelled
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    const TopoDS_Face& face = TopoDS::Face(e.Current());
    if (sound && sound(face)) {
      faults.emplace_back();
      continue;
    }
    GProp_GProps area;
    BRepGProp::SurfaceProperties(face.Oriented(TopAbs_FORWARD), area);
    TopLoc_Location location;
    const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
    if (area.Mass() < 0.0)
      faults.push_back("its boundary runs the wrong way round");
    else if (area.Mass() > tolerance * tolerance && (triangulation.IsNull() || triangulation->NbTriangles() == 0))
      faults.push_back("its boundary crosses itself: no mesh covers it");
    else
      faults.emplace_back();
  }
  BRepTools::Clean(judged);  // (the mesh stays out of the shape, as in triangulate)
  return faults;
}

// A solid, or a compound of solids (a mesh of several bodies).
bool is_solid_shape(const TopoDS_Shape& shape) {
  if (shape.ShapeType() == TopAbs_SOLID) return true;
  if (shape.ShapeType() != TopAbs_COMPOUND) return false;
  bool any = false;
  for (TopoDS_Iterator it(shape); it.More(); it.Next()) {
    if (it.Value().ShapeType() != TopAbs_SOLID) return false;
    any = true;
  }
  return any;
}

bool no_faults(const std::vector<std::string>& faults) {
  return std::all_of(faults.begin(), faults.end(), [](const std::string& f) { return f.empty(); });
}

// Two edges of a wire that meet tangentially (a fillet's arc running into a larger arc) cross once
// more beside their common vertex wherever that vertex lies a little off their exact point of
// tangency, which BRepCheck takes for a self-intersecting wire unless the vertex's tolerance covers
// the crossing. Raises it to do so for crossings within `reach` of the vertex.
void cover_tangent_crossings(const TopoDS_Face& face, double reach) {
  if (has_vanishing_edge(face)) return;
  BRep_Builder builder;
  for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) {
    std::vector<TopoDS_Edge> edges;
    for (BRepTools_WireExplorer e(TopoDS::Wire(w.Current()), face); e.More(); e.Next()) edges.push_back(e.Current());
    for (size_t i = 0; i < edges.size() && edges.size() > 1; ++i) {
      const TopoDS_Edge &a = edges[i], &b = edges[(i + 1) % edges.size()];
      TopoDS_Vertex v;
      if (!TopExp::CommonVertex(a, b, v)) continue;
      double a0, a1, b0, b1;
      const Handle(Geom_Curve) ca = BRep_Tool::Curve(a, a0, a1), cb = BRep_Tool::Curve(b, b0, b1);
      if (ca.IsNull() || cb.IsNull()) continue;
      gp_Pnt pa, pb;
      gp_Vec ta, tb;
      ca->D1(BRep_Tool::Parameter(v, a), pa, ta);
      cb->D1(BRep_Tool::Parameter(v, b), pb, tb);
      if (ta.Magnitude() <= 0.0 || tb.Magnitude() <= 0.0 || ta.Crossed(tb).Magnitude() > 0.1 * ta.Magnitude() * tb.Magnitude())
        continue;  // not tangent (beyond about 6°): no second crossing near the vertex
      GeomAPI_ExtremaCurveCurve extrema(ca, cb, a0, a1, b0, b1);
      const gp_Pnt centre = BRep_Tool::Pnt(v);
      const double touching = BRep_Tool::Tolerance(a) + BRep_Tool::Tolerance(b);
      double cover = BRep_Tool::Tolerance(v);
      for (int n = 1; n <= extrema.NbExtrema(); ++n) {
        if (extrema.Distance(n) > touching) continue;
        gp_Pnt p, q;
        extrema.Points(n, p, q);
        const double away = std::max(centre.Distance(p), centre.Distance(q)) + touching;
        if (away <= reach) cover = std::max(cover, 1.01 * away);
      }
      if (cover > BRep_Tool::Tolerance(v)) builder.UpdateVertex(v, cover);
    }
  }
}

// An edge used by one face only (seams, used twice by their face, and degenerate edges aside).
bool has_free_edges(const TopoDS_Shape& shape) {
  TopTools_IndexedDataMapOfShapeListOfShape faces_of_edge;
  TopExp::MapShapesAndUniqueAncestors(shape, TopAbs_EDGE, TopAbs_FACE, faces_of_edge);
  for (int i = 1; i <= faces_of_edge.Extent(); ++i) {
    const TopoDS_Edge& edge = TopoDS::Edge(faces_of_edge.FindKey(i));
    const TopTools_ListOfShape& faces = faces_of_edge(i);
    if (BRep_Tool::Degenerated(edge) || faces.Extent() >= 2) continue;
    if (faces.Extent() == 0 || !BRep_Tool::IsClosed(edge, TopoDS::Face(faces.First()))) return true;
  }
  return false;
}

// The largest distance between a B-spline edge's 3D curve and its curve on `face`, at 33
// parameters: a lower bound of BRepLib_CheckCurveOnSurface's, at a small part of its cost. 0 for
// other edges and without the curves.
double sampled_pcurve_gap(const TopoDS_Edge& edge, const TopoDS_Face& face) {
  double first, last;
  const Handle(Geom_Curve) curve = BRep_Tool::Curve(edge, first, last);
  if (curve.IsNull() || !curve->IsKind(STANDARD_TYPE(Geom_BSplineCurve)) ||
      BRep_Tool::CurveOnSurface(edge, face, first, last).IsNull())
    return 0.0;
  const BRepAdaptor_Curve in_space(edge), on_face(edge, face);
  constexpr int kSamples = 32;
  double gap = 0.0;
  for (int i = 0; i <= kSamples; ++i) {
    const double t = first + (last - first) * i / kSamples;
    gap = std::max(gap, in_space.Value(t).Distance(on_face.Value(t)));
  }
  return gap;
}

int euler_characteristic(const TopoDS_Shape& shape) {
  TopTools_IndexedMapOfShape vertices, edges, faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  for (TopExp_Explorer e(shape, TopAbs_EDGE); e.More(); e.Next()) {
    const TopoDS_Edge& edge = TopoDS::Edge(e.Current());
    if (BRep_Tool::Degenerated(edge)) continue;
    edges.Add(edge);
    TopExp::MapShapes(edge, TopAbs_VERTEX, vertices);
  }
  int chi = vertices.Extent() - edges.Extent();
  for (int i = 1; i <= faces.Extent(); ++i) {
    int wires = 0;
    for (TopExp_Explorer w(faces(i), TopAbs_WIRE); w.More(); w.Next()) ++wires;
    chi += 2 - wires;
  }
  return chi;
}

}  // namespace idealize
