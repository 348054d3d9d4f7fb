#include "curvature/curvature.h"

#include <cmath>

namespace idealize {

namespace {

constexpr double kPi = 3.14159265358979323846;

double cotangent(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  const double sine = u.cross(v).norm();
  // A zero-area corner has no defined cotangent; prepare_mesh removed those, refinement creates none.
  return sine > 0.0 ? u.dot(v) / sine : 0.0;
}

double angle_between(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

MatrixX3d vertex_normals(const TriangleMesh& mesh) {
  MatrixX3d normals = MatrixX3d::Zero(mesh.num_vertices(), 3);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d p[3] = {mesh.V.row(mesh.F(f, 0)), mesh.V.row(mesh.F(f, 1)),
                                  mesh.V.row(mesh.F(f, 2))};
    const Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double length = n.norm();
    if (length == 0.0) continue;
    for (int c = 0; c < 3; ++c) {
      const double angle = angle_between(p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]);
      normals.row(mesh.F(f, c)) += (angle / length) * n.transpose();
    }
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    const double length = normals.row(v).norm();
    if (length > 0.0) normals.row(v) /= length;
  }
  return normals;
}

VertexCurvature vertex_curvature(const TriangleMesh& mesh, const MeshTopology& topology,
                                 const ProgressSpan& progress) {
  const int nv = mesh.num_vertices();
  VertexCurvature out;
  out.normal = vertex_normals(mesh);
  progress.step(0.3);
  out.area = Eigen::VectorXd::Zero(nv);
  MatrixX3d laplace = MatrixX3d::Zero(nv, 3);  // Σ (cot α + cot β)(x_i − x_j), per vertex
  Eigen::VectorXd angle_sum = Eigen::VectorXd::Zero(nv);

  for_each_polled(mesh.num_faces(), progress.sub(0.3, 0.9), [&](int f) {
    const int idx[3] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
    const Eigen::Vector3d p[3] = {mesh.V.row(idx[0]), mesh.V.row(idx[1]), mesh.V.row(idx[2])};
    const double area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    double cot[3], angle[3];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d u = p[(c + 1) % 3] - p[c], v = p[(c + 2) % 3] - p[c];
      cot[c] = cotangent(u, v);
      angle[c] = angle_between(u, v);
      angle_sum[idx[c]] += angle[c];
    }
    const bool obtuse = angle[0] > kPi / 2 || angle[1] > kPi / 2 || angle[2] > kPi / 2;
    for (int c = 0; c < 3; ++c) {
      const int i = idx[c];
      const Eigen::Vector3d eij = p[c] - p[(c + 1) % 3], eik = p[c] - p[(c + 2) % 3];
      // Edge ij is opposite corner k, edge ik opposite corner j.
      laplace.row(i) += (cot[(c + 2) % 3] * eij + cot[(c + 1) % 3] * eik).transpose();
      if (!obtuse) {
        out.area[i] += (eij.squaredNorm() * cot[(c + 2) % 3] + eik.squaredNorm() * cot[(c + 1) % 3]) / 8.0;
      } else {
        out.area[i] += angle[c] > kPi / 2 ? area / 2.0 : area / 4.0;
      }
    }
  });

  out.mean.resize(nv);
  out.gaussian.resize(nv);
  std::vector<char> defined(nv, 0);
  for (int v = 0; v < nv; ++v) {
    defined[v] = !topology.is_boundary_vertex(v) && out.area[v] > 0.0 && topology.vertex_face_count(v) > 0;
    if (!defined[v]) {
      out.mean[v] = out.gaussian[v] = 0.0;
      continue;
    }
    // Mean-curvature normal K = Δx = 2 H n; its component along the outward normal gives signed H.
    out.mean[v] = 0.25 * laplace.row(v).dot(out.normal.row(v)) / out.area[v];
    out.gaussian[v] = (2.0 * kPi - angle_sum[v]) / out.area[v];
  }
  // Boundary vertices borrow from their defined neighbours, repeatedly inward-out.
  progress.step(0.9);
  bool changed = true;
  while (changed) {
    progress.check();
    changed = false;
    for (int v = 0; v < nv; ++v) {
      if (defined[v]) continue;
      double weight = 0.0, h = 0.0, k = 0.0;
      for (const int* n = topology.vertex_neighbors_begin(v); n != topology.vertex_neighbors_end(v); ++n)
        if (defined[*n] == 1) {
          const double w = out.area[*n] > 0.0 ? out.area[*n] : 1.0;
          weight += w;
          h += w * out.mean[*n];
          k += w * out.gaussian[*n];
        }
      if (weight > 0.0) {
        out.mean[v] = h / weight;
        out.gaussian[v] = k / weight;
        defined[v] = 2;  // filled this round; becomes a source next round
        changed = true;
      }
    }
    for (char& d : defined)
      if (d == 2) d = 1;
  }

  out.kmax.resize(nv);
  out.kmin.resize(nv);
  for (int v = 0; v < nv; ++v) {
    const double spread = std::sqrt(std::max(out.mean[v] * out.mean[v] - out.gaussian[v], 0.0));
    out.kmax[v] = out.mean[v] + spread;
    out.kmin[v] = out.mean[v] - spread;
  }
  progress.step(1.0);
  return out;
}

}  // namespace idealize
