// Two-sided distance between a B-rep and the triangle mesh it was built from: the honest part of
// "a valid solid". OpenCASCADE's checker accepts a closed solid whose face took the wrong branch
// of its surface, or whose edges cut a feature off; only the distance to the mesh tells.
//
// The shape's faces are sampled through their triangulation (BRepMesh, chordal deviation
// `deflection`): the nodes lie on the faces, the triangles' centroids within `deflection` of them.
// Faces that are the mesh's own triangles (planar facets) are not meshed: their triangles join the
// shape's triangulation as they are, and lie at distance 0.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"

#include <TopoDS_Face.hxx>

#include <Eigen/Dense>

#include <vector>

namespace idealize {

struct ShapeMeshDistance {
  std::vector<double> face_to_mesh;  // per sampled face: largest distance of its samples from the mesh
  Eigen::VectorXd vertex_to_shape;   // per queried mesh vertex: distance from the shape's faces
};

// `faces`: the faces to sample (not the facets). `mesh`: #V x 3, #F x 3. `facet_triangles`: rows
// of mesh.F that are faces of the shape themselves. `query`: mesh vertices whose distance from
// the shape is wanted. `deflection` > 0. Throws Cancelled through `progress`.
ShapeMeshDistance shape_mesh_distance(const std::vector<TopoDS_Face>& faces, const TriangleMesh& mesh,
                                      const std::vector<int>& facet_triangles, const std::vector<int>& query,
                                      double deflection, const ProgressSpan& progress = {});

// Signed volume enclosed by a closed, consistently oriented triangle mesh (positive when its
// triangles turn counter-clockwise seen from outside).
double enclosed_volume(const TriangleMesh& mesh);

}  // namespace idealize
