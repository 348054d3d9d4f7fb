#include "fit/surface_fitting.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace idealize {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The surface moved by a small parameter step `d` (parameter_count entries): the axis tilts in
// its own frame, so every step is a local, minimal parametrisation.
Surface perturbed(const Surface& s, const double* d) {
  Surface out = s;
  Eigen::Vector3d e1, e2;
  orthonormal_frame(s.axis, e1, e2);
  auto tilt_axis = [&] { out.axis = (s.axis + d[0] * e1 + d[1] * e2).normalized(); };
  switch (s.type) {
    case SurfaceType::Plane:
      tilt_axis();
      out.point += d[2] * s.axis;
      break;
    case SurfaceType::Sphere:
      out.point += Eigen::Vector3d(d[0], d[1], d[2]);
      out.radius += d[3];
      break;
    case SurfaceType::Cylinder:
      tilt_axis();
      out.point += d[2] * e1 + d[3] * e2;
      out.radius += d[4];
      break;
    case SurfaceType::Cone:
      tilt_axis();
      out.point += Eigen::Vector3d(d[2], d[3], d[4]);
      out.half_angle += d[5];
      break;
    case SurfaceType::Torus:
      tilt_axis();
      out.point += Eigen::Vector3d(d[2], d[3], d[4]);
      out.radius += d[5];
      out.minor += d[6];
      break;
    case SurfaceType::Freeform: break;
  }
  return out;
}

// A torus is a ring or spindle torus (radius >= 0), or with `lemon` the lemon of a spindle torus.
bool plausible(const Surface& s, bool lemon = false) {
  const bool finite = s.point.allFinite() && s.axis.allFinite() && std::isfinite(s.radius) &&
                      std::isfinite(s.minor) && std::isfinite(s.half_angle);
  if (!finite) return false;
  switch (s.type) {
    case SurfaceType::Sphere:
    case SurfaceType::Cylinder: return s.radius > 0.0;
    case SurfaceType::Cone: return s.half_angle > 0.0 && s.half_angle < 0.5 * M_PI;
    case SurfaceType::Torus: return s.minor > 0.0 && (lemon ? s.radius < 0.0 && s.radius > -s.minor : s.radius >= 0.0);
    default: return true;
  }
}

// Weighted points and normals in a frame centred on their centroid and scaled to unit RMS
// radius, so that lengths and angles weigh alike in the refinement.
struct Sample {
  std::vector<Eigen::Vector3d> p;  // points
  std::vector<double> w;           // their weights, summing to 1
  std::vector<Eigen::Vector3d> q, n;  // oriented samples: positions and normals
  std::vector<double> v;              // their weights, summing to 1
};

Eigen::Vector3d smallest_eigenvector(const Eigen::Matrix3d& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(m);
  return solver.eigenvectors().col(0);
}

// Circle (N = 2) or sphere (N = 3) through points, algebraic (Kåsa) fit: |q|² = 2 c·q + (r² − |c|²)
// in the weighted least-squares sense. Returns false when the points are collinear (coplanar).
template <int N>
bool algebraic_sphere(const std::vector<Eigen::Matrix<double, N, 1>>& q, const std::vector<double>& w,
                      Eigen::Matrix<double, N, 1>& centre, double& radius) {
  Eigen::Matrix<double, N + 1, N + 1> a = Eigen::Matrix<double, N + 1, N + 1>::Zero();
  Eigen::Matrix<double, N + 1, 1> b = Eigen::Matrix<double, N + 1, 1>::Zero();
  for (size_t i = 0; i < q.size(); ++i) {
    Eigen::Matrix<double, N + 1, 1> row;
    row << 2.0 * q[i], 1.0;
    a += w[i] * row * row.transpose();
    b += w[i] * row * q[i].squaredNorm();
  }
  const Eigen::Matrix<double, N + 1, 1> x = a.ldlt().solve(b);
  centre = x.template head<N>();
  const double r2 = x[N] + centre.squaredNorm();
  radius = r2 > 0.0 ? std::sqrt(r2) : 0.0;
  return x.allFinite() && radius > 0.0;
}

Eigen::Vector3d weighted_mean(const std::vector<Eigen::Vector3d>& v, const std::vector<double>& w) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < v.size(); ++i) sum += w[i] * v[i];
  return sum;
}

// Direction along which the normals vary least: the axis of a cylinder or cone.
Eigen::Vector3d constant_angle_axis(const Sample& s) {
  const Eigen::Vector3d mean = weighted_mean(s.n, s.v);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < s.n.size(); ++i) cov += s.v[i] * (s.n[i] - mean) * (s.n[i] - mean).transpose();
  return smallest_eigenvector(cov);
}

// Height along and distance from an axis, for profile fits.
void profile(const Sample& s, const Eigen::Vector3d& origin, const Eigen::Vector3d& axis,
             std::vector<Eigen::Vector2d>& zr) {
  zr.resize(s.p.size());
  for (size_t i = 0; i < s.p.size(); ++i) {
    const AxialCoordinates c = axial_coordinates(origin, axis, s.p[i]);
    zr[i] = Eigen::Vector2d(c.height, c.distance);
  }
}

Surface seed_plane(const Sample& s) {
  Surface out;
  out.type = SurfaceType::Plane;
  out.point = weighted_mean(s.p, s.w);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < s.p.size(); ++i) cov += s.w[i] * (s.p[i] - out.point) * (s.p[i] - out.point).transpose();
  out.axis = smallest_eigenvector(cov);
  if (out.axis.dot(weighted_mean(s.n, s.v)) < 0.0) out.axis = -out.axis;
  return out;
}

Surface seed_sphere(const Sample& s) {
  Surface out;
  out.type = SurfaceType::Sphere;
  Eigen::Vector3d centre;
  algebraic_sphere<3>(s.p, s.w, centre, out.radius);  // a failed fit leaves an implausible sphere
  out.point = centre;
  return out;
}

// A cylinder's axis is perpendicular to all its normals. Across a narrow band their mean is long,
// and they vary least along it (to second order), not along the axis, where noise tilts them: the
// axis is then sought perpendicular to the mean.
Eigen::Vector3d cylinder_axis(const Sample& s) {
  const Eigen::Vector3d mean = weighted_mean(s.n, s.v);
  if (mean.norm() < 0.5) return constant_angle_axis(s);  // most of the way round
  Eigen::Vector3d e1, e2;
  orthonormal_frame(mean.normalized(), e1, e2);
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < s.n.size(); ++i) {
    const Eigen::Vector2d t(s.n[i].dot(e1), s.n[i].dot(e2));
    cov += s.v[i] * t * t.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(cov);
  const Eigen::Vector2d least = solver.eigenvectors().col(0);
  return (least.x() * e1 + least.y() * e2).normalized();
}

Surface seed_cylinder(const Sample& s) {
  Surface out;
  out.type = SurfaceType::Cylinder;
  out.axis = cylinder_axis(s);
  Eigen::Vector3d e1, e2;
  orthonormal_frame(out.axis, e1, e2);
  std::vector<Eigen::Vector2d> q(s.p.size());
  for (size_t i = 0; i < s.p.size(); ++i) q[i] = Eigen::Vector2d(s.p[i].dot(e1), s.p[i].dot(e2));
  Eigen::Vector2d centre;
  if (!algebraic_sphere<2>(q, s.w, centre, out.radius)) out.radius = 0.0;
  out.point = centre.x() * e1 + centre.y() * e2;
  return out;
}

Surface seed_cone(const Sample& s) {
  Surface out;
  out.type = SurfaceType::Cone;
  out.axis = constant_angle_axis(s);
  // Every normal line meets the axis: with the axis direction a known, its moment m = c × a
  // (m ⟂ a) solves a·(p × n) + n·m = 0 in the least-squares sense.
  Eigen::Vector3d e1, e2;
  orthonormal_frame(out.axis, e1, e2);
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < s.q.size(); ++i) {
    const Eigen::Vector2d row(s.n[i].dot(e1), s.n[i].dot(e2));
    a += s.v[i] * row * row.transpose();
    b -= s.v[i] * row * out.axis.dot(s.q[i].cross(s.n[i]));
  }
  const Eigen::Vector2d m = a.ldlt().solve(b);
  const Eigen::Vector3d origin = out.axis.cross(m.x() * e1 + m.y() * e2);
  // Profile: distance from the axis grows linearly with the height, ρ = ρ0 + t z.
  std::vector<Eigen::Vector2d> zr;
  profile(s, origin, out.axis, zr);
  Eigen::Matrix2d la = Eigen::Matrix2d::Zero();
  Eigen::Vector2d lb = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < zr.size(); ++i) {
    const Eigen::Vector2d row(1.0, zr[i].x());
    la += s.w[i] * row * row.transpose();
    lb += s.w[i] * row * zr[i].y();
  }
  Eigen::Vector2d line = la.ldlt().solve(lb);
  if (line[1] < 0.0) {
    out.axis = -out.axis;
    line[1] = -line[1];
  }
  out.half_angle = std::atan(line[1]);
  out.point = origin - (line[0] / line[1]) * out.axis;
  return out;
}

Surface seed_torus(const Sample& s) {
  // The axis (direction a, moment m) meets every normal line (n, p × n): a·(p × n) + n·m = 0,
  // the smallest eigenvector of the 6 x 6 moment matrix.
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  for (size_t i = 0; i < s.q.size(); ++i) {
    Eigen::Matrix<double, 6, 1> line;
    line << s.q[i].cross(s.n[i]), s.n[i];
    m += s.v[i] * line * line.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> solver(m);
  const Eigen::Matrix<double, 6, 1> x = solver.eigenvectors().col(0);
  Surface out;
  out.type = SurfaceType::Torus;
  Eigen::Vector3d a = x.head<3>(), moment = x.tail<3>();
  const double length = a.norm();
  if (!(length > 1e-9)) return out;  // normals all parallel: no axis
  moment -= (a.dot(moment) / (length * length)) * a;
  const Eigen::Vector3d origin = a.cross(moment) / (length * length);
  out.axis = a / length;
  std::vector<Eigen::Vector2d> zr;
  profile(s, origin, out.axis, zr);
  Eigen::Vector2d tube;
  if (!algebraic_sphere<2>(zr, s.w, tube, out.minor)) return out;
  out.point = origin + tube.x() * out.axis;
  out.radius = tube.y();
  return out;
}

Surface seed(SurfaceType type, const Sample& s) {
  switch (type) {
    case SurfaceType::Plane: return seed_plane(s);
    case SurfaceType::Sphere: return seed_sphere(s);
    case SurfaceType::Cylinder: return seed_cylinder(s);
    case SurfaceType::Cone: return seed_cone(s);
    case SurfaceType::Torus: return seed_torus(s);
    case SurfaceType::Freeform: break;
  }
  return Surface{};
}

double cost(const Surface& surface, const Sample& s, const std::vector<double>& w, std::vector<double>& d) {
  signed_distances(surface, s.p.data(), s.p.size(), d.data());
  double sum = 0.0;
  for (size_t i = 0; i < d.size(); ++i) sum += w[i] * d[i] * d[i];
  return sum;
}

// Levenberg–Marquardt on the weighted geometric distances, forward-difference Jacobian.
Surface refine(Surface surface, const Sample& s, const std::vector<double>& w, int max_iterations, bool lemon) {
  const int k = parameter_count(surface.type);
  const int n = static_cast<int>(s.p.size());
  if (n < k) return surface;
  constexpr double kStep = 1e-7;
  Eigen::MatrixXd jacobian(n, k);
  Eigen::VectorXd residual(n);
  std::vector<double> d(n), sqrt_w(n);
  for (int i = 0; i < n; ++i) sqrt_w[i] = std::sqrt(w[i]);
  double current = cost(surface, s, w, d);
  std::vector<double> d_current = d;  // distances to `surface`, kept from the accepted step's cost
  double lambda = 1e-3;
  for (int it = 0; it < max_iterations; ++it) {
    for (int i = 0; i < n; ++i) residual[i] = sqrt_w[i] * d_current[i];
    for (int j = 0; j < k; ++j) {
      double step[7] = {0, 0, 0, 0, 0, 0, 0};
      step[j] = kStep;
      signed_distances(perturbed(surface, step), s.p.data(), n, d.data());
      for (int i = 0; i < n; ++i) jacobian(i, j) = (sqrt_w[i] * d[i] - residual[i]) / kStep;
    }
    const Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
    const Eigen::VectorXd gradient = jacobian.transpose() * residual;
    bool improved = false;
    while (lambda < 1e12) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += lambda * (normal.diagonal().array() + 1e-12).matrix();
      const Eigen::VectorXd step = damped.ldlt().solve(-gradient);
      const Surface candidate = perturbed(surface, step.data());
      const double next = plausible(candidate, lemon) ? cost(candidate, s, w, d) : kInfinity;
      if (next < current) {
        const double decrease = current - next;
        surface = candidate;
        current = next;
        d_current.swap(d);
        lambda = std::max(lambda * 0.3, 1e-12);
        improved = decrease > 1e-10 * current;
        break;
      }
      lambda *= 4.0;
    }
    if (!improved) break;
  }
  return surface;
}

// Huber weights for residuals scaled by their robust spread (1.345 σ: 95 % efficiency on
// Gaussian noise).
std::vector<double> huber_weights(const Surface& surface, const Sample& s) {
  std::vector<double> distance(s.p.size());
  for (size_t i = 0; i < s.p.size(); ++i) distance[i] = std::abs(signed_distance(surface, s.p[i]));
  std::vector<double> sorted = distance;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double limit = 1.345 * 1.4826 * sorted[sorted.size() / 2];
  std::vector<double> w = s.w;
  double total = 0.0;
  for (size_t i = 0; i < w.size(); ++i) {
    if (limit > 0.0 && distance[i] > limit) w[i] *= limit / distance[i];
    total += w[i];
  }
  for (double& x : w) x /= total;
  return w;
}

Surface to_local(Surface s, const Eigen::Vector3d& centre, double scale) {
  s.point = (s.point - centre) / scale;
  s.radius /= scale;
  s.minor /= scale;
  return s;
}

Surface to_world(Surface s, const Eigen::Vector3d& centre, double scale) {
  s.point = centre + scale * s.point;
  s.radius *= scale;
  s.minor *= scale;
  return s;
}

}  // namespace

SurfaceFit fit_of(const Surface& surface, const FitData& data) {
  SurfaceFit fit;
  fit.surface = surface;
  fit.valid = true;
  fit_residuals(surface, data.points, data.weights, fit.rms, fit.max_error);
  return fit;
}

void fit_residuals(const Surface& surface, const MatrixX3d& points, const Eigen::VectorXd& weights,
                   double& rms, double& max_error) {
  double sum = 0.0, total = 0.0;
  max_error = 0.0;
  // Row-major rows of three doubles are an array of points.
  std::vector<double> distance(points.rows());
  signed_distances(surface, reinterpret_cast<const Eigen::Vector3d*>(points.data()), distance.size(), distance.data());
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const double d = distance[i];
    sum += weights[i] * d * d;
    total += weights[i];
    max_error = std::max(max_error, std::abs(d));
  }
  rms = total > 0.0 ? std::sqrt(sum / total) : 0.0;
}

double weighted_median(std::vector<std::pair<double, double>> values) {
  if (values.empty()) return 0.0;
  double total = 0.0;
  for (const auto& v : values) total += v.second;
  const double half = 0.5 * total;
  // The first value in ascending order at which the running weight reaches half the total: halve the
  // range that holds it around its middle value (expected linear time), then sort what is left.
  constexpr std::ptrdiff_t kSorted = 32;
  auto low = values.begin(), high = values.end();
  double below = 0.0;  // the weight before `low`
  while (high - low > kSorted) {
    const auto middle = low + (high - low) / 2;
    std::nth_element(low, middle, high);
    double through = below;
    for (auto v = low; v <= middle; ++v) through += v->second;
    if (through >= half) {
      high = middle + 1;
    } else {
      below = through;
      low = middle + 1;
    }
  }
  std::sort(low, high);
  for (auto v = low; v != high; ++v) {
    below += v->second;
    if (below >= half) return v->first;
  }
  return std::max_element(values.begin(), values.end())->first;  // weights that are not numbers
}

namespace {
// Medians and means of this many points and samples (an even subsample) are as good as of all.
constexpr Eigen::Index kStatisticsPoints = 2000;
}  // namespace

void measure_spreads(const FitData& data, SurfaceFit& fit) {
  const Eigen::Index point_stride = std::max<Eigen::Index>(1, data.points.rows() / kStatisticsPoints);
  const Eigen::Index sample_stride = std::max<Eigen::Index>(1, data.sample_points.rows() / kStatisticsPoints);
  std::vector<std::pair<double, double>> distance, angle;
  for (Eigen::Index i = 0; i < data.points.rows(); i += point_stride)
    distance.emplace_back(std::abs(signed_distance(fit.surface, data.points.row(i).transpose())), data.weights[i]);
  double sum = 0.0, total = 0.0;
  for (Eigen::Index i = 0; i < data.sample_points.rows(); i += sample_stride) {
    const Eigen::Vector3d n = surface_normal(fit.surface, data.sample_points.row(i).transpose());
    const double a = std::acos(std::min(std::abs(n.dot(data.sample_normals.row(i).transpose())), 1.0));
    angle.emplace_back(a, data.sample_weights[i]);
    sum += data.sample_weights[i] * a * a;
    total += data.sample_weights[i];
  }
  fit.normal_rms = total > 0.0 ? std::sqrt(sum / total) : 0.0;
  fit.spread = 1.4826 * weighted_median(std::move(distance));
  fit.normal_spread = 1.4826 * weighted_median(std::move(angle));
}

// sigma times the square root of the radius's diagonal entry of (J^T J)^-1, J the derivatives of
// the points' distances by the surface's parameters (the Gauss-Newton covariance of the fit), on an
// even subsample whose J^T J grows by its stride to that of all points.
double tube_radius_error(const Surface& surface, const MatrixX3d& points) {
  int radius_index = -1;  // of the radius among perturbed()'s parameters
  switch (surface.type) {
    case SurfaceType::Sphere: radius_index = 3; break;
    case SurfaceType::Cylinder: radius_index = 4; break;
    case SurfaceType::Torus: radius_index = 6; break;
    default: return 0.0;
  }
  const int k = parameter_count(surface.type);
  const Eigen::Index stride = std::max<Eigen::Index>(1, points.rows() / kStatisticsPoints);
  std::vector<Eigen::Vector3d> p;
  for (Eigen::Index i = 0; i < points.rows(); i += stride) p.push_back(points.row(i).transpose());
  const int n = static_cast<int>(p.size());
  if (n <= k) return std::numeric_limits<double>::infinity();
  // In the frame of the points' centre and spread, where the finite differences are well scaled;
  // a distance's derivative by the radius is the same in both frames.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& q : p) centre += q / n;
  double scale = 0.0;
  for (Eigen::Vector3d& q : p) {
    q -= centre;
    scale += q.squaredNorm() / n;
  }
  scale = std::sqrt(scale);
  if (!(scale > 0.0)) return std::numeric_limits<double>::infinity();
  for (Eigen::Vector3d& q : p) q /= scale;
  Surface local = to_local(surface, centre, scale);
  // A cylinder's axis tilts about its point: the one nearest the points, or the tilt would move
  // them as much as a shift does and the two would not be told apart.
  if (local.type == SurfaceType::Cylinder) local.point -= local.point.dot(local.axis) * local.axis;
  constexpr double kStep = 1e-5;  // central differences
  std::vector<double> ahead(n), behind(n);
  Eigen::MatrixXd jacobian(n, k);
  for (int j = 0; j < k; ++j) {
    double step[7] = {0, 0, 0, 0, 0, 0, 0};
    step[j] = kStep;
    signed_distances(perturbed(local, step), p.data(), n, ahead.data());
    step[j] = -kStep;
    signed_distances(perturbed(local, step), p.data(), n, behind.data());
    for (int i = 0; i < n; ++i) jacobian(i, j) = (ahead[i] - behind[i]) / (2 * kStep);
  }
  std::vector<double> distance(n);
  signed_distances(local, p.data(), n, distance.data());
  for (double& x : distance) x = std::abs(x);
  std::nth_element(distance.begin(), distance.begin() + n / 2, distance.end());
  const double sigma = 1.4826 * distance[n / 2] * scale;
  const Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
  const Eigen::LDLT<Eigen::MatrixXd> solver(normal);
  const Eigen::VectorXd column = solver.solve(Eigen::VectorXd::Unit(k, radius_index));
  const double variance = column[radius_index];
  if (solver.info() != Eigen::Success || !std::isfinite(variance) || !(variance > 0.0))
    return std::numeric_limits<double>::infinity();
  return sigma * std::sqrt(variance / stride);
}

FitData concatenate(const FitData& a, const FitData& b) {
  FitData out;
  out.points.resize(a.points.rows() + b.points.rows(), 3);
  out.points << a.points, b.points;
  out.weights.resize(out.points.rows());
  out.weights << a.weights, b.weights;
  out.sample_points.resize(a.sample_points.rows() + b.sample_points.rows(), 3);
  out.sample_points << a.sample_points, b.sample_points;
  out.sample_normals.resize(out.sample_points.rows(), 3);
  out.sample_normals << a.sample_normals, b.sample_normals;
  out.sample_weights.resize(out.sample_points.rows());
  out.sample_weights << a.sample_weights, b.sample_weights;
  return out;
}

SurfaceFit fit_surface(SurfaceType type, const FitData& data, const FitOptions& options, const Surface* start) {
  const MatrixX3d& points = data.points;
  const Eigen::VectorXd& weights = data.weights;
  SurfaceFit fit;
  fit.surface.type = type;
  const Eigen::Index count = points.rows();
  const double total = weights.sum();
  if (type == SurfaceType::Freeform || count < parameter_count(type) || !(total > 0.0)) return fit;

  const Eigen::Vector3d centre = (points.transpose() * weights) / total;
  const double scale = std::sqrt(((points.rowwise() - centre.transpose()).rowwise().squaredNorm().transpose() * weights)(0) / total);
  if (!(scale > 0.0)) return fit;

  Sample sample;
  const Eigen::Index stride = std::max<Eigen::Index>(1, (count + options.max_points - 1) / options.max_points);
  double sampled = 0.0;
  for (Eigen::Index i = 0; i < count; i += stride) {
    sample.p.push_back((points.row(i).transpose() - centre) / scale);
    sample.w.push_back(weights[i]);
    sampled += weights[i];
  }
  for (double& w : sample.w) w /= sampled;
  const Eigen::Index samples = data.sample_points.rows();
  const Eigen::Index sample_stride = std::max<Eigen::Index>(1, (samples + options.max_points - 1) / options.max_points);
  double sample_total = 0.0;
  for (Eigen::Index i = 0; i < samples; i += sample_stride) {
    sample.q.push_back((data.sample_points.row(i).transpose() - centre) / scale);
    sample.n.push_back(data.sample_normals.row(i).transpose());
    sample.v.push_back(data.sample_weights[i]);
    sample_total += data.sample_weights[i];
  }
  if (!(sample_total > 0.0)) return fit;
  for (double& v : sample.v) v /= sample_total;

  const Surface initial = start && start->type == type ? to_local(*start, centre, scale) : seed(type, sample);
  // The start decides whether a torus is a lemon (a seed only where options.lemons allows it); the
  // refinement does not cross from one to the other.
  const bool lemon = type == SurfaceType::Torus && initial.radius < 0.0 && (options.lemons || start);
  if (!plausible(initial, lemon) || initial.type != type) return fit;
  Surface refined = refine(initial, sample, sample.w, options.max_iterations, lemon);
  if (options.robust) refined = refine(refined, sample, huber_weights(refined, sample), options.max_iterations, lemon);

  // The refinement is kept only where it lowers the residual (on the points it saw).
  std::vector<double> d(sample.p.size());
  const bool better = cost(refined, sample, sample.w, d) <= cost(initial, sample, sample.w, d);
  fit.surface = to_world(better ? refined : initial, centre, scale);
  fit_residuals(fit.surface, points, weights, fit.rms, fit.max_error);
  fit.valid = plausible(fit.surface, lemon);
  measure_spreads(data, fit);
  return fit;
}

namespace {

// The circle through 2-D points of weights w (any scale): Taubin's algebraic fit, nearly unbiased on
// a short noisy arc where the plain algebraic fit shrinks the circle (G. Taubin, "Estimation of
// planar curves, surfaces and nonplanar space curves defined by implicit equations", IEEE PAMI
// 13(11), 1991; solved by Newton's method on its characteristic polynomial after N. Chernov), then
// Gauss-Newton steps on the geometric distances. False where the points lie on a line.
bool profile_circle(const std::vector<Eigen::Vector2d>& q, const Eigen::VectorXd& w, Eigen::Vector2d& centre,
                    double& radius) {
  double total = 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < q.size(); ++i) {
    total += w[i];
    mean += w[i] * q[i];
  }
  if (!(total > 0.0)) return false;
  mean /= total;
  double mxx = 0, myy = 0, mxy = 0, mxz = 0, myz = 0, mzz = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    const Eigen::Vector2d d = q[i] - mean;
    const double z = d.squaredNorm(), v = w[i] / total;
    mxx += v * d.x() * d.x();
    myy += v * d.y() * d.y();
    mxy += v * d.x() * d.y();
    mxz += v * d.x() * z;
    myz += v * d.y() * z;
    mzz += v * z * z;
  }
  const double mz = mxx + myy, cov_xy = mxx * myy - mxy * mxy, var_z = mzz - mz * mz;
  const double a3 = 4.0 * mz, a2 = -3.0 * mz * mz - mzz;
  const double a1 = var_z * mz + 4.0 * cov_xy * mz - mxz * mxz - myz * myz;
  const double a0 = mxz * (mxz * myy - myz * mxy) + myz * (myz * mxx - mxz * mxy) - var_z * cov_xy;
  double x = 0.0, y = a0;
  for (int iteration = 0; iteration < 20; ++iteration) {
    const double dy = a1 + x * (2.0 * a2 + 3.0 * a3 * x);
    const double next = x - y / dy;
    if (!std::isfinite(next)) return false;
    const double next_y = a0 + next * (a1 + next * (a2 + next * a3));
    if (std::abs(next_y) >= std::abs(y)) break;
    x = next;
    y = next_y;
  }
  const double det = x * x - x * mz + cov_xy;
  if (!(std::abs(det) > 0.0)) return false;
  centre = mean + Eigen::Vector2d(mxz * (myy - x) - myz * mxy, myz * (mxx - x) - mxz * mxy) / (2.0 * det);
  radius = std::sqrt((centre - mean).squaredNorm() + mz);
  // Gauss-Newton on the distances |q - c| - r, kept while they shrink.
  auto cost = [&](const Eigen::Vector2d& c, double r) {
    double sum = 0.0;
    for (size_t i = 0; i < q.size(); ++i) sum += w[i] * std::pow((q[i] - c).norm() - r, 2);
    return sum;
  };
  double current = cost(centre, radius);
  for (int iteration = 0; iteration < 20 && std::isfinite(current); ++iteration) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < q.size(); ++i) {
      const Eigen::Vector2d d = q[i] - centre;
      const double length = d.norm();
      if (!(length > 0.0)) continue;
      const Eigen::Vector3d j(-d.x() / length, -d.y() / length, -1.0);
      jtj += w[i] * j * j.transpose();
      jtr += w[i] * j * (length - radius);
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) break;
    const Eigen::Vector2d next_centre = centre + step.head<2>();
    const double next_radius = radius + step.z(), next = cost(next_centre, next_radius);
    if (!(next < current)) break;
    centre = next_centre;
    radius = next_radius;
    current = next;
  }
  return centre.allFinite() && std::isfinite(radius) && radius > 0.0;
}

}  // namespace

SurfaceFit fit_about_axis(SurfaceType type, const FitData& data, const Eigen::Vector3d& origin,
                          const Eigen::Vector3d& axis) {
  SurfaceFit fit;
  fit.surface.type = type;
  const double total = data.weights.sum();
  const bool torus = type == SurfaceType::Torus;
  if ((type != SurfaceType::Cylinder && type != SurfaceType::Cone && !torus) || data.points.rows() < (torus ? 3 : 2) ||
      !(total > 0.0))
    return fit;
  // Profile: height z along the axis, distance ρ from it; weighted means and covariance.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> zr(data.points.rows());
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) {
    const AxialCoordinates c = axial_coordinates(origin, axis, data.points.row(i).transpose());
    zr[i] = Eigen::Vector2d(c.height, c.distance);
    mean += data.weights[i] * zr[i];
  }
  mean /= total;
  Surface& s = fit.surface;
  s.axis = axis;
  if (type == SurfaceType::Cylinder) {
    s.point = origin;
    s.radius = mean.y();
  } else if (torus) {
    // The profile's circle: its centre's height fixes the centre, its distance from the axis the
    // major radius (negative beyond the axis: a lemon), its radius the minor one.
    Eigen::Vector2d centre;
    double radius;
    if (!profile_circle(zr, data.weights, centre, radius)) return fit;
    s.point = origin + centre.x() * axis;
    s.radius = centre.y();
    s.minor = radius;
    if (!plausible(s, s.radius < 0.0)) return fit;
    fit_residuals(s, data.points, data.weights, fit.rms, fit.max_error);
    fit.valid = true;
    return fit;
  } else {
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (size_t i = 0; i < zr.size(); ++i) cov += data.weights[i] * (zr[i] - mean) * (zr[i] - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(cov);
    Eigen::Vector2d line = solver.eigenvectors().col(1);  // along the profile
    if (line.y() < 0.0) line = -line;                     // ρ grows along it
    if (!(line.x() != 0.0) || !(line.y() > 0.0)) return fit;  // along or across the axis
    const double sign = line.x() < 0.0 ? -1.0 : 1.0;         // the cone opens along sign · axis
    s.axis = sign * axis;
    const double along = std::abs(line.x());
    s.half_angle = std::atan2(line.y(), along);
    // The apex: where the profile line meets the axis (ρ = 0), as a height along s.axis.
    const double z_apex = sign * mean.x() - mean.y() * along / line.y();
    s.point = origin + z_apex * s.axis;
  }
  if (!plausible(s)) return fit;
  fit_residuals(s, data.points, data.weights, fit.rms, fit.max_error);
  fit.valid = true;
  return fit;
}

}  // namespace idealize
