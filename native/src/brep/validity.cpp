// OpenCASCADE's validity check, less the facets (validity.h).
#include "brep/validity.h"

#include <BRepCheck_Analyzer.hxx>
#include <BRepCheck_ListOfStatus.hxx>
#include <BRepCheck_Shell.hxx>
#include <BRepCheck_Solid.hxx>
#include <BRep_Builder.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Iterator.hxx>
#include <BRepCheck_Result.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <cstdio>
#include <cstdlib>

namespace idealize {
namespace {

bool no_error(const BRepCheck_ListOfStatus& statuses) {
  for (BRepCheck_ListOfStatus::Iterator it(statuses); it.More(); it.Next())
    if (it.Value() != BRepCheck_NoError) return false;
  return true;
}

}  // namespace

bool is_valid_with_facets(const TopoDS_Shape& shape, const std::function<bool(const TopoDS_Face&)>& facet,
                          const ProgressSpan& progress) {
  progress.step(0.0);
  BRep_Builder builder;
  TopoDS_Compound checked;
  builder.MakeCompound(checked);
  bool any = false;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next())
    if (!facet(TopoDS::Face(e.Current()))) {
      builder.Add(checked, e.Current());
      any = true;
    }
  if (any && !BRepCheck_Analyzer(checked, Standard_True, Standard_True).IsValid()) return false;
  progress.step(0.5);
  for (TopExp_Explorer e(shape, TopAbs_SHELL); e.More(); e.Next()) {
    progress.check();
    BRepCheck_Shell check(TopoDS::Shell(e.Current()));
    check.Minimum();
    if (!no_error(check.Status()) || check.Closed() != BRepCheck_NoError || check.Orientation() != BRepCheck_NoError)
      return false;
  }
  for (TopExp_Explorer e(shape, TopAbs_SOLID); e.More(); e.Next()) {
    int shells = 0;
    for (TopoDS_Iterator it(e.Current()); it.More(); it.Next()) ++shells;
    if (shells < 2) continue;  // nothing nested to check
    progress.check();
    BRepCheck_Solid check(TopoDS::Solid(e.Current()));
    check.Minimum();
    if (!no_error(check.Status())) return false;
  }
  progress.step(1.0);
  return true;
}

std::vector<FaceFault> faces_at_fault(const TopoDS_Shape& shape, const std::function<bool(const TopoDS_Face&)>& facet) {
  std::vector<FaceFault> faults;
  TopTools_IndexedMapOfShape blamed;
  BRep_Builder builder;
  TopoDS_Compound checked;
  builder.MakeCompound(checked);
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next())
    if (!facet(TopoDS::Face(e.Current()))) builder.Add(checked, e.Current());
  const BRepCheck_Analyzer analyzer(checked, Standard_True);
  const auto in_error = [&](const TopoDS_Shape& part) {
    const Handle(BRepCheck_Result) result = analyzer.Result(part);
    if (result.IsNull()) return false;
    if (!no_error(result->Status())) return true;
    for (result->InitContextIterator(); result->MoreShapeInContext(); result->NextShapeInContext())
      if (!no_error(result->StatusOnShape())) return true;
    return false;
  };
  for (TopExp_Explorer e(checked, TopAbs_FACE); e.More(); e.Next()) {
    bool fault = in_error(e.Current());
    for (const TopAbs_ShapeEnum type : {TopAbs_WIRE, TopAbs_EDGE, TopAbs_VERTEX})
      for (TopExp_Explorer part(e.Current(), type); part.More() && !fault; part.Next()) fault = in_error(part.Current());
    if (fault && blamed.Add(e.Current()) > static_cast<int>(faults.size()))
      faults.push_back({TopoDS::Face(e.Current()), "it is not valid where it meets its neighbours"});
  }
  // Each use of an edge by a face (a seam is used twice by its one face): a closed manifold shell
  // uses every edge twice.
  TopTools_IndexedDataMapOfShapeListOfShape uses;
  TopExp::MapShapesAndAncestors(shape, TopAbs_EDGE, TopAbs_FACE, uses);
  for (int i = 1; i <= uses.Extent(); ++i) {
    if (uses(i).Extent() <= 2) continue;
    for (TopTools_ListOfShape::Iterator it(uses(i)); it.More(); it.Next())
      if (blamed.Add(it.Value()) > static_cast<int>(faults.size()))
        faults.push_back({TopoDS::Face(it.Value()), "more than two faces meet at an edge of its border"});
  }
  return faults;
}

}  // namespace idealize
