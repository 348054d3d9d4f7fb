// The fitted B-rep: one analytic face per region of the feature layer, trimmed by the
// intersection curves of adjacent ideal surfaces, sewn into a shell and a solid with OpenCASCADE.
//
// Built here in the native core against OCCT rather than through FreeCAD's Part module: the
// command line writes STEP without FreeCAD, the construction runs without the GIL, and the edges
// are created once and shared by their two faces (no sewing by tolerance, which merges or misses
// edges on small features).
//
// Topology comes from the mesh (topology.h): each region boundary chain becomes an edge on
// the exact intersection of the two ideal surfaces (line, circle or ellipse in closed form for the
// pairs an idealized prismatic part has; OCCT's surface intersection otherwise; a B-spline through
// the chain projected onto both surfaces where the surfaces touch tangentially and no closed form
// applies), each corner a vertex at the point closest to all surfaces meeting there.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"
#include "fit/surface.h"

#include <TopoDS_Shape.hxx>

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace idealize {

struct BrepOptions {
  // Distance below which geometry is equal (edge and vertex tolerance baseline); 0 derives it
  // as 0.1 % of the bounding-box diagonal, the feature layer's distance tolerance.
  double tolerance = 0.0;
  // Merge faces and edges that lie on the same surface or curve (ShapeUpgrade_UnifySameDomain).
  bool unify = true;
  // What the mesh is, as the feature layer decided it (FeatureLayer::mesh_kind). Unset for a layer
  // stored without it: then the builder judges as the layer does, from how exactly the surfaces
  // pass through the vertices.
  std::optional<MeshKind> mesh_kind;
  // The feature layer's angle tolerance (FeatureLayer::angle_tolerance_degrees): directions this
  // close are parallel where no exact closed form is found, and surfaces whose normals differ by
  // less along an edge meet tangentially (the feature graph's G1 criterion).
  double angle_tolerance_degrees = 5.0;
  // Receives the progress (0..1 over the call) and is polled for cancellation (throws Cancelled).
  Progress* progress = nullptr;
};

// One problem with one feature: it has no face in the result, or its face is not valid.
struct BrepProblem {
  int feature = -1;
  std::string message;
};

// One edge of the B-rep as built from the mesh, before healing and merging.
struct BrepEdge {
  int a = -1, b = -1;       // the features on either side (b = -1 on an open mesh boundary)
  int mesh_vertices = 0;    // length of the boundary chain it replaces
  bool closed = false;      // no corner on it
  std::string curve;        // "closed form", "intersection", "fitted", or "" when it failed
};

// How one region of the mesh became a face: `analytic` (its feature's surface), `bspline` (a surface
// fitted to a freeform region) or `faceted` (its triangles as planar facets, where its surface gave
// no valid face: `reason` says why).
struct BrepRegionFace {
  int feature = -1;
  std::string kind;
  std::string reason;
  double area = 0.0;  // of the region's triangles
};

struct BrepResult {
  TopoDS_Shape shape;      // a solid when `solid`, otherwise a shell or compound of the faces made
  bool valid = false;      // BRepCheck_Analyzer accepts the whole shape
  bool closed = false;     // no free edges
  bool solid = false;      // shape is a valid closed solid
  int faces = 0;
  double volume = 0.0;     // of the solid (0 otherwise)
  double max_tolerance = 0.0;  // largest vertex or edge tolerance: the widest gap the shape bridges
  std::map<std::string, int> surface_types;  // face count per surface type name
  std::vector<BrepProblem> problems;
  std::vector<int> face_features;            // per face of `shape` (TopExp order): its feature, -1 unknown
  std::vector<BrepEdge> edges;
  std::vector<BrepRegionFace> regions;       // per region of the labelled mesh
  // Features whose regions a neighbour's surface explained as well as their own, before any
  // geometry was made: (feature, the feature it joined); none of their own faces.
  std::vector<std::pair<int, int>> joined;
  double analytic_area_fraction = 0.0;       // of the mesh's area, on analytic faces
  // Honest validity, measured on a closed valid shape (0 otherwise): the largest distance of a
  // mesh vertex from the faces, and of a point of the faces from the mesh; the largest a region
  // is allowed (its fit, or its border's distance from its edges, plus the tolerance); the volume
  // the mesh encloses. A solid stays within its regions' allowances and its volume within what
  // they account for, or it is not a solid.
  double mesh_to_shape = 0.0, shape_to_mesh = 0.0, deviation_bound = 0.0, mesh_volume = 0.0;
  // The Euler characteristic V - E + F of the solid's faces and of the mesh (0 both when there is
  // no solid): equal when the solid has the mesh's handles and bodies (2 - 2 genus
  // per body). Where they differ, a problem says so.
  int euler_shape = 0, euler_mesh = 0;
  std::vector<std::pair<std::string, double>> timings;
};

// Builds the B-rep of `mesh` (the input, counter-clockwise seen from outside) whose faces carry
// feature `labels` (#F, -1 = transition, joined to the nearest adjacent feature) on `surfaces`
// (per feature; freeform features have no face and are reported).
BrepResult build_brep(const TriangleMesh& mesh, const std::vector<int>& labels,
                      const std::vector<Surface>& surfaces, const BrepOptions& options = {});

}  // namespace idealize
