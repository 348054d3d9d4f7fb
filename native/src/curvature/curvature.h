// Discrete differential geometry on triangle meshes.
//
// Mean curvature by the cotangent formula and Gaussian curvature by the angle defect, both over
// mixed Voronoi areas: M. Meyer, M. Desbrun, P. Schröder, A. H. Barr, "Discrete
// Differential-Geometry Operators for Triangulated 2-Manifolds", VisMath 2003.
// Sign convention: convex is positive (a sphere with outward normals has H = +1/r).
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

namespace idealize {

struct VertexCurvature {
  Eigen::VectorXd mean;        // "v:mean_curvature" H
  Eigen::VectorXd gaussian;    // "v:gaussian_curvature" K
  Eigen::VectorXd kmax, kmin;  // principal curvatures H ± sqrt(max(H² − K, 0))
  Eigen::VectorXd area;        // "v:mixed_area", the Voronoi region each value integrates over
  MatrixX3d normal;            // "v:normal", angle-weighted unit normals
};

// Angle-weighted unit vertex normals (#V x 3); zero rows for isolated vertices.
MatrixX3d vertex_normals(const TriangleMesh& mesh);

// Curvatures of every vertex. On boundary and non-manifold vertices the discrete operators are
// not defined; those take the area-weighted mean of their interior neighbours instead.
// Reports into `progress` and throws Cancelled when it is cancelled.
VertexCurvature vertex_curvature(const TriangleMesh& mesh, const MeshTopology& topology,
                                 const ProgressSpan& progress = {});

}  // namespace idealize
