#include "fit/bspline_fitting.h"

#include "fit/surface.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <optional>
#include <vector>

namespace idealize {

namespace {

constexpr int kDegree = 3;
// Noise may tilt a few face normals of a height field a long way; more than this share of them
// beyond the limit is a fold.
constexpr double kFoldedShare = 0.01;
// Rounds of parameter correction of a profile curve's fit.
constexpr int kParameterRounds = 30;

// Uniform knots of `spans` spans over [low, high], clamped: the full vector (NURBS Book 2.2).
std::vector<double> full_knots(double low, double high, int spans) {
  std::vector<double> knots(kDegree, low);
  for (int i = 0; i <= spans; ++i) knots.push_back(low + (high - low) * i / spans);
  knots.insert(knots.end(), kDegree, high);
  return knots;
}

// The index of the first of the degree + 1 basis functions that are nonzero at t, and their values
// (NURBS Book A2.2).
int basis(const std::vector<double>& knots, int spans, double t, std::array<double, kDegree + 1>& n) {
  const double low = knots[kDegree], high = knots[kDegree + spans];
  const int span = std::clamp(static_cast<int>(std::floor((t - low) / (high - low) * spans)), 0, spans - 1);
  const int k = span + kDegree;  // knots[k] <= t < knots[k + 1]
  std::array<double, kDegree + 1> left{}, right{};
  n[0] = 1.0;
  for (int j = 1; j <= kDegree; ++j) {
    left[j] = t - knots[k + 1 - j];
    right[j] = knots[k + j] - t;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double term = n[r] / (right[r + 1] + left[j - r]);
      n[r] = saved + right[r + 1] * term;
      saved = left[j - r] * term;
    }
    n[j] = saved;
  }
  return span;
}

// Greville abscissae of the knot vector: where the poles of a linear function sit.
std::vector<double> greville(const std::vector<double>& knots, int count) {
  std::vector<double> g(count);
  for (int i = 0; i < count; ++i) {
    double sum = 0.0;
    for (int j = 1; j <= kDegree; ++j) sum += knots[i + j];
    g[i] = sum / kDegree;
  }
  return g;
}

struct HeightFit {
  int spans_u = 0, spans_v = 0;
  std::vector<double> knots_u, knots_v;
  Eigen::VectorXd heights;  // (spans_u + 3)·(spans_v + 3), row-major in u
  double rms = 0.0, max_error = 0.0;
};

// Least-squares heights over the grid of spans_u x spans_v spans on [u0, u1] x [v0, v1].
HeightFit fit_heights(const std::vector<Eigen::Vector3d>& uvz, const Eigen::VectorXd& weights, double u0, double u1,
                      double v0, double v1, int spans_u, int spans_v, double smoothing) {
  HeightFit fit;
  fit.spans_u = spans_u;
  fit.spans_v = spans_v;
  fit.knots_u = full_knots(u0, u1, spans_u);
  fit.knots_v = full_knots(v0, v1, spans_v);
  const int nu = spans_u + kDegree, nv = spans_v + kDegree, unknowns = nu * nv;
  std::vector<Eigen::Triplet<double>> data;
  data.reserve(uvz.size() * 256);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  std::array<double, kDegree + 1> bu{}, bv{};
  for (size_t k = 0; k < uvz.size(); ++k) {
    const int iu = basis(fit.knots_u, spans_u, uvz[k].x(), bu), iv = basis(fit.knots_v, spans_v, uvz[k].y(), bv);
    for (int a = 0; a <= kDegree; ++a)
      for (int b = 0; b <= kDegree; ++b) {
        const int row = (iu + a) * nv + iv + b;
        const double coefficient = weights[k] * bu[a] * bv[b];
        rhs[row] += coefficient * uvz[k].z();
        for (int c = 0; c <= kDegree; ++c)
          for (int d = 0; d <= kDegree; ++d) data.emplace_back(row, (iu + c) * nv + iv + d, coefficient * bu[c] * bv[d]);
      }
  }
  Eigen::SparseMatrix<double> normal(unknowns, unknowns);
  normal.setFromTriplets(data.begin(), data.end());
  // Bending energy of the control net: second differences along u and v and the mixed one, per
  // squared pole spacing.
  const double du = (u1 - u0) / spans_u, dv = (v1 - v0) / spans_v;
  std::vector<Eigen::Triplet<double>> bending;
  auto add_row = [&](const std::vector<std::pair<int, double>>& row) {
    for (const auto& [i, a] : row)
      for (const auto& [j, b] : row) bending.emplace_back(i, j, a * b);
  };
  const auto at = [&](int i, int j) { return i * nv + j; };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      if (i + 2 < nu) add_row({{at(i, j), 1 / (du * du)}, {at(i + 1, j), -2 / (du * du)}, {at(i + 2, j), 1 / (du * du)}});
      if (j + 2 < nv) add_row({{at(i, j), 1 / (dv * dv)}, {at(i, j + 1), -2 / (dv * dv)}, {at(i, j + 2), 1 / (dv * dv)}});
      if (i + 1 < nu && j + 1 < nv) {
        const double m = std::sqrt(2.0) / (du * dv);
        add_row({{at(i, j), m}, {at(i + 1, j), -m}, {at(i, j + 1), -m}, {at(i + 1, j + 1), m}});
      }
    }
  Eigen::SparseMatrix<double> energy(unknowns, unknowns);
  energy.setFromTriplets(bending.begin(), bending.end());
  double data_trace = 0.0, energy_trace = 0.0;
  for (int i = 0; i < unknowns; ++i) {
    data_trace += normal.coeff(i, i);
    energy_trace += energy.coeff(i, i);
  }
  if (energy_trace > 0.0) normal += (smoothing * data_trace / energy_trace) * energy;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(normal);
  if (solver.info() != Eigen::Success) return fit;
  fit.heights = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !fit.heights.allFinite()) {
    fit.heights.resize(0);
    return fit;
  }
  double sum = 0.0, total = 0.0;
  for (size_t k = 0; k < uvz.size(); ++k) {
    const int iu = basis(fit.knots_u, spans_u, uvz[k].x(), bu), iv = basis(fit.knots_v, spans_v, uvz[k].y(), bv);
    double h = 0.0;
    for (int a = 0; a <= kDegree; ++a)
      for (int b = 0; b <= kDegree; ++b) h += bu[a] * bv[b] * fit.heights[(iu + a) * nv + iv + b];
    const double residual = uvz[k].z() - h;
    sum += weights[k] * residual * residual;
    total += weights[k];
    fit.max_error = std::max(fit.max_error, std::abs(residual));
  }
  fit.rms = total > 0.0 ? std::sqrt(sum / total) : 0.0;
  return fit;
}

struct CurveFit {
  int spans = 0;
  std::vector<double> knots;
  Eigen::MatrixX2d poles;  // spans + 3 poles
  double rms = 0.0, max_error = 0.0;
};

// The point of the curve at parameter t.
Eigen::Vector2d curve_point(const CurveFit& fit, double t) {
  std::array<double, kDegree + 1> b{};
  const int i = basis(fit.knots, fit.spans, t, b);
  Eigen::Vector2d at = Eigen::Vector2d::Zero();
  for (int a = 0; a <= kDegree; ++a) at += b[a] * fit.poles.row(i + a).transpose();
  return at;
}

// Least-squares poles of a planar cubic B-spline curve of `spans` uniform spans on [low, high]
// through the points `xy` at parameters `s`, with the bending energy of fit_heights (second
// differences of the poles), which carries the curve straight on beyond its points.
CurveFit fit_curve(const std::vector<double>& s, const std::vector<Eigen::Vector2d>& xy, const std::vector<double>& w,
                   double low, double high, int spans, double smoothing) {
  CurveFit fit;
  fit.spans = spans;
  fit.knots = full_knots(low, high, spans);
  const int n = spans + kDegree;
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n), energy = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixX2d rhs = Eigen::MatrixX2d::Zero(n, 2);
  std::array<double, kDegree + 1> b{};
  for (size_t k = 0; k < s.size(); ++k) {
    const int i = basis(fit.knots, spans, s[k], b);
    for (int a = 0; a <= kDegree; ++a) {
      rhs.row(i + a) += w[k] * b[a] * xy[k].transpose();
      for (int c = 0; c <= kDegree; ++c) normal(i + a, i + c) += w[k] * b[a] * b[c];
    }
  }
  const double step = (high - low) / spans;
  for (int i = 0; i + 2 < n; ++i) {
    const Eigen::Vector3d row(1 / (step * step), -2 / (step * step), 1 / (step * step));
    energy.block<3, 3>(i, i) += row * row.transpose();
  }
  if (energy.trace() > 0.0) normal += (smoothing * normal.trace() / energy.trace()) * energy;
  const Eigen::LDLT<Eigen::MatrixXd> solver(normal);
  fit.poles = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !fit.poles.allFinite()) {
    fit.poles.resize(0, 2);
    return fit;
  }
  double sum = 0.0, total = 0.0;
  for (size_t k = 0; k < s.size(); ++k) {
    const double residual = (xy[k] - curve_point(fit, s[k])).norm();
    sum += w[k] * residual * residual;
    total += w[k];
    fit.max_error = std::max(fit.max_error, residual);
  }
  fit.rms = total > 0.0 ? std::sqrt(sum / total) : 0.0;
  return fit;
}

// The direction every normal lies across (the least eigenvector of their scatter), when they all
// do within `max_tilt`.
std::optional<Eigen::Vector3d> extrusion_direction(const MatrixX3d& normals, double max_tilt) {
  if (normals.rows() < 2) return std::nullopt;
  const Eigen::Matrix3d scatter = normals.transpose() * normals;
  const Eigen::Vector3d d = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  if ((normals * d).cwiseAbs().maxCoeff() > std::sin(max_tilt)) return std::nullopt;
  return d;
}

// An extruded profile: the points across `direction` ordered along the profile (a chain of nearest
// neighbours), a cubic B-spline curve fitted to them over their chord lengths, and
// swept along `direction`. Both reach beyond the points by the margin.
BSplineSurfaceFit fit_extrusion(const MatrixX3d& points, const Eigen::VectorXd& weights, const Eigen::Vector3d& direction,
                                const BSplineFitOptions& options) {
  BSplineSurfaceFit result;
  result.problem = "the freeform patch folds over its mean plane and is no extruded profile: no B-spline surface";
  const Eigen::Index stride = std::max<Eigen::Index>(1, (points.rows() + options.max_profile_points - 1) / options.max_profile_points);
  const double total = weights.sum();
  const Eigen::Vector3d centre = (points.transpose() * weights) / total;
  Eigen::Vector3d e1, e2;
  orthonormal_frame(direction, e1, e2);
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> w;
  double along_low = std::numeric_limits<double>::infinity(), along_high = -along_low;
  for (Eigen::Index k = 0; k < points.rows(); ++k) {
    const Eigen::Vector3d d = points.row(k).transpose() - centre;
    along_low = std::min(along_low, d.dot(direction));
    along_high = std::max(along_high, d.dot(direction));
    if (k % stride) continue;
    xy.emplace_back(d.dot(e1), d.dot(e2));
    w.push_back(weights[k]);
  }
  const size_t n = xy.size();
  // The chain grows from the first point at both ends, each time by the unplaced point nearest to
  // either end.
  std::deque<size_t> chain{0};
  std::vector<char> taken(n, 0);
  taken[0] = 1;
  while (chain.size() < n) {
    size_t next = n;
    bool at_front = false;
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < n; ++k) {
      if (taken[k]) continue;
      const double to_front = (xy[k] - xy[chain.front()]).squaredNorm(), to_back = (xy[k] - xy[chain.back()]).squaredNorm();
      if (std::min(to_front, to_back) < nearest) {
        nearest = std::min(to_front, to_back);
        next = k;
        at_front = to_front < to_back;
      }
    }
    taken[next] = 1;
    if (at_front) chain.push_front(next); else chain.push_back(next);
  }
  const std::vector<size_t> order(chain.begin(), chain.end());
  std::vector<double> s{0.0};
  for (size_t k = 1; k < n; ++k) s.push_back(s.back() + (xy[order[k]] - xy[order[k - 1]]).norm());
  const double length = s.back();
  if (!(length > 0.0) || !(along_high > along_low)) return result;
  // A profile that closes (a tube) ends beside its start: no open curve describes it.
  double longest_step = 0.0;
  for (size_t k = 1; k < n; ++k) longest_step = std::max(longest_step, s[k] - s[k - 1]);
  if ((xy[order.back()] - xy[order.front()]).norm() <= 2.0 * longest_step) return result;
  std::vector<Eigen::Vector2d> ordered(n);
  std::vector<double> ordered_w(n);
  for (size_t k = 0; k < n; ++k) {
    ordered[k] = xy[order[k]];
    ordered_w[k] = w[order[k]];
  }
  const double low = -options.margin * length, high = (1.0 + options.margin) * length;
  // Every span count the points allow, then the coarsest that fits about as well as the best.
  std::vector<CurveFit> fits;
  for (int spans = 1; spans <= options.max_spans; spans *= 2) {
    if (!fits.empty() && n < static_cast<size_t>(options.min_points_per_span * spans * length / (high - low))) break;
    // Chord lengths only approximate where each point lies on the curve: each refit takes the
    // parameters of the points' feet on the last curve (Gauss–Newton steps; Hoschek's parameter
    // correction), which makes the fit's distances the points' distances from the curve.
    std::vector<double> t = s;
    CurveFit fit = fit_curve(t, ordered, ordered_w, low, high, spans, options.smoothing);
    for (int round = 0; round < kParameterRounds && fit.poles.rows() > 0; ++round) {
      const double h = 1e-6 * (high - low);
      for (size_t k = 0; k < n; ++k)
        for (int step = 0; step < 3; ++step) {
          const Eigen::Vector2d at = curve_point(fit, t[k]);
          const Eigen::Vector2d tangent = (curve_point(fit, t[k] + h) - curve_point(fit, t[k] - h)) / (2 * h);
          if (!(tangent.squaredNorm() > 0.0)) break;
          t[k] = std::clamp(t[k] + (ordered[k] - at).dot(tangent) / tangent.squaredNorm(), low, high);
        }
      CurveFit refit = fit_curve(t, ordered, ordered_w, low, high, spans, options.smoothing);
      if (refit.poles.rows() == 0 || !(refit.rms < fit.rms)) break;
      fit = std::move(refit);
    }
    if (fit.poles.rows() == 0) break;
    fits.push_back(std::move(fit));
  }
  double least = std::numeric_limits<double>::infinity();
  for (const CurveFit& fit : fits) least = std::min(least, fit.rms);
  const CurveFit* best = nullptr;
  for (const CurveFit& fit : fits)
    if (fit.rms * options.refinement_gain <= least) {
      best = &fit;
      break;
    }
  // A chain that jumped across the profile (which came close to itself) leaves the curve far from
  // its points.
  if (!best || best->max_error > 1e-2 * length) return result;
  const double margin = options.margin * std::max(length, along_high - along_low);
  const std::vector<double> along_knots = full_knots(along_low - margin, along_high + margin, 1);
  const std::vector<double> gv = greville(along_knots, kDegree + 1);
  result.valid = true;
  result.problem.clear();
  result.extrusion = true;
  result.degree = kDegree;
  result.count_u = best->spans + kDegree;
  result.count_v = kDegree + 1;
  result.knots_u = Eigen::Map<const Eigen::VectorXd>(best->knots.data() + kDegree, best->spans + 1);
  result.knots_v = Eigen::Map<const Eigen::VectorXd>(along_knots.data() + kDegree, 2);
  result.poles.resize(result.count_u * result.count_v, 3);
  for (int i = 0; i < result.count_u; ++i)
    for (int j = 0; j < result.count_v; ++j)
      result.poles.row(i * result.count_v + j) =
          (centre + best->poles(i, 0) * e1 + best->poles(i, 1) * e2 + gv[j] * direction).transpose();
  result.origin = centre;
  result.u_direction = e1;
  result.v_direction = direction;
  result.rms = best->rms;
  result.max_error = best->max_error;
  return result;
}

}  // namespace

BSplineSurfaceFit fit_bspline_surface(const MatrixX3d& points, const Eigen::VectorXd& weights, const MatrixX3d& normals,
                                      const BSplineFitOptions& options) {
  BSplineSurfaceFit result;
  const Eigen::Index count = points.rows();
  const double total = weights.size() == count ? weights.sum() : 0.0;
  if (!points.allFinite() || !normals.allFinite() || !(total > 0.0)) {
    result.problem = "points or normals not finite, or no positive weight: no B-spline surface";
    return result;
  }
  if (count < (kDegree + 1) * (kDegree + 1)) {
    result.problem = "too few points for a B-spline surface";
    return result;
  }
  // The mean plane: weighted principal components.
  const Eigen::Vector3d centre = (points.transpose() * weights) / total;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (Eigen::Index k = 0; k < count; ++k) {
    const Eigen::Vector3d d = points.row(k).transpose() - centre;
    covariance += weights[k] * d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  Eigen::Vector3d normal = solver.eigenvectors().col(0), e1 = solver.eigenvectors().col(2);
  if (normals.rows() > 0 && normals.colwise().sum().dot(normal) < 0.0) normal = -normal;
  const Eigen::Vector3d e2 = normal.cross(e1);  // (e1, e2, normal) right-handed
  int folded = 0;
  for (Eigen::Index k = 0; k < normals.rows(); ++k) folded += normals.row(k).dot(normal) < std::cos(options.max_tilt);
  if (folded > kFoldedShare * normals.rows()) {
    if (const std::optional<Eigen::Vector3d> direction = extrusion_direction(normals, options.max_extrusion_tilt))
      return fit_extrusion(points, weights, *direction, options);
    result.problem = "the freeform patch folds over its mean plane (not a height field): no B-spline surface";
    return result;
  }
  std::vector<Eigen::Vector3d> uvz(count);
  Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), high = -low;
  for (Eigen::Index k = 0; k < count; ++k) {
    const Eigen::Vector3d d = points.row(k).transpose() - centre;
    uvz[k] = Eigen::Vector3d(d.dot(e1), d.dot(e2), d.dot(normal));
    low = low.cwiseMin(uvz[k].head<2>());
    high = high.cwiseMax(uvz[k].head<2>());
  }
  const Eigen::Vector2d extent = high - low;
  if (!(extent.minCoeff() > 0.0)) {
    result.problem = "the freeform patch has no extent across its mean plane";
    return result;
  }
  // A square domain margin: the margin goes by the larger extent, so that a narrow patch's sides
  // reach as far beyond it as its ends.
  low -= Eigen::Vector2d::Constant(options.margin * extent.maxCoeff());
  high += Eigen::Vector2d::Constant(options.margin * extent.maxCoeff());
  const Eigen::Vector2d size = high - low;

  // Every grid the points allow; then the coarsest that fits about as well as the best of them.
  std::vector<HeightFit> fits;
  for (int level = 1; level <= options.max_spans; level *= 2) {
    const int spans_u = std::max(1, static_cast<int>(std::lround(level * size.x() / size.maxCoeff())));
    const int spans_v = std::max(1, static_cast<int>(std::lround(level * size.y() / size.maxCoeff())));
    // Spans over the points only: the margin holds none.
    const double covered = spans_u * spans_v * (extent.x() / size.x()) * (extent.y() / size.y());
    if (!fits.empty() && count < options.min_points_per_span * covered) break;
    HeightFit fit = fit_heights(uvz, weights, low.x(), high.x(), low.y(), high.y(), spans_u, spans_v, options.smoothing);
    if (fit.heights.size() == 0) break;
    fits.push_back(std::move(fit));
  }
  HeightFit best;
  double least = std::numeric_limits<double>::infinity();
  for (const HeightFit& fit : fits) least = std::min(least, fit.rms);
  for (HeightFit& fit : fits)
    if (fit.rms * options.refinement_gain <= least) {
      best = std::move(fit);
      break;
    }
  if (best.heights.size() == 0) {
    result.problem = "the B-spline surface could not be solved for";
    return result;
  }
  const int nu = best.spans_u + kDegree, nv = best.spans_v + kDegree;
  const std::vector<double> gu = greville(best.knots_u, nu), gv = greville(best.knots_v, nv);
  result.valid = true;
  result.degree = kDegree;
  result.count_u = nu;
  result.count_v = nv;
  result.knots_u = Eigen::Map<const Eigen::VectorXd>(best.knots_u.data() + kDegree, best.spans_u + 1);
  result.knots_v = Eigen::Map<const Eigen::VectorXd>(best.knots_v.data() + kDegree, best.spans_v + 1);
  result.poles.resize(nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j)
      result.poles.row(i * nv + j) = (centre + gu[i] * e1 + gv[j] * e2 + best.heights[i * nv + j] * normal).transpose();
  result.origin = centre;
  result.u_direction = e1;
  result.v_direction = e2;
  result.rms = best.rms;
  result.max_error = best.max_error;
  return result;
}

}  // namespace idealize
