// Two-sided distance between a B-rep and its mesh (deviation.h).
#include "brep/deviation.h"

#include "prepare/remesh_cgal.h"
#include "brep/occt_progress.h"

#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Poly_Triangulation.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS_Compound.hxx>

#include <algorithm>

namespace idealize {

ShapeMeshDistance shape_mesh_distance(const std::vector<TopoDS_Face>& faces, const TriangleMesh& mesh,
                                      const std::vector<int>& facet_triangles, const std::vector<int>& query,
                                      double deflection, const ProgressSpan& progress) {
  ShapeMeshDistance out;
  out.face_to_mesh.assign(faces.size(), 0.0);
  progress.step(0.0);
  BRep_Builder builder;
  TopoDS_Compound sampled;
  builder.MakeCompound(sampled);
  for (const TopoDS_Face& face : faces) builder.Add(sampled, face);
  IMeshTools_Parameters parameters;
  parameters.Deflection = deflection;
  parameters.Angle = 0.5;  // rad, OpenCASCADE's default: the chordal deflection decides on curved faces
  parameters.Relative = Standard_False;
  parameters.InParallel = Standard_True;
  Handle(OcctProgress) indicator = new OcctProgress(progress.sub(0.0, 0.3));
  BRepMesh_IncrementalMesh mesher(sampled, parameters, indicator->Start());
  progress.step(0.3);  // throws Cancelled when the mesher stopped early

  // The shape's triangulation (for the mesh's vertices) and each face's samples (for its distance).
  std::vector<Eigen::Vector3d> nodes;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Eigen::Vector3d> samples;
  std::vector<int> sample_face;
  for (size_t i = 0; i < faces.size(); ++i) {
    TopLoc_Location location;
    const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(faces[i], location);
    if (triangulation.IsNull()) continue;
    const gp_Trsf& to_world = location.Transformation();
    const int first = static_cast<int>(nodes.size());
    for (int n = 1; n <= triangulation->NbNodes(); ++n) {
      const gp_Pnt p = triangulation->Node(n).Transformed(to_world);
      nodes.emplace_back(p.X(), p.Y(), p.Z());
      samples.push_back(nodes.back());
      sample_face.push_back(static_cast<int>(i));
    }
    for (int t = 1; t <= triangulation->NbTriangles(); ++t) {
      int a, b, c;
      triangulation->Triangle(t).Get(a, b, c);
      triangles.emplace_back(first + a - 1, first + b - 1, first + c - 1);
      samples.push_back((nodes[first + a - 1] + nodes[first + b - 1] + nodes[first + c - 1]) / 3.0);
      sample_face.push_back(static_cast<int>(i));
    }
  }
  BRepTools::Clean(sampled);  // (the triangulation stays out of the shape, as in triangulate)
  progress.step(0.4);

  if (!samples.empty()) {
    MatrixX3d points(static_cast<Eigen::Index>(samples.size()), 3);
    for (size_t i = 0; i < samples.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = samples[i].transpose();
    std::vector<double> distances;
    closest_faces(mesh, points, &distances, progress.sub(0.4, 0.7));
    for (size_t i = 0; i < samples.size(); ++i)
      out.face_to_mesh[sample_face[i]] = std::max(out.face_to_mesh[sample_face[i]], distances[i]);
  }

  out.vertex_to_shape = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(query.size()));
  if (query.empty()) return out;
  TriangleMesh shape_mesh;
  shape_mesh.V = mesh.V;  // the facets' triangles keep their own rows
  const Eigen::Index offset = shape_mesh.V.rows();
  shape_mesh.V.conservativeResize(offset + static_cast<Eigen::Index>(nodes.size()), 3);
  for (size_t i = 0; i < nodes.size(); ++i) shape_mesh.V.row(offset + static_cast<Eigen::Index>(i)) = nodes[i].transpose();
  shape_mesh.F.resize(static_cast<Eigen::Index>(triangles.size() + facet_triangles.size()), 3);
  Eigen::Index row = 0;
  for (const Eigen::Vector3i& t : triangles) shape_mesh.F.row(row++) = (t.array() + static_cast<int>(offset)).transpose();
  for (int f : facet_triangles) shape_mesh.F.row(row++) = mesh.F.row(f);
  if (row == 0) return out;
  MatrixX3d points(static_cast<Eigen::Index>(query.size()), 3);
  for (size_t i = 0; i < query.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = mesh.V.row(query[i]);
  std::vector<double> distances;
  closest_faces(shape_mesh, points, &distances, progress.sub(0.7, 1.0));
  for (size_t i = 0; i < query.size(); ++i) out.vertex_to_shape[static_cast<Eigen::Index>(i)] = distances[i];
  return out;
}

double enclosed_volume(const TriangleMesh& mesh) {
  double six_volume = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

}  // namespace idealize
