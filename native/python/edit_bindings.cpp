// Bindings of the feature-based editing (native/src/edit).
#include "conversions.h"
#include "edit/copy_features.h"
#include "edit/delete_features.h"
#include "edit/edit.h"
#include "edit/feature_groups.h"
#include "edit/hole_depth.h"
#include "prepare/remesh_cgal.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace idealize {

namespace py = pybind11;

namespace {


EditParameter parameter_named(const std::string& name) {
  static const std::map<std::string, EditParameter> names{{"none", EditParameter::None},
                                                          {"offset", EditParameter::Offset},
                                                          {"radius", EditParameter::Radius},
                                                          {"minor_radius", EditParameter::MinorRadius},
                                                          {"half_angle", EditParameter::HalfAngle}};
  const auto it = names.find(name);
  if (it == names.end())
    throw std::invalid_argument("unknown parameter '" + name + "': offset, radius, minor_radius or half_angle");
  return it->second;
}

KeepRelations keep_from(const py::dict& keep) {
  KeepRelations k;
  const std::map<std::string, bool*> flags{{"tangent", &k.tangent},
                                           {"coplanar", &k.coplanar},
                                           {"coaxial", &k.coaxial},
                                           {"concentric", &k.concentric},
                                           {"equal_radius", &k.equal_radius}};
  for (const auto& [key, value] : keep) {
    const std::string name = py::str(key);
    const auto it = flags.find(name);
    if (it == flags.end())
      throw std::invalid_argument("unknown relation '" + name +
                                  "' to keep: tangent, coplanar, coaxial, concentric or equal_radius");
    *it->second = value.cast<bool>();
  }
  return k;
}

std::vector<FeatureAdjacency> adjacency_from(const std::vector<py::dict>& list) {
  std::vector<FeatureAdjacency> out;
  for (const py::dict& d : list) {
    FeatureAdjacency a;
    a.a = d["a"].cast<int>();
    a.b = d["b"].cast<int>();
    a.continuity = d["continuity"].cast<std::string>() == "G1" ? Continuity::G1 : Continuity::G0;
    out.push_back(a);
  }
  return out;
}

std::vector<FeatureRelation> relations_from(const std::vector<py::dict>& list) {
  std::vector<FeatureRelation> out;
  for (const py::dict& d : list) out.push_back({d["kind"].cast<std::string>(), d["features"].cast<std::vector<int>>()});
  return out;
}

std::vector<Surface> surfaces_from(const std::vector<std::string>& types, const std::vector<py::dict>& params) {
  if (types.size() != params.size()) throw std::invalid_argument("one type and one parameter set per feature");
  std::vector<Surface> surfaces;
  for (size_t i = 0; i < types.size(); ++i) surfaces.push_back(surface_from_params(types[i], params[i]));
  return surfaces;
}

EditOptions structure_options(double distance_tolerance, bool remesh, std::vector<double> target_edge_lengths) {
  EditOptions options;
  options.distance_tolerance = distance_tolerance;
  options.remesh = remesh;
  options.target_edge_lengths = std::move(target_edge_lengths);
  return options;
}

// The parts of a structure-altering edit's result that every one returns.
py::dict edited_mesh(TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<char>& created,
                     Eigen::VectorXd& deviation, std::vector<double>& targets, const std::string& problem) {
  py::dict d;
  d["V"] = std::move(mesh.V);
  d["F"] = std::move(mesh.F);
  d["labels"] = py::array_t<int>(static_cast<py::ssize_t>(labels.size()), labels.data());
  d["created"] = py::array_t<bool>(static_cast<py::ssize_t>(created.size()), reinterpret_cast<const bool*>(created.data()));
  d["vertex_deviation"] = std::move(deviation);
  d["target_edge_lengths"] = std::move(targets);
  d["remeshing_problem"] = problem;
  return d;
}

py::list params_of(const std::vector<Surface>& surfaces) {
  py::list out;
  for (const Surface& s : surfaces) out.append(surface_params(s));
  return out;
}

void bind_structure_edits(py::module_& m) {
  m.def(
      "self_intersections",
      [](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, long long max_pairs) {
        const TriangleMesh mesh = mesh_from(V, F);
        py::gil_scoped_release release;
        return count_self_intersections(mesh, max_pairs);
      },
      py::arg("V"), py::arg("F"), py::arg("max_pairs") = 1000,
      "The number of pairs of triangles that cross (CGAL), counted up to max_pairs; V, F a prepared mesh.");
  m.def(
      "feature_group",
      [](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, std::vector<int> labels,
         const std::vector<std::string>& types, const std::vector<py::dict>& params, int seed,
         double distance_tolerance) {
        const std::vector<Surface> surfaces = surfaces_from(types, params);
        const TriangleMesh mesh = mesh_from(V, F);
        check_layer(mesh, labels, surfaces, {}, {});
        FeatureGroup group;
        {
          py::gil_scoped_release release;
          group = feature_group(mesh, labels, surfaces, seed, distance_tolerance);
        }
        py::dict d;
        d["members"] = group.members;
        d["hosts"] = group.hosts;
        d["island"] = group.island;
        return d;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"), py::arg("params"), py::arg("seed"),
      py::kw_only(), py::arg("distance_tolerance") = 0.0,
      "The feature group of feature `seed` in a layer's idealized mesh (V, F oriented, labels, the features' "
      "types and params; the layer's distance tolerance): dict(members, hosts (sorted ids), island (each "
      "border loop of the group runs along one host)).");
  m.def(
      "delete_features",
      [](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, std::vector<int> labels,
         const std::vector<std::string>& types, const std::vector<py::dict>& params,
         const std::vector<py::dict>& adjacency, std::vector<int> features, double distance_tolerance, bool remesh,
         std::vector<double> target_edge_lengths) {
        const std::vector<Surface> surfaces = surfaces_from(types, params);
        const TriangleMesh mesh = mesh_from(V, F);
        const std::vector<FeatureAdjacency> graph = adjacency_from(adjacency);
        const EditOptions options = structure_options(distance_tolerance, remesh, std::move(target_edge_lengths));
        DeleteResult result;
        {
          py::gil_scoped_release release;
          result = delete_features(mesh, labels, surfaces, graph, features, options);
        }
        py::dict d = edited_mesh(result.mesh, result.labels, result.created, result.vertex_deviation,
                                 result.target_edge_lengths, result.remeshing_problem);
        d["kept"] = result.kept;
        d["hosts"] = result.hosts;
        d["merged"] = result.merged;
        d["edges"] = result.edges;
        d["new_edges"] = result.new_edges;
        d["corners"] = result.corners;
        return d;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"), py::arg("params"), py::arg("adjacency"),
      py::arg("features"), py::kw_only(), py::arg("distance_tolerance") = 0.0, py::arg("remesh") = true,
      py::arg("target_edge_lengths") = std::vector<double>(),
      "Deletes `features` from a layer's idealized mesh; the faces around each gap erode into it until it is "
      "closed: dict(V, F, labels (new ids), kept (old id per new id), hosts (new ids), merged ((old id, old id "
      "it joined) for identical faces a gap joined), edges (new ids of the features along each new edge), "
      "new_edges, corners, vertex_deviation, target_edge_lengths, remeshing_problem). Raises EditConflict "
      "naming the features when the faces around a gap cannot close it.");

  m.def(
      "set_hole_depth",
      [](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, std::vector<int> labels,
         const std::vector<std::string>& types, const std::vector<py::dict>& params,
         const std::vector<py::dict>& adjacency, int wall, double depth, int entry, double distance_tolerance,
         bool remesh, std::vector<double> target_edge_lengths) {
        const std::vector<Surface> surfaces = surfaces_from(types, params);
        const TriangleMesh mesh = mesh_from(V, F);
        const std::vector<FeatureAdjacency> graph = adjacency_from(adjacency);
        const EditOptions options = structure_options(distance_tolerance, remesh, std::move(target_edge_lengths));
        HoleResult result;
        {
          py::gil_scoped_release release;
          result = set_hole_depth(mesh, labels, surfaces, graph, wall, depth, entry, options);
        }
        py::dict d = edited_mesh(result.mesh, result.labels, result.created, result.vertex_deviation,
                                 result.target_edge_lengths, result.remeshing_problem);
        d["params"] = params_of(result.surfaces);
        d["kept"] = result.kept;
        d["wall"] = result.wall;
        d["floor"] = result.floor;
        d["through"] = result.through;
        d["depth"] = result.depth;
        d["hosts"] = result.hosts;
        return d;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"), py::arg("params"), py::arg("adjacency"),
      py::arg("wall"), py::arg("depth"), py::kw_only(), py::arg("entry") = -1, py::arg("distance_tolerance") = 0.0,
      py::arg("remesh") = true, py::arg("target_edge_lengths") = std::vector<double>(),
      "Gives the plain hole of cylinder `wall` the depth `depth` from its entry face (a through hole when it "
      "reaches the far side): dict(V, F, labels, params (the kept features', then the wall's and the floor's), "
      "kept (old id per new id, -1 new), wall, floor (-1: through), through, depth, hosts, created, "
      "vertex_deviation, target_edge_lengths, remeshing_problem). Raises EditConflict when it cannot.");
  using Placing = CopyResult (*)(const TriangleMesh&, const std::vector<int>&, const std::vector<Surface>&,
                                 const std::vector<FeatureAdjacency>&, const std::vector<int>&, const Placement&,
                                 const EditOptions&);
  auto placing = [](Placing function) {
    return [function](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                      std::vector<int> labels, const std::vector<std::string>& types,
                      const std::vector<py::dict>& params, const std::vector<py::dict>& adjacency,
                      std::vector<int> features, const Eigen::Vector3d& translation, double rotation, int onto,
                      double distance_tolerance, bool remesh, std::vector<double> target_edge_lengths) {
      const std::vector<Surface> surfaces = surfaces_from(types, params);
      const TriangleMesh mesh = mesh_from(V, F);
      const std::vector<FeatureAdjacency> graph = adjacency_from(adjacency);
      const Placement placement{translation, rotation, onto};
      const EditOptions options = structure_options(distance_tolerance, remesh, std::move(target_edge_lengths));
      CopyResult result;
      {
        py::gil_scoped_release release;
        result = function(mesh, labels, surfaces, graph, features, placement, options);
      }
      py::dict d = edited_mesh(result.mesh, result.labels, result.created, result.vertex_deviation,
                               result.target_edge_lengths, result.remeshing_problem);
      d["params"] = params_of(result.surfaces);
      d["copies"] = result.copies;
      d["hosts"] = result.hosts;
      return d;
    };
  };
  for (const auto& [name, function, doc] : {
           std::tuple<const char*, Placing, const char*>{
               "copy_features", &copy_features,
               "Copies `features` (a group on host planes), turned by `rotation` (radians) about its first host's "
               "normal through its centroid and moved by `translation` (along the hosts; onto: another plane to go to): "
               "dict(V, F, labels, params "
               "(every feature's, the copies' appended), copies (new id per feature given), hosts, vertex_deviation, "
               "target_edge_lengths, remeshing_problem). Raises EditConflict naming what the new place conflicts "
               "with."},
           std::tuple<const char*, Placing, const char*>{
               "move_features", &move_features,
               "Moves `features` (a group on host planes) as copy_features would copy them, deleting them from "
               "their old place first; the features keep their ids (copies: the ids given)."}})
    m.def(name, placing(function), py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"),
          py::arg("params"), py::arg("adjacency"), py::arg("features"), py::arg("translation"),
          py::arg("rotation") = 0.0, py::kw_only(), py::arg("onto") = -1, py::arg("distance_tolerance") = 0.0,
          py::arg("remesh") = true,
          py::arg("target_edge_lengths") = std::vector<double>(), doc);
}

}  // namespace

void bind_edit(py::module_& m) {
  bind_structure_edits(m);
  py::register_exception<EditConflict>(m, "EditConflict", PyExc_ValueError);
  m.def(
      "edit_features",
      [](const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F, std::vector<int> labels,
         const std::vector<std::string>& types, const std::vector<py::dict>& params,
         const std::vector<py::dict>& adjacency, const std::vector<py::dict>& relations, std::vector<int> features,
         const Eigen::Matrix4d& motion, const std::string& parameter, double value, const py::dict& keep,
         double distance_tolerance, bool remesh, std::vector<double> target_edge_lengths) {
        if (types.size() != params.size()) throw std::invalid_argument("one type and one parameter set per feature");
        std::vector<Surface> surfaces;
        for (size_t i = 0; i < types.size(); ++i) surfaces.push_back(surface_from_params(types[i], params[i]));
        TriangleMesh mesh;
        mesh.V = V;
        mesh.F = F;
        FeatureEdit edit;
        edit.features = std::move(features);
        edit.motion.matrix() = motion;
        if (!(motion.bottomRows<1>() - Eigen::RowVector4d(0, 0, 0, 1)).isZero() ||
            !(motion.topLeftCorner<3, 3>().transpose() * motion.topLeftCorner<3, 3>()).isIdentity(1e-9))
          throw std::invalid_argument("the motion must be a rigid 4x4 transform (a rotation and a translation)");
        edit.parameter = parameter_named(parameter);
        edit.value = value;
        EditOptions options;
        options.keep = keep_from(keep);
        options.distance_tolerance = distance_tolerance;
        options.remesh = remesh;
        options.target_edge_lengths = std::move(target_edge_lengths);
        const std::vector<FeatureAdjacency> graph = adjacency_from(adjacency);
        const std::vector<FeatureRelation> related = relations_from(relations);
        EditResult result;
        {
          py::gil_scoped_release release;
          result = edit_features(mesh, labels, surfaces, graph, related, edit, options);
        }
        py::list new_params, changed;
        for (size_t i = 0; i < result.surfaces.size(); ++i) {
          new_params.append(surface_params(result.surfaces[i]));
          changed.append(static_cast<bool>(result.changed[i]));
        }
        py::dict d;
        d["V"] = std::move(result.mesh.V);
        d["F"] = std::move(result.mesh.F);
        d["labels"] = py::array_t<int>(static_cast<py::ssize_t>(result.labels.size()), result.labels.data());
        d["params"] = new_params;
        d["changed"] = changed;
        d["vertex_deviation"] = std::move(result.vertex_deviation);
        d["target_edge_lengths"] = std::move(result.target_edge_lengths);
        d["remeshing_problem"] = result.remeshing_problem;
        return d;
      },
      py::arg("V"), py::arg("F"), py::arg("labels"), py::arg("types"), py::arg("params"), py::arg("adjacency"),
      py::arg("relations"), py::arg("features"), py::kw_only(), py::arg("motion") = Eigen::Matrix4d::Identity(),
      py::arg("parameter") = "none", py::arg("value") = 0.0, py::arg("keep") = py::dict(),
      py::arg("distance_tolerance") = 0.0, py::arg("remesh") = true, py::arg("target_edge_lengths") = std::vector<double>(),
      "Feature-based edit of a layer's idealized mesh (V, F oriented, labels, the features' types and params, "
      "adjacency and relations as the report gives them): `features` move by `motion` (4x4 rigid), then "
      "`parameter` (offset, radius, minor_radius, half_angle) takes `value`; target_edge_lengths: per feature "
      "(empty: each feature's own). Returns V, F, labels, params, changed, vertex_deviation and the "
      "target_edge_lengths used. Raises EditConflict when no ideal configuration satisfies the edit.");
}

}  // namespace idealize
