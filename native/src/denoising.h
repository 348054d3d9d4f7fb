// Feature-preserving denoising by bilateral filtering of face normals followed by vertex updates
// that fit the filtered normals: Y. Zheng, H. Fu, O. K.-C. Au, C.-L. Tai, "Bilateral Normal
// Filtering for Mesh Denoising", IEEE TVCG 17(10), 2011.
//
// Segmentation uses it only to estimate curvature: scan noise of 0.1% of the part size makes raw
// cotangent curvature useless (its spread exceeds feature curvatures), while Laplacian smoothing
// spreads sharp edges over many rings. Both kernel widths come from the data.
#pragma once

#include "mesh.h"

namespace idealize {

struct DenoisingOptions {
  int normal_iterations = 5;    // bilateral passes over the face normals
  int vertex_iterations = 15;   // vertex updates towards the filtered normals
  // The range kernel's width, in multiples of the median normal difference of edge-adjacent faces
  // (the noise); sharp edges differ several times more and are not mixed across.
  double range_factor = 1.5;
};

// A denoised copy of the positions (same connectivity). A mesh whose adjacent faces are mostly
// exactly coplanar (noise-free CAD data) is returned unchanged.
MatrixX3d denoised_positions(const TriangleMesh& mesh, const MeshTopology& topology,
                             const DenoisingOptions& options = {});

}  // namespace idealize
