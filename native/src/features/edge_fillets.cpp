#include "features/edge_fillets.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <utility>

#include <Eigen/Eigenvalues>

namespace idealize {
namespace {

using Vector2 = Eigen::Vector2d;

// The band's vertices are fitted on an even subsample of at most this many, about a hundred of them
// near the arc (half as many left the radius of one of the NIST parts' small fillets 15 % short).
constexpr int kSamplePoints = 400;

// The plane of the cross-section in which two features' surfaces are lines meeting at a corner:
// across the line where two planes meet (`around_axis` false: a fillet is a cylinder along it), or
// through the axis of a cylinder or cone and a plane across it (a fillet is a torus about it).
struct Section {
  bool around_axis = false;
  Eigen::Vector3d origin, direction;  // a point of the planes' line and its direction; or of the axis
  Eigen::Vector3d e1, e2;             // the section's axes across the line; or a frame across the axis

  // Coordinates in the section: along e1 and e2; or distance from the axis and height along it.
  Vector2 profile(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - origin;
    if (!around_axis) return {q.dot(e1), q.dot(e2)};
    const double z = q.dot(direction);
    return {(q - z * direction).norm(), z};
  }
  // Where along the edge: the length along the line, or the angle about the axis.
  double position(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - origin;
    return around_axis ? std::atan2(q.dot(e2), q.dot(e1)) : q.dot(direction);
  }
};

// The section through the axis of `s` (a cylinder, cone or torus), from its point.
Section axial_section(const Surface& s) {
  Section section;
  section.around_axis = true;
  section.origin = s.point;
  section.direction = s.axis;
  orthonormal_frame(section.direction, section.e1, section.e2);
  return section;
}

// A surface's line in the section: a point of it and a unit direction.
struct ProfileLine {
  Vector2 point, direction;
};

// The line of `s` in `section`: a plane through its line, or across its axis; a cylinder or cone
// about the axis. None for anything else.
std::optional<ProfileLine> profile_line(const Surface& s, const Section& section, double angle_tolerance) {
  const double parallel = std::cos(angle_tolerance);
  if (!section.around_axis) {
    if (s.type != SurfaceType::Plane) return std::nullopt;
    const Eigen::Vector3d in_plane = section.direction.cross(s.axis).normalized();
    return ProfileLine{Vector2::Zero(), Vector2(in_plane.dot(section.e1), in_plane.dot(section.e2)).normalized()};
  }
  const double along = s.axis.dot(section.direction);
  if (std::abs(along) < parallel) return std::nullopt;
  switch (s.type) {
    case SurfaceType::Plane:
      return ProfileLine{Vector2(0.0, (s.point - section.origin).dot(section.direction)), Vector2(1.0, 0.0)};
    case SurfaceType::Cylinder:
      return ProfileLine{Vector2(s.radius, 0.0), Vector2(0.0, 1.0)};
    case SurfaceType::Cone:  // from the apex, widening along the cone's axis
      return ProfileLine{Vector2(0.0, (s.point - section.origin).dot(section.direction)),
                         Vector2(std::sin(s.half_angle), along > 0.0 ? std::cos(s.half_angle) : -std::cos(s.half_angle))};
    default:
      return std::nullopt;
  }
}

// The section of two adjacent features meeting at an angle, or none: two planes; a plane across the
// axis of a cylinder or cone (their axis; the plane's normal within the angle tolerance of it); a
// cone and a cylinder or cone about one axis (within the angle tolerance, and the second's axis
// passing within `off_axis` of the first's).
std::optional<Section> section_between(const Surface& a, const Surface& b, double angle_tolerance, double off_axis) {
  auto revolved = [](const Surface& s) { return s.type == SurfaceType::Cylinder || s.type == SurfaceType::Cone; };
  Section section;
  if (a.type == SurfaceType::Plane && b.type == SurfaceType::Plane) {
    const Eigen::Vector3d direction = a.axis.cross(b.axis);
    if (direction.norm() < std::sin(angle_tolerance)) return std::nullopt;
    section.direction = direction.normalized();
    Eigen::Matrix3d rows;
    rows << a.axis.transpose(), b.axis.transpose(), section.direction.transpose();
    section.origin = rows.colPivHouseholderQr().solve(Eigen::Vector3d(a.axis.dot(a.point), b.axis.dot(b.point), 0.0));
  } else if (a.type == SurfaceType::Plane || b.type == SurfaceType::Plane) {
    const Surface& round = a.type == SurfaceType::Plane ? b : a;
    if (!revolved(round)) return std::nullopt;
    section.around_axis = true;
    section.direction = round.axis;
    section.origin = round.point;
  } else if (revolved(a) && revolved(b) && (a.type == SurfaceType::Cone || b.type == SurfaceType::Cone)) {
    if (std::abs(a.axis.dot(b.axis)) < std::cos(angle_tolerance) ||
        axial_coordinates(a.point, a.axis, b.point).distance > off_axis)
      return std::nullopt;
    section.around_axis = true;
    section.direction = a.axis;
    section.origin = a.point;
  } else {
    return std::nullopt;
  }
  orthonormal_frame(section.direction, section.e1, section.e2);
  return section;
}

// The wedge in the section: its corner, the first half-line along +x from it (`rotation` turns
// section coordinates about the corner so), the second along `second`; `normal_a` and `normal_b` are
// the unit normals of their lines pointing into the wedge between them.
struct Wedge {
  Section section;
  Vector2 corner;
  Eigen::Matrix2d rotation;
  Vector2 second, normal_a, normal_b;
  double opening = 0.0;  // the angle between the half-lines (radians)
  Eigen::Matrix2d inverse_normals;  // of the matrix whose rows are normal_a, normal_b

  // Wedge coordinates of p, and the section coordinates of wedge coordinates x.
  Vector2 local(const Eigen::Vector3d& p) const { return rotation * (section.profile(p) - corner); }
  Vector2 profile(const Vector2& x) const { return corner + rotation.transpose() * x; }
};

// Turns the wedge so that its first half-line (direction `first` in the section) runs along +x,
// the second (`second`) where it then lies.
void orient(Wedge& w, const Vector2& first, const Vector2& second) {
  w.rotation << first.x(), first.y(), -first.y(), first.x();
  w.second = w.rotation * second;
  w.opening = std::acos(std::clamp(w.second.x(), -1.0, 1.0));
  w.normal_a = Vector2(0.0, w.second.y() >= 0.0 ? 1.0 : -1.0);
  w.normal_b = Vector2(std::abs(w.second.y()), w.second.y() >= 0.0 ? -w.second.x() : w.second.x());
  Eigen::Matrix2d normals;
  normals << w.normal_a.transpose(), w.normal_b.transpose();
  w.inverse_normals = normals.inverse();
}

// The wedge's lines moved by `offset` (along their inward normals) and joined by the arc of radius
// r tangent to both (r = 0: the sharp corner).
struct Rounding {
  Vector2 offset;
  double radius = 0.0;
  Vector2 centre, touch_a, touch_b;
};

Rounding round_wedge(const Wedge& w, const Vector2& offset, double radius) {
  Rounding g{offset, radius, w.inverse_normals * (offset + Vector2::Constant(radius)), {}, {}};
  g.touch_a = g.centre - radius * w.normal_a;
  g.touch_b = g.centre - radius * w.normal_b;
  return g;
}

// Signed distance of x from the rounded wedge and its gradient with respect to the offsets.
double residual(const Wedge& w, const Rounding& g, const Vector2& x, Vector2& gradient) {
  const bool on_a = x.x() >= g.touch_a.x(), on_b = (x - g.touch_b).dot(w.second) >= 0.0;
  const double to_a = w.normal_a.dot(x) - g.offset.x(), to_b = w.normal_b.dot(x) - g.offset.y();
  if (on_a && (!on_b || std::abs(to_a) <= std::abs(to_b))) {
    gradient = Vector2(-1.0, 0.0);
    return to_a;
  }
  if (on_b) {
    gradient = Vector2(0.0, -1.0);
    return to_b;
  }
  const Vector2 v = x - g.centre;
  const double d = v.norm();
  gradient = d > 0.0 ? Vector2(w.inverse_normals.transpose() * (v / d)) : Vector2::Zero();
  return g.radius - d;  // positive towards the centre, as the lines' residuals are into the wedge
}

// The least sum of squared residuals of `points` from the wedge rounded by `radius` over the
// offsets: a few Gauss-Newton steps from `offset`, which returns the best (the offsets move little
// from one radius to the next).
double fit_offsets(const Wedge& w, const std::vector<Vector2>& points, double radius, Vector2& offset) {
  double best = std::numeric_limits<double>::infinity();
  Vector2 current = offset;
  for (int pass = 0; pass < 3; ++pass) {
    const Rounding g = round_wedge(w, current, radius);
    Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
    Vector2 rhs = Vector2::Zero(), gradient;
    double sum = 0.0;
    for (const Vector2& x : points) {
      const double r = residual(w, g, x, gradient);
      sum += r * r;
      normal += gradient * gradient.transpose();
      rhs -= gradient * r;
    }
    if (!(sum < best)) break;
    best = sum;
    offset = current;
    normal.diagonal().array() += 1e-12 * (normal.trace() + 1.0);  // a side without points keeps its offset
    current += normal.ldlt().solve(rhs);
  }
  return best;
}

struct Border {
  std::vector<int> faces;  // faces of either feature along the border
  std::vector<int> edges;  // mesh edges between them
};

// Where along the edge a border runs: an interval of lengths along a line, or of angles about an
// axis (circular).
struct Extent {
  double low = 0.0, span = 0.0;
  bool circular = false;

  bool contains(double position, double margin) const {
    if (!circular) return position >= low - margin && position <= low + span + margin;
    const double t = position - low - 2.0 * M_PI * std::floor((position - low) / (2.0 * M_PI));  // in [0, 2 pi)
    return t <= span + margin || t >= 2.0 * M_PI - margin;
  }
};

// The extent of `positions` (not empty); about an axis, the circle less its widest gap.
Extent extent_of(std::vector<double> positions, bool circular) {
  std::sort(positions.begin(), positions.end());
  Extent extent{positions.front(), positions.back() - positions.front(), circular};
  if (!circular) return extent;
  double gap = positions.front() + 2.0 * M_PI - positions.back();
  for (size_t i = 1; i < positions.size(); ++i)
    if (positions[i] - positions[i - 1] > gap) {
      gap = positions[i] - positions[i - 1];
      extent.low = positions[i];
    }
  extent.span = 2.0 * M_PI - gap;
  return extent;
}

// Faces of labels a and b reached from the border through faces of a and b whose centroid lies
// within `reach` of the wedge's corner in the section, and along the edge within `margin` of the
// border's extent. `seen` (#F, all 0) is left as it was.
std::vector<int> faces_near(const MatrixX3d& centroids, const MeshTopology& topology, const std::vector<int>& labels,
                            const Border& border, int a, int b, const Wedge& w, const Extent& extent, double reach,
                            double margin, std::vector<char>& seen) {
  std::vector<int> found, reached;
  std::vector<int> stack;
  for (int f : border.faces)
    if (!seen[f]) {
      seen[f] = 1;
      reached.push_back(f);
      stack.push_back(f);
    }
  auto near = [&](int f) {
    const Eigen::Vector3d c = centroids.row(f).transpose();
    return w.local(c).norm() <= reach && extent.contains(w.section.position(c), margin);
  };
  while (!stack.empty()) {
    const int f = stack.back();
    stack.pop_back();
    if (!near(f)) continue;
    found.push_back(f);
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && !seen[g] && (labels[g] == a || labels[g] == b)) {
        seen[g] = 1;
        reached.push_back(g);
        stack.push_back(g);
      }
    }
  }
  for (int f : reached) seen[f] = 0;
  std::sort(found.begin(), found.end());
  return found;
}

// The vertices of `faces`, in order of first use; `seen` (#V, all 0) is left as it was.
std::vector<int> distinct_vertices(const TriangleMesh& mesh, const std::vector<int>& faces, std::vector<char>& seen) {
  std::vector<int> vertices;
  for (int f : faces)
    for (int k = 0; k < 3; ++k)
      if (!seen[mesh.F(f, k)]) {
        seen[mesh.F(f, k)] = 1;
        vertices.push_back(mesh.F(f, k));
      }
  for (int v : vertices) seen[v] = 0;
  return vertices;
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

// An even subsample of at most kSamplePoints of `points`.
std::vector<Vector2> even_sample(const std::vector<Vector2>& points) {
  const size_t step = std::max<size_t>(1, points.size() / kSamplePoints);
  std::vector<Vector2> sample;
  for (size_t i = 0; i < points.size(); i += step) sample.push_back(points[i]);
  return sample;
}

// The wedge fitted to `points` rounded: the radius (searched over log r between `smallest` and
// `largest`: a grid, then golden section around its best) and the offsets of the least sum of
// squared residuals. None when no rounding fits better than the sharp corner, or the best is at the
// largest radius (no fillet of the band's size).
struct Fillet {
  double radius = 0.0;
  Vector2 offset = Vector2::Zero();
};

std::optional<Fillet> fit_fillet(const Wedge& w, const std::vector<Vector2>& points, double smallest, double largest) {
  if (!(largest > smallest)) return std::nullopt;
  Fillet best;
  Vector2 sharp_offset = Vector2::Zero();
  const double sharp = fit_offsets(w, points, 0.0, sharp_offset);
  double least_rounded = std::numeric_limits<double>::infinity();
  Vector2 offset = sharp_offset;  // warm: from the previous radius
  double best_log_r = 0.0;
  auto rounded = [&](double log_r) {
    const double value = fit_offsets(w, points, std::exp(log_r), offset);
    if (value < least_rounded) least_rounded = value, best_log_r = log_r, best.offset = offset;
    return value;
  };
  constexpr int kGrid = 12;
  const double lo = std::log(smallest), hi = std::log(largest);
  int arg = 0;
  double least = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kGrid; ++i) {
    const double value = rounded(lo + (hi - lo) * i / kGrid);
    if (value < least) least = value, arg = i;
  }
  if (!(least < sharp) || arg == kGrid) return std::nullopt;
  double x0 = lo + (hi - lo) * std::max(arg - 1, 0) / kGrid, x1 = lo + (hi - lo) * (arg + 1) / kGrid;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double u = x1 - golden * (x1 - x0), v = x0 + golden * (x1 - x0);
  double fu = rounded(u), fv = rounded(v);
  for (int i = 0; i < 12; ++i) {
    if (fu < fv) {
      x1 = v, v = u, fv = fu;
      u = x1 - golden * (x1 - x0);
      fu = rounded(u);
    } else {
      x0 = u, u = v, fu = fv;
      v = x0 + golden * (x1 - x0);
      fv = rounded(v);
    }
  }
  best.radius = std::exp(best_log_r);
  return best;
}

// The robust spread (σ for Gaussian residuals) of `points` from the wedge as `fillet` rounds it,
// to set beside the features' own spreads: the band may hold a few faces of a surface beyond the
// features' ends (a blend at a short cylinder's other end), which its RMS would count in full.
double rounded_spread(const Wedge& w, const Fillet& fillet, const std::vector<Vector2>& points) {
  const Rounding g = round_wedge(w, fillet.offset, fillet.radius);
  std::vector<double> distances;
  Vector2 gradient;
  for (const Vector2& x : points) distances.push_back(std::abs(residual(w, g, x, gradient)));
  if (distances.empty()) return 0.0;
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  return 1.4826 * distances[distances.size() / 2];
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

double independent_share(const TriangleMesh& mesh, const std::vector<Feature>& features,
                         const std::vector<int>& labels) {
  double product = 0.0, square = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] < 0 || features[labels[f]].type != SurfaceType::Plane) continue;
    const Surface& plane = features[labels[f]].surface;
    std::array<double, 3> r;
    for (int k = 0; k < 3; ++k) r[k] = (mesh.V.row(mesh.F(f, k)).transpose() - plane.point).dot(plane.axis);
    product += r[0] * r[1] + r[1] * r[2] + r[2] * r[0];
    square += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  }
  const double rho = square > 0.0 ? std::clamp(product / square, 0.0, 1.0) : 0.0;
  return (1.0 - rho) / (1.0 + rho);
}

std::vector<char> round_edges(const TriangleMesh& mesh, const MeshTopology& topology, const EdgeFilletOptions& options,
                              std::vector<Feature>& features, std::vector<int>& labels) {
  std::vector<char> changed(features.size(), 0);
  const double edge = median_edge_length(mesh, topology);
  if (!(edge > 0.0)) return changed;
  const double band = options.band_edges * edge;
  const double independent = independent_share(mesh, features, labels);
  auto is_edge_surface = [&](int l) {
    if (l < 0) return false;
    const SurfaceType t = features[l].type;
    return t == SurfaceType::Plane || t == SurfaceType::Cylinder || t == SurfaceType::Cone;
  };
  std::map<std::pair<int, int>, Border> borders;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < f || labels[f] == labels[g] || !is_edge_surface(labels[f]) || !is_edge_surface(labels[g])) continue;
      Border& border = borders[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}];
      border.faces.push_back(f);
      border.faces.push_back(g);
      border.edges.push_back(topology.face_edge(f, c));
    }
  std::vector<char> seen(mesh.num_faces(), 0), vertex_seen(mesh.num_vertices(), 0);
  MatrixX3d centroids(mesh.num_faces(), 3);
  for (int f = 0; f < mesh.num_faces(); ++f) centroids.row(f) = face_centroid(mesh, f).transpose();

  for (const auto& [pair, border] : borders) {
    const auto [a, b] = pair;
    const Surface &sa = features[a].surface, &sb = features[b].surface;
    const std::optional<Section> section = section_between(sa, sb, options.angle_tolerance, edge);
    if (!section) continue;
    const std::optional<ProfileLine> line_a = profile_line(sa, *section, options.angle_tolerance);
    const std::optional<ProfileLine> line_b = profile_line(sb, *section, options.angle_tolerance);
    if (!line_a || !line_b) continue;
    auto cross = [](const Vector2& x, const Vector2& y) { return x.x() * y.y() - x.y() * y.x(); };
    const double sine = cross(line_a->direction, line_b->direction);
    if (std::abs(sine) < std::sin(options.angle_tolerance)) continue;  // parallel: no corner
    Wedge w;
    w.section = *section;
    w.corner = line_a->point + cross(line_b->point - line_a->point, line_b->direction) / sine * line_a->direction;
    w.rotation.setIdentity();
    if (section->around_axis && !(w.corner.x() > edge)) continue;  // the corner circle must be a circle
    // Along the edge, a margin of `reach` is a length on a line and an angle about the axis.
    const double to_angle = section->around_axis ? 1.0 / w.corner.x() : 1.0;
    std::vector<double> positions;
    for (int e : border.edges) {
      const auto& v = topology.edge_vertices(e);
      positions.push_back(section->position(0.5 * (mesh.V.row(v[0]) + mesh.V.row(v[1])).transpose()));
    }
    const Extent extent = extent_of(positions, section->around_axis);
    const std::vector<int> near =
        faces_near(centroids, topology, labels, border, a, b, w, extent, band, band * to_angle, seen);

    // Each half-line runs from the corner towards its feature's faces near the border.
    Vector2 towards_a = Vector2::Zero(), towards_b = Vector2::Zero();
    for (int f : near) (labels[f] == a ? towards_a : towards_b) += w.local(centroids.row(f).transpose());
    const Vector2 da = towards_a.dot(line_a->direction) >= 0.0 ? line_a->direction : Vector2(-line_a->direction);
    const Vector2 db = towards_b.dot(line_b->direction) >= 0.0 ? line_b->direction : Vector2(-line_b->direction);
    orient(w, da, db);
    if (w.opening < options.angle_tolerance || w.opening > M_PI - options.angle_tolerance) continue;

    // The vertices of those faces within the band and the border's extent (an even subsample).
    std::vector<Vector2> local;
    for (int v : distinct_vertices(mesh, near, vertex_seen)) {
      const Eigen::Vector3d p = mesh.V.row(v).transpose();
      const Vector2 x = w.local(p);
      if (x.norm() <= band && extent.contains(section->position(p), 0.0)) local.push_back(x);
    }
    if (static_cast<int>(local.size()) <= 2 * parameter_count(SurfaceType::Cylinder)) continue;
    const std::vector<Vector2> sample = even_sample(local);

    const std::optional<Fillet> fillet = fit_fillet(w, sample, edge / 8.0, 0.5 * band * std::tan(0.5 * w.opening));
    if (!fillet) continue;
    // The evidence is every vertex of the band (a long narrow fillet sags by little more than the
    // noise, and the subsample that fixes its shape holds too few of its vertices): the sums of
    // squares of the sharp and the fitted rounded wedge over all, with their offsets refitted.
    const int n = static_cast<int>(local.size());
    Vector2 sharp_offset = Vector2::Zero(), rounded_offset = fillet->offset;
    const double sharp = fit_offsets(w, local, 0.0, sharp_offset);
    const double rounded = fit_offsets(w, local, fillet->radius, rounded_offset);
    const double variance = rounded / std::max(n - 3, 1);
    const double spread = std::max(features[a].spread, features[b].spread);
    // BIC for one more parameter, over the independent residuals; the band explained as the
    // features explain their patches; an arc longer than a sharp edge's (the features turn by pi
    // less the opening).
    const double effective = std::max(independent * n, 2.0);
    if (!(independent * (sharp - rounded) > std::log(effective) * variance) ||
        rounded_spread(w, *fillet, sample) > options.residual_ratio * spread ||
        fillet->radius * (M_PI - w.opening) < options.shortest_arc * edge)
      continue;

    // The faces whose centroid lies between the radii to the tangent lines.
    const Rounding g = round_wedge(w, fillet->offset, fillet->radius);
    const Vector2 to_a = g.touch_a - g.centre, to_b = g.touch_b - g.centre;
    std::vector<int> arc;
    for (int f : near) {
      if (labels[f] != a && labels[f] != b) continue;
      const Eigen::Vector3d c = centroids.row(f).transpose();
      const Vector2 v = w.local(c) - g.centre;
      if (!extent.contains(section->position(c), edge * to_angle) || v.dot(to_a + to_b) <= 0.0) continue;
      if (cross(to_a, v) * cross(to_a, to_b) < 0.0 || cross(to_b, v) * cross(to_b, to_a) < 0.0) continue;
      arc.push_back(f);
    }
    if (static_cast<int>(distinct_vertices(mesh, arc, vertex_seen).size()) <= 2 * parameter_count(SurfaceType::Cylinder))
      continue;

    Feature rounding;
    rounding.id = static_cast<int>(features.size());
    Surface& surface = rounding.surface;
    surface.axis = section->direction;
    surface.radius = fillet->radius;
    const Vector2 centre = w.profile(g.centre);
    if (!section->around_axis) {
      surface.type = SurfaceType::Cylinder;
      surface.point = section->origin + centre.x() * section->e1 + centre.y() * section->e2;
    } else {  // about the axis: a torus whose tube is the arc
      if (!(centre.x() > fillet->radius)) continue;
      surface.type = SurfaceType::Torus;
      surface.point = section->origin + centre.y() * section->direction;
      surface.radius = centre.x();
      surface.minor = fillet->radius;
    }
    rounding.type = rounding.curvature_type = surface.type;
    for (int f : arc) labels[f] = rounding.id;
    features.push_back(rounding);
    changed.resize(features.size(), 0);
    changed[a] = changed[b] = changed.back() = 1;
  }
  return changed;
}

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
      return std::abs(v.x() * direction.y() - v.y() * direction.x()) <= options.residual_ratio * typical_spread;
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
    if (std::sqrt(round / (n - 3)) <= options.residual_ratio * typical_spread) continue;

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
