// OpenCASCADE's validity check of a shape whose faces are partly the mesh's own triangles.
//
// BRepCheck_Analyzer checks every face, wire, edge and vertex, then every shell and solid. On a
// part with thousands of planar facets (faces of last resort, facets.h) the facets took most of
// the time (20 s of a 30k-facet solid) though each is valid by construction: three vertices that
// are not collinear, three straight edges between them, in their plane. Here the faces that are
// not facets are checked with their edges and vertices (the border edges they share with facets
// among them), then each shell for closure and orientation, and each solid of several shells for
// their nesting: what the analyzer would check of the whole, less what holds by construction.
#pragma once

#include "core/progress.h"

#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>

#include <functional>
#include <string>
#include <vector>

namespace idealize {

// `facet`: whether a face is a planar facet (valid by construction). Throws Cancelled through
// `progress` between the checks.
bool is_valid_with_facets(const TopoDS_Shape& shape, const std::function<bool(const TopoDS_Face&)>& facet,
                          const ProgressSpan& progress = {});

// The faces to blame when a shape is invalid though each face alone passes its checks: those that
// fail among their neighbours (an edge they share, whose tolerance or pcurves do not suit both),
// and those along an edge that more than two face sides use (the shell is not a manifold there:
// a border that collapsed onto another). Facets are checked for the second only.
struct FaceFault {
  TopoDS_Face face;
  std::string reason;
};
std::vector<FaceFault> faces_at_fault(const TopoDS_Shape& shape, const std::function<bool(const TopoDS_Face&)>& facet);

}  // namespace idealize
