// OpenCASCADE's validity check, less the facets (validity.h).
#include "validity.h"

#include <BRepCheck_Analyzer.hxx>
#include <BRepCheck_ListOfStatus.hxx>
#include <BRepCheck_Shell.hxx>
#include <BRepCheck_Solid.hxx>
#include <BRep_Builder.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Iterator.hxx>

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

}  // namespace idealize
