// Bindings of sculpting (native/src/sculpt): a Sculptor holds a mesh between strokes, so that the
// half-edge structure is built once per sculpting session, not once per stroke.
#include "conversions.h"
#include "sculpt/brushes.h"
#include "sculpt/sculpt_mesh.h"
#include "fit/surface.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <memory>
#include <vector>

namespace idealize {

namespace py = pybind11;

namespace {


StrokeOptions stroke_options(double radius, double strength, double spacing, double target_edge_length,
                             bool dynamic_topology) {
  StrokeOptions options;
  options.radius = radius;
  options.strength = strength;
  options.spacing = spacing;
  options.target_edge_length = target_edge_length;
  options.dynamic_topology = dynamic_topology;
  return options;
}

py::dict report_dict(const StrokeReport& report) {
  py::dict out;
  out["dabs"] = report.dabs;
  out["moved_vertices"] = report.moved_vertices;
  out["target_edge_length"] = report.target_edge_length;
  return out;
}

}  // namespace

void bind_sculpt(py::module_& m) {
  py::class_<SculptMesh>(m, "Sculptor",
                         "A mesh being sculpted: strokes of brushes with dynamic topology (native/src/sculpt).")
      .def(py::init([](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                       const std::vector<int>& labels) {
             return std::make_unique<SculptMesh>(mesh_from(V, F), labels);
           }),
           py::arg("V"), py::arg("F"), py::arg("labels") = std::vector<int>(),
           "From V (#V x 3), F (#F x 3, a consistently oriented manifold) and per-face labels (or none). Raises "
           "MeshError naming the problem otherwise.")
      .def(
          "stroke",
          [](SculptMesh& mesh, const std::string& brush, const Eigen::Ref<const RowMatrixX3d>& points,
             const Eigen::Ref<const RowMatrixX3d>& directions, double radius, double strength, double spacing,
             double target_edge_length, bool dynamic_topology) {
            const StrokeOptions options =
                stroke_options(radius, strength, spacing, target_edge_length, dynamic_topology);
            const Brush b = brush_named(brush);
            const MatrixX3d p = points, d = directions;
            StrokeReport report;
            {
              py::gil_scoped_release release;
              report = sculpt_stroke(mesh, b, p, d, options);
            }
            return report_dict(report);
          },
          py::arg("brush"), py::arg("points"), py::arg("directions"), py::kw_only(), py::arg("radius"),
          py::arg("strength") = 0.5, py::arg("spacing") = 0.2, py::arg("target_edge_length") = 0.0,
          py::arg("dynamic_topology") = true,
          "Applies a brush (draw, inflate, flatten, smooth, pinch, crease, grab) along a stroke: points (#S x 3), "
          "view directions (#S x 3, or 0 rows). Returns dict(dabs, moved_vertices, target_edge_length).")
      .def(
          "mesh",
          [](const SculptMesh& mesh) {
            std::vector<int> labels;
            std::vector<char> modified;
            const TriangleMesh out = mesh.compacted(labels, modified);
            py::dict d;
            d["V"] = RowMatrixX3d(out.V);
            d["F"] = RowMatrixX3i(out.F);
            d["labels"] = Eigen::VectorXi(Eigen::Map<const Eigen::VectorXi>(labels.data(), static_cast<Eigen::Index>(labels.size())));
            Eigen::Matrix<bool, Eigen::Dynamic, 1> changed(static_cast<Eigen::Index>(modified.size()));
            for (size_t f = 0; f < modified.size(); ++f) changed[static_cast<Eigen::Index>(f)] = modified[f] != 0;
            d["modified"] = changed;
            return d;
          },
          "The mesh now: dict(V, F, labels (per face, carried from the face it came from), modified (per face: "
          "changed since the marks were last cleared)).")
      .def(
          "first_hit",
          [](const SculptMesh& mesh, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) -> py::object {
            if (!(direction.norm() > 0.0)) throw std::invalid_argument("a ray needs a direction");
            Eigen::Vector3d hit;
            bool found;
            {
              py::gil_scoped_release release;
              found = first_hit(mesh, origin, direction, hit);
            }
            return found ? py::cast(hit) : py::none();
          },
          py::arg("origin"), py::arg("direction"),
          "Where the ray from origin along direction first meets the mesh (a 3-vector), or None.")
      .def("clear_marks", &SculptMesh::clear_marks, "Forgets which faces were modified.")
      .def_property_readonly("faces", &SculptMesh::num_faces);

  py::class_<Stroke>(m, "Stroke",
                     "A stroke under way on a Sculptor, dab by dab as its points come (brushes.h: the same dabs "
                     "as one stroke of all the points).")
      .def(py::init([](SculptMesh& mesh, const std::string& brush, const Eigen::Vector3d& point,
                       const Eigen::Vector3d& direction, double radius, double strength, double spacing,
                       double target_edge_length, bool dynamic_topology) {
             const StrokeOptions options =
                 stroke_options(radius, strength, spacing, target_edge_length, dynamic_topology);
             const Brush b = brush_named(brush);
             py::gil_scoped_release release;
             return std::make_unique<Stroke>(mesh, b, point, direction, options);
           }),
           py::arg("sculptor"), py::arg("brush"), py::arg("point"), py::arg("direction"), py::kw_only(),
           py::arg("radius"), py::arg("strength") = 0.5, py::arg("spacing") = 0.2, py::arg("target_edge_length") = 0.0,
           py::arg("dynamic_topology") = true, py::keep_alive<1, 2>(),
           "Starts a stroke on `sculptor` at `point` seen along `direction` (zero: from every side), with its "
           "first dab.")
      .def(
          "extend",
          [](Stroke& stroke, const Eigen::Ref<const RowMatrixX3d>& points, const Eigen::Ref<const RowMatrixX3d>& directions) {
            if (directions.rows() != 0 && directions.rows() != points.rows())
              throw std::invalid_argument("one view direction per stroke point, or none");
            const MatrixX3d p = points, d = directions;
            py::gil_scoped_release release;
            for (Eigen::Index i = 0; i < p.rows(); ++i)
              stroke.extend(p.row(i).transpose(), d.rows() ? Eigen::Vector3d(d.row(i).transpose()) : Eigen::Vector3d::Zero());
          },
          py::arg("points"), py::arg("directions"), "Continues the stroke through points (#S x 3), seen along directions (#S x 3, or 0 rows).")
      .def(
          "finish",
          [](Stroke& stroke) {
            StrokeReport report;
            {
              py::gil_scoped_release release;
              report = stroke.finish();
            }
            return report_dict(report);
          },
          "Ends the stroke. Returns dict(dabs, moved_vertices, target_edge_length).");

  m.def(
      "onto_surface",
      [](const std::string& type, const py::dict& params, const Eigen::Ref<const RowMatrixX3d>& points) {
        const Surface surface = surface_from_params(type, params);
        RowMatrixX3d closest(points.rows(), 3);
        Eigen::VectorXd distance(points.rows());
        for (Eigen::Index i = 0; i < points.rows(); ++i) {
          const Eigen::Vector3d p = points.row(i).transpose();
          closest.row(i) = closest_point(surface, p).transpose();
          distance(i) = std::abs(signed_distance(surface, p));
        }
        return py::make_tuple(closest, distance);
      },
      py::arg("type"), py::arg("params"), py::arg("points"),
      "(the nearest points on the surface of a feature's type and params to `points` (#P x 3), their distances).");
}

}  // namespace idealize
