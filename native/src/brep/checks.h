// Checks of the B-rep's faces, shells and solids: OpenCASCADE's checker, what it passes and the
// mesher or the boolean operations reject, and the repairs that keep a sound face from failing it.
#pragma once

#include "core/progress.h"

#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>

#include <functional>
#include <string>
#include <vector>

namespace idealize {

// A fitted edge (a B-spline through the mesh's border between two features) whose 3D curve and
// pcurve lie this many tolerances apart bounds no face of its surface. (An exact circle on a
// sphere that is no parallel may have its approximated pcurve as far off: its tolerance covers it.)
inline constexpr double kStrayEdge = 10.0;

// Whether an edge of `shape` spans no parameter range on a face it bounds (BRepCheck would never
// return on it).
bool has_vanishing_edge(const TopoDS_Shape& shape);

// "plane", "cylinder", "cone", "sphere", "torus", "bspline" or "other".
const char* occt_surface_name(const TopoDS_Face& face);

// BRepCheck's verdict, invalid outright with an edge of no parameter range.
bool is_valid(const TopoDS_Shape& shape, bool parallel = false);

// What BRepCheck finds wrong with an invalid face ("SelfIntersectingWire", ...).
std::string invalid_reason(const TopoDS_Shape& face);

// Why a face of a shell that did not close cannot be kept (empty: it can): BRepCheck's and the
// boolean operations' checks, and a tolerance beyond `size` (the part's).
std::string shell_face_fault(const TopoDS_Shape& face, double size);

// Why each face of a closed shell fails where BRepCheck passes it ("" where it does not), meshed at
// `deflection`; faces of less area than `tolerance` squared and those `sound` says are valid by
// construction are not judged. The mesher stops, and Cancelled is thrown, when `progress` is
// cancelled.
std::vector<std::string> closed_shell_faults(const TopoDS_Shape& shape, double deflection, double tolerance,
                                             const std::function<bool(const TopoDS_Face&)>& sound = {},
                                             const ProgressSpan& progress = {});

// A solid, or a compound of solids (a mesh of several bodies).
bool is_solid_shape(const TopoDS_Shape& shape);

// Every fault empty.
bool no_faults(const std::vector<std::string>& faults);

// Raises the tolerance of a vertex where two edges of `face` meet tangentially to cover their
// crossing beside it, for crossings within `reach` of the vertex.
void cover_tangent_crossings(const TopoDS_Face& face, double reach);

// An edge used by one face only (seams and degenerate edges aside).
bool has_free_edges(const TopoDS_Shape& shape);

// The Euler characteristic V - E + F of a shape's faces as a cell complex: a face bounded by w
// wires counts 2 - w (a disc with w - 1 holes), a seam once as an edge, a degenerate edge (a pole)
// not at all. A closed surface of genus g has 2 - 2g; so has the closed mesh it was made from.
int euler_characteristic(const TopoDS_Shape& shape);

// The largest distance between a B-spline edge's 3D curve and its curve on `face`, at 33
// parameters (0 for other edges and without the curves).
double sampled_pcurve_gap(const TopoDS_Edge& edge, const TopoDS_Face& face);

}  // namespace idealize
