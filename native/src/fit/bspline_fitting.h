// A bicubic B-spline surface fitted to the points of a freeform patch, the thesis's future work
// (J. S.-S. Chen, "Hybrid CAD modeler", chapter 6): a patch that no plane, cylinder, cone, sphere or
// torus explains still becomes one face of the solid.
//
// The patch is taken as a height field over its mean plane (principal components), and the surface
// as S(u, v) = c + u·e1 + v·e2 + h(u, v)·n with h a tensor-product B-spline (L. Piegl, W. Tiller,
// "The NURBS Book", 2nd ed., Springer 1997, 9.4): the poles sit at the Greville abscissae over the
// plane, where a B-spline reproduces linear functions, so that u and v are exact and only the
// heights are fitted, by linear least squares with a small bending energy (second differences of
// the control net) that carries the surface smoothly over the margin and any gap in the points.
// Of the grids with enough points per span (spans doubled from one), the coarsest that fits about
// as well as the best: on an exact tessellation the finest the points' density allows, on a scan the
// one whose residual reaches the noise.
//
// A patch that folds over every plane but whose normals all lie across one direction (an extruded
// profile whose tangent turns by more than a right angle) is taken as a profile curve swept along
// that direction: the points across it ordered by a chain of nearest neighbours, a cubic B-spline
// curve fitted to them over chord lengths with parameter correction (J. Hoschek, "Intrinsic
// parametrization for approximation", CAGD 5(1), 1988), and its poles repeated at the Greville
// abscissae along the direction, where the surface is exactly linear.
#pragma once

#include "core/mesh.h"

#include <string>

namespace idealize {

struct BSplineFitOptions {
  // The surface reaches beyond the points by this share of their extent on every side, so that the
  // surfaces beside the patch cut it (the edges of its face are those cuts).
  double margin = 0.15;
  // The finest grid keeps at least this many points per span cell over the points (each point
  // weighs on 16 poles; with fewer, heights between the points are the bending energy's guess).
  int min_points_per_span = 6;
  int max_spans = 32;  // per direction
  // Of the grids the points allow (spans doubled from one), the coarsest whose RMS residual is at
  // most the least one divided by this: on a scan, finer grids only follow the noise.
  double refinement_gain = 0.8;
  // Weight of the control net's bending energy against the data (relative to their traces): small
  // enough to leave the fit to the points wherever there are some.
  double smoothing = 1e-6;
  // Normals further than this angle (radians) from the mean plane's normal fold the height field:
  // such a patch (a tube, a wrapped sheet) gets no surface.
  double max_tilt = 80.0 * 3.14159265358979323846 / 180.0;
  // A patch that folds but whose normals all lie within this angle (radians) of a plane is an
  // extruded profile (a sketched spline pulled straight), fitted as that profile swept along the
  // plane's normal. On an exact tessellation its normals lie across the direction to rounding; a
  // scan's noise tilts them by more.
  double max_extrusion_tilt = 0.5 * 3.14159265358979323846 / 180.0;
  int max_profile_points = 2000;  // the profile is ordered and fitted on an even subsample of more
};

struct BSplineSurfaceFit {
  bool valid = false;
  std::string problem;  // why not, for a user, when invalid
  int degree = 3;
  int count_u = 0, count_v = 0;  // poles per direction
  Eigen::VectorXd knots_u, knots_v;  // distinct knots (uniform, clamped by multiplicity degree + 1)
  MatrixX3d poles;                   // count_u·count_v x 3, pole (i, j) at row i·count_v + j
  // The mean plane: S(u, v) lies over origin + u·u_direction + v·v_direction, along their normal
  // u_direction x v_direction, which points the way most of the given normals do.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero(), u_direction = Eigen::Vector3d::UnitX(),
                  v_direction = Eigen::Vector3d::UnitY();
  double rms = 0.0, max_error = 0.0;  // distances of the points along the plane's normal
  // Or the surface is a profile swept along v_direction (S(u, v) = C(u) + v·v_direction): u is the
  // profile curve's parameter, not a coordinate over a plane; rms and max_error are distances from
  // the profile across v_direction.
  bool extrusion = false;
};

// Fits the surface to `points` (#P x 3) with `weights` (#P, non-negative, e.g. vertex areas);
// `normals` (#N x 3, unit, any count: e.g. face normals) check that the patch is a height field
// over its mean plane, or else an extruded profile. Invalid, with a problem, when it is neither, or
// for fewer than 16 points.
BSplineSurfaceFit fit_bspline_surface(const MatrixX3d& points, const Eigen::VectorXd& weights,
                                      const MatrixX3d& normals, const BSplineFitOptions& options = {});

}  // namespace idealize
