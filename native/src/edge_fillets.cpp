#include "edge_fillets.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace idealize {
namespace {

using Vector2 = Eigen::Vector2d;

// The band's vertices are fitted on an even subsample of at most this many, about a hundred of them
// near the arc (half as many left the radius of one of the NIST parts' small fillets 15 % short).
constexpr int kSamplePoints = 400;

// The cross-section of two half-planes meeting at a line, in the plane perpendicular to it: the
// first half-plane runs from the corner along +x, the second along `second`; `normal_a` and
// `normal_b` are the unit normals of their lines pointing into the wedge between them.
struct Wedge {
  Eigen::Vector3d origin, along, x_axis, y_axis;
  Vector2 second, normal_a, normal_b;
  double opening = 0.0;  // the angle between the half-planes (radians)
  Eigen::Matrix2d inverse_normals;  // of the matrix whose rows are normal_a, normal_b

  Vector2 section(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - origin;
    return {q.dot(x_axis), q.dot(y_axis)};
  }
  double position(const Eigen::Vector3d& p) const { return (p - origin).dot(along); }
};

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
  std::vector<int> faces;  // faces of either plane along the border
  std::vector<int> edges;  // mesh edges between them
};

// Faces of labels a and b reached from the border through faces of a and b whose centroid lies
// within `reach` of the wedge's line, and along it within the border's extent widened by `reach`.
// `seen` (#F, all 0) is left as it was.
std::vector<int> faces_near(const MatrixX3d& centroids, const MeshTopology& topology, const std::vector<int>& labels,
                            const Border& border, int a, int b, const Wedge& w, double low, double high, double reach,
                            std::vector<char>& seen) {
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
    const double s = w.position(c);
    return w.section(c).norm() <= reach && s >= low - reach && s <= high + reach;
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

// The correlation of the plane features' residuals at the ends of their mesh edges: about 0 for a
// scan's independent noise, near 1 for a sculpted part's smooth undulation, whose residuals are not
// independent evidence (measured on the benchmark: 0.02-0.27 on the scans, 0.74-0.87 sculpted).
double neighbour_correlation(const TriangleMesh& mesh, const std::vector<Feature>& features,
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
  return square > 0.0 ? std::clamp(product / square, 0.0, 1.0) : 0.0;
}

double median_edge_length(const TriangleMesh& mesh, const MeshTopology& topology) {
  std::vector<double> lengths(topology.num_edges());
  for (int e = 0; e < topology.num_edges(); ++e) {
    const auto& v = topology.edge_vertices(e);
    lengths[e] = (mesh.V.row(v[0]) - mesh.V.row(v[1])).norm();
  }
  if (lengths.empty()) return 0.0;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  return lengths[lengths.size() / 2];
}

}  // namespace

std::vector<char> round_plane_edges(const TriangleMesh& mesh, const MeshTopology& topology,
                                    const EdgeFilletOptions& options, std::vector<Feature>& features,
                                    std::vector<int>& labels) {
  std::vector<char> changed(features.size(), 0);
  const double edge = median_edge_length(mesh, topology);
  if (!(edge > 0.0)) return changed;
  const double band = options.band_edges * edge;
  // Correlated residuals weigh as fewer independent ones: n (1 - rho) / (1 + rho).
  const double rho = neighbour_correlation(mesh, features, labels);
  const double independent = (1.0 - rho) / (1.0 + rho);
  auto is_plane = [&](int l) { return l >= 0 && features[l].type == SurfaceType::Plane; };
  std::map<std::pair<int, int>, Border> borders;
  std::vector<char> seen(mesh.num_faces(), 0), vertex_seen(mesh.num_vertices(), 0);
  MatrixX3d centroids(mesh.num_faces(), 3);
  for (int f = 0; f < mesh.num_faces(); ++f) centroids.row(f) = face_centroid(mesh, f).transpose();
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < f || labels[f] == labels[g] || !is_plane(labels[f]) || !is_plane(labels[g])) continue;
      Border& border = borders[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}];
      border.faces.push_back(f);
      border.faces.push_back(g);
      border.edges.push_back(topology.face_edge(f, c));
    }

  for (const auto& [pair, border] : borders) {
    const auto [a, b] = pair;
    const Surface &pa = features[a].surface, &pb = features[b].surface;
    Wedge w;
    const Eigen::Vector3d direction = pa.axis.cross(pb.axis);
    if (direction.norm() < std::sin(options.angle_tolerance)) continue;
    w.along = direction.normalized();
    Eigen::Matrix3d rows;
    rows << pa.axis.transpose(), pb.axis.transpose(), w.along.transpose();
    w.origin = rows.colPivHouseholderQr().solve(Eigen::Vector3d(pa.axis.dot(pa.point), pb.axis.dot(pb.point), 0.0));
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (int e : border.edges) {
      const auto& v = topology.edge_vertices(e);
      const double s = w.position(0.5 * (mesh.V.row(v[0]) + mesh.V.row(v[1])).transpose());
      low = std::min(low, s);
      high = std::max(high, s);
    }
    // Which way each half-plane runs from the line: towards its faces near the border.
    w.x_axis = w.along.cross(pa.axis);
    w.y_axis = w.along.cross(w.x_axis);
    const std::vector<int> near = faces_near(centroids, topology, labels, border, a, b, w, low, high, band, seen);
    Vector2 towards_a = Vector2::Zero();
    Eigen::Vector3d in_b = w.along.cross(pb.axis);
    double side_b = 0.0;
    for (int f : near) {
      const Eigen::Vector3d c = centroids.row(f).transpose();
      if (labels[f] == a) towards_a += w.section(c);
      else side_b += (c - w.origin).dot(in_b);
    }
    if (towards_a.x() < 0.0) {
      w.x_axis = -w.x_axis;
      w.y_axis = -w.y_axis;
    }
    if (side_b < 0.0) in_b = -in_b;
    w.second = w.section(w.origin + in_b).normalized();
    w.opening = std::acos(std::clamp(w.second.x(), -1.0, 1.0));
    if (w.opening < options.angle_tolerance || w.opening > M_PI - options.angle_tolerance) continue;
    w.normal_a = Vector2(0.0, w.second.y() >= 0.0 ? 1.0 : -1.0);
    w.normal_b = Vector2(std::abs(w.second.y()), w.second.y() >= 0.0 ? -w.second.x() : w.second.x());
    Eigen::Matrix2d normals;
    normals << w.normal_a.transpose(), w.normal_b.transpose();
    w.inverse_normals = normals.inverse();

    // The vertices of those faces within the band and the border's extent (an even subsample).
    const std::vector<int> vertices = distinct_vertices(mesh, near, vertex_seen);
    std::vector<Vector2> section;
    for (int v : vertices) {
      const Eigen::Vector3d p = mesh.V.row(v).transpose();
      const double s = w.position(p);
      if (s >= low && s <= high && w.section(p).norm() <= band) section.push_back(w.section(p));
    }
    const int count = static_cast<int>(section.size());
    if (count <= 2 * parameter_count(SurfaceType::Cylinder)) continue;
    const int step = std::max(1, count / kSamplePoints);
    std::vector<Vector2> sample;
    for (int i = 0; i < count; i += step) sample.push_back(section[i]);
    const int n = static_cast<int>(sample.size());

    // The sharp wedge, then the rounded one over log r: a grid, then golden section around its best.
    Vector2 sharp_offset = Vector2::Zero();
    const double sharp = fit_offsets(w, sample, 0.0, sharp_offset);
    const double tangent_per_radius = 1.0 / std::tan(0.5 * w.opening);  // tangent line's distance from the corner
    const double largest = 0.5 * band / tangent_per_radius, smallest = edge / 8.0;
    if (!(largest > smallest)) continue;
    Vector2 offset = sharp_offset;  // warm: from the previous radius
    double fillet = std::numeric_limits<double>::infinity(), best_log_r = 0.0;
    Vector2 best_offset = offset;
    auto rounded = [&](double log_r) {
      const double value = fit_offsets(w, sample, std::exp(log_r), offset);
      if (value < fillet) fillet = value, best_log_r = log_r, best_offset = offset;
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
    // No rounding fits better than the sharp edge; or still better at the band's limit: no fillet
    // of the band's size.
    if (!(least < sharp) || arg == kGrid) continue;
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
    const double radius = std::exp(best_log_r);
    const double variance = fillet / std::max(n - 3, 1);
    const double plane_spread = std::max(features[a].spread, features[b].spread);
    // BIC for one more parameter, over the independent residuals; the band explained as the planes
    // explain their patches; an arc longer than a sharp edge's (the planes turn by pi minus the opening).
    const double effective = std::max(independent * n, 2.0);
    if (!(independent * (sharp - fillet) > std::log(effective) * variance) ||
        std::sqrt(variance) > options.residual_ratio * plane_spread || radius * (M_PI - w.opening) < options.shortest_arc * edge)
      continue;

    // The faces whose centroid lies between the radii to the tangent lines.
    const Rounding g = round_wedge(w, best_offset, radius);
    auto cross = [](const Vector2& x, const Vector2& y) { return x.x() * y.y() - x.y() * y.x(); };
    const Vector2 to_a = g.touch_a - g.centre, to_b = g.touch_b - g.centre;
    std::vector<int> arc;
    for (int f : near) {
      if (labels[f] != a && labels[f] != b) continue;
      const Eigen::Vector3d c = centroids.row(f).transpose();
      const double s = w.position(c);
      const Vector2 v = w.section(c) - g.centre;
      if (s < low - edge || s > high + edge || v.dot(to_a + to_b) <= 0.0) continue;
      if (cross(to_a, v) * cross(to_a, to_b) < 0.0 || cross(to_b, v) * cross(to_b, to_a) < 0.0) continue;
      arc.push_back(f);
    }
    if (static_cast<int>(distinct_vertices(mesh, arc, vertex_seen).size()) <= 2 * parameter_count(SurfaceType::Cylinder))
      continue;

    Feature fillet_feature;
    fillet_feature.id = static_cast<int>(features.size());
    fillet_feature.type = fillet_feature.curvature_type = SurfaceType::Cylinder;
    fillet_feature.surface.type = SurfaceType::Cylinder;
    fillet_feature.surface.axis = w.along;
    fillet_feature.surface.point = w.origin + g.centre.x() * w.x_axis + g.centre.y() * w.y_axis;
    fillet_feature.surface.radius = radius;
    for (int f : arc) labels[f] = fillet_feature.id;
    features.push_back(fillet_feature);
    changed.resize(features.size(), 0);
    changed[a] = changed[b] = changed.back() = 1;
  }
  return changed;
}

}  // namespace idealize
