// Fitting one analytic surface to the points of a patch.
//
// Seeds come from direct, non-iterative formulas (thesis 4.2, here on normals rather than on
// principal curvatures, which are the noisiest quantity of a scan): plane by principal components;
// sphere by the algebraic fit; cylinder and cone axes as the direction the normals do not vary in
// (normals of a cone make a constant angle with its axis, those of a cylinder a right angle; across
// a cylinder's narrow band it is sought perpendicular to the normals' mean), their profiles by
// linear fits; a torus axis as the line that all normal lines meet, found as the linear
// line complex of the normals (H. Pottmann, T. Randrup, "Rotational and helical surface
// approximation for reverse engineering", Computing 60(4), 1998), its tube from a circle fitted to
// the profile. Going beyond the thesis, a Levenberg–Marquardt refinement of the geometric distance
// (Huber-weighted against outliers) starts from the seed and is kept only where it lowers the RMS
// residual.
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <utility>
#include <vector>

namespace idealize {

struct FitOptions {
  int max_iterations = 40;  // Levenberg–Marquardt steps per round
  int max_points = 500;     // the refinement runs on an even subsample of larger patches
  bool robust = true;       // a second, Huber-weighted round against outliers
  // A torus seeded from the points may be a lemon: the part of a spindle torus whose tube crosses
  // the axis, on the far side of it (radius < 0, |radius| < minor), a domed screw head revolved from
  // an arc centred beyond the axis. (A fit that starts from a lemon stays one.) Off by default: the
  // few points of a small piece fit a lemon exactly, and on a noisy patch a lemon passes for other
  // surfaces (measured on the benchmark: CAD, scan and sculpt faces lost).
  bool lemons = false;
};

// What a fit sees of a patch: points whose distances are minimised, and oriented samples of the
// surface (a position and its unit normal, e.g. face centroids and face normals) that seed the
// axes and check the normals. Face normals are exact at the centroid of a chord facet, where the
// averaged vertex normals of a coarse tessellation are off by half a facet angle.
struct FitData {
  MatrixX3d points;                 // #P x 3
  Eigen::VectorXd weights;          // #P, non-negative (e.g. vertex areas)
  MatrixX3d sample_points;          // #S x 3
  MatrixX3d sample_normals;         // #S x 3, unit, oriented consistently
  Eigen::VectorXd sample_weights;   // #S, non-negative (e.g. face areas)
};

// Both data sets of `a` followed by those of `b`.
FitData concatenate(const FitData& a, const FitData& b);

struct SurfaceFit {
  Surface surface;
  bool valid = false;       // the seed could be formed (a cone needs a tilt, a torus an axis)
  double rms = 0.0;         // weighted RMS distance of the points from the surface
  double max_error = 0.0;   // largest distance
  double normal_rms = 0.0;  // weighted RMS angle (radians) between the sample normals and the surface's
  // Robust spreads (1.4826 x weighted median absolute value, σ for Gaussian residuals) of the
  // distances and the normal angles: blind to the few wrong faces a patch rim may still hold.
  double spread = 0.0, normal_spread = 0.0;
};

// Fits a surface of `type` (not Freeform) to `data`. The refinement starts from `initial` when
// given (a surface of the same type, e.g. the fit before the patch changed a little), from the
// direct formulas otherwise.
SurfaceFit fit_surface(SurfaceType type, const FitData& data, const FitOptions& options = {},
                       const Surface* initial = nullptr);

// Fits a cylinder, cone or torus (`type`) whose axis is the line through `origin` along `axis`
// (unit) to `data`: only the profile is fitted (radius; apex and half-angle, by a total-least-squares
// line through the points' heights along and distances from the axis; a torus's centre height and
// radii by the circle through them, a lemon where its centre lies beyond the axis). The thesis's semi-defined
// features (4.3), whose axis a related feature defines. Invalid where the profile is not of the
// type (a cone's line along or across the axis). The spreads are left to measure_spreads.
SurfaceFit fit_about_axis(SurfaceType type, const FitData& data, const Eigen::Vector3d& origin,
                          const Eigen::Vector3d& axis);

// The fit's normal RMS angle and robust spreads over `data` (fit_surface measures them).
void measure_spreads(const FitData& data, SurfaceFit& fit);

// How well `points` (#P x 3) determine the tube radius of `surface` (a cylinder's or sphere's
// radius, a torus's minor radius; 0 for other types): the standard error of the radius of the
// least-squares fit at `surface`, for points that scatter independently by their robust spread
// from it. Infinite where the points do not determine it (fewer than the surface's parameters).
double tube_radius_error(const Surface& surface, const MatrixX3d& points);

// The weighted median of (value, weight) pairs (0 for none).
double weighted_median(std::vector<std::pair<double, double>> values);

// RMS and maximum distance of the points from a surface.
void fit_residuals(const Surface& surface, const MatrixX3d& points, const Eigen::VectorXd& weights,
                   double& rms, double& max_error);

// A given surface as a fit of `data`: valid, with its RMS and maximum distance (the spreads are
// left to measure_spreads).
SurfaceFit fit_of(const Surface& surface, const FitData& data);

}  // namespace idealize
