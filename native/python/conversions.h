// Conversions between the native types and the Python report's dictionaries.
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <Eigen/Core>
#include <pybind11/pybind11.h>

#include <string>

namespace idealize {

// NumPy's (n, 3) arrays as they usually come: C order.
using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

// A TriangleMesh of the vertices V (#V x 3) and faces F (#F x 3) given from Python (any Eigen
// expressions of those shapes: the bindings take them as Eigen::Ref).
template <class Vertices, class Faces>
TriangleMesh mesh_from(const Vertices& V, const Faces& F) {
  TriangleMesh mesh;
  mesh.V = V;
  mesh.F = F;
  return mesh;
}

// A surface's parameters as the report gives them: plane normal/point, cylinder axis/point/radius,
// cone axis/apex/half_angle (radians), sphere center/radius, torus axis/center/major/minor.
pybind11::dict surface_params(const Surface& s);

// The inverse of surface_params: a surface from the report's type name and parameters. Throws
// std::invalid_argument for an unknown type, a missing or non-finite parameter.
Surface surface_from_params(const std::string& type, const pybind11::dict& params);

// Binds the feature-based editing (edit_features) into the module.
void bind_edit(pybind11::module_& m);

// Binds sculpting (the Sculptor: brushes with dynamic topology) into the module.
void bind_sculpt(pybind11::module_& m);

}  // namespace idealize
