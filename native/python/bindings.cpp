// The only place where C++ meets Python. Arrays cross as numpy: V float64 (#V, 3), F int32 (#F, 3),
// row-major. Long computations release the GIL (inputs are converted to C++ before, results to
// Python after); C++ exceptions become Python exceptions. They take an optional Progress that
// another Python thread reads and may cancel while they run.
#include "brep/brep.h"
#include "export/export.h"
#include "fit/bspline_fitting.h"
#include "curvature/curvature.h"
#include "features/feature_layer.h"
#include "features/feature_tables.h"
#include "core/mesh.h"
#include "io/mesh_io.h"
#include "core/progress.h"
#include "prepare/remesh_cgal.h"
#include "segment/segmentation.h"
#include "conversions.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <mutex>
#include <set>

namespace py = pybind11;
using namespace idealize;

namespace {

using VectorXi32 = Eigen::Matrix<int, Eigen::Dynamic, 1>;

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

py::dict mesh_check_dict(const MeshCheck& c) {
  py::dict d;
  d["shells"] = c.shells;
  d["boundary_edges"] = c.boundary_edges;
  d["nonmanifold_edges"] = c.nonmanifold_edges;
  d["nonmanifold_vertices"] = c.nonmanifold_vertices;
  d["boundary_loops"] = c.boundary_loops;
  d["largest_hole_edges"] = c.largest_hole_edges;
  d["inconsistent_edges"] = c.inconsistent_edges;
  d["flipped_faces_repaired"] = c.flipped_faces_repaired;
  d["closed_shells_turned_outward"] = c.closed_shells_turned_outward;
  d["nonorientable_shells"] = c.nonorientable_shells;
  d["self_intersecting_pairs"] = c.self_intersecting_pairs;
  d["self_intersections_capped"] = c.self_intersections_capped;
  d["degenerate_removed"] = c.degenerate_removed;
  d["duplicate_removed"] = c.duplicate_removed;
  d["unused_vertices_removed"] = c.unused_vertices_removed;
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
    patch["mean_gaussian"] = p.mean_gaussian;
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
  d["zero_mean_curvature"] = py::make_tuple(s.zero_low, s.zero_high);
  d["mesh_check"] = mesh_check_dict(s.mesh_check);
  if (s.input_flipped.empty()) d["input_flipped"] = py::none();
  else d["input_flipped"] = Eigen::Map<const Eigen::Matrix<char, Eigen::Dynamic, 1>>(s.input_flipped.data(), static_cast<Eigen::Index>(s.input_flipped.size())).cast<bool>().eval();
  return d;
}

py::dict feature_layer_dict(FeatureLayer&& layer) {
  py::list features;
  for (const Feature& f : layer.features) {
    py::dict d;
    d["id"] = f.id;
    d["type"] = surface_type_name(f.type);
    d["curvature_type"] = surface_type_name(f.curvature_type);
    d["curvature"] = py::dict(py::arg("mean") = f.curvature.mean, py::arg("gaussian") = f.curvature.gaussian);
    d["params"] = surface_params(f.type == SurfaceType::Freeform ? Surface{} : f.surface);
    d["best_fit"] = py::make_tuple(surface_type_name(f.surface.type), surface_params(f.surface));
    d["rms"] = f.rms;
    d["max_error"] = f.max_error;
    d["normal_rms"] = f.normal_rms;
    d["spread"] = f.spread;
    d["normal_spread"] = f.normal_spread;
    d["radius_error"] = f.radius_error;
    d["area"] = f.area;
    d["triangles"] = f.triangles;
    d["fit_vertices"] = f.vertices;
    features.append(d);
  }
  py::list adjacency;
  for (const FeatureAdjacency& a : layer.adjacency) {
    py::dict d;
    d["a"] = a.a;
    d["b"] = a.b;
    d["continuity"] = a.continuity == Continuity::G1 ? "G1" : "G0";
    d["angle"] = a.angle;
    d["length"] = a.length;
    adjacency.append(d);
  }
  py::list relations;
  for (const FeatureRelation& r : layer.relations) {
    py::dict d;
    d["kind"] = r.kind;
    d["features"] = r.features;
    relations.append(d);
  }
  py::list timings;
  for (const auto& [stage, seconds] : layer.timings) timings.append(py::make_tuple(stage, seconds));
  py::dict d;
  d["labels"] = to_array(layer.labels);
  d["features"] = features;
  d["adjacency"] = adjacency;
  d["relations"] = relations;
  d["idealized_vertices"] = std::move(layer.idealized_vertices);
  d["vertex_deviation"] = std::move(layer.vertex_deviation);
  d["max_deviation"] = layer.max_deviation;
  d["rms_deviation"] = layer.rms_deviation;
  d["distance_tolerance"] = layer.distance_tolerance;
  d["form_deviation"] = layer.form_deviation;
  d["angle_tolerance_degrees"] = layer.angle_tolerance_degrees;
  d["mesh_kind"] = layer.mesh_kind == MeshKind::ExactTessellation ? "exact tessellation" : "measured surface";
  d["noise"] = layer.noise;
  d["normal_noise"] = layer.normal_noise;
  d["timings"] = timings;
  return d;
}

// Progress keeps stage names as pointers to strings that live as long as the program: names
// reported from Python are kept in a set (a handful of distinct names).
const char* interned(const std::string& name) {
  static std::mutex mutex;
  static std::set<std::string> names;
  const std::lock_guard<std::mutex> lock(mutex);
  return names.insert(name).first->c_str();
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "Idealize native core: mesh reading, curvature, feature segmentation.";
  py::register_exception<MeshError>(m, "MeshError", PyExc_ValueError);
  py::register_exception<Cancelled>(m, "Cancelled", PyExc_RuntimeError);
  bind_edit(m);
  bind_sculpt(m);

  // Shared between the thread that runs a computation and the one that shows it: every member is
  // atomic, so none of these needs the GIL held by the computing thread.
  py::class_<Progress>(m, "Progress",
                       "Progress of a long computation, readable and cancellable from another thread.")
      .def(py::init<>())
      .def("cancel", &Progress::cancel, "Ask the computation to stop; it raises Cancelled soon after.")
      .def_property_readonly("cancelled", &Progress::cancelled)
      .def_property_readonly("fraction", &Progress::fraction, "Overall fraction done, 0..1 (never decreases).")
      .def_property_readonly("stage", &Progress::stage, "Name of the step running now.")
      .def_property_readonly("range", [](const Progress& p) { return py::make_tuple(p.range_start(), p.range_end()); },
                             "(start, end): the part of the overall fraction the next call fills.")
      .def("set_range", &Progress::set_range, py::arg("start"), py::arg("end"), py::arg("restart") = true,
           "Let the next call fill [start, end] of the overall fraction; restart: set the fraction to start.")
      .def(
          "report",
          [](Progress& p, const std::string& stage, double fraction) { p.report(interned(stage), fraction); },
          py::arg("stage"), py::arg("fraction"),
          "Report `fraction` (0..1) of the current range done, in step `stage` (for Python-side steps).")
      .def("__repr__", [](const Progress& p) {
        return "<idealize.Progress " + std::to_string(p.fraction()) + " '" + p.stage() + "'" +
               (p.cancelled() ? " cancelled>" : ">");
      });

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
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F, Progress* progress,
         bool self_intersections, double part_share) {
        const TriangleMesh mesh = mesh_from(V, F);
        if (!(part_share > 0.0 && part_share <= 1.0))
          throw std::invalid_argument("part_share is the mesh's share of the part's surface, in (0, 1]");
        SegmentationOptions options;
        options.progress = progress;
        options.refinement.part_share = part_share;
        if (self_intersections) options.check.self_intersections = count_self_intersections;
        Segmentation s;
        {
          py::gil_scoped_release release;
          s = segment_mesh(mesh, options);
        }
        return segmentation_dict(std::move(s));
      },
      py::arg("V"), py::arg("F"), py::kw_only(), py::arg("progress") = nullptr, py::arg("self_intersections") = false,
      py::arg("part_share") = 1.0,
      "Two-pass mean-curvature-histogram segmentation; with self_intersections, the mesh check counts "
      "intersecting triangle pairs (CGAL; about 1.2 us per triangle); part_share: the mesh's share of "
      "the whole part's surface (RefinementOptions::part_share).");

  m.def(
      "identify_features",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F, std::vector<int> labels,
         const std::vector<double>& patch_mean, const std::vector<double>& patch_gaussian, double zero_low,
         double zero_high, Progress* progress, double angle_tolerance_degrees, double distance_tolerance,
         double radius_tolerance, bool idealize, bool measured) {
        const TriangleMesh mesh = mesh_from(V, F);
        if (patch_mean.size() != patch_gaussian.size())
          throw MeshError("one mean and one Gaussian curvature per patch are needed");
        std::vector<PatchCurvature> curvature(patch_mean.size());
        for (size_t p = 0; p < curvature.size(); ++p) curvature[p] = {patch_mean[p], patch_gaussian[p]};
        FeatureOptions options;
        options.progress = progress;
        options.angle_tolerance_degrees = angle_tolerance_degrees;
        options.distance_tolerance = distance_tolerance;
        options.radius_tolerance = radius_tolerance;
        options.idealize = idealize;
        options.measured = measured;
        FeatureLayer layer;
        {
          py::gil_scoped_release release;
          layer = identify_features(mesh, labels, curvature, EffectiveZero{zero_low, zero_high}, options);
        }
        return feature_layer_dict(std::move(layer));
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("patch_mean"), py::arg("patch_gaussian"),
      py::arg("zero_low"), py::arg("zero_high"), py::kw_only(), py::arg("progress") = nullptr,
      py::arg("angle_tolerance_degrees") = FeatureOptions{}.angle_tolerance_degrees,
      py::arg("distance_tolerance") = FeatureOptions{}.distance_tolerance,
      py::arg("radius_tolerance") = FeatureOptions{}.radius_tolerance, py::arg("idealize") = FeatureOptions{}.idealize,
      py::arg("measured") = FeatureOptions{}.measured,
      "Feature identification, graph and projection (thesis ch. 4); options as FeatureOptions "
      "(distance_tolerance 0: 0.1 % of the bounding-box diagonal).");

  m.def(
      "feature_tables",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F,
         const Eigen::Ref<const VectorXi32>& labels, int num_features) {
        const TriangleMesh mesh = mesh_from(V, F);
        const std::vector<int> face_labels(labels.data(), labels.data() + labels.size());
        FeatureTables t;
        {
          py::gil_scoped_release release;
          t = feature_tables(mesh, face_labels, num_features);
        }
        using Pairs = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;
        Pairs vertex_features(t.vertex_features.size(), 2), adjacent(t.adjacent.size(), 2);
        for (size_t k = 0; k < t.vertex_features.size(); ++k)
          vertex_features.row(k) << t.vertex_features[k][0], t.vertex_features[k][1];
        for (size_t k = 0; k < t.adjacent.size(); ++k) adjacent.row(k) << t.adjacent[k].first, t.adjacent[k].second;
        py::dict d;
        d["vertex_features"] = vertex_features;
        d["adjacent"] = adjacent;
        d["area"] = Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(t.area.data(), static_cast<Eigen::Index>(t.area.size())));
        d["triangles"] = to_array(t.triangles);
        return d;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("num_features"),
      "The tables of a labelled mesh (labels int32 #F, -1 for none): vertex_features (M, 2) the "
      "distinct (vertex, feature) pairs by feature then vertex, adjacent (K, 2) the features sharing "
      "an edge (a < b, sorted), area and triangles per feature.");

  m.def(
      "surface_colors",
      [] {
        py::dict d;
        for (SurfaceType t : {SurfaceType::Plane, SurfaceType::Cylinder, SurfaceType::Cone, SurfaceType::Sphere,
                              SurfaceType::Torus, SurfaceType::Freeform}) {
          const std::array<double, 3> c = surface_color(t);
          d[surface_type_name(t)] = py::make_tuple(c[0], c[1], c[2]);
        }
        return d;
      },
      "The colour of each surface type (red, green, blue in 0..1): the thesis's feature colours, grey "
      "for freeform. The one table of the STEP export and the workbench.");

  m.def(
      "feature_defaults",
      [] {
        const FeatureOptions o;
        py::dict d;
        d["angle_tolerance_degrees"] = o.angle_tolerance_degrees;
        d["distance_tolerance"] = o.distance_tolerance;
        d["radius_tolerance"] = o.radius_tolerance;
        d["idealize"] = o.idealize;
        return d;
      },
      "The defaults of the options a user sets (FeatureOptions, where each says where its value comes "
      "from): the one source of the Python API's, the document object's and the task panel's.");

  py::class_<BrepResult>(m, "Brep", "A fitted B-rep: solid, or the shell of the faces that could be made.")
      .def_readonly("valid", &BrepResult::valid)
      .def_readonly("closed", &BrepResult::closed)
      .def_readonly("solid", &BrepResult::solid)
      .def_readonly("faces", &BrepResult::faces)
      .def_readonly("volume", &BrepResult::volume)
      .def_readonly("max_tolerance", &BrepResult::max_tolerance)
      .def_readonly("surface_types", &BrepResult::surface_types)
      .def_readonly("face_features", &BrepResult::face_features)
      .def_readonly("analytic_area_fraction", &BrepResult::analytic_area_fraction)
      .def_readonly("mesh_to_shape", &BrepResult::mesh_to_shape)
      .def_readonly("shape_to_mesh", &BrepResult::shape_to_mesh)
      .def_readonly("deviation_bound", &BrepResult::deviation_bound)
      .def_readonly("mesh_volume", &BrepResult::mesh_volume)
      .def_readonly("euler_shape", &BrepResult::euler_shape)
      .def_readonly("euler_mesh", &BrepResult::euler_mesh)
      .def_readonly("timings", &BrepResult::timings)
      .def_property_readonly("regions", [](const BrepResult& r) {
        py::list regions;
        for (const BrepRegionFace& face : r.regions) {
          py::dict d;
          d["feature"] = face.feature; d["kind"] = face.kind; d["reason"] = face.reason; d["area"] = face.area;
          regions.append(d);
        }
        return regions;
      })
      .def_property_readonly("edges", [](const BrepResult& r) {
        py::list edges;
        for (const BrepEdge& e : r.edges) {
          py::dict d;
          d["a"] = e.a; d["b"] = e.b; d["mesh_vertices"] = e.mesh_vertices; d["closed"] = e.closed; d["curve"] = e.curve;
          edges.append(d);
        }
        return edges;
      })
      .def_property_readonly("joined", [](const BrepResult& r) {
        py::list joined;
        for (const auto& [feature, into] : r.joined) joined.append(py::make_tuple(feature, into));
        return joined;
      })
      .def_property_readonly("problems", [](const BrepResult& r) {
        py::list problems;
        for (const BrepProblem& p : r.problems) problems.append(py::make_tuple(p.feature, p.message));
        return problems;
      })
      .def("brep_string", [](const BrepResult& r) { return py::bytes(brep_string(r.shape)); },
           "The shape in OCCT BRep text format (Part.Shape().importBrepFromString).")
      .def(
          "write_step",
          [](const BrepResult& r, const std::string& path) {
            py::gil_scoped_release release;
            write_step(r.shape, path);
          },
          py::arg("path"), "Write STEP AP214 in millimetres, faces coloured by surface type.")
      .def(
          "triangulate",
          [](const BrepResult& r, double deflection, Progress* progress) {
            if (!(deflection > 0)) throw std::invalid_argument("deflection must be positive");
            TriangleMesh mesh;
            {
              py::gil_scoped_release release;
              mesh = triangulate(r.shape, deflection, ProgressSpan(progress, "triangulation"));
            }
            return py::make_tuple(std::move(mesh.V), std::move(mesh.F));
          },
          py::arg("deflection"), py::kw_only(), py::arg("progress") = nullptr,
          "Triangulation (V, F) with chordal deviation at most `deflection`.");

  m.def(
      "build_brep",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F, std::vector<int> labels,
         const std::vector<std::string>& types, const std::vector<py::dict>& params, double tolerance,
         Progress* progress, std::optional<std::string> mesh_kind, std::optional<double> angle_tolerance) {
        if (types.size() != params.size()) throw std::invalid_argument("one type and one parameter set per feature");
        std::vector<Surface> surfaces;
        for (size_t i = 0; i < types.size(); ++i) surfaces.push_back(surface_from_params(types[i], params[i]));
        const TriangleMesh mesh = mesh_from(V, F);
        BrepOptions options;
        options.tolerance = tolerance;
        options.progress = progress;
        if (mesh_kind) {
          if (*mesh_kind == "exact tessellation") options.mesh_kind = MeshKind::ExactTessellation;
          else if (*mesh_kind == "measured surface") options.mesh_kind = MeshKind::MeasuredSurface;
          else throw std::invalid_argument("mesh_kind is \"exact tessellation\" or \"measured surface\", not \"" + *mesh_kind + "\"");
        }
        if (angle_tolerance) {
          if (!(*angle_tolerance > 0.0 && *angle_tolerance < 90.0))
            throw std::invalid_argument("the angle tolerance must lie between 0 and 90 degrees");
          options.angle_tolerance_degrees = *angle_tolerance;
        }
        BrepResult result;
        {
          py::gil_scoped_release release;
          result = build_brep(mesh, labels, surfaces, options);
        }
        return result;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"), py::arg("params"), py::arg("tolerance") = 0.0,
      py::kw_only(), py::arg("progress") = nullptr, py::arg("mesh_kind") = py::none(),
      py::arg("angle_tolerance") = py::none(),
      "Fitted B-rep of a labelled mesh whose features lie on the given surfaces. mesh_kind: the feature "
      "layer's (\"exact tessellation\" or \"measured surface\"; None: judged from the fit); angle_tolerance: "
      "the layer's, in degrees (None: the default).");

  m.def(
      "mesh_distances",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F,
         const Eigen::Ref<const MatrixX3d>& points, Progress* progress) {
        const TriangleMesh mesh = mesh_from(V, F);
        const MatrixX3d query = points;
        std::vector<double> distances;
        {
          py::gil_scoped_release release;
          closest_faces(mesh, query, &distances, ProgressSpan(progress, "deviation"));
        }
        return Eigen::Map<const Eigen::VectorXd>(distances.data(), static_cast<Eigen::Index>(distances.size())).eval();
      },
      py::arg("V"), py::arg("F"), py::arg("points"), py::kw_only(), py::arg("progress") = nullptr,
      "Distance of each point from the mesh (AABB tree).");

  m.def(
      "fit_surface",
      [](const std::string& type, const Eigen::Ref<const MatrixX3d>& points, const Eigen::Ref<const MatrixX3d>& normals,
         const Eigen::VectorXd& weights) {
        SurfaceType t = SurfaceType::Freeform;
        for (SurfaceType candidate : {SurfaceType::Plane, SurfaceType::Cylinder, SurfaceType::Cone,
                                      SurfaceType::Sphere, SurfaceType::Torus})
          if (type == surface_type_name(candidate)) t = candidate;
        if (t == SurfaceType::Freeform) throw std::invalid_argument("unknown surface type '" + type + "'");
        if (points.rows() != normals.rows() || points.rows() != weights.size())
          throw std::invalid_argument("points, normals and weights must have one row per point");
        const FitData data{points, weights, points, normals, weights};
        const SurfaceFit fit = fit_surface(t, data);
        py::dict d;
        d["valid"] = fit.valid;
        d["params"] = surface_params(fit.surface);
        d["rms"] = fit.rms;
        d["max_error"] = fit.max_error;
        d["normal_rms"] = fit.normal_rms;
        return d;
      },
      py::arg("type"), py::arg("points"), py::arg("normals"), py::arg("weights"),
      "Fit one surface type to points with normals and weights (the points double as the oriented samples).");

  m.def(
      "fit_bspline_surface",
      [](const Eigen::Ref<const MatrixX3d>& points, const Eigen::Ref<const MatrixX3d>& normals,
         const Eigen::VectorXd& weights) {
        if (points.rows() != weights.size()) throw std::invalid_argument("points and weights must have one row per point");
        const MatrixX3d p = points, n = normals;
        BSplineSurfaceFit fit;
        {
          py::gil_scoped_release release;
          fit = fit_bspline_surface(p, weights, n);
        }
        py::dict d;
        d["valid"] = fit.valid;
        d["problem"] = fit.problem;
        d["degree"] = fit.degree;
        d["knots_u"] = fit.knots_u;
        d["knots_v"] = fit.knots_v;
        d["poles"] = py::array_t<double>({fit.count_u, fit.count_v, 3}, fit.poles.data());
        d["origin"] = fit.origin;
        d["u_direction"] = fit.u_direction;
        d["v_direction"] = fit.v_direction;
        d["rms"] = fit.rms;
        d["max_error"] = fit.max_error;
        d["extrusion"] = fit.extrusion;
        return d;
      },
      py::arg("points"), py::arg("normals"), py::arg("weights"),
      "Fit a bicubic B-spline height field over the points' mean plane (a freeform patch's surface): "
      "poles (#u x #v x 3), distinct uniform knots (clamped), the plane (S(u, v) lies over origin + u "
      "u_direction + v v_direction), RMS and largest distance along the plane's normal. A patch that "
      "folds over the plane but whose normals all lie across one direction gets its profile swept "
      "along v_direction instead (extrusion: true; u is the profile's parameter).");

  m.def(
      "vertex_curvature",
      [](const Eigen::Ref<const MatrixX3d>& V, const Eigen::Ref<const MatrixX3i>& F) {
        const TriangleMesh mesh = mesh_from(V, F);
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
        const TriangleMesh mesh = mesh_from(V, F);
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
        const TriangleMesh mesh = mesh_from(V, F);
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
