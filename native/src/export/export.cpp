// Output of the fitted B-rep: BRep text for FreeCAD, STEP files, triangulations.
#include "export/export.h"
#include "brep/brep.h"
#include "brep/occt_progress.h"
#include "brep/occt_signals.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRep_Builder.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Wire.hxx>
#include <gp_Vec.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Tool.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Poly_Triangulation.hxx>
#include <Quantity_Color.hxx>
#include <STEPCAFControl_Writer.hxx>
#include <STEPControl_StepModelType.hxx>
#include <Standard_Failure.hxx>
#include <TDocStd_Document.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <XCAFApp_Application.hxx>
#include <XCAFDoc_ColorTool.hxx>
#include <XCAFDoc_DocumentTool.hxx>
#include <XCAFDoc_ShapeTool.hxx>

#include <array>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace idealize {

std::string brep_string(const TopoDS_Shape& shape) {
  std::ostringstream out;
  BRepTools::Write(shape, out);
  return out.str();
}

namespace {

// The face's colour by its surface's type (surface_color).
Quantity_Color face_color(const TopoDS_Face& face) {
  SurfaceType type = SurfaceType::Freeform;
  switch (BRepAdaptor_Surface(face).GetType()) {
    case GeomAbs_Plane: type = SurfaceType::Plane; break;
    case GeomAbs_Cylinder: type = SurfaceType::Cylinder; break;
    case GeomAbs_Cone: type = SurfaceType::Cone; break;
    case GeomAbs_Sphere: type = SurfaceType::Sphere; break;
    case GeomAbs_Torus: type = SurfaceType::Torus; break;
    default: break;
  }
  const std::array<double, 3> rgb = surface_color(type);
  return Quantity_Color(rgb[0], rgb[1], rgb[2], Quantity_TOC_RGB);
}

// Keeps OCCT's default messenger quiet while alive (the STEP writer reports its progress on
// standard output); the printers, FreeCAD's report view among them, come back afterwards.
class QuietMessenger {
 public:
  QuietMessenger() : saved_(Message::DefaultMessenger()->Printers()) { Message::DefaultMessenger()->ChangePrinters().Clear(); }
  ~QuietMessenger() { Message::DefaultMessenger()->ChangePrinters() = saved_; }
  QuietMessenger(const QuietMessenger&) = delete;
  QuietMessenger& operator=(const QuietMessenger&) = delete;

 private:
  Message_SequenceOfPrinters saved_;
};

// The corners of a planar face bounded by one wire of three straight edges (a facet of a faceted
// region), turned to face the way the face does; none for any other face.
std::optional<std::array<gp_Pnt, 3>> facet_corners(const TopoDS_Face& face) {
  const BRepAdaptor_Surface surface(face, Standard_False);
  if (surface.GetType() != GeomAbs_Plane) return std::nullopt;
  TopExp_Explorer wires(face, TopAbs_WIRE);
  if (!wires.More()) return std::nullopt;
  const TopoDS_Wire wire = TopoDS::Wire(wires.Current());
  wires.Next();
  if (wires.More()) return std::nullopt;
  std::array<gp_Pnt, 3> corners;
  int n = 0;
  for (BRepTools_WireExplorer it(wire, face); it.More(); it.Next()) {
    if (n == 3 || BRepAdaptor_Curve(it.Current()).GetType() != GeomAbs_Line) return std::nullopt;
    corners[n++] = BRep_Tool::Pnt(it.CurrentVertex());
  }
  if (n != 3) return std::nullopt;
  gp_Dir normal = surface.Plane().Axis().Direction();
  if (face.Orientation() == TopAbs_REVERSED) normal.Reverse();
  const gp_Vec turn = gp_Vec(corners[0], corners[1]).Crossed(gp_Vec(corners[0], corners[2]));
  if (turn.Magnitude() > 0 && turn.Dot(gp_Vec(normal)) < 0) std::swap(corners[1], corners[2]);
  return corners;
}

TriangleMesh triangulate_faces(const TopoDS_Shape& shape, double deflection, const ProgressSpan& progress) {
  progress.step(0.0);
  // Facets are their own triangle; the mesher (a fifth of a millisecond a face) gets the others.
  std::vector<TopoDS_Face> faces;
  std::vector<std::optional<std::array<gp_Pnt, 3>>> facets;
  BRep_Builder builder;
  TopoDS_Compound meshed;
  builder.MakeCompound(meshed);
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
    progress.poll(static_cast<long long>(faces.size()), 1 << 10);
    faces.push_back(TopoDS::Face(e.Current()));
    facets.push_back(facet_corners(faces.back()));
    if (!facets.back()) builder.Add(meshed, faces.back());
  }
  IMeshTools_Parameters parameters;  // as BRepMesh_IncrementalMesh(shape, deflection, false, 0.2, true) sets them
  parameters.Deflection = deflection;
  parameters.Angle = 0.2;
  parameters.Relative = Standard_False;
  parameters.InParallel = Standard_True;  // faces meshed independently: the same mesh, on both cores
  Handle(OcctProgress) indicator = new OcctProgress(progress.sub(0.0, 0.9));
  BRepMesh_IncrementalMesh mesher(meshed, parameters, indicator->Start());
  progress.step(0.9);  // throws Cancelled when the mesher stopped early
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3i> triangles;
  for (size_t f = 0; f < faces.size(); ++f) {
    const TopoDS_Face& face = faces[f];
    if (facets[f]) {
      const int offset = static_cast<int>(points.size());
      for (const gp_Pnt& p : *facets[f]) points.emplace_back(p.X(), p.Y(), p.Z());
      triangles.emplace_back(offset, offset + 1, offset + 2);
      continue;
    }
    TopLoc_Location location;
    const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
    if (triangulation.IsNull()) continue;
    const int offset = static_cast<int>(points.size());
    for (int i = 1; i <= triangulation->NbNodes(); ++i) {
      const gp_Pnt p = triangulation->Node(i).Transformed(location.Transformation());
      points.emplace_back(p.X(), p.Y(), p.Z());
    }
    const bool reversed = face.Orientation() == TopAbs_REVERSED;
    for (int i = 1; i <= triangulation->NbTriangles(); ++i) {
      int a, b, c;
      triangulation->Triangle(i).Get(a, b, c);
      if (reversed) std::swap(b, c);
      triangles.emplace_back(offset + a - 1, offset + b - 1, offset + c - 1);
    }
  }
  // The mesh stays out of the shape: OpenCASCADE's mesher leaves polygons on the triangulation that
  // its own checker rejects where a corner lies a vertex tolerance away from an edge's curve, and a
  // shape carrying them (BRep text for FreeCAD) would no longer be the valid solid that was checked.
  BRepTools::Clean(meshed);
  TriangleMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  mesh.F.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t i = 0; i < points.size(); ++i) mesh.V.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  for (size_t i = 0; i < triangles.size(); ++i) mesh.F.row(static_cast<Eigen::Index>(i)) = triangles[i].transpose();
  progress.step(1.0);
  return mesh;
}

}  // namespace

void write_step(const TopoDS_Shape& shape, const std::string& path) {
  const QuietMessenger quiet;
  const OcctSignalHandlers handlers;
  try {
    OCC_CATCH_SIGNALS
    Handle(XCAFApp_Application) application = XCAFApp_Application::GetApplication();
    Handle(TDocStd_Document) document;
    application->NewDocument("MDTV-XCAF", document);
    Handle(XCAFDoc_ShapeTool) shapes = XCAFDoc_DocumentTool::ShapeTool(document->Main());
    Handle(XCAFDoc_ColorTool) colors = XCAFDoc_DocumentTool::ColorTool(document->Main());
    const TDF_Label part = shapes->AddShape(shape, Standard_False);
    for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) {
      const TDF_Label face = shapes->AddSubShape(part, e.Current());
      if (!face.IsNull()) colors->SetColor(face, face_color(TopoDS::Face(e.Current())), XCAFDoc_ColorSurf);
    }
    Interface_Static::SetCVal("write.step.unit", "MM");
    Interface_Static::SetCVal("write.step.schema", "AP214IS");
    STEPCAFControl_Writer writer;
    writer.SetColorMode(Standard_True);
    writer.SetNameMode(Standard_False);
    const bool transferred = writer.Transfer(document, STEPControl_AsIs);
    const bool written = transferred && writer.Write(path.c_str()) == IFSelect_RetDone;
    application->Close(document);
    if (!written) throw std::runtime_error("could not write the STEP file " + path);
  } catch (const Standard_Failure& failure) {
    throw std::runtime_error("could not write the STEP file " + path + ": " + failure.GetMessageString());
  }
}

TriangleMesh triangulate(const TopoDS_Shape& shape, double deflection, const ProgressSpan& progress) {
  const OcctSignalHandlers handlers;
  try {
    OCC_CATCH_SIGNALS
    return triangulate_faces(shape, deflection, progress);
  } catch (const Standard_Failure& failure) {
    throw std::runtime_error(std::string("could not triangulate the shape: ") + failure.GetMessageString());
  }
}

}  // namespace idealize
