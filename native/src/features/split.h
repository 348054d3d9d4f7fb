// Splitting what no surface fits: into planar regions and grown surfaces, and undoing the splits of
// an exact tessellation that found nothing exact.
#pragma once

#include "features/feature_layer.h"
#include "features/patch_points.h"

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

// Splits a patch that no surface fits (the segmentation merged faces across an edge it did not
// resolve) into planar regions grown from its largest faces: a face joins while its vertices lie
// within 3 σ of the region's plane and its normal within 3 σ of the plane's, σ being the noise of
// the mesh's well-fitted patches. Regions of fewer than `min_region_faces` faces go back to a
// remainder whose connected components become patches of their own: on a noisy mesh a curved face
// stays whole that way, while on an exact tessellation (min_region_faces = 1) curved parts fall
// apart into planar facets that merging joins again. The first region keeps the patch's id, the
// others get new ids from `next_id` on.
int split_patch(const TriangleMesh& mesh, const MeshTopology& topology, const Eigen::VectorXd& area, int patch,
                double noise, double normal_noise, int min_region_faces, std::vector<int>& labels, int next_id,
                const ProgressSpan& progress);

// Splits a noisy patch that no single surface fits into regions that one surface each fits: a chain
// of blends of one radius (cylinder, torus, cylinder) has one mean curvature, so the histogram
// cannot tell its members apart. From the face deepest inside the patch, a disc of faces is
// identified; when one surface fits it to within `fits_below` RMS, the region grows over the faces
// whose vertices lie within 3 σ of the surface and whose normals lie within 3 σ_n of its normals (σ
// the larger of the mesh's noise and the fit's spread), refitted as it doubles. Regions of at least
// `min_region_faces` faces get new ids from `next_id` on; the faces no region took are labelled by
// label_remainder (a corner ball between fillets, a small boss on a plate), and the reassignment
// that follows moves rim faces to the surfaces that explain them. A growing region's refit that no
// longer fits within `fits_below` (and has drifted by more than the noise from its disc's fit) ends
// its growth at the last region that did. A region that grew on as a torus (a sector of a tube's
// bend, below) makes the patch split once more with the tori grown first; the regions that stand as
// tori are entered in `generalized` (new id -> its torus).
int split_into_surfaces(const TriangleMesh& mesh, const MeshTopology& topology, int patch, double noise,
                        double normal_noise, double fits_below, int min_region_faces,
                        const std::function<Feature(const PatchPoints&)>& identify_points, const FitOptions& fit_options,
                        std::vector<int>& labels, int next_id, std::map<int, Surface>& generalized,
                        const ProgressSpan& progress);

// On an exact tessellation, faces that the segmentation merged come apart into pieces that their
// surfaces fit exactly. Where most of a split patch ended in pieces that fit only approximately (to
// more than `exact` RMS) or in single triangles (which any plane fits), it was a freeform surface:
// the split is undone and the patch identified afresh.
void undo_inexact_splits(const TriangleMesh& mesh, const Eigen::VectorXd& area, const std::vector<int>& original,
                         const std::vector<char>& was_split, double exact,
                         const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                         const std::vector<PatchCurvature>& curvature, std::vector<Feature>& features,
                         std::vector<int>& labels);

}  // namespace idealize
