// The feature layer: every patch of a segmentation becomes a feature with a surface type and exact
// parameters, features are related to each other (the feature graph), and the mesh is moved onto
// the ideal surfaces.
//
// J. S.-S. Chen, "Hybrid CAD modeler", thesis ch. 4 (identification by the signs of the patch's
// mean and Gaussian curvature with effective zero ranges from the histograms, parameters by direct
// formulas, relations, projection). Departures, each because the thesis's step is fragile: the type
// suggested by the curvature signs is verified by fitting every surface type to the patch and kept
// only when its residual is close to the best one's, otherwise the simplest surface that fits is
// taken (cone and cylinder, torus and sphere differ in the thesis by principal-curvature
// histograms, the noisiest quantity on a scan); a patch that no surface fits as well as the typical
// patch of the same mesh is reported as freeform.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"
#include "fit/surface.h"
#include "fit/surface_fitting.h"

#include <string>
#include <utility>
#include <vector>

namespace idealize {

struct FeatureOptions {
  FitOptions fit;
  // Directions within this angle are parallel (or perpendicular); surfaces whose normals differ by
  // less along their common boundary meet tangentially (G1). The thesis's alignment tolerance.
  double angle_tolerance_degrees = 5.0;
  // Axes, centres, radii and plane offsets closer than this are equal; 0 derives it from the data
  // as 0.1 % of the bounding-box diagonal (the thesis: 0.1 mm on parts of about 100 mm).
  double distance_tolerance = 0.0;
  // Radii within this fraction of each other are one design radius: a fillet's radius fitted to a
  // scan's quarter arc is off by 1-3 % (the thesis snaps radii to the peaks of the k_max histogram).
  double radius_tolerance = 0.05;
  // A surface type is accepted when its residual (robust spread) is at most this many times the
  // best type's:
  // two types that both describe the patch differ by the noise only, a wrong type's residual grows
  // with the patch.
  double residual_ratio = 1.5;
  // ... and the same holds for the angle between the vertex normals and the surface's, up to this
  // floor (degrees): the vertex normals of a coarse CAD tessellation deviate that much. Normals
  // tell surfaces apart that the points alone do not: the vertices of a coarse CAD fillet lie on
  // its two end arcs, which a sphere passes through as well as the cylinder.
  double normal_floor_degrees = 2.0;
  // A patch is freeform when even its best fit leaves this many times the median spread of all
  // patches of the mesh (the mesh's own noise and undulation level).
  double freeform_ratio = 3.0;
  // ... and more than this fraction of its size (square root of its area): smooth undulations of a
  // sculpted or warped part stay below it, a surface that is not of the fitted type does not.
  double freeform_relative_size = 0.01;
  // A patch is split (and its pieces merged again where they fit together) when its RMS residual
  // exceeds this many times the typical patch's spread, plus the distance tolerance (measured on
  // the benchmark: 2 left a plane fitted with two half holes whole, 0.5 split sound CAD faces).
  double split_ratio = 1.0;
  // Rounds of moving rim faces to the neighbouring feature whose surface explains them, each
  // followed by refitting the patches that changed.
  int reassignment_rounds = 10;
  // Passes of merging adjacent patches that one surface fits together (each patch merges at most
  // once per pass) on a noisy mesh; more join undulating neighbours. On an exact tessellation, where
  // a merge must explain every vertex, merging runs until nothing fits together.
  int merge_passes = 8;
  // Rounds of flooding the borders of a noisy mesh's patches again from their surfaces
  // (relaxation.h), each followed by refitting, and how far (edge steps) a border may move in one
  // round. Measured on the benchmark (faces correct): 3 rounds over 2 gave 4 more on the scans and
  // 2 on the sculpted meshes for 0.02 s at 84k triangles; bands of 1 to 4 came within 5 faces of
  // each other, while flooding whole patches lost 14 and took 3.5 times as long.
  int relaxation_rounds = 3;
  int relaxation_band = 3;
  // Make the relations exact and snap axes to the part's ideal directions (idealization.h) before
  // the mesh is projected.
  bool idealize = true;
  // The mesh is known not to be an exact tessellation, whatever most of its patches look like: a
  // sculpted region re-idealized with the ring of CAD faces around it (reidealize), whose sculpted
  // surfaces are smooth and finely meshed, not faceted.
  bool measured = false;
  // Receives the progress (0..1 over the call) and is polled for cancellation (throws Cancelled).
  Progress* progress = nullptr;
};

// The curvature statistics of one patch that identification reads (area-weighted means).
struct PatchCurvature {
  double mean = 0.0;      // H
  double gaussian = 0.0;  // K
};

// The effective zero range of H: the histogram range around the plane peak.
struct EffectiveZero {
  double low = 0.0, high = 0.0;
};

struct Feature {
  int id = 0;
  SurfaceType type = SurfaceType::Freeform;
  SurfaceType curvature_type = SurfaceType::Freeform;  // the thesis's guess from curvature signs
  PatchCurvature curvature;  // of the segmentation patch the feature grew from
  Surface surface;           // the fitted surface (the best analytic fit also for freeform)
  double rms = 0.0;          // residual of the fit over the patch's vertices
  double max_error = 0.0;
  double normal_rms = 0.0;   // RMS angle (radians) between vertex and surface normals
  double spread = 0.0, normal_spread = 0.0;  // their robust counterparts (SurfaceFit)
  double radius_error = 0.0;  // standard error of the tube radius (measure_radius_errors)
  double area = 0.0;
  int triangles = 0;
  int vertices = 0;          // vertices the fit used

  // Takes the fit's surface, type and residuals.
  void set_fit(const SurfaceFit& fit);
};

enum class Continuity { G0, G1 };

struct FeatureAdjacency {
  int a = 0, b = 0;           // feature ids, a < b
  Continuity continuity = Continuity::G0;
  double length = 0.0;        // length of the common boundary
  double angle = 0.0;         // median angle (radians) between the two surfaces' normals along it
};

struct FeatureRelation {
  std::string kind;           // parallel, perpendicular, coplanar, coaxial, equal_radius, concentric, tangent
  std::vector<int> features;  // a group of two or more features (pairs for perpendicular and tangent)
};

struct FeatureLayer {
  std::vector<int> labels;                  // per face: feature id (the patch labels, rims reassigned)
  std::vector<Feature> features;            // indexed by feature id
  std::vector<FeatureAdjacency> adjacency;  // sorted by (a, b)
  std::vector<FeatureRelation> relations;
  MatrixX3d idealized_vertices;  // the input vertices moved onto their features (same connectivity)
  // Per input vertex: distance from the nearest surface of the analytic features around it; NaN
  // where only freeform features (or none) touch it.
  Eigen::VectorXd vertex_deviation;
  double max_deviation = 0.0;    // largest distance of an input vertex from its nearest feature surface
  double rms_deviation = 0.0;
  double distance_tolerance = 0.0;  // the one used
  double angle_tolerance_degrees = 5.0;  // the one used (FeatureOptions)
  // The mesh's kind and noise, decided once by the split stage from the typical patch's fit (the
  // lower median of the patches' robust spreads: an exact tessellation fits to a hundredth of the
  // distance tolerance); every later stage and the B-rep read them.
  MeshKind mesh_kind = MeshKind::MeasuredSurface;
  double noise = 0.0;         // the typical patch's spread plus the coordinates' floor (distance)
  double normal_noise = 0.0;  // its normals' spread plus the normal floor (radians)
  double form_deviation = 0.0;  // of the mesh from the fitted surfaces beyond noise (feature_graph.h)
  std::vector<std::pair<std::string, double>> timings;
};

// Builds the feature layer of `mesh` (the input mesh) whose faces carry patch `labels`
// (#F, -1 = none; patch ids 0..patch_curvature.size()-1), with the effective zero of H.
FeatureLayer identify_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                               const std::vector<PatchCurvature>& patch_curvature,
                               const EffectiveZero& zero_mean_curvature, const FeatureOptions& options = {});

}  // namespace idealize
