// Fully automatic feature segmentation by mean-curvature histograms.
//
// J. S.-S. Chen and H.-Y. Feng, "Automatic prismatic feature segmentation of scanning-derived
// meshes utilizing mean curvature histograms", Virtual and Physical Prototyping 9(1):45–61, 2014
// (thesis ch. 3). Pass 1 cuts out the sharpest features; pass 2 smooths the curvature of the
// remaining region, rebuilds the histogram and splits at every remaining valley. Triangles whose
// three vertices share a range form patches; the others are transitions, thinned to
// one-triangle-wide strips, which are finally folded into the adjacent patches so that every
// triangle belongs to a feature.
//
// Departures from the thesis, each measured on the benchmark (BENCHMARKS.md): curvature is
// estimated on a copy denoised by bilateral normal filtering; pass 1 cuts where the local sampling
// stops resolving a radius instead of at the extremity peaks' valleys (chamfered sharp edges form
// a low plateau whose valley the histogram does not show reliably); ripple valleys are removed by
// persistence on square-root counts; long thin CAD triangles are refined first.
#pragma once

#include "curvature/curvature.h"
#include "prepare/denoising.h"
#include "segment/histogram.h"
#include "core/mesh.h"
#include "prepare/mesh_check.h"
#include "core/progress.h"
#include "prepare/refinement.h"

#include <string>
#include <utility>
#include <vector>

namespace idealize {

struct SegmentationOptions {
  HistogramOptions histogram;
  RefinementOptions refinement;
  // Pass 2 smooths the curvature values of the non-sharp region this many times (area-weighted
  // one-ring means): the thesis's "aggressive" smoothing, moderated because denoising already
  // removed the noise; more flattens fillets a dozen triangles wide into ramps.
  int curvature_smoothing_iterations = 15;
  // Feature-preserving denoising of a copy of the positions before curvature is estimated.
  DenoisingOptions denoising;
  // Pass 1 calls a vertex sharp when its curvature radius is below this many local edge lengths:
  // fewer than about three edges per quarter circle cannot tell a round from a sharp edge.
  double sharp_radius_in_edges = 2.0;
  // The checks of the prepared mesh (and whether they count self-intersections).
  MeshCheckOptions check;
  // Receives the progress (0..1 over the call) and is polled for cancellation (throws Cancelled).
  Progress* progress = nullptr;
};

// What one patch is, in terms the later stages and the report use.
enum class PatchKind { SharpConcave, SharpConvex, Smooth };

struct PatchSummary {
  int id = 0;
  PatchKind kind = PatchKind::Smooth;
  int input_triangles = 0;       // input faces labelled with this patch
  double area = 0.0;             // their total area
  double mean_curvature = 0.0;   // area-weighted mean of H over the patch
  double mean_gaussian = 0.0;    // area-weighted mean of K over the patch
  double range_low = 0.0, range_high = 0.0;  // histogram range of the patch's vertices
};

struct Segmentation {
  std::vector<int> labels;             // per input face: patch id; -1 where degenerate or unreachable
  std::vector<char> transition;        // per input face: lay on a transition strip before folding
  std::vector<PatchSummary> patches;   // indexed by patch id

  // The working mesh the analysis ran on, with its results, for the later stages.
  RefinedMesh working;                 // prepared + refined mesh; face_origin maps to input faces
  std::vector<int> working_labels;     // per working face
  Eigen::VectorXd mean_curvature;      // "v:mean_curvature" of the denoised working mesh
  Eigen::VectorXd gaussian_curvature;  // "v:gaussian_curvature" of the denoised working mesh
  Eigen::VectorXd vertex_area;         // "v:mixed_area" of the denoised working mesh
  Eigen::VectorXd smoothed_mean;       // pass-2 curvature values (raw H outside the smooth region)
  HistogramRanges histogram;           // pass-2 histogram and its ranges
  double zero_low = 0.0, zero_high = 0.0;  // effective zero of H: the histogram range holding 0

  int removed_degenerate = 0, removed_duplicate = 0;
  // The findings of check_mesh on the prepared input (its `flipped` left empty); the working mesh
  // has the repaired orientation.
  MeshCheck mesh_check;
  // Per input face: turned over by the orientation repair (empty when none is).
  std::vector<char> input_flipped;
  std::vector<std::pair<std::string, double>> timings;  // seconds per stage, in order
};

// Segments `mesh` into feature patches. Throws MeshError for unusable input.
Segmentation segment_mesh(const TriangleMesh& mesh, const SegmentationOptions& options = {});

}  // namespace idealize
