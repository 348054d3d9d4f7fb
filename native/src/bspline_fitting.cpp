#include "bspline_fitting.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace idealize {

namespace {

constexpr int kDegree = 3;
// Noise may tilt a few face normals of a height field a long way; more than this share of them
// beyond the limit is a fold.
constexpr double kFoldedShare = 0.01;

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
