// Feature-preserving denoising: bilateral filtering of face normals, then vertex updates that fit
// the faces to the filtered normals. Y. Zheng, H. Fu, O. K.-C. Au, C.-L. Tai, "Bilateral Normal
// Filtering for Mesh Denoising", IEEE TVCG 17(10), 2011.
//
// Segmentation estimates curvature on the denoised copy: scan noise of 0.1% of the part size makes
// raw cotangent curvature useless (its spread exceeds feature curvatures), the facet folds of a CAD
// tessellation concentrate a curved face's curvature on lines, and Laplacian smoothing spreads
// sharp edges over many rings, where this keeps them crisp. Both kernel widths come from the data.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

namespace idealize {

struct DenoisingOptions {
  int normal_iterations = 5;    // bilateral passes over the face normals
  int vertex_iterations = 30;   // vertex updates towards them (measured: 15 leaves facet folds, 60 no better)
  // The range kernel's width, in multiples of the median normal difference of neighbouring faces
  // (the noise, or the facet folds of a CAD tessellation); sharp edges differ several times more
  // and are not mixed across.
  double range_factor = 1.5;
  // Folds turning by more than this angle (radians) are edges of the part, neither noise nor facet
  // folds: a mesh whose only folds are such edges (a box's tessellation) is not filtered at all.
  // 0 takes every fold for noise; segmentation passes the angle its first pass calls sharp.
  double edge_fold = 0.0;
};

// A denoised copy of the positions (#V x 3, same connectivity). A mesh without any fold (all faces
// coplanar with their neighbours) is returned unchanged.
// Reports into `progress` and throws Cancelled when it is cancelled.
MatrixX3d denoised_positions(const TriangleMesh& mesh, const MeshTopology& topology,
                             const DenoisingOptions& options = {}, const ProgressSpan& progress = {});

}  // namespace idealize
