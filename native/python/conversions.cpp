// Conversions between the native types and the Python report's dictionaries, shared by the
// bindings' modules.
#include "conversions.h"

#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <vector>

namespace idealize {

namespace py = pybind11;

namespace {

Eigen::Vector3d vector3(const py::dict& params, const char* key) {
  if (!params.contains(key)) throw std::invalid_argument(std::string("surface parameters lack '") + key + "'");
  const auto v = params[key].cast<std::vector<double>>();
  if (v.size() != 3) throw std::invalid_argument(std::string("surface parameter '") + key + "' needs 3 values");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

double scalar(const py::dict& params, const char* key) {
  if (!params.contains(key)) throw std::invalid_argument(std::string("surface parameters lack '") + key + "'");
  return params[key].cast<double>();
}

}  // namespace

py::dict surface_params(const Surface& s) {
  using V3 = Eigen::Vector3d;
  auto list = [](const V3& v) { return py::make_tuple(v.x(), v.y(), v.z()); };
  py::dict d;
  switch (s.type) {
    case SurfaceType::Plane: d["normal"] = list(s.axis); d["point"] = list(s.point); break;
    case SurfaceType::Cylinder: d["axis"] = list(s.axis); d["point"] = list(s.point); d["radius"] = s.radius; break;
    case SurfaceType::Cone: d["axis"] = list(s.axis); d["apex"] = list(s.point); d["half_angle"] = s.half_angle; break;
    case SurfaceType::Sphere: d["center"] = list(s.point); d["radius"] = s.radius; break;
    case SurfaceType::Torus:
      d["axis"] = list(s.axis); d["center"] = list(s.point); d["major"] = s.radius; d["minor"] = s.minor;
      break;
    case SurfaceType::Freeform: break;
  }
  return d;
}

// The inverse of surface_params: a surface from the report's type name and parameters.
Surface surface_from_params(const std::string& type, const py::dict& params) {
  Surface s;
  if (type == "plane") {
    s.type = SurfaceType::Plane; s.axis = vector3(params, "normal").normalized(); s.point = vector3(params, "point");
  } else if (type == "cylinder") {
    s.type = SurfaceType::Cylinder; s.axis = vector3(params, "axis").normalized(); s.point = vector3(params, "point");
    s.radius = scalar(params, "radius");
  } else if (type == "cone") {
    s.type = SurfaceType::Cone; s.axis = vector3(params, "axis").normalized(); s.point = vector3(params, "apex");
    s.half_angle = scalar(params, "half_angle");
  } else if (type == "sphere") {
    s.type = SurfaceType::Sphere; s.point = vector3(params, "center"); s.radius = scalar(params, "radius");
  } else if (type == "torus") {
    s.type = SurfaceType::Torus; s.axis = vector3(params, "axis").normalized(); s.point = vector3(params, "center");
    s.radius = scalar(params, "major"); s.minor = scalar(params, "minor");
  } else if (type != "freeform") {
    throw std::invalid_argument("unknown surface type '" + type + "'");
  }
  if (!s.point.allFinite() || !s.axis.allFinite() || !std::isfinite(s.radius) || !std::isfinite(s.minor))
    throw std::invalid_argument("a " + type + " has a NaN or infinite parameter");
  return s;
}

}  // namespace idealize
