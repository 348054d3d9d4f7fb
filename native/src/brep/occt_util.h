// Small conversions between Eigen and OpenCASCADE, shared by the B-rep's modules.
#pragma once

#include <Standard_Failure.hxx>
#include <gp_Dir.hxx>
#include <gp_Pnt.hxx>

#include <Eigen/Dense>

#include <string>

namespace idealize {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

inline gp_Pnt to_pnt(const Vec3& v) { return gp_Pnt(v.x(), v.y(), v.z()); }
inline gp_Dir to_dir(const Vec3& v) { return gp_Dir(v.x(), v.y(), v.z()); }
inline Vec3 to_vec(const gp_Pnt& p) { return Vec3(p.X(), p.Y(), p.Z()); }

// "what: OpenCASCADE's message", for a user.
inline std::string occt_message(const Standard_Failure& failure, const char* what) {
  const char* text = failure.GetMessageString();
  return std::string(what) + ((text && *text) ? std::string(": ") + text : std::string(" (OpenCASCADE failure)"));
}

}  // namespace idealize
