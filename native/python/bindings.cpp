// The only place where C++ meets Python. Arrays cross as numpy: V float64 (#V, 3), F int32 (#F, 3),
// row-major. Long computations release the GIL; C++ exceptions become Python exceptions.
#include "curvature.h"
#include "mesh.h"
#include "mesh_io.h"
#include "remesh_cgal.h"
#include "segmentation.h"

#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace py = pybind11;
using namespace idealize;

namespace {

using VectorXi32 = Eigen::Matrix<int, Eigen::Dynamic, 1>;

TriangleMesh make_mesh(const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F) {
  TriangleMesh mesh;
  mesh.V = V;
  mesh.F = F;
  return mesh;
}

VectorXi32 to_array(const std::vector<int>& values) {
  return Eigen::Map<const VectorXi32>(values.data(), static_cast<Eigen::Index>(values.size()));
}

const char* kind_name(PatchKind kind) {
  switch (kind) {
    case PatchKind::SharpConcave: return "sharp_concave";
    case PatchKind::SharpConvex: return "sharp_convex";
    case PatchKind::Smooth: return "smooth";
  }
  return "smooth";
}

py::dict histogram_dict(const HistogramRanges& ranges) {
  py::dict d;
  d["low"] = ranges.histogram.low;
  d["high"] = ranges.histogram.high;
  d["counts"] = ranges.histogram.counts;
  d["smoothed"] = ranges.histogram.smoothed;
  d["peak_bins"] = ranges.peak_bins;
  d["valley_bins"] = ranges.valley_bins;
  d["valleys"] = ranges.valleys;
  return d;
}

py::dict segmentation_dict(Segmentation&& s) {
  py::dict d;
  d["labels"] = to_array(s.labels);
  d["transition"] = Eigen::Map<const Eigen::Matrix<char, Eigen::Dynamic, 1>>(s.transition.data(), static_cast<Eigen::Index>(s.transition.size())).cast<bool>().eval();
  py::list patches;
  for (const PatchSummary& p : s.patches) {
    py::dict patch;
    patch["id"] = p.id;
    patch["kind"] = kind_name(p.kind);
    patch["triangles"] = p.input_triangles;
    patch["area"] = p.area;
    patch["mean_curvature"] = p.mean_curvature;
    patch["curvature_range"] = py::make_tuple(p.range_low, p.range_high);
    patches.append(patch);
  }
  d["patches"] = patches;
  py::list timings;
  for (const auto& [stage, seconds] : s.timings) timings.append(py::make_tuple(stage, seconds));
  d["timings"] = timings;
  d["removed_degenerate"] = s.removed_degenerate;
  d["removed_duplicate"] = s.removed_duplicate;
  d["working_vertices"] = std::move(s.working.mesh.V);
  d["working_faces"] = std::move(s.working.mesh.F);
  d["working_face_origin"] = to_array(s.working.face_origin);
  d["working_labels"] = to_array(s.working_labels);
  d["working_target_edge_length"] = s.working.target_edge_length;
  d["mean_curvature"] = std::move(s.mean_curvature);
  d["smoothed_mean_curvature"] = std::move(s.smoothed_mean);
  d["histogram"] = histogram_dict(s.histogram);
  d["shells"] = s.shells;
  d["boundary_edges"] = s.boundary_edges;
  d["nonmanifold_edges"] = s.nonmanifold_edges;
  return d;
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "Idealize native core: mesh reading, curvature, feature segmentation.";
  py::register_exception<MeshError>(m, "MeshError", PyExc_ValueError);

  m.def(
      "read_mesh",
      [](const std::string& path) {
        MeshReadInfo info;
        TriangleMesh mesh;
        {
          py::gil_scoped_release release;
          mesh = read_mesh(path, &info);
        }
        py::dict d;
        d["format"] = info.format;
        d["file_triangles"] = info.file_triangles;
        d["file_vertices"] = info.file_vertices;
        return py::make_tuple(std::move(mesh.V), std::move(mesh.F), d);
      },
      py::arg("path"), "Read STL/OBJ/OFF/PLY; returns (V, F, info).");

  m.def(
      "segment",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F) {
        const TriangleMesh mesh = make_mesh(V, F);
        Segmentation s;
        {
          py::gil_scoped_release release;
          s = segment_mesh(mesh);
        }
        return segmentation_dict(std::move(s));
      },
      py::arg("V"), py::arg("F"), "Two-pass mean-curvature-histogram segmentation.");

  m.def(
      "vertex_curvature",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F) {
        const TriangleMesh mesh = make_mesh(V, F);
        VertexCurvature c;
        {
          py::gil_scoped_release release;
          const MeshTopology topology(mesh);
          c = vertex_curvature(mesh, topology);
        }
        py::dict d;
        d["mean"] = std::move(c.mean);
        d["gaussian"] = std::move(c.gaussian);
        d["kmax"] = std::move(c.kmax);
        d["kmin"] = std::move(c.kmin);
        d["area"] = std::move(c.area);
        d["normal"] = std::move(c.normal);
        return d;
      },
      py::arg("V"), py::arg("F"), "Per-vertex curvature (Meyer et al. 2003).");

  m.def(
      "remesh_isotropic",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F, double target_edge_length,
         int iterations) {
        const TriangleMesh mesh = make_mesh(V, F);
        TriangleMesh out;
        {
          py::gil_scoped_release release;
          out = remesh_isotropic(mesh, target_edge_length, iterations);
        }
        return py::make_tuple(std::move(out.V), std::move(out.F));
      },
      py::arg("V"), py::arg("F"), py::arg("target_edge_length"), py::arg("iterations"),
      "Isotropic remeshing without feature protection (CGAL).");

  m.def(
      "closest_faces",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F,
         const Eigen::Ref<const MatrixX3d>& points) {
        const TriangleMesh mesh = make_mesh(V, F);
        const MatrixX3d query = points;
        std::vector<int> faces;
        {
          py::gil_scoped_release release;
          faces = closest_faces(mesh, query);
        }
        return to_array(faces);
      },
      py::arg("V"), py::arg("F"), py::arg("points"), "Index of the closest face for each point.");
}
