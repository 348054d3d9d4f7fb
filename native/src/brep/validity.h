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

#include "../progress.h"

#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>

#include <functional>

namespace idealize {

// `facet`: whether a face is a planar facet (valid by construction). Throws Cancelled through
// `progress` between the checks.
bool is_valid_with_facets(const TopoDS_Shape& shape, const std::function<bool(const TopoDS_Face&)>& facet,
                          const ProgressSpan& progress = {});

}  // namespace idealize
