// The fitted surfaces as OpenCASCADE's: analytic surfaces placed so that their parametric seams lie
// away from their faces, and freeform features' B-splines with a local tangent plane.
#pragma once

#include "fit/bspline_fitting.h"
#include "fit/surface.h"
#include "brep/occt_util.h"

#include <Geom_BSplineSurface.hxx>
#include <Geom_Surface.hxx>

#include <optional>
#include <vector>

namespace idealize {

// How a face goes all round an axis: the axis (a sphere's polar one) and the direction of the seam.
struct RoundFace {
  Vec3 axis, seam;
  bool winds = false;  // a loop of several chains winds round the axis (else one is a closed chain)
  int split = -1;      // the chain of the winding loop that the seam crosses
};

// A unit vector orthogonal to `axis`, pointing from the axis towards -mean of the points' radial
// directions (`mean_radial`): the parametric seam (u = 0) of a revolved surface then lies opposite
// to its face.
Vec3 seam_direction(const Vec3& axis, const Vec3& mean_radial);

// A unit vector orthogonal to `axis` that depends on the axis line only (not on its sense): the
// seam of every face that goes all round an axis.
Vec3 common_seam_direction(const Vec3& axis);

// The surface of feature `s` for a face through `points` (#points, its triangles' centres);
// `round`: set when the face goes all round an axis. Null for a freeform feature.
Handle(Geom_Surface) make_surface(const Surface& s, const std::vector<Vec3>& points, const std::optional<RoundFace>& round);

// Whether `a` and `b` are one surface within `tol` (and parallel axes within 1e-9).
bool same_surface(const Surface& a, const Surface& b, double tol);

// A freeform feature's B-spline as OpenCASCADE's surface; u and v as in the fit.
Handle(Geom_BSplineSurface) occt_bspline(const BSplineSurfaceFit& fit);

// A freeform feature's fitted surface, and its tangent plane nearest a point: Gauss–Newton for the
// foot point from the point's place over the mean plane (the surface is a height field over it), or
// for an extruded profile from the nearest of a row of samples along the profile.
struct FreeformSurface {
  Handle(Geom_BSplineSurface) surface;
  Vec3 origin, u_direction, v_direction;
  bool extrusion = false;

  // The tangent plane at the point of the surface nearest `p`.
  Surface tangent_plane(const Vec3& p) const;
};

}  // namespace idealize
