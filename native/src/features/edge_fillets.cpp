#include "features/edge_fillets.h"

#include "features/section_profile.h"
#include "fit/fits_as_well.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <utility>

namespace idealize {
namespace {

using detail::distinct_vertices;
using detail::even_sample;
using detail::Section;
using detail::Vector2;

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
        !fits_as_well(rounded_spread(w, *fillet, sample), spread, options.residual_ratio) ||
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

}  // namespace idealize
