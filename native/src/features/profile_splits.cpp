#include "features/profile_splits.h"

#include "features/section_profile.h"
#include "fit/fits_as_well.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <utility>

#include <Eigen/Eigenvalues>

namespace idealize {
namespace {

using detail::distinct_vertices;
using detail::even_sample;
using detail::Section;
using detail::Vector2;

// The section through the axis of `s` (a cylinder, cone or torus), from its point.
Section axial_section(const Surface& s) {
  Section section;
  section.around_axis = true;
  section.origin = s.point;
  section.direction = s.axis;
  orthonormal_frame(section.direction, section.e1, section.e2);
  return section;
}

// The median spread of the features that have a surface (0 if none).
double typical_feature_spread(const std::vector<Feature>& features) {
  std::vector<double> spreads;
  for (const Feature& f : features)
    if (f.type != SurfaceType::Freeform) spreads.push_back(f.spread);
  if (spreads.empty()) return 0.0;
  std::nth_element(spreads.begin(), spreads.begin() + spreads.size() / 2, spreads.end());
  return spreads[spreads.size() / 2];
}

// The faces of each feature of one of `types` (none for the others).
std::vector<std::vector<int>> faces_of_features(const std::vector<int>& labels, const std::vector<Feature>& features,
                                                std::initializer_list<SurfaceType> types) {
  std::vector<std::vector<int>> faces(features.size());
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] >= 0 && std::find(types.begin(), types.end(), features[labels[f]].type) != types.end())
      faces[labels[f]].push_back(static_cast<int>(f));
  return faces;
}

// The profile (`profile` of each point) of the vertices of `faces` (feature `label`) that only its
// faces touch: the rim of a scan's patch lies on the rounded-off edges. All of them where fewer
// than `least` are inside. `seen` (#V, all 0) is left as it was.
template <class ProfileOf>
std::vector<Vector2> inner_profile(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                                   int label, const std::vector<int>& faces, int least, const ProfileOf& profile,
                                   std::vector<char>& seen) {
  std::vector<Vector2> inside, rim;
  for (int v : distinct_vertices(mesh, faces, seen)) {
    const bool interior = std::all_of(topology.vertex_faces_begin(v), topology.vertex_faces_end(v),
                                      [&](int f) { return labels[f] == label; });
    (interior ? inside : rim).push_back(profile(mesh.V.row(v).transpose()));
  }
  if (static_cast<int>(inside.size()) < least) inside.insert(inside.end(), rim.begin(), rim.end());
  return inside;
}

// What the finders measure of the mesh first: its median edge length (0 for none), the share of
// its residuals that counts as independent, and the typical feature's spread.
struct MeshScale {
  double edge = 0.0, independent = 0.0, typical_spread = 0.0;
};

MeshScale mesh_scale(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<Feature>& features,
                     const std::vector<int>& labels) {
  MeshScale scale;
  scale.edge = median_edge_length(mesh, topology);
  if (!(scale.edge > 0.0)) return scale;
  scale.independent = independent_share(mesh, features, labels);
  scale.typical_spread = typical_feature_spread(features);
  return scale;
}

// A circle of the section continued, past the point where its outward normal is `normal`, by its
// tangent line running along `along` (perpendicular to it): points past that point along `along`
// lie on the line, the others on the circle. `circle`: centre (2) and radius.
struct Continuation {
  Vector2 normal = Vector2::UnitX(), along = Vector2::UnitY();
};

double continuation_residual(const Eigen::Vector3d& circle, const Continuation* continuation, const Vector2& x) {
  const Vector2 centre = circle.head<2>();
  if (continuation) {
    const Vector2 touch = centre + circle.z() * continuation->normal;
    if ((x - touch).dot(continuation->along) > 0.0) return (x - touch).dot(continuation->normal);
  }
  return (x - centre).norm() - circle.z();
}

// The least sum of squared residuals of `points` over the circle (Gauss-Newton from `circle`,
// which returns the best), continued or not.
double fit_continuation(const std::vector<Vector2>& points, const Continuation* continuation, Eigen::Vector3d& circle) {
  auto sum_of_squares = [&](const Eigen::Vector3d& c) {
    double sum = 0.0;
    for (const Vector2& x : points) sum += std::pow(continuation_residual(c, continuation, x), 2);
    return sum;
  };
  double best = sum_of_squares(circle);
  for (int iteration = 0; iteration < 8; ++iteration) {
    const double step = 1e-6 * std::max(std::abs(circle.z()), circle.head<2>().norm());
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (const Vector2& x : points) {
      const double r = continuation_residual(circle, continuation, x);
      Eigen::Vector3d gradient;
      for (int k = 0; k < 3; ++k)
        gradient[k] = (continuation_residual(circle + step * Eigen::Vector3d::Unit(k), continuation, x) - r) / step;
      normal += gradient * gradient.transpose();
      rhs -= gradient * r;
    }
    normal.diagonal().array() += 1e-12 * (normal.trace() + 1.0);
    const Eigen::Vector3d next = circle + normal.ldlt().solve(rhs);
    const double value = sum_of_squares(next);
    if (!(value < best)) break;
    best = value;
    circle = next;
  }
  return best;
}

// Running sums of profile points (distance from the axis, height) sorted by height, from which
// the total least squares line of any run of them and its sum of squared distances follow at once.
class ProfileRuns {
 public:
  explicit ProfileRuns(const std::vector<Vector2>& sorted) : sums_(sorted.size() + 1, Sums{}) {
    for (size_t i = 0; i < sorted.size(); ++i) {
      const Vector2& x = sorted[i];
      sums_[i + 1] = sums_[i];
      Sums& s = sums_[i + 1];
      s.n += 1.0, s.r += x.x(), s.z += x.y(), s.rr += x.x() * x.x(), s.zz += x.y() * x.y(), s.rz += x.x() * x.y();
    }
  }
  // The line of points [begin, end): its mean point and unit direction (rising in height); the
  // sum of squared distances from it.
  double line(size_t begin, size_t end, Vector2& mean, Vector2& direction) const {
    const Sums &a = sums_[begin], &b = sums_[end];
    const double n = b.n - a.n;
    mean = Vector2(b.r - a.r, b.z - a.z) / n;
    Eigen::Matrix2d scatter;
    scatter << b.rr - a.rr - n * mean.x() * mean.x(), b.rz - a.rz - n * mean.x() * mean.y(),
        b.rz - a.rz - n * mean.x() * mean.y(), b.zz - a.zz - n * mean.y() * mean.y();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
    direction = eigen.eigenvectors().col(1);
    if (direction.y() < 0.0) direction = -direction;
    return std::max(eigen.eigenvalues()[0], 0.0);
  }
  double sum(size_t begin, size_t end) const {
    Vector2 mean, direction;
    return line(begin, end, mean, direction);
  }

 private:
  struct Sums {
    double n = 0.0, r = 0.0, z = 0.0, rr = 0.0, zz = 0.0, rz = 0.0;
  };
  std::vector<Sums> sums_;
};

// The least sum of squared residuals of a profile's points from a parabola about its line through
// `mean` along `direction` (the offset across the line quadratic in the length along it).
double parabola_sum(const std::vector<Vector2>& profile, const Vector2& mean, const Vector2& direction) {
  const int n = static_cast<int>(profile.size());
  std::vector<double> along(n);
  for (int i = 0; i < n; ++i) along[i] = (profile[i] - mean).dot(direction);
  const auto [low, high] = std::minmax_element(along.begin(), along.end());
  const double middle = 0.5 * (*low + *high), scale = std::max(0.5 * (*high - *low), 1e-12);
  Eigen::MatrixX3d design(n, 3);
  Eigen::VectorXd offset(n);
  for (int i = 0; i < n; ++i) {
    const double t = (along[i] - middle) / scale;
    design.row(i) << 1.0, t, t * t;
    const Vector2 v = profile[i] - mean;
    offset[i] = v.x() * direction.y() - v.y() * direction.x();
  }
  const Eigen::Vector3d c = design.colPivHouseholderQr().solve(offset);
  return (design * c - offset).squaredNorm();
}

// The surface about `axis` through `origin` whose profile is the line through `mean` along
// `direction` (distance from the axis, height): a cylinder, a plane across the axis or a cone.
Surface revolved_line(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis, const Vector2& mean,
                      const Vector2& direction, double angle_tolerance) {
  Surface s;
  s.axis = axis;
  if (std::abs(direction.x()) < std::sin(angle_tolerance)) {
    s.type = SurfaceType::Cylinder;
    s.point = origin;
    s.radius = mean.x();
  } else if (std::abs(direction.y()) < std::sin(angle_tolerance)) {
    s.type = SurfaceType::Plane;
    s.point = origin + mean.y() * axis;
  } else {  // the apex where the line meets the axis; the axis towards the opening
    s.type = SurfaceType::Cone;
    const double slope = direction.x() / direction.y();  // radius gained per height
    s.point = origin + (mean.y() - mean.x() / slope) * axis;
    s.half_angle = std::atan(std::abs(slope));
    if (slope < 0.0) s.axis = -axis;
  }
  return s;
}

// Gives feature t the first of `surfaces` and the faces of `parts[0]`, and makes each other part a
// new feature of its surface, relabelling its faces; marks all of them changed.
void split_feature(size_t t, const std::vector<Surface>& surfaces, const std::vector<std::vector<int>>& parts,
                   std::vector<Feature>& features, std::vector<int>& labels, std::vector<char>& changed) {
  for (size_t i = 0; i < surfaces.size(); ++i) {
    int id = static_cast<int>(t);
    if (i > 0) {
      id = static_cast<int>(features.size());
      features.emplace_back();
      features.back().id = id;
      changed.push_back(0);
    }
    Feature& f = features[id];
    f.surface = surfaces[i];
    f.type = f.curvature_type = surfaces[i].type;
    for (int face : parts[i]) labels[face] = id;
    changed[id] = 1;
  }
}

}  // namespace

std::vector<char> split_tangent_continuations(const TriangleMesh& mesh, const MeshTopology& topology,
                                              const EdgeFilletOptions& options, std::vector<Feature>& features,
                                              std::vector<int>& labels) {
  std::vector<char> changed(features.size(), 0);
  const MeshScale scale = mesh_scale(mesh, topology, features, labels);
  if (!(scale.edge > 0.0)) return changed;
  const double edge = scale.edge, independent = scale.independent;
  std::vector<std::vector<int>> faces_of = faces_of_features(labels, features, {SurfaceType::Torus});
  std::vector<char> vertex_seen(mesh.num_vertices(), 0);
  const size_t existing = features.size();
  for (size_t t = 0; t < existing; ++t) {
    if (features[t].type != SurfaceType::Torus) continue;
    const Surface torus = features[t].surface;
    const Section section = axial_section(torus);
    std::vector<Vector2> profile;
    for (int v : distinct_vertices(mesh, faces_of[t], vertex_seen)) profile.push_back(section.profile(mesh.V.row(v).transpose()));
    if (static_cast<int>(profile.size()) <= 2 * parameter_count(SurfaceType::Torus)) continue;
    const std::vector<Vector2> sample = even_sample(profile);
    const int n = static_cast<int>(sample.size());

    // The tube's circle alone, and continued by a line along the axis or across it at one of its
    // four tangent points, each way: as many parameters, and the better one is kept where it fits
    // better by more than one more parameter would (the choice among the eight).
    Eigen::Vector3d circle(torus.radius, 0.0, torus.minor);
    const double alone = fit_continuation(sample, nullptr, circle);
    double best = std::numeric_limits<double>::infinity();
    Continuation chosen;
    Eigen::Vector3d continued = circle;
    for (const Vector2& normal : {Vector2(1, 0), Vector2(-1, 0), Vector2(0, 1), Vector2(0, -1)})
      for (double sign : {1.0, -1.0}) {
        const Continuation c{normal, sign * Vector2(-normal.y(), normal.x())};
        Eigen::Vector3d fitted = circle;
        const double value = fit_continuation(sample, &c, fitted);
        if (value < best) best = value, chosen = c, continued = fitted;
      }
    const double variance = best / std::max(n - 3, 1);
    if (!(independent * (alone - best) > std::log(std::max(independent * n, 2.0)) * variance)) continue;
    const Vector2 centre = continued.head<2>(), touch = centre + continued.z() * chosen.normal;
    if (!(centre.x() > continued.z() && continued.z() > 0.0)) continue;  // a ring torus still

    // The faces past the tangent point go to the line's surface: a cylinder along the axis, or a
    // plane across it.
    std::vector<int> past, kept;
    double length = 0.0;  // how far the line runs past the tangent point
    for (int f : faces_of[t]) {
      const double beyond = (section.profile(face_centroid(mesh, f)) - touch).dot(chosen.along);
      (beyond > 0.0 ? past : kept).push_back(f);
      length = std::max(length, beyond);
    }
    // Both parts must be features, and the line longer than a sharp edge's rounding.
    if (static_cast<int>(distinct_vertices(mesh, past, vertex_seen).size()) <= 2 * parameter_count(SurfaceType::Cylinder) ||
        static_cast<int>(distinct_vertices(mesh, kept, vertex_seen).size()) <= 2 * parameter_count(SurfaceType::Torus) ||
        length < options.shortest_arc * edge)
      continue;
    Feature line;  // a cylinder (the line along the axis) or a plane across it
    line.id = static_cast<int>(features.size());
    line.surface = revolved_line(torus.point, torus.axis, touch, chosen.along, options.angle_tolerance);
    if (line.surface.type == SurfaceType::Cylinder && !(touch.x() > 0.0)) continue;
    line.type = line.curvature_type = line.surface.type;
    Surface& ring = features[t].surface;
    ring.point = torus.point + centre.y() * torus.axis;
    ring.radius = centre.x();
    ring.minor = continued.z();
    for (int f : past) labels[f] = line.id;
    features.push_back(line);
    changed.resize(features.size(), 0);
    changed[t] = changed.back() = 1;
  }
  return changed;
}

std::vector<char> split_coaxial_steps(const TriangleMesh& mesh, const MeshTopology& topology,
                                      const EdgeFilletOptions& options, std::vector<Feature>& features,
                                      std::vector<int>& labels) {
  std::vector<char> changed(features.size(), 0);
  const MeshScale scale = mesh_scale(mesh, topology, features, labels);
  if (!(scale.edge > 0.0)) return changed;
  const double edge = scale.edge, independent = scale.independent, typical_spread = scale.typical_spread;
  std::vector<std::vector<int>> faces_of = faces_of_features(labels, features, {SurfaceType::Cylinder, SurfaceType::Cone});
  std::vector<char> vertex_seen(mesh.num_vertices(), 0);
  // A split part is split again: a counterbore's two cylinders and the cone between them.
  for (size_t t = 0; t < features.size(); ++t) {
    if (features[t].type != SurfaceType::Cylinder && features[t].type != SurfaceType::Cone) continue;
    const Surface source = features[t].surface;
    const Eigen::Vector3d axis = source.axis, origin = source.point;
    const Section section = axial_section(source);
    auto profile = [&](const Eigen::Vector3d& p) { return section.profile(p); };
    const int least = 2 * parameter_count(SurfaceType::Cone);  // points on each side of a step
    std::vector<Vector2> sample =
        even_sample(inner_profile(mesh, topology, labels, static_cast<int>(t), faces_of[t], 2 * least, profile, vertex_seen));
    const int n = static_cast<int>(sample.size());
    if (n < 2 * least) continue;
    std::sort(sample.begin(), sample.end(), [](const Vector2& a, const Vector2& b) { return a.y() < b.y(); });

    // One line, or two meeting at a height (a step, a bend): three parameters more, kept where
    // the BIC over the independent residuals prefers them.
    const ProfileRuns runs(sample);
    const double whole = runs.sum(0, n);
    double best = std::numeric_limits<double>::infinity();
    int split = 0;
    for (int k = least; k <= n - least; ++k) {
      const double value = runs.sum(0, k) + runs.sum(k, n);
      if (value < best) best = value, split = k;
    }
    // The BIC prefers the step to the one line and to a smooth bend of the profile with two
    // parameters less (a parabola about the line: a sculpted part's undulation, the profile of a
    // torus taken for a cylinder).
    const double variance = best / std::max(n - 5, 1), penalty = std::log(std::max(independent * n, 2.0)) * variance;
    Vector2 mean, direction;
    runs.line(0, n, mean, direction);
    const double bend = parabola_sum(sample, mean, direction);
    if (!(independent * (whole - best) > 3.0 * penalty) || !(independent * (bend - best) > 2.0 * penalty))
      continue;
    if (sample[split - 1].y() - sample.front().y() < options.shortest_arc * edge ||
        sample.back().y() - sample[split].y() < options.shortest_arc * edge)
      continue;  // a part no longer than a rounded-off edge

    Vector2 lower_mean, lower_direction, upper_mean, upper_direction;
    runs.line(0, split, lower_mean, lower_direction);
    runs.line(split, n, upper_mean, upper_direction);
    const Surface lower = revolved_line(origin, axis, lower_mean, lower_direction, options.angle_tolerance);
    const Surface upper = revolved_line(origin, axis, upper_mean, upper_direction, options.angle_tolerance);
    // A cylinder beside another of a clearly different radius (a long cylinder's undulation tilts its
    // halves' profiles apart; relations take radii that close for equal), or beside a cone. Not two
    // cones: a short cone's fitted axis may tilt, and then its profile about it smears into a band
    // that two lines fit better than one.
    if (lower.type == SurfaceType::Plane || upper.type == SurfaceType::Plane ||
        (lower.type != SurfaceType::Cylinder && upper.type != SurfaceType::Cylinder))
      continue;
    if (lower.type == upper.type && std::abs(lower.radius - upper.radius) <=
                                        options.radius_tolerance * std::max(lower.radius, upper.radius) + features[t].spread)
      continue;

    // Each face goes to the part whose line alone explains its centroid; by height where both lines
    // or neither do (at a bend; the rim).
    auto near = [&](const Vector2& x, const Vector2& mean, const Vector2& direction) {
      const Vector2 v = x - mean;
      return fits_as_well(std::abs(v.x() * direction.y() - v.y() * direction.x()), typical_spread, options.residual_ratio);
    };
    const double height = 0.5 * (sample[split - 1].y() + sample[split].y());
    std::vector<int> below, above;
    for (int f : faces_of[t]) {
      const Vector2 x = profile(face_centroid(mesh, f));
      const bool near_lower = near(x, lower_mean, lower_direction), near_upper = near(x, upper_mean, upper_direction);
      (near_lower != near_upper ? near_lower : x.y() < height) ? below.push_back(f) : above.push_back(f);
    }
    if (static_cast<int>(distinct_vertices(mesh, below, vertex_seen).size()) <= least ||
        static_cast<int>(distinct_vertices(mesh, above, vertex_seen).size()) <= least)
      continue;
    split_feature(t, {lower, upper}, {below, above}, features, labels, changed);
    faces_of[t] = below;
    faces_of.push_back(above);
    --t;  // each part may step again
  }
  return changed;
}

std::vector<char> split_cornered_tori(const TriangleMesh& mesh, const MeshTopology& topology,
                                      const EdgeFilletOptions& options, std::vector<Feature>& features,
                                      std::vector<int>& labels) {
  std::vector<char> changed(features.size(), 0);
  const MeshScale scale = mesh_scale(mesh, topology, features, labels);
  if (!(scale.edge > 0.0)) return changed;
  const double edge = scale.edge, independent = scale.independent, typical_spread = scale.typical_spread;
  const std::vector<std::vector<int>> faces_of = faces_of_features(labels, features, {SurfaceType::Torus});
  std::vector<char> vertex_seen(mesh.num_vertices(), 0);
  const size_t existing = features.size();
  for (size_t t = 0; t < existing; ++t) {
    if (features[t].type != SurfaceType::Torus) continue;
    const Surface torus = features[t].surface;
    const Section section = axial_section(torus);
    auto profile = [&](const Eigen::Vector3d& p) { return section.profile(p); };
    const int least = 2 * parameter_count(SurfaceType::Cone);  // points on each line
    const std::vector<Vector2> points = even_sample(
        inner_profile(mesh, topology, labels, static_cast<int>(t), faces_of[t], 3 * least, profile, vertex_seen));
    const int n = static_cast<int>(points.size());
    if (n < 3 * least) continue;
    // Only a torus that its patch's profile does not fit as well as the mesh's features fit theirs
    // (lines placed as the nearest to each point fit a small arc's noise better than the arc does).
    Eigen::Vector3d circle(torus.radius, 0.0, torus.minor);
    const double round = fit_continuation(points, nullptr, circle);
    if (fits_as_well(std::sqrt(round / (n - 3)), typical_spread, options.residual_ratio)) continue;

    // Lines along the axis (cylinders) and across it (planes) in turn, each point on the nearest:
    // a corner (one of each) or a step (three). Fitted from the extreme distances and heights of
    // the points by alternating assignment and refit; the parameters counted are the lines'
    // positions and, for each corner between them, one more (where it lies on either line).
    std::vector<double> radii, heights;
    for (const Vector2& x : points) radii.push_back(x.x()), heights.push_back(x.y());
    std::sort(radii.begin(), radii.end());
    std::sort(heights.begin(), heights.end());
    const double r_low = radii[n / 20], r_high = radii[n - 1 - n / 20], z_low = heights[n / 20],
                 z_high = heights[n - 1 - n / 20], z_middle = heights[n / 2], r_middle = radii[n / 2];
    struct Staircase {
      std::vector<std::pair<bool, double>> lines;  // (along the axis, its distance or height)
      double sum = std::numeric_limits<double>::infinity();
    };
    auto nearest = [](const Staircase& c, const Vector2& x, double& residual) {
      int best = 0;
      residual = std::numeric_limits<double>::infinity();
      for (size_t i = 0; i < c.lines.size(); ++i) {
        const double r = (c.lines[i].first ? x.x() : x.y()) - c.lines[i].second;
        if (std::abs(r) < std::abs(residual)) residual = r, best = static_cast<int>(i);
      }
      return best;
    };
    auto fit = [&](Staircase c) {
      for (int iteration = 0; iteration < 10; ++iteration) {
        std::vector<double> total(c.lines.size(), 0.0);
        std::vector<int> count(c.lines.size(), 0);
        c.sum = 0.0;
        for (const Vector2& x : points) {
          double residual;
          const int line = nearest(c, x, residual);
          c.sum += residual * residual;
          total[line] += c.lines[line].first ? x.x() : x.y();
          ++count[line];
        }
        for (size_t i = 0; i < c.lines.size(); ++i)
          if (count[i] < least) return Staircase{};  // a line without points of its own
          else c.lines[i].second = total[i] / count[i];
      }
      return c;
    };
    std::vector<Staircase> candidates;
    for (double r : {r_low, r_high})
      for (double z : {z_low, z_high}) candidates.push_back(fit(Staircase{{{true, r}, {false, z}}, 0.0}));
    candidates.push_back(fit(Staircase{{{true, r_low}, {false, z_middle}, {true, r_high}}, 0.0}));
    candidates.push_back(fit(Staircase{{{false, z_low}, {true, r_middle}, {false, z_high}}, 0.0}));
    double smallest = round;
    for (const Staircase& c : candidates) smallest = std::min(smallest, c.sum);
    const int circle_parameters = 3;
    const double variance = smallest / std::max(n - 5, 1), penalty = std::log(std::max(independent * n, 2.0)) * variance;
    const Staircase* chosen = nullptr;
    double best_score = independent * round;
    for (const Staircase& c : candidates) {
      if (c.lines.empty()) continue;
      const int extra = 2 * static_cast<int>(c.lines.size()) - 1 - circle_parameters;
      const double score = independent * c.sum + extra * penalty;
      if (score < best_score) best_score = score, chosen = &c;
    }
    if (!chosen) continue;

    // The faces go to the line nearest their centroid; each line must run longer than a
    // rounded-off edge.
    std::vector<std::vector<int>> parts(chosen->lines.size());
    std::vector<double> low(parts.size(), std::numeric_limits<double>::infinity()), high(parts.size(), -low[0]);
    for (int f : faces_of[t]) {
      const Vector2 x = profile(face_centroid(mesh, f));
      double residual;
      const int line = nearest(*chosen, x, residual);
      parts[line].push_back(f);
      const double position = chosen->lines[line].first ? x.y() : x.x();
      low[line] = std::min(low[line], position), high[line] = std::max(high[line], position);
    }
    std::vector<Surface> lines;
    bool long_enough = true;
    for (size_t i = 0; i < parts.size(); ++i) {
      const auto [along_axis, position] = chosen->lines[i];
      long_enough &= high[i] - low[i] >= options.shortest_arc * edge && (!along_axis || position > 0.0);
      lines.push_back(revolved_line(torus.point, torus.axis, along_axis ? Vector2(position, 0.0) : Vector2(0.0, position),
                                    along_axis ? Vector2(0.0, 1.0) : Vector2(1.0, 0.0), options.angle_tolerance));
    }
    if (!long_enough) continue;
    bool features_each = true;
    for (const std::vector<int>& part : parts)
      features_each &= static_cast<int>(distinct_vertices(mesh, part, vertex_seen).size()) > least;
    if (features_each) split_feature(t, lines, parts, features, labels, changed);
  }
  return changed;
}

}  // namespace idealize
