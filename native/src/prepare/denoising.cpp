#include "prepare/denoising.h"

#include "core/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace idealize {

namespace {

constexpr double kCoplanar = 1e-9;  // normal difference of faces coplanar up to rounding

struct FaceGeometry {
  MatrixX3d normal, centroid;
  Eigen::VectorXd area;
};

FaceGeometry face_geometry(const MatrixX3d& V, const MatrixX3i& F) {
  FaceGeometry g;
  g.normal.resize(F.rows(), 3);
  g.centroid.resize(F.rows(), 3);
  g.area.resize(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double length = n.norm();
    g.area[f] = 0.5 * length;
    g.normal.row(f) = (length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero()).transpose();
    g.centroid.row(f) = ((a + b + c) / 3.0).transpose();
  }
  return g;
}

// Faces sharing at least one vertex with each face (itself included), compressed.
void face_rings(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& offsets,
                std::vector<int>& ring, const ProgressSpan& progress) {
  const int nf = mesh.num_faces();
  offsets.assign(nf + 1, 0);
  ring.clear();
  ring.reserve(static_cast<size_t>(nf) * 13);
  std::vector<int> stamp(nf, -1);
  for_each_polled(nf, progress, [&](int f) {
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      for (const int* g = topology.vertex_faces_begin(v); g != topology.vertex_faces_end(v); ++g)
        if (stamp[*g] != f) {
          stamp[*g] = f;
          ring.push_back(*g);
        }
    }
    offsets[f + 1] = static_cast<int>(ring.size());
  });
}


// Bilateral filtering of the face normals (Zheng et al., eq. 4).
MatrixX3d filtered_face_normals(const TriangleMesh& mesh, const MeshTopology& topology,
                                const DenoisingOptions& options, const ProgressSpan& progress) {
  const int nf = mesh.num_faces();
  FaceGeometry g = face_geometry(mesh.V, mesh.F);

  // Kernel widths from the data, over all pairs of faces that share a vertex: spatial = their mean
  // centroid distance; range = a multiple of their median normal difference, counting only pairs
  // that are not coplanar: on scans that is the noise, on CAD tessellations the facet folds of
  // curved faces (coplanar pairs inside flat faces say nothing about either).
  // Preparing the kernels costs about as much as one filtering pass: it is polled as well.
  std::vector<int> offsets, ring;
  face_rings(mesh, topology, offsets, ring, progress.sub(0.0, 0.07));
  // `spatial` holds the normal jumps until it holds the spatial weights.
  std::vector<double> normal_jumps, distances(ring.size()), spatial(ring.size());
  std::vector<double>& jumps = spatial;
  const ProgressSpan measuring = progress.sub(0.07, 0.14);
  for_each_polled_on_two_threads(nf, measuring, [&](int f) {
    for (int k = offsets[f]; k < offsets[f + 1]; ++k) {
      distances[k] = (g.centroid.row(f) - g.centroid.row(ring[k])).norm();
      jumps[k] = (g.normal.row(f) - g.normal.row(ring[k])).norm();
    }
  });
  // The sum in one order: the same kernel whatever the threads did.
  const double edge_jump = options.edge_fold > 0.0 ? 2.0 * std::sin(0.5 * options.edge_fold)  // |n1 - n2|
                                                   : std::numeric_limits<double>::infinity();
  double centroid_distance = 0.0;
  normal_jumps.reserve(ring.size());
  for (int f = 0; f < nf; ++f)
    for (int k = offsets[f]; k < offsets[f + 1]; ++k) {
      if (ring[k] == f) continue;
      centroid_distance += distances[k];
      if (jumps[k] > kCoplanar) normal_jumps.push_back(jumps[k]);
    }
  // A flat mesh, or one whose only folds are edges of the part (a box's tessellation): nothing to
  // filter. (A range kernel measured on edges would smooth across them.)
  if (std::none_of(normal_jumps.begin(), normal_jumps.end(), [&](double j) { return j <= edge_jump; }))
    return g.normal;
  centroid_distance /= static_cast<double>(ring.size() - nf);
  auto middle = normal_jumps.begin() + normal_jumps.size() / 2;
  std::nth_element(normal_jumps.begin(), middle, normal_jumps.end());
  const double sigma_range = options.range_factor * *middle;
  if (!(sigma_range > 0.0) || !(centroid_distance > 0.0)) return g.normal;

  progress.step(0.16);
  const ProgressSpan weighting = progress.sub(0.16, 0.2);
  for_each_polled_on_two_threads(static_cast<int>(ring.size()), weighting, [&](int k) {
    spatial[k] = g.area[ring[k]] * std::exp(-distances[k] * distances[k] / (2.0 * centroid_distance * centroid_distance));
  }, 1 << 18);

  MatrixX3d normals = g.normal, next(nf, 3);
  const double range_scale = 1.0 / (2.0 * sigma_range * sigma_range);
  for (int it = 0; it < options.normal_iterations; ++it) {
    // A pass over a million faces takes over a second: poll inside it.
    const ProgressSpan pass = progress.sub(0.2 + 0.8 * it / options.normal_iterations,
                                           0.2 + 0.8 * (it + 1) / options.normal_iterations);
    for_each_polled_on_two_threads(nf, pass, [&](int f) {
      Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
      for (int k = offsets[f]; k < offsets[f + 1]; ++k) {
        const int h = ring[k];
        const double jump = (normals.row(f) - normals.row(h)).squaredNorm();
        sum += spatial[k] * std::exp(-jump * range_scale) * normals.row(h);
      }
      const double length = sum.norm();
      next.row(f) = length > 0.0 ? (sum / length).eval() : normals.row(f);
    });
    normals.swap(next);
  }

  return normals;
}

// Moves each vertex so that its faces agree with the filtered normals (Zheng et al., eq. 7):
//   v += 1/|F(v)| sum_f n_f n_f^T (c_f - v) = 1/|F(v)| (sum_f n_f (n_f . c_f) - M_v v),
// where M_v = sum_f n_f n_f^T does not change between iterations: each pass then needs one number
// per face. Coordinates are taken about the box centre, so that the two sums, which no longer
// subtract positions before multiplying, lose nothing to an offset from the origin. Each vertex
// gathers its faces in the order of its list of faces.
MatrixX3d positions_fitting_normals(const TriangleMesh& mesh, const MeshTopology& topology,
                                    const MatrixX3d& normals, int iterations, const ProgressSpan& progress) {
  const int nv = mesh.num_vertices(), nf = mesh.num_faces();
  const Eigen::RowVector3d centre = 0.5 * (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff());
  MatrixX3d V = mesh.V.rowwise() - centre, next(nv, 3);
  std::vector<Eigen::Matrix3d> projection(nv, Eigen::Matrix3d::Zero());  // M_v
  for_each_polled_on_two_threads(nv, progress.sub(0.0, 0.05), [&](int v) {
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f)
      projection[v].noalias() += normals.row(*f).transpose() * normals.row(*f);
  });
  Eigen::VectorXd offset(nf);  // n_f . c_f
  for (int it = 0; it < iterations; ++it) {
    const ProgressSpan pass = progress.sub(0.05 + 0.95 * it / iterations, 0.05 + 0.95 * (it + 1) / iterations);
    for_each_polled_on_two_threads(nf, pass.sub(0.0, 0.3), [&](int f) {
      offset[f] = normals.row(f).dot(V.row(mesh.F(f, 0)) + V.row(mesh.F(f, 1)) + V.row(mesh.F(f, 2))) / 3.0;
    });
    for_each_polled_on_two_threads(nv, pass.sub(0.3, 1.0), [&](int v) {
      const int count = topology.vertex_face_count(v);
      next.row(v) = V.row(v);
      if (count == 0 || topology.is_boundary_vertex(v)) return;
      Eigen::RowVector3d pull = Eigen::RowVector3d::Zero();
      for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f)
        pull += offset[*f] * normals.row(*f);
      next.row(v) += (pull - V.row(v) * projection[v]) / count;
    });
    V.swap(next);
  }
  return V.rowwise() + centre;
}

}  // namespace

MatrixX3d denoised_positions(const TriangleMesh& mesh, const MeshTopology& topology,
                             const DenoisingOptions& options, const ProgressSpan& progress) {
  const MatrixX3d normals = filtered_face_normals(mesh, topology, options, progress.sub(0.0, 0.6));
  MatrixX3d V = positions_fitting_normals(mesh, topology, normals, options.vertex_iterations, progress.sub(0.6, 1.0));
  progress.step(1.0);
  return V;
}

}  // namespace idealize
