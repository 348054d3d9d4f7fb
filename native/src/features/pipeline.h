// The feature pipeline: the stages that turn a segmentation's patches into features, run in order
// over one explicit state (FeatureState), each of them timed into the layer's timings.
//
// The stages, in order (pipeline.cpp lists them; docs/features.md explains each):
//   fit                    every patch identified (identify.h)
//   reassign               rim faces to the neighbour that explains them (reassign.h)
//   split                  what no surface fits, into regions; decides the mesh kind (split.h)
//   reassign_after_split
//   dissolve               strips the surfaces around them explain (noisy meshes; relaxation.h)
//   relax                  borders flooded again from the surfaces (noisy meshes; relaxation.h)
//   merge                  patches one surface fits together (merge.h, exact_fragments.h)
//   reassign_after_merge, dissolve_after_merge
//   settle                 inexact splits undone, features renumbered, exact refits (retyping.h)
//   edge_fillets           shared axes, narrow fillets, tori (noisy meshes; noisy_edges.h)
//   classify               freeform features, retyping rules (retyping.h)
//   relations              the feature graph and its relations (feature_graph.h)
//   idealize               relations made exact (idealize_relations.h)
//   tangent_boundaries     borders moved to where tangent surfaces touch (noisy meshes)
//   projection             the mesh moved onto its features (project_vertices.h)
#pragma once

#include "features/feature_layer.h"
#include "features/patch_points.h"
#include "features/relaxation.h"

#include <limits>
#include <vector>

namespace idealize {

// What the stages share. The mesh, its topology and areas, the options and the segmentation's
// patches are fixed; the layer, the patches' points and what the split stage decides about the
// mesh change as the stages go.
struct FeatureState {
  FeatureState(const TriangleMesh& mesh, const std::vector<int>& labels,
               const std::vector<PatchCurvature>& patch_curvature, const EffectiveZero& zero_mean_curvature,
               const FeatureOptions& options);

  const TriangleMesh& mesh;
  const std::vector<int>& segment_labels;              // #F: the segmentation's patch of every face
  const std::vector<PatchCurvature>& patch_curvature;  // per segmentation patch
  const EffectiveZero& zero_mean_curvature;
  const FeatureOptions& options;
  const ProgressSpan progress;  // the whole run; stages take their shares of it
  const MeshTopology topology;
  const Eigen::VectorXd area;   // #F
  const int num_patches;        // the segmentation's
  const double floor;           // how finely the coordinates are written (coordinate_floor)

  FeatureLayer layer;           // the result: labels, features, graph, idealized mesh, timings
  // What an exact tessellation's vertices may deviate from their surface.
  double exact_distance = 0.0;
  std::vector<PatchCurvature> curvature;  // per patch, growing with split patches
  std::vector<char> was_split;            // per patch: 1 split as an exact tessellation, 2 as a noisy mesh
  std::vector<PatchPoints> points;        // what the fits see of every patch, as the last stage left it
  std::vector<PatchPoints> whole;         // every vertex of each feature's faces (from `relations` on)
  // The mesh's kind and noise, decided by the split stage from the patches' fits (decide_mesh_kind):
  // an exact tessellation (its vertices on their faces, as a CAD export's) or a measured surface.
  bool exact_mesh = false;
  bool noiseless = false;     // the best-fitting tenth of the patches fits to a hundredth of the tolerance (exact or not)
  double noise = 0.0;         // the typical patch's spread (distance)
  double normal_noise = 0.0;  // and its normals' (radians)
  // The RMS distance above which a surface does not fit its patch (decided with the noise; none before).
  double split_above = std::numeric_limits<double>::infinity();
  int patches = 0;            // features after splitting; merging keeps their ids until `settle`
  bool rimless = false;       // whether `points` leave out a ring of faces along every rim

  // The patch identified from its points and curvature (identify.h).
  Feature identify_points(const PatchPoints& pp, const PatchCurvature& c) const;
  // Identifies the patches p with which[p] from `patch_points`, on two threads.
  void identify_all(const std::vector<PatchPoints>& patch_points, const std::vector<char>& which,
                    const ProgressSpan& span);
  // Triangles per feature.
  std::vector<int> triangle_counts() const;
  // Refits the surfaces of the patches that changed (same type, starting from the previous fit) to
  // `points`.
  void refit_changed(const std::vector<char>& changed, const ProgressSpan& span);
  // The surfaces of the features with their spreads, at least the mesh's noise; none for a freeform
  // feature, nor, on a noiseless measured surface, for one whose surface does not fit it.
  std::vector<FloodSurface> flood_surfaces() const;
  // On a noisy mesh, dissolves the patches that the surfaces around them explain (relaxation.h) and
  // refits the changed ones without their rims; returns whether `points` are those rim-less points.
  bool dissolve_strips();
};

// The stages defined outside pipeline.cpp, each in the module of its concern.
void reassign_rims(FeatureState& state, const ProgressSpan& span);  // reassign.cpp
void split_badly_fitting(FeatureState& state);                       // split.cpp
void merge_stage(FeatureState& state);                               // merge.cpp
void settle_features(FeatureState& state);                           // retyping.cpp
void fit_noisy_edges(FeatureState& state);                           // noisy_edges.cpp
void classify_features(FeatureState& state);                         // retyping.cpp
void relate_features(FeatureState& state);                           // retyping.cpp
void idealize_layer(FeatureState& state);                            // idealize_relations.cpp

}  // namespace idealize
