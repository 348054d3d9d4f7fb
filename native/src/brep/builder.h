// The B-rep builder (build_brep, brep.h): its state, shared by its stages, one file each.
//
//   builder.cpp            the rounds: topology, surfaces, curves once; then edges, faces, shell and
//                          checks in rounds, failing regions degraded between them
//   builder_vertices.cpp   corners: the point nearest the surfaces that meet there
//   builder_edges.cpp      edge curves (closed form, intersection, fitted) and the mesh's polylines
//   builder_faces.cpp      faces on the surfaces, bounded by their loops of edges
//   builder_assemble.cpp   healing, sewing, the facets joined, shells into solids
//   builder_deviation.cpp  honest validity: the solid lies where the mesh does
//
// Internal to native/src/brep/.
#pragma once

#include "fit/bspline_fitting.h"
#include "brep/occt_signals.h"
#include "core/parallel.h"
#include "brep/brep.h"
#include "brep/checks.h"
#include "brep/corners.h"
#include "brep/curves.h"
#include "brep/deviation.h"
#include "brep/facets.h"
#include "brep/occt_progress.h"
#include "brep/solids.h"
#include "brep/surfaces.h"
#include "brep/topology.h"
#include "brep/validity.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRepAdaptor_Surface.hxx>
#include <BOPAlgo_ArgumentAnalyzer.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepCheck.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepCheck_ListIteratorOfListOfStatus.hxx>
#include <BRepCheck_Result.hxx>
#include <BRepGProp.hxx>
#include <BRepLib_CheckCurveOnSurface.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Poly_Triangulation.hxx>
#include <ElSLib.hxx>
#include <GProp_GProps.hxx>
#include <Geom2d_Curve.hxx>
#include <GeomAPI_IntSS.hxx>
#include <GeomAPI_PointsToBSpline.hxx>
#include <GeomAPI_ExtremaCurveCurve.hxx>
#include <GeomAPI_ProjectPointOnCurve.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Geom_BSplineCurve.hxx>
#include <Geom_BSplineSurface.hxx>
#include <Geom_Circle.hxx>
#include <Geom_RectangularTrimmedSurface.hxx>
#include <Geom_ConicalSurface.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <Geom_Ellipse.hxx>
#include <Geom_Line.hxx>
#include <Geom_Plane.hxx>
#include <Geom_SphericalSurface.hxx>
#include <Geom_ToroidalSurface.hxx>
#include <Geom_TrimmedCurve.hxx>
#include <Precision.hxx>
#include <BRepTools_ReShape.hxx>
#include <ShapeBuild_ReShape.hxx>
#include <ShapeFix_Edge.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <ShapeFix_Face.hxx>
#include <ShapeFix_Solid.hxx>
#include <ShapeUpgrade_UnifySameDomain.hxx>
#include <Standard_Failure.hxx>
#include <TColStd_Array1OfInteger.hxx>
#include <TColStd_Array1OfReal.hxx>
#include <TColgp_Array1OfPnt.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Iterator.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <exception>
#include <functional>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <tuple>
#include <sstream>

namespace idealize {

// The noise of a mesh about its surfaces, from the distances of its vertices (0 for none): sigma of
// Gaussian residuals, whose median is 0.6745 sigma (1.4826 = 1 / 0.6745), robust to the blurred
// edges and to a region its surface does not explain.
double noise_sigma(std::vector<double> residuals);

class BrepBuilder {
 public:
  BrepBuilder(const TriangleMesh& mesh, const std::vector<Surface>& surfaces, const BrepOptions& options)
      : mesh_(mesh), surfaces_(surfaces), features_(static_cast<int>(surfaces.size())),
        progress_(options.progress, "topology") {
    diagonal_ = bounding_box_diagonal(mesh);
    tol_ = options.tolerance > 0 ? options.tolerance : 1e-3 * diagonal_;
    angle_eps_ = std::max(1e-9, tol_ / std::max(diagonal_, 1e-300));
    mesh_kind_ = options.mesh_kind;
    tangent_angle_ = options.angle_tolerance_degrees * M_PI / 180.0;
    nearly_parallel_ = std::sin(tangent_angle_);
  }

  BrepResult run(const std::vector<int>& labels, const BrepOptions& options);

 private:
  using Clock = std::chrono::steady_clock;
  void stage(BrepResult& result, const char* name, Clock::time_point& since) {
    const auto now = Clock::now();
    result.timings.emplace_back(name, std::chrono::duration<double>(now - since).count());
    since = now;
  }
  // The stages of run(), in order.
  std::vector<int> clean_mesh(const std::vector<int>& labels);
  std::vector<int> face_features(const MeshTopology& topology, const std::vector<int>& clean_labels);
  void make_region_surfaces();
  void degrade_in_rounds(BrepResult& result, const BrepOptions& options);
  void report_regions(BrepResult& result) const;
  void check_euler_characteristic(BrepResult& result, long long edge_count) const;
  std::vector<int> merge_same_surfaces(const std::vector<int>& labels) const;
  std::optional<RoundFace> round_face(int region) const;
  bool split_at_seam(int chain, const Handle(Geom_Curve)& curve, double u0, double u1, const TopoDS_Vertex& v0,
                     const TopoDS_Vertex& v1, double tolerance);
  bool most_features_exact(const TriangleMesh& mesh, const std::vector<int>& labels) const;
  std::vector<int> dissolve_sampling_blends(const TriangleMesh& mesh, const MeshTopology& topology,
                                            std::vector<int> labels) const;
  std::vector<int> join_explained_regions(std::vector<int> face_feature, BrepResult& result) const;
  void fit_freeform_surfaces(const TriangleMesh& mesh, const std::vector<int>& face_feature, BrepResult& result);
  LocalSurface local_surface(int feature) const;
  void make_vertices(const MeshTopology& topology);
  TopoDS_Vertex vertex_at_corner(int mesh_vertex) const { return vertices_.at(mesh_vertex); }
  struct ChainCurve {
    BrepEdge report;           // what the result says of the edge
    Handle(Geom_Curve) curve;  // null: no edge
    double u0 = 0, u1 = 0, tolerance = 0;
    Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero();  // its ends' points
    std::string problem;       // why it has none (empty: none to report)
  };
  ChainCurve chain_curve(size_t chain) const;
  void compute_curves();
  void make_edges(BrepResult& result);
  void make_faces(BrepResult& result);
  bool is_cap(size_t region) const;  // a cone or sphere bounded by one closed chain
  std::optional<TopoDS_Face> pole_cap(size_t region);
  // The healed, sewn and merged shape; `closed_faults`: closed_shell_faults of the solid returned
  // where merging had to judge its faces already, else empty.
  TopoDS_Shape assemble(BrepResult& result, const BrepOptions& options, std::vector<std::string>& closed_faults);
  std::vector<char> fit_edge_tolerances(BrepResult& result);
  std::vector<char> sound_faces() const;
  void cover_sewn_pcurve_gaps(const TopoDS_Shape& shape) const;
  TopoDS_Shape facets_only(BrepResult& result, const ProgressSpan& progress);
  TopoDS_Shape sew(BrepResult& result, const std::vector<char>& stray, const std::vector<char>& sound,
                   const ProgressSpan& progress);
  TopoDS_Shape with_facets(const TopoDS_Shape& sewn, const BRepBuilderAPI_Sewing& sewing, ShapeBuild_ReShape& healed) const;
  // The region whose surface `face` lies on, -1 none.
  int region_of(const TopoDS_Face& face) const;

  const TriangleMesh& mesh_;
  std::vector<Surface> surfaces_;  // the layer's, and one freeform feature for what none explains
  int features_ = 0;               // the layer's
  // Shares of the whole run, as measured on a scan of a million triangles.
  const ProgressSpan progress_;
  double diagonal_ = 0, tol_ = 0, angle_eps_ = 0;
  std::optional<MeshKind> mesh_kind_;  // as the feature layer decided it (BrepOptions::mesh_kind)
  // The layer's angle tolerance: the G1 angle (radians) and its sine, within which directions are
  // parallel where no exact closed form is found.
  double tangent_angle_ = 0, nearly_parallel_ = 0;
  BoundaryTopology topo_;
  std::map<int, FreeformSurface> freeform_;  // feature -> its fitted B-spline
  std::vector<Handle(Geom_Surface)> region_surfaces_;
  std::vector<double> region_sense_;  // +1 when the surface normal points out of the part
  std::vector<char> region_winds_;    // a loop of several chains winds round the surface's axis
  std::map<int, int> seam_splits_;    // chain -> the winding region whose seam crosses it
  std::map<int, std::array<TopoDS_Edge, 2>> split_edges_;  // such a chain's edge, in two at the seam
  std::vector<Vec3> region_centroid_;  // mean of the region's triangle centroids
  std::map<int, TopoDS_Vertex> vertices_;
  std::map<int, Vec3> corner_points_;
  std::vector<TopoDS_Edge> edges_;
  std::vector<char> edge_ok_;
  std::vector<char> collapsed_;  // chains whose two corners are one vertex: no edge
  std::vector<TopoDS_Face> faces_;
  std::vector<int> face_region_;
  std::vector<char> face_facet_;  // per face of faces_: a planar facet of a faceted region

  // Graceful degradation (build_round): regions made of their triangles, and the chains that run
  // as the mesh's polyline because a faceted region or a failed curve lies along them.
  TriangleMesh clean_;                      // the mesh without degenerate triangles
  std::vector<std::vector<int>> region_faces_;
  std::vector<ChainCurve> curves_;          // per chain, computed once
  std::vector<char> faceted_, bounded_, polyline_;
  std::vector<std::string> facet_reason_;   // per region: why it is faceted
  std::unique_ptr<FacetBuilder> facets_;
  std::map<int, std::vector<TopoDS_Edge>> chain_pieces_;  // polyline chain -> its edges, along it
  std::map<const Standard_Transient*, int> facet_region_;  // facet plane -> region
  bool is_facet(const TopoDS_Face& face) const { return facet_region_.count(BRep_Tool::Surface(face).get()) != 0; }
  // OpenCASCADE's check of the whole shape, the facets (valid by construction) left out.
  bool valid(const TopoDS_Shape& shape, const ProgressSpan& progress) const;
  std::vector<Handle(Geom_Surface)> facet_planes_;         // (keeps those keys alive)
  std::map<int, std::string> failed_;       // regions whose face failed this round -> why
  // Whether the mesh has a border: an edge of one triangle. (Along an edge of four triangles, two
  // sheets touching, the traced chains have no region on their right, but the facets close there.)
  bool open_mesh() const { return open_mesh_; }
  bool open_mesh_ = false;
  void fail(int region, const std::string& why) {
    if (region >= 0) failed_.try_emplace(region, why);
  }
  void place_polylines();
  std::vector<int> polyline_vertices(size_t chain) const;
  bool build_round(BrepResult& result, const BrepOptions& options);

  // Honest validity (deviation.h): how far each region's face may lie from its mesh.
  std::vector<double> region_fit_;  // per region: the sagitta of its triangles plus the noise's extent
  std::vector<double> region_noise_;  // per region: the noise's extent alone (sigma sqrt(2 ln n))
  std::vector<double> chain_gap_;   // per chain with a curve: largest distance of its vertices from it
  double mesh_volume_ = 0.0;        // enclosed by the clean mesh (0 when it is open)
  void measure_fits();
  // Per region; `border`, when given, receives the border's share alone (gaps, tolerance, deflection).
  std::vector<double> deviation_allowances(double deflection, std::vector<double>* border = nullptr) const;
  bool follows_mesh(const TopoDS_Shape& shape, BrepResult& result, const ProgressSpan& progress);
};

}  // namespace idealize
