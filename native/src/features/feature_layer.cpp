#include "features/feature_layer.h"
#include "fit/bspline_fitting.h"
#include "features/relaxation.h"

#include "features/edge_fillets.h"
#include "features/feature_graph.h"
#include "features/idealization.h"
#include "core/parallel.h"
#include "features/shared_axes.h"
#include "features/tangent_boundaries.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <cmath>

namespace idealize {

void Feature::set_fit(const SurfaceFit& fit) {
  surface = fit.surface;
  type = fit.surface.type;
  rms = fit.rms;
  max_error = fit.max_error;
  normal_rms = fit.normal_rms;
  spread = fit.spread;
  normal_spread = fit.normal_spread;
}

namespace {

constexpr int kNone = -1;
constexpr int kSeveral = -2;

// The patches p with which[p] (#which <= #points), the largest (most points) first.
std::vector<int> largest_first(const std::vector<FitData>& points, const std::vector<char>& which) {
  std::vector<int> order;
  for (size_t p = 0; p < which.size() && p < points.size(); ++p)
    if (which[p]) order.push_back(static_cast<int>(p));
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return points[x].points.rows() > points[y].points.rows(); });
  return order;
}

// Fits use a patch's interior vertices when it has at least this many: enough for a torus (seven
// parameters) with noise.
constexpr int kInteriorPoints = 24;
// A CAD exporter tessellates a curved face finer than a facet turn of 45° (a quarter circle in two
// facets): on an exact tessellation a sharper crease is an edge between two faces, even where one
// surface passes through both (the corners of a box lie on a sphere).
constexpr double kLargestFacetTurn = 0.25 * M_PI;
// A chord facet's normal leaves the surface's by up to half its turn where the surface is convex, and
// by more on the saddle of a torus (beyond the normals at its corners). A surface that the exact
// vertices of a large patch fix may claim facets up to the largest turn; one that a few vertices of
// small pieces fix, only up to half of it: the sides and chamfers of a hexagon lie on a torus.
constexpr double kFewPointsChordTurn = 0.5 * kLargestFacetTurn;

// The order of preference when several surface types fit: the fewest parameters first, but a short
// band of a large sphere fits as well as the cylinder it usually is. A sphere precedes the cone
// (thesis 4.3 models cones first): a zone of a sphere, such as a ball between three fillets or the
// coarse facets of a CAD export's corner, also fits a wide cone.
constexpr std::array<SurfaceType, 5> kTypesByPreference = {SurfaceType::Plane, SurfaceType::Cylinder,
                                                           SurfaceType::Sphere, SurfaceType::Cone,
                                                           SurfaceType::Torus};

using PatchPoints = FitData;

// The label shared by all faces around each vertex, kNone if none, kSeveral if they differ.
std::vector<int> vertex_labels(const TriangleMesh& mesh, const std::vector<int>& labels) {
  std::vector<int> out(mesh.num_vertices(), kNone);
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      int& v = out[mesh.F(f, c)];
      if (v == kNone) v = labels[f];
      else if (v != labels[f]) v = kSeveral;
    }
  return out;
}

// What a fit sees of a set of faces: their vertices (a third of the area of the faces around each)
// and the faces themselves (centroid, normal, area). When at least kInteriorPoints of the vertices
// are `interior`, only those are kept: on a scan the rim of a patch lies on the rounded-off edge,
// while a coarse CAD face may have no interior vertex and its rim lies on the surface. `slot` is a
// per-vertex scratch array of -1, left as it was found.
template <typename Interior>
PatchPoints face_points(const TriangleMesh& mesh, const int* faces, int count, std::vector<int>& slot,
                        const Interior& interior) {
  PatchPoints pp;
  pp.sample_points.resize(count, 3);
  pp.sample_normals.resize(count, 3);
  pp.sample_weights.resize(count);
  std::vector<int> vertices;
  std::vector<double> vertex_area;
  for (int i = 0; i < count; ++i) {
    const int f = faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double area = 0.5 * n.norm();
    pp.sample_points.row(i) = (a + b + c) / 3.0;
    pp.sample_normals.row(i) = area > 0.0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
    pp.sample_weights[i] = area;
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.F(f, k);
      if (slot[v] < 0) {
        slot[v] = static_cast<int>(vertices.size());
        vertices.push_back(v);
        vertex_area.push_back(0.0);
      }
      vertex_area[slot[v]] += area / 3.0;
    }
  }
  const auto interior_count = std::count_if(vertices.begin(), vertices.end(), interior);
  const bool interior_only = interior_count >= kInteriorPoints;
  pp.points.resize(interior_only ? interior_count : static_cast<Eigen::Index>(vertices.size()), 3);
  pp.weights.resize(pp.points.rows());
  Eigen::Index k = 0;
  for (size_t i = 0; i < vertices.size(); ++i) {
    const int v = vertices[i];
    slot[v] = -1;
    if (interior_only && !interior(v)) continue;
    pp.points.row(k) = mesh.V.row(v);
    pp.weights[k] = vertex_area[i];
    ++k;
  }
  return pp;
}

// What the fits see of every patch (face_points, interior: the vertices only the patch touches,
// and with `rim_rings` > 0 not on that many rings of faces along its rim either; with `rim_rings`
// < 0 every vertex of the patch's faces).
std::vector<PatchPoints> patch_points(const TriangleMesh& mesh, const std::vector<int>& labels, int num_patches,
                                      int rim_rings = 0) {
  // Faces bucketed by patch (counting sort).
  std::vector<int> offset(num_patches + 1, 0);
  for (int l : labels)
    if (l >= 0) ++offset[l + 1];
  for (int p = 0; p < num_patches; ++p) offset[p + 1] += offset[p];
  std::vector<int> faces(offset[num_patches]);
  {
    std::vector<int> next(offset.begin(), offset.end() - 1);
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (labels[f] >= 0) faces[next[labels[f]]++] = f;
  }
  std::vector<int> shared = vertex_labels(mesh, labels);
  for (int ring = 0; ring < rim_rings; ++ring) {
    std::vector<char> near_rim(mesh.num_faces(), 0);
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) near_rim[f] |= shared[mesh.F(f, c)] == kSeveral;
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (near_rim[f])
        for (int c = 0; c < 3; ++c) shared[mesh.F(f, c)] = kSeveral;
  }
  std::vector<int> slot(mesh.num_vertices(), -1);
  std::vector<PatchPoints> out(num_patches);
  for (int p = 0; p < num_patches; ++p)
    out[p] = face_points(mesh, faces.data() + offset[p], offset[p + 1] - offset[p], slot,
                         [&](int v) { return rim_rings >= 0 && shared[v] == p; });
  return out;
}

// The thesis's identification (after Besl & Jain) from the signs of H and K.
SurfaceType curvature_type(const PatchCurvature& c, const EffectiveZero& zero_h) {
  // K = k1 k2 with both principal curvatures inside the zero range of H.
  const double zero_k = std::pow(std::max(-zero_h.low, zero_h.high), 2);
  if (c.mean >= zero_h.low && c.mean <= zero_h.high && std::abs(c.gaussian) <= zero_k) return SurfaceType::Plane;
  if (std::abs(c.gaussian) <= zero_k) return SurfaceType::Cylinder;
  return c.gaussian > 0.0 ? SurfaceType::Sphere : SurfaceType::Torus;
}

// The simplest surface type that fits the points about as well as the best one; with `curved_only`
// planes are not candidates.
Feature identify(const PatchPoints& pp, const PatchCurvature& curvature, const EffectiveZero& zero_h,
                 const FeatureOptions& options, double tolerance, bool curved_only = false) {
  Feature feature;
  feature.vertices = static_cast<int>(pp.points.rows());
  feature.curvature_type = curvature_type(curvature, zero_h);
  feature.curvature = curvature;
  std::array<SurfaceFit, 5> fits;
  double best = std::numeric_limits<double>::infinity(), best_normal = best;
  for (size_t t = curved_only ? 1 : 0; t < kTypesByPreference.size(); ++t) {
    fits[t] = fit_surface(kTypesByPreference[t], pp, options.fit);
    if (fits[t].valid) {
      best = std::min(best, fits[t].spread);
      best_normal = std::min(best_normal, fits[t].normal_spread);
    }
  }
  // Surfaces that deviate by less than the distance tolerance are as good as equal.
  const double accepted = options.residual_ratio * best + tolerance;
  const double accepted_normal = options.residual_ratio * best_normal + options.normal_floor_degrees * M_PI / 180.0;
  // The first accepted type: a more general surface always fits a little better.
  int chosen = -1;
  for (size_t t = curved_only ? 1 : 0; t < fits.size() && chosen < 0; ++t)
    if (fits[t].valid && fits[t].spread <= accepted && fits[t].normal_spread <= accepted_normal)
      chosen = static_cast<int>(t);
  if (chosen < 0) return feature;  // no surface could be fitted at all
  feature.set_fit(fits[chosen]);
  return feature;
}

// How well `surface` explains face f: the largest of its vertices' distances in units of
// `distance_unit` and of its normal's angle from the surface's at its centroid in units of
// `angle_unit` (radians). At most 1 when the surface explains the face.
double face_misfit(const TriangleMesh& mesh, int f, const Surface& surface, double distance_unit, double angle_unit) {
  double worst = 0.0;
  for (int k = 0; k < 3; ++k)
    worst = std::max(worst, std::abs(signed_distance(surface, mesh.V.row(mesh.F(f, k)).transpose())) / distance_unit);
  const double cosine = std::abs(face_normal(mesh, f).dot(surface_normal(surface, face_centroid(mesh, f))));
  return std::max(worst, std::acos(std::min(cosine, 1.0)) / angle_unit);
}

// face_misfit of a feature's surface in units of three times the fit's robust spread (3 σ) plus a
// floor; infinite for a freeform feature.
double misfit(const TriangleMesh& mesh, int f, const Feature& feature, double floor, double normal_floor) {
  if (feature.type == SurfaceType::Freeform) return std::numeric_limits<double>::infinity();
  return face_misfit(mesh, f, feature.surface, 3.0 * feature.spread + floor, 3.0 * feature.normal_spread + normal_floor);
}

// Moves faces on the rim of a patch to an edge-adjacent patch whose surface explains them when
// their own does not, or explains them several times better (segmentation leaves the first facets
// of a coarse fillet on the plane beside it, whose tolerances they may just meet). A moved face
// opens its neighbours to the same test, so a whole strip moves in one call. Returns which patches
// changed.
std::vector<char> reassign_faces(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<Feature>& features,
                                 const FeatureOptions& options, double floor, std::vector<int>& labels,
                                 const ProgressSpan& progress) {
  const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
  std::vector<char> changed(features.size(), 0);
  std::vector<int> queue;
  for (int f = 0; f < mesh.num_faces(); ++f) queue.push_back(f);
  for (size_t head = 0; head < queue.size(); ++head) {
    progress.poll(static_cast<long long>(head));
    const int f = queue[head];
    const int p = labels[f];
    if (p < 0) continue;
    bool rim = false;
    for (int c = 0; c < 3 && !rim; ++c) {
      const int g = topology.face_neighbor(f, c);
      rim = g >= 0 && labels[g] >= 0 && labels[g] != p;
    }
    if (!rim) continue;
    int target = kNone;
    const double own = misfit(mesh, f, features[p], floor, normal_floor);
    // Noise alone rarely makes one surface four times better than another.
    double best = own > 1.0 ? 1.0 : own / 4.0;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] < 0 || labels[g] == p) continue;
      const double m = misfit(mesh, f, features[labels[g]], floor, normal_floor);
      if (m < best) {
        best = m;
        target = labels[g];
      }
    }
    if (target == kNone) continue;
    labels[f] = target;
    changed[p] = changed[target] = 1;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g >= 0 && labels[g] == p) queue.push_back(g);
    }
  }
  return changed;
}

// Whether `surface` explains every point of `data` to within `distance` and every facet normal (the
// samples are facets: centroid, normal, area) to within `angle` (radians) plus what the facet's
// chord allows: a facet whose corners lie on a surface of curvature k sags by about k w² / 2 at its
// centroid and turns by about k w across its width w, so by at most 4 sag / w from the surface
// normal there (up to `largest_chord_turn`). On an exact tessellation a merge must not hide one stray
// facet in an RMS over many.
bool explains_every_point(const Surface& surface, const PatchPoints& data, double distance, double angle,
                          double largest_chord_turn) {
  for (Eigen::Index i = 0; i < data.points.rows(); ++i)
    if (std::abs(signed_distance(surface, data.points.row(i).transpose())) > distance) return false;
  for (Eigen::Index i = 0; i < data.sample_points.rows(); ++i) {
    if (!(data.sample_weights[i] > 0.0)) continue;
    const Eigen::Vector3d centroid = data.sample_points.row(i).transpose();
    const double sag = std::abs(signed_distance(surface, centroid));
    const double allowed = angle + std::min(4.0 * sag / std::sqrt(data.sample_weights[i]), largest_chord_turn);
    const Eigen::Vector3d n = surface_normal(surface, centroid);
    if (std::abs(n.dot(data.sample_normals.row(i).transpose())) < std::cos(std::min(allowed, 0.5 * M_PI))) return false;
  }
  return true;
}

// The angle between the normals of faces f and g (π for a degenerate face).
double facet_turn(const TriangleMesh& mesh, int f, int g) {
  const double turn = std::acos(std::clamp(face_normal(mesh, f).dot(face_normal(mesh, g)), -1.0, 1.0));
  return std::isfinite(turn) ? turn : M_PI;
}

// The sharpest turn between the facets of each pair of adjacent patches, in radians, keyed (a, b)
// with a < b; with `inside`, also the sharpest turn inside each patch, keyed (p, p).
std::map<std::pair<int, int>, double> boundary_turns(const TriangleMesh& mesh, const MeshTopology& topology,
                                                     const std::vector<int>& labels, bool inside = false) {
  std::map<std::pair<int, int>, double> turns;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < f || labels[f] < 0 || labels[g] < 0 || (labels[f] == labels[g] && !inside)) continue;
      double& t = turns[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}];
      t = std::max(t, facet_turn(mesh, f, g));
    }
  return turns;
}

// Whether the mesh vertices on the border between patches a and b lie, at the median, within
// `distance_a` of a's surface and `distance_b` of b's: two planes of a face that undulates meet
// where their patches meet, while the two levels of a step do not.
bool surfaces_meet_at_border(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                             int a, int b, const Surface& sa, const Surface& sb, double distance_a, double distance_b) {
  std::vector<double> da, db;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] != a) continue;
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] != b) continue;
      for (int k : {1, 2}) {  // the edge opposite corner c
        const Eigen::Vector3d v = mesh.V.row(mesh.F(f, (c + k) % 3)).transpose();
        da.push_back(std::abs(signed_distance(sa, v)));
        db.push_back(std::abs(signed_distance(sb, v)));
      }
    }
  }
  if (da.empty()) return false;
  auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  return median(da) <= distance_a && median(db) <= distance_b;
}

// The pairs of patches (a, b) with a < b that share a mesh edge.
std::vector<std::pair<int, int>> adjacent_pairs(const TriangleMesh& mesh, const MeshTopology& topology,
                                                const std::vector<int>& labels) {
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels)) pairs.push_back(pair);
  return pairs;
}


// A small ball where fillets meet (thesis 4.3, case 2) fits a cylinder about as well as a sphere on
// a noisy mesh, and identification takes the simpler cylinder (a scan of blended boxes: a ball of
// r 0.1, 48 facets, between three fillets, fitted by a cylinder of r 0.12 across the corner). A
// cylinder beside two or more cylinders of one radius whose axes are not parallel and pass within
// the distance tolerance of one point is that ball, where the sphere about the point with their
// radius, which touches them all, fits its points as well as its cylinder (within the residual
// ratio; `points` by feature id, what their fits saw).
void make_balls_of_corner_cylinders(const TriangleMesh& mesh, const MeshTopology& topology, double angle_tolerance,
                                    double distance_tolerance, const FeatureOptions& options,
                                    const std::vector<int>& labels, const std::vector<PatchPoints>& points,
                                    std::vector<Feature>& features) {
  std::vector<std::vector<int>> beside(features.size());
  for (const auto& [a, b] : adjacent_pairs(mesh, topology, labels)) {
    beside[a].push_back(b);
    beside[b].push_back(a);
  }
  for (Feature& f : features) {
    if (f.type != SurfaceType::Cylinder) continue;
    std::vector<const Surface*> fillets;
    for (int n : beside[f.id])
      if (features[n].type == SurfaceType::Cylinder) fillets.push_back(&features[n].surface);
    if (fillets.size() < 2) continue;
    const AxesMeeting meeting = point_nearest_to_axes(fillets);
    if (!(meeting.fixed > 1.0 - std::cos(angle_tolerance))) continue;  // parallel within the tolerance
    const Eigen::Vector3d& centre = meeting.point;
    double radius = 0.0;
    for (const Surface* c : fillets) radius += c->radius / fillets.size();
    const double near = std::max(distance_tolerance, options.radius_tolerance * radius);
    if (!std::all_of(fillets.begin(), fillets.end(), [&](const Surface* c) {
          return axial_coordinates(c->point, c->axis, centre).distance <= near && std::abs(c->radius - radius) <= near;
        }))
      continue;
    Surface ball;
    ball.type = SurfaceType::Sphere;
    ball.point = centre;
    ball.radius = radius;
    SurfaceFit fit = fit_of(ball, points[f.id]);
    if (!(fit.rms <= options.residual_ratio * fit_of(f.surface, points[f.id]).rms)) continue;
    measure_spreads(points[f.id], fit);
    f.set_fit(fit);
  }
}

// Distinct points of `data` (pieces share their rim vertices).
int distinct_points(const PatchPoints& data) {
  std::set<std::array<double, 3>> seen;
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) seen.insert({data.points(i, 0), data.points(i, 1), data.points(i, 2)});
  return static_cast<int>(seen.size());
}

// The number of parallels of a surface of revolution (heights along its axis more than `distance`
// apart) on which the points lie: a tessellation's vertices on k parallels only fix a meridian
// through k points, which a circle does for any three.
int distinct_parallels(const PatchPoints& data, const Surface& surface, double distance) {
  std::vector<double> heights(data.points.rows());
  for (Eigen::Index i = 0; i < data.points.rows(); ++i)
    heights[i] = (data.points.row(i).transpose() - surface.point).dot(surface.axis);
  std::sort(heights.begin(), heights.end());
  int count = heights.empty() ? 0 : 1;
  for (size_t i = 1; i < heights.size(); ++i) count += heights[i] - heights[i - 1] > distance;
  return count;
}

// A lemon (the inner part of a spindle torus) fitted to `data`, if its points fix one: on more than
// three parallels (see above; or it starts from `start`, a lemon fixed before), and with its centre
// circle off its axis by more than `tolerance` (else it is a sphere).
std::optional<SurfaceFit> fit_lemon(const PatchPoints& data, const FitOptions& options, double tolerance,
                                    double distance, const Surface* start = nullptr) {
  FitOptions lemons = options;
  lemons.lemons = true;
  const SurfaceFit fit = fit_surface(SurfaceType::Torus, data, lemons, start);
  if (!fit.valid || fit.surface.radius >= -tolerance || (!start && distinct_parallels(data, fit.surface, distance) <= 3))
    return std::nullopt;
  return fit;
}

// On an exact tessellation, a small curved face (a chamfer cone cut by a hexagon) may fall apart
// into single facets of which no pair determines its surface. From each small piece, its nearest
// small neighbours are gathered until they have three distinct vertices more than a surface type
// has parameters; the simplest type that explains every vertex and facet normal of them exactly
// then grows over the adjacent small pieces it explains, and all of them merge into one patch.
// Returns whether any piece merged.
bool merge_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                     const FeatureOptions& options, double exact_distance, std::vector<Feature>& features,
                     std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<char> small(num, 0);
  for (int p = 0; p < num; ++p) small[p] = points[p].points.rows() > 0 && points[p].points.rows() < kInteriorPoints;
  // Small pieces meeting without a crease (in order of id).
  std::vector<std::vector<int>> neighbours(num);
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels))
    if (small[pair.first] && small[pair.second] && turn <= kLargestFacetTurn) {
      neighbours[pair.first].push_back(pair.second);
      neighbours[pair.second].push_back(pair.first);
    }
  for (std::vector<int>& n : neighbours) std::sort(n.begin(), n.end());
  const double angle = options.normal_floor_degrees * M_PI / 180.0;
  std::vector<int> into(num);
  for (int p = 0; p < num; ++p) into[p] = p;
  std::vector<char> taken(num, 0), in_group(num, 0);
  bool any = false;
  for (int seed = 0; seed < num; ++seed) {
    if (!small[seed] || taken[seed] || neighbours[seed].empty()) continue;
    for (SurfaceType type : kTypesByPreference) {
      // The seed's nearest untaken small neighbours, breadth first, until the type is determined.
      std::vector<int> group{seed};
      in_group[seed] = 1;
      PatchPoints data = points[seed];
      for (size_t head = 0; head < group.size() && distinct_points(data) < parameter_count(type) + 3; ++head)
        for (int q : neighbours[group[head]])
          if (!taken[q] && !in_group[q] && distinct_points(data) < parameter_count(type) + 3) {
            in_group[q] = 1;
            group.push_back(q);
            data = concatenate(data, points[q]);
          }
      SurfaceFit fit;
      bool exact = distinct_points(data) >= parameter_count(type) + 3;
      if (exact) {
        fit = fit_surface(type, data, options.fit);
        exact = fit.valid && explains_every_point(fit.surface, data, exact_distance, angle, kFewPointsChordTurn);
      }
      const size_t gathered = group.size();  // their points are in `data` already
      if (exact) {  // grow over the small pieces the surface explains
        for (size_t head = 0; head < group.size(); ++head)
          for (int q : neighbours[group[head]])
            if (!taken[q] && !in_group[q] && explains_every_point(fit.surface, points[q], exact_distance, angle, kFewPointsChordTurn)) {
              in_group[q] = 1;
              group.push_back(q);
            }
      }
      for (int q : group) in_group[q] = 0;
      if (!exact) continue;
      const int id = features[seed].id;
      for (size_t i = gathered; i < group.size(); ++i) data = concatenate(data, points[group[i]]);
      const SurfaceFit refit = fit_surface(type, data, options.fit, &fit.surface);
      features[seed].set_fit(refit.valid && refit.rms <= fit.rms + exact_distance ? refit : fit);
      features[seed].id = id;
      for (int q : group) {
        into[q] = seed;
        taken[q] = 1;
      }
      any = true;
      break;
    }
  }
  for (int& l : labels)
    if (l >= 0) l = into[l];
  return any;
}

// On an exact tessellation, the small pieces that no surface explains exactly once merging has
// finished join the large neighbour they meet without a crease whose surface comes nearest to their
// vertices, if within `tolerance`: the facets along the trimmed rim of a torus band that the
// tessellation cut with a single chord across (its other facets lie on a cone). Returns whether any
// piece joined.
bool absorb_fragments(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                      double tolerance, const std::vector<Feature>& features, std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<int> into(num, kNone);
  std::vector<double> nearest(num, tolerance);
  for (const auto& [pair, turn] : boundary_turns(mesh, topology, labels)) {
    if (turn > kLargestFacetTurn) continue;
    for (const auto& [piece, large] : {pair, std::make_pair(pair.second, pair.first)}) {
      if (points[piece].points.rows() >= kInteriorPoints || points[large].points.rows() < kInteriorPoints ||
          features[large].type == SurfaceType::Freeform)
        continue;
      double worst = 0.0;
      for (Eigen::Index i = 0; i < points[piece].points.rows(); ++i)
        worst = std::max(worst, std::abs(signed_distance(features[large].surface, points[piece].points.row(i).transpose())));
      if (worst < nearest[piece]) {
        nearest[piece] = worst;
        into[piece] = large;
      }
    }
  }
  bool any = false;
  for (int& l : labels)
    if (l >= 0 && into[l] != kNone) {
      l = into[l];
      any = true;
    }
  return any;
}

// On an exact tessellation, the small pieces that nothing placed once merging has finished may hold
// facets of two faces that the planar split took for one (the first, narrow facet of a tangent
// fillet beside a facet of the cylinder it rounds, turned by a fraction of a degree): each of their
// facets becomes a piece of its own, for merging to place them one by one. A facet takes the id of
// a patch that merging emptied, and a plane through it. Returns whether any piece fell apart.
bool shatter_fragments(const TriangleMesh& mesh, const std::vector<PatchPoints>& points, const FeatureOptions& options,
                       std::vector<Feature>& features, std::vector<int>& labels) {
  const int num = static_cast<int>(points.size());
  std::vector<std::vector<int>> facets(num);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] >= 0 && points[labels[f]].points.rows() < kInteriorPoints) facets[labels[f]].push_back(f);
  std::vector<int> free_ids;
  for (int p = num - 1; p >= 0; --p)
    if (points[p].points.rows() == 0) free_ids.push_back(p);
  std::vector<int> slot(mesh.num_vertices(), -1);
  bool any = false;
  for (int p = 0; p < num; ++p) {
    if (facets[p].size() < 2 || facets[p].size() - 1 > free_ids.size()) continue;
    const Feature piece = features[p];
    for (size_t i = 0; i < facets[p].size(); ++i) {
      const int f = facets[p][i];
      const SurfaceFit plane =
          fit_surface(SurfaceType::Plane, face_points(mesh, &f, 1, slot, [](int) { return false; }), options.fit);
      if (!plane.valid) continue;  // a degenerate facet stays with the piece
      const int id = i == 0 ? p : free_ids.back();  // the first facet keeps the piece's id
      if (id != p) free_ids.pop_back();
      features[id] = piece;
      features[id].id = id;
      features[id].set_fit(plane);
      labels[f] = id;
      any |= id != p;
    }
  }
  return any;
}

// Whether two features may be pieces of one surface by their parameters: one type, parallel axes,
// radii that relations would take for equal (cones: half-angles within the angle tolerance); or a
// zone of a torus between two parallels, which a cone or cylinder about its axis fits.
bool alike(const Feature& a, const Feature& b, double angle_tolerance, double distance_tolerance, double radius_tolerance) {
  if (a.type == SurfaceType::Freeform || b.type == SurfaceType::Freeform) return false;
  auto zone = [](SurfaceType t) { return t == SurfaceType::Cone || t == SurfaceType::Cylinder; };
  const bool torus_zone = (a.type == SurfaceType::Torus && zone(b.type)) || (b.type == SurfaceType::Torus && zone(a.type));
  if (a.type != b.type && !torus_zone) return false;
  if (a.surface.has_direction() && std::abs(a.surface.axis.dot(b.surface.axis)) < std::cos(angle_tolerance)) return false;
  if (torus_zone) return true;
  if (a.type == SurfaceType::Cone) return std::abs(a.surface.half_angle - b.surface.half_angle) <= angle_tolerance;
  return a.type == SurfaceType::Plane || equal_radii(a, b, distance_tolerance, radius_tolerance);
}

// Merges adjacent patches whose union one surface fits as well as each part alone: a fillet or a
// cylinder that segmentation split along the facet folds of a coarse tessellation. Patches of one
// type are refitted together; a patch too small to have interior vertices may also join a
// neighbour of another type (a single facet of a fillet is planar). Plain RMS values decide
// here, not the robust spreads, which would not see a small foreign face in the union. Each patch
// merges at most once per call; `rejected` remembers the pairs that did not fit together until one
// of them grows. On an exact tessellation (`exact`) the merged surface must also explain every
// vertex to within `exact_distance` and every facet normal; on a noisy one each part must fit it
// about as well as its own surface, `noise` being the least RMS expected. Returns whether any pair
// merged.
bool merge_patches(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<PatchPoints>& points,
                   const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                   const FeatureOptions& options, double tolerance, bool exact, double exact_distance, double noise,
                   std::vector<Feature>& features, std::vector<int>& labels, std::set<std::pair<int, int>>& rejected, const ProgressSpan& progress) {
  // Adjacent pairs, on an exact tessellation not across a crease: sharper than kLargestFacetTurn, and
  // than a quarter more than the sharpest turn inside the larger patch, which on the saddle of a
  // coarse torus exceeds it (the CAD tessellations of the benchmark: up to 54° inside tori, 22°
  // inside any other face).
  std::vector<std::pair<int, int>> pairs;
  const std::map<std::pair<int, int>, double> turns = boundary_turns(mesh, topology, labels, true);
  auto inside_turn = [&](int p) {
    const auto it = turns.find({p, p});
    return it == turns.end() ? 0.0 : it->second;
  };
  for (const auto& [pair, turn] : turns) {
    if (pair.first == pair.second) continue;
    const int larger = points[pair.first].weights.sum() >= points[pair.second].weights.sum() ? pair.first : pair.second;
    if (!exact || turn <= std::max(kLargestFacetTurn, 1.25 * inside_turn(larger))) pairs.push_back(pair);
  }

  struct Candidate {
    double cost;
    int a, b;
    Feature feature;
  };
  std::vector<Candidate> candidates;
  std::vector<std::pair<int, int>> absorbed;  // (large, piece): the large patch's surface explains the piece
  const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
  const double angle_tolerance = options.angle_tolerance_degrees * M_PI / 180.0;
  // Each pair is judged on its own (reading the features, points and labels only): on two threads,
  // the verdicts then taken in the pairs' order.
  enum class Verdict { kUnchanged, kAbsorbed, kMerged, kRejected };
  struct Judgement {
    Verdict verdict = Verdict::kUnchanged;
    Candidate candidate;  // kAbsorbed: (large, piece); kMerged: the pair and its surface
  };
  auto judge = [&](size_t i) -> Judgement {
    const int a = pairs[i].first, b = pairs[i].second;  // (not a structured binding: lambdas below capture them)
    if (rejected.count({a, b})) return {};  // neither changed since
    const Feature &fa = features[a], &fb = features[b];
    const PatchPoints &pa = points[a], &pb = points[b];
    const bool a_small = pa.points.rows() < kInteriorPoints, b_small = pb.points.rows() < kInteriorPoints;
    const bool same_type = fa.type == fb.type && fa.type != SurfaceType::Freeform;
    const bool a_larger = pa.weights.sum() >= pb.weights.sum();
    const Feature &larger = a_larger ? fa : fb, &smaller = a_larger ? fb : fa;
    const PatchPoints &larger_points = a_larger ? pa : pb, &smaller_points = a_larger ? pb : pa;
    const bool larger_small = a_larger ? a_small : b_small;
    const double limit = options.residual_ratio * std::max(fa.rms, fb.rms) + kExactFraction * tolerance;
    const double normal_limit = options.residual_ratio * std::max(fa.normal_rms, fb.normal_rms) + normal_floor;
    // A surface that the vertices of a large patch fix takes the neighbours it explains as it is,
    // several in one call: on an exact tessellation when it explains every point and the normals of
    // both together fit it as a merge would require (the fragments along a coarse torus); on a
    // noisy one a curved surface takes a large neighbour of another type that it fits about as well
    // as the neighbour's own surface (a zone of a torus that a sphere fits).
    const bool noisy_other_type = !exact && !same_type && !a_small && !b_small && larger.type != SurfaceType::Plane;
    if ((exact || noisy_other_type) && !larger_small && larger.type != SurfaceType::Freeform) {
      SurfaceFit piece;
      piece.surface = larger.surface;
      measure_spreads(smaller_points, piece);
      bool explained;
      if (exact) {
        const double w_larger = larger_points.sample_weights.sum(), w_smaller = smaller_points.sample_weights.sum();
        const double normal_rms = std::sqrt((w_larger * larger.normal_rms * larger.normal_rms +
                                             w_smaller * piece.normal_rms * piece.normal_rms) / (w_larger + w_smaller));
        const double angle = 3.0 * std::max(fa.normal_spread, fb.normal_spread) + normal_floor;
        explained = normal_rms <= normal_limit &&
                    explains_every_point(larger.surface, smaller_points, exact_distance, angle, kLargestFacetTurn);
      } else {
        double rms, max_error;
        fit_residuals(larger.surface, smaller_points.points, smaller_points.weights, rms, max_error);
        explained = rms <= options.residual_ratio * std::max(smaller.rms, noise) && piece.normal_rms <= normal_limit;
      }
      if (explained) return {Verdict::kAbsorbed, {0.0, a_larger ? a : b, a_larger ? b : a, Feature()}};
    }
    // Two large patches of different types make one surface only on an exact tessellation: a coarse
    // torus falls into bands between its meridians, each of which a cylinder or cone fits exactly.
    if (!same_type && !a_small && !b_small && !exact) return {};
    // On a noisy mesh, two cylinders of one radius whose axes turn may be sectors of another surface
    // that the histogram cut up: a torus's tube (a wide blend whose mean curvature passes through
    // zero), a slender cone. Their union is identified afresh.
    const bool sectors = !exact && same_type && fa.type == SurfaceType::Cylinder &&
                         std::abs(fa.surface.axis.dot(fb.surface.axis)) < std::cos(angle_tolerance) &&
                         equal_radii(fa, fb, tolerance, options.radius_tolerance);
    // Two alike pieces (planes within the angle tolerance; coaxial cylinders of one radius, and so
    // on) that meet without a crease (no facet turns more across their border than inside either)
    // are one surface where it explains each part (below), or, planes, where both pass through their
    // border as closely as through their own points (not a step): a sculpted face's undulation bends
    // it by more than its pieces' fits allow a merge (a sculpted fillet in two pieces 1.5° apart),
    // and a large face by more than the distance tolerance (the sculpted box's sides, in two planes
    // 1° apart), but not by an edge. Idealization would make such planes parallel, and so, sharing a
    // border, coplanar.
    const auto border = turns.find({std::min(a, b), std::max(a, b)});
    const bool one_surface = same_type && alike(fa, fb, angle_tolerance, tolerance, options.radius_tolerance) &&
                             border != turns.end() && border->second <= std::max(inside_turn(a), inside_turn(b));
    const bool one_plane = one_surface && fa.type == SurfaceType::Plane;
    const PatchPoints both = concatenate(pa, pb);
    auto accepted = [&](const Feature& u) {
      if (u.type == SurfaceType::Freeform) return false;
      // (A curved union keeps to the normals' limit: the refit of two pieces of a narrow fillet may
      // flatten into a cylinder of 20 m, which then grows over the plane beside it.)
      const bool loose = !exact && one_surface && u.type == fa.type;
      if ((!loose && u.rms > limit) || (!(loose && one_plane) && u.normal_rms > normal_limit)) return false;
      if (!exact) {
        // An RMS over the union hides a small foreign part (a pocket's wall in a large plane, whose
        // RMS then lets the next one in).
        for (const auto& [part, own] : {std::pair{&pa, &fa}, std::pair{&pb, &fb}}) {
          double rms, max_error;
          fit_residuals(u.surface, part->points, part->weights, rms, max_error);
          if (rms > options.residual_ratio * std::max(own->rms, noise) + tolerance)
            return one_plane && u.type == SurfaceType::Plane &&
                   surfaces_meet_at_border(mesh, topology, labels, a, b, fa.surface, fb.surface,
                                           std::max(tolerance, fa.max_error), std::max(tolerance, fb.max_error));
        }
        return true;
      }
      // Exact only with a point more than the surface's parameters fit anyway (the six vertices of
      // two creased quads lie on three lines through a point, and so on a cone).
      if (distinct_points(both) <= parameter_count(u.type)) return false;
      // As much normal spread as the parts have is allowed, plus the floor (and the facets' chords).
      const double angle = 3.0 * std::max(fa.normal_spread, fb.normal_spread) + normal_floor;
      const double chord_turn = larger_small ? kFewPointsChordTurn : kLargestFacetTurn;
      return explains_every_point(u.surface, pa, exact_distance, angle, chord_turn) &&
             explains_every_point(u.surface, pb, exact_distance, angle, chord_turn);
    };
    // A small piece joins its neighbour's surface; two small pieces may make a new one.
    Feature merged = larger;
    bool ok = false;
    if ((same_type || !larger_small) && larger.type != SurfaceType::Freeform) {
      const SurfaceFit fit = fit_surface(larger.type, both, options.fit, &larger.surface);
      if (fit.valid) {
        merged.set_fit(fit);
        ok = accepted(merged);
      }
    }
    // On an exact tessellation, two large pieces of which one is curved may lie on a third surface:
    // the bands of a coarse torus between its parallels are cones or spheres each.
    const bool one_curved = exact && (fa.type != SurfaceType::Plane || fb.type != SurfaceType::Plane) &&
                            fa.type != SurfaceType::Freeform && fb.type != SurfaceType::Freeform;
    if (!ok && ((a_small && b_small) || one_curved || sectors)) {
      merged = identify_points(both, larger.curvature);
      ok = accepted(merged);
      // Identification accepts the simplest type within the distance tolerance, which on an exact
      // tessellation may take a sphere or a cone for two curved pieces of a lemon-shaped dome (a
      // spindle torus's inner part) that it does not explain: then the torus, if it does, from the
      // piece that is a lemon already if one is. (Planar facets tell no curvature: the few points
      // of two fit a lemon of any shape.)
      auto curved = [](SurfaceType t) { return t != SurfaceType::Plane && t != SurfaceType::Freeform; };
      auto lemon_piece = [](const Feature& f) { return f.type == SurfaceType::Torus && f.surface.radius < 0.0; };
      const Surface* start = lemon_piece(fa) ? &fa.surface : lemon_piece(fb) ? &fb.surface : nullptr;
      if (exact && !ok && curved(merged.type) && (merged.type != SurfaceType::Torus || start) && curved(fa.type) &&
          curved(fb.type)) {
        if (const std::optional<SurfaceFit> lemon = fit_lemon(both, options.fit, tolerance, exact_distance, start)) {
          Feature torus = merged;
          torus.set_fit(*lemon);
          if ((ok = accepted(torus))) merged = torus;
        }
      }
    }
    // On a noisy mesh, two planes may be the halves of a narrow fillet, each as flat as the noise
    // lets it look: a curved surface joins them when its normals fit the union better than either
    // plane's fit its own half (two faces of a real edge fit their planes better), and its
    // distances no worse. Most pairs of planes are faces of a real edge: only planes that turn by
    // less than 60° (the halves of a rounded edge of up to 120°) are tried, and the other curved
    // types only where a cylinder bends the right way but does not fit (measured on the benchmark's
    // scans: 3 of 1242 pairs merged, all within 40°; fitting them all doubled the merging time).
    const bool halves = std::abs(fa.surface.axis.dot(fb.surface.axis)) > 0.5;
    if (!ok && !exact && same_type && fa.type == SurfaceType::Plane && halves) {
      const double plane_normal_rms = std::min(fa.normal_rms, fb.normal_rms);
      for (SurfaceType type : {SurfaceType::Cylinder, SurfaceType::Cone, SurfaceType::Sphere, SurfaceType::Torus}) {
        const SurfaceFit fit = fit_surface(type, both, options.fit);
        if (!fit.valid) continue;
        Feature curved = larger;
        curved.set_fit(fit);
        const bool bends = curved.normal_rms < plane_normal_rms;
        if (bends && curved.rms <= std::max(fa.rms, fb.rms) && accepted(curved)) {
          merged = curved;
          ok = true;
          break;
        }
        if (type == SurfaceType::Cylinder && !bends) break;
      }
    }
    if (!ok) return {Verdict::kRejected, {0.0, a, b, Feature()}};
    return {Verdict::kMerged, {merged.rms / limit, a, b, merged}};
  };
  std::vector<Judgement> judgements(pairs.size());
  std::vector<int> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  on_two_threads(order, [&](int i) { judgements[i] = judge(i); }, progress);
  for (Judgement& j : judgements) {
    if (j.verdict == Verdict::kAbsorbed) absorbed.push_back({j.candidate.a, j.candidate.b});
    if (j.verdict == Verdict::kMerged) candidates.push_back(std::move(j.candidate));
    if (j.verdict == Verdict::kRejected) rejected.insert({j.candidate.a, j.candidate.b});
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return x.cost != y.cost ? x.cost < y.cost : std::make_pair(x.a, x.b) < std::make_pair(y.a, y.b);
  });
  std::vector<char> merged(features.size(), 0);
  std::vector<int> into(features.size());
  for (size_t p = 0; p < into.size(); ++p) into[p] = static_cast<int>(p);
  bool any = false;
  // Absorbed pieces first, into the largest patches first; a patch that absorbs keeps its surface
  // for this call (no merge with a refit).
  std::sort(absorbed.begin(), absorbed.end(), [&](const auto& x, const auto& y) {
    const double wx = points[x.first].weights.sum(), wy = points[y.first].weights.sum();
    return wx != wy ? wx > wy : x < y;
  });
  std::vector<char> absorbing(features.size(), 0);
  std::map<int, PatchPoints> grown;  // the points of each absorbing patch and its pieces
  for (const auto& [large, piece] : absorbed) {
    if (merged[piece] || absorbing[piece] || merged[large]) continue;
    merged[piece] = absorbing[large] = 1;
    into[piece] = large;
    const auto it = grown.find(large);
    grown[large] = concatenate(it == grown.end() ? points[large] : it->second, points[piece]);
    any = true;
  }
  // The surface refitted to all of them, starting from the one that explained them.
  for (const auto& [large, data] : grown) {
    Feature& f = features[large];
    const SurfaceFit fit = fit_surface(f.type, data, options.fit, &f.surface);
    if (fit.valid && fit.rms <= f.rms + exact_distance) {
      const int id = f.id;
      f.set_fit(fit);
      f.id = id;
    }
  }
  for (const Candidate& c : candidates) {
    if (merged[c.a] || merged[c.b] || absorbing[c.a] || absorbing[c.b]) continue;
    merged[c.a] = merged[c.b] = 1;
    into[c.b] = c.a;
    const int id = features[c.a].id;
    features[c.a] = c.feature;
    features[c.a].id = id;
    any = true;
  }
  for (size_t p = 0; p < absorbing.size(); ++p) merged[p] |= absorbing[p];
  for (int& l : labels)
    if (l >= 0) l = into[l];
  for (auto it = rejected.begin(); it != rejected.end();)  // pairs with a grown patch are open again
    it = merged[it->first] || merged[it->second] ? rejected.erase(it) : std::next(it);
  return any;
}

// State of each face of a patch being split: not in the patch, not yet reached, grown into a region
// that turned out too small (it goes to the remainder), in a kept region, or gathered into a
// remainder component.
enum FaceState : char { kOutside, kUnvisited, kGrown, kKept, kRemainder };

// The faces of `patch` that no kept region took (state kUnvisited or kGrown), in connected
// components: a component too small to be a face of its own joins the kept region it borders most,
// the others become patches, the first of them keeping the id `patch` when `patch_free`. `faces`
// orders the seeds. Returns the next free id.
int label_remainder(const MeshTopology& topology, const std::vector<int>& faces, int patch, bool patch_free,
                    std::vector<char>& state, std::vector<int>& labels, int next_id, const ProgressSpan& progress) {
  long long visited = 0;
  for (int seed : faces) {
    if (state[seed] != kUnvisited && state[seed] != kGrown) continue;
    std::vector<int> component{seed};
    state[seed] = kRemainder;
    std::vector<std::pair<int, int>> borders;  // (region id, shared edges)
    for (size_t head = 0; head < component.size(); ++head) {
      progress.poll(++visited, 1 << 12);
      const int f = component[head];
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0) continue;
        if (state[g] == kKept) {
          auto it = std::find_if(borders.begin(), borders.end(), [&](const auto& b) { return b.first == labels[g]; });
          if (it == borders.end()) borders.emplace_back(labels[g], 1);
          else ++it->second;
        } else if (state[g] == kUnvisited || state[g] == kGrown) {
          state[g] = kRemainder;
          component.push_back(g);
        }
      }
    }
    int id;
    if (static_cast<int>(component.size()) < kInteriorPoints && !borders.empty()) {
      id = std::max_element(borders.begin(), borders.end(), [](const auto& x, const auto& y) {
             return x.second != y.second ? x.second < y.second : x.first > y.first;
           })->first;
    } else {
      id = patch_free ? patch : next_id++;
      patch_free = false;
    }
    for (int f : component) labels[f] = id;
  }
  return next_id;
}

// Splits a patch that no surface fits (the segmentation merged faces across an edge it did not
// resolve) into planar regions grown from its largest faces: a face joins while its vertices lie
// within 3 σ of the region's plane and its normal within 3 σ of the plane's, σ being the noise of
// the mesh's well-fitted patches. Regions of fewer than `min_region_faces` faces go back to a
// remainder whose connected components become patches of their own: on a noisy mesh a curved face
// stays whole that way, while on an exact tessellation (min_region_faces = 1) curved parts fall
// apart into planar facets that merging joins again. The first region keeps the patch's id, the
// others get new ids from `next_id` on.
int split_patch(const TriangleMesh& mesh, const MeshTopology& topology, const Eigen::VectorXd& area, int patch,
                double noise, double normal_noise, int min_region_faces, std::vector<int>& labels, int next_id,
                const ProgressSpan& progress) {
  std::vector<int> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] == patch) faces.push_back(f);
  std::stable_sort(faces.begin(), faces.end(), [&](int x, int y) { return area[x] > area[y]; });
  std::vector<char> open(mesh.num_faces(), kOutside);
  for (int f : faces) open[f] = kUnvisited;
  const double cos_limit = std::cos(std::min(3.0 * normal_noise, 0.5 * M_PI));
  bool first = true;
  long long visited = 0;  // faces taken from the queues: polled every few thousand
  for (int seed : faces) {
    if (open[seed] != kUnvisited) continue;
    Surface plane;
    plane.type = SurfaceType::Plane;
    plane.axis = face_normal(mesh, seed);
    plane.point = face_centroid(mesh, seed);
    std::vector<int> region{seed}, queue{seed};
    open[seed] = kGrown;
    size_t fitted = 1;
    Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double weight = 0.0;
    auto accumulate = [&](int f) {
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector3d v = mesh.V.row(mesh.F(f, c));
        moment += area[f] * v * v.transpose();
        sum += area[f] * v;
        weight += area[f];
      }
    };
    accumulate(seed);
    for (size_t head = 0; head < queue.size(); ++head) {
      progress.poll(++visited, 1 << 12);
      const int f = queue[head];
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || open[g] != kUnvisited || std::abs(face_normal(mesh, g).dot(plane.axis)) < cos_limit) continue;
        bool near = true;
        for (int k = 0; k < 3 && near; ++k)
          near = std::abs(signed_distance(plane, mesh.V.row(mesh.F(g, k)).transpose())) <= 3.0 * noise;
        if (!near) continue;
        open[g] = kGrown;
        region.push_back(g);
        queue.push_back(g);
        accumulate(g);
        if (region.size() >= 2 * fitted) {  // refit the plane as the region doubles
          const Eigen::Vector3d centre = sum / weight;
          const Eigen::Matrix3d covariance = moment / weight - centre * centre.transpose();
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
          Eigen::Vector3d axis = solver.eigenvectors().col(0);
          plane.axis = axis.dot(plane.axis) < 0.0 ? Eigen::Vector3d(-axis) : axis;
          plane.point = centre;
          fitted = region.size();
        }
      }
    }
    if (static_cast<int>(region.size()) < min_region_faces) continue;  // stays open: remainder
    const int id = first ? patch : next_id++;
    first = false;
    for (int f : region) labels[f] = id;
    for (int f : region) open[f] = kKept;
  }
  return label_remainder(topology, faces, patch, first, open, labels, next_id, progress);
}

// How far `surface` bends away from the plane of `data` across its points: the spread of its
// distances from their projections on that plane (zero for a plane).
double bend(const Surface& surface, const FitData& data) {
  const SurfaceFit plane = fit_surface(SurfaceType::Plane, data);
  if (!plane.valid || surface.type == SurfaceType::Plane) return 0.0;
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) {
    const Eigen::Vector3d p = data.points.row(i).transpose();
    const double d = signed_distance(surface, p - signed_distance(plane.surface, p) * plane.surface.axis);
    low = std::min(low, d);
    high = std::max(high, d);
  }
  return high - low;
}

// Splits a noisy patch that no single surface fits into regions that one surface each fits: a chain
// of blends of one radius (cylinder, torus, cylinder) has one mean curvature, so the histogram
// cannot tell its members apart. From the face deepest inside the patch, a disc of faces is
// identified; when one surface fits it to within `fits_below` RMS, the region grows over the faces
// whose vertices lie within 3 σ of the surface and whose normals lie within 3 σ_n of its normals (σ
// the larger of the mesh's noise and the fit's spread), refitted as it doubles. Regions of at least
// `min_region_faces` faces get new ids from `next_id` on; the faces no region took are labelled by
// label_remainder (a corner ball between fillets, a small boss on a plate), and the reassignment
// that follows moves rim faces to the surfaces that explain them. A growing region's refit that no
// longer fits within `fits_below` (and has drifted by more than the noise from its disc's fit) ends
// its growth at the last region that did. A region that grew on as a torus (a sector of a tube's
// bend, below) makes the patch split once more with the tori grown first; the regions that stand as
// tori are entered in `generalized` (new id -> its torus).
int split_into_surfaces(const TriangleMesh& mesh, const MeshTopology& topology, int patch, double noise,
                        double normal_noise, double fits_below, int min_region_faces,
                        const std::function<Feature(const PatchPoints&)>& identify_points, const FitOptions& fit_options,
                        std::vector<int>& labels, int next_id, std::map<int, Surface>& generalized,
                        const ProgressSpan& progress) {
  // Depth of every face of the patch: edge steps from its rim (multi-source breadth-first search).
  std::vector<int> depth(mesh.num_faces(), -1), queue, faces;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] != patch) continue;
    faces.push_back(f);
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0 || labels[g] != patch) {
        depth[f] = 0;
        queue.push_back(f);
        break;
      }
    }
  }
  for (size_t head = 0; head < queue.size(); ++head)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(queue[head], c);
      if (g >= 0 && labels[g] == patch && depth[g] < 0) {
        depth[g] = depth[queue[head]] + 1;
        queue.push_back(g);
      }
    }
  std::vector<int> seeds = queue;  // deepest first, ties by face index
  std::stable_sort(seeds.begin(), seeds.end(), [&](int x, int y) { return depth[x] != depth[y] ? depth[x] > depth[y] : x < y; });

  const int disc_faces = 2 * kInteriorPoints;
  const int first_id = next_id;
  std::vector<char> tried(mesh.num_faces(), 0), in_region(mesh.num_faces(), 0);
  std::vector<int> slot(mesh.num_vertices(), -1);
  auto all_points = [&](const std::vector<int>& region_faces) {
    return face_points(mesh, region_faces.data(), static_cast<int>(region_faces.size()), slot, [](int) { return false; });
  };
  // The disc: the nearest `size` faces of the patch from `seed` that no region took.
  auto disc = [&](int seed, int size) {
    std::vector<int> region{seed};
    in_region[seed] = 1;
    for (size_t head = 0; head < region.size() && static_cast<int>(region.size()) < size; ++head)
      for (int c = 0; c < 3 && static_cast<int>(region.size()) < size; ++c) {
        const int g = topology.face_neighbor(region[head], c);
        if (g >= 0 && labels[g] == patch && !in_region[g]) {
          in_region[g] = 1;
          region.push_back(g);
        }
      }
    for (int f : region) in_region[f] = 0;
    return region;
  };
  auto fits = [&](const Feature& f) { return f.type != SurfaceType::Freeform && f.rms <= fits_below; };
  long long visited = 0;
  struct Grown {
    int id;
    std::vector<int> faces;
    Feature feature;
  };
  std::vector<Grown> tori;  // the regions that grew on as tori
  // Grows `region` (faces of the patch) as `feature`, fitted to a disc as a `disc_type`.
  auto grow = [&](std::vector<int> region, Feature feature, SurfaceType disc_type) {
    for (int f : region) tried[f] = in_region[f] = 1;
    size_t fitted = region.size();
    auto explains = [&](int g) {
      return face_misfit(mesh, g, feature.surface, 3.0 * std::max(noise, feature.spread),
                         3.0 * std::max(normal_noise, feature.normal_spread)) <= 1.0;
    };
    // The disc's faces that the surface does not explain leave it; the rest grows.
    for (int f : region) in_region[f] = explains(f);
    region.erase(std::remove_if(region.begin(), region.end(), [&](int f) { return !in_region[f]; }), region.end());
    // A refit that no longer fits (the region crept over a neighbouring surface that it explains
    // near their tangent border, and the refit bent towards it) ends growth at the last region
    // that fitted.
    const double disc_rms = feature.rms;
    Feature fitting = feature;
    size_t fitting_size = region.size();
    bool overgrown = false;
    auto refit = [&] {
      const SurfaceFit fit = fit_surface(feature.type, all_points(region), fit_options, &feature.surface);
      if (fit.valid) feature.set_fit(fit);
      fitted = region.size();
      overgrown = !fits(feature) && feature.rms > disc_rms + noise;
      if (overgrown) return;
      fitting = feature;
      fitting_size = region.size();
    };
    // A cylinder grown on a sector of a tube's bend (a torus whose tube it approximates, the
    // histogram having cut the bend up) stops, or overgrows, where the bend turns away from it.
    // Where the region together with as many faces again beyond it fits no cylinder as well as its
    // disc did, but a ring torus bending across the cylinder's axis (not a barrel about it) does, it
    // grows on as that torus.
    auto generalize = [&] {
      if (feature.type != SurfaceType::Cylinder) return false;
      std::vector<int> wider = region;
      for (size_t head = 0; head < wider.size() && wider.size() < 2 * region.size(); ++head)
        for (int c = 0; c < 3; ++c) {
          const int g = topology.face_neighbor(wider[head], c);
          if (g >= 0 && labels[g] == patch && !in_region[g]) {
            in_region[g] = 1;
            wider.push_back(g);
          }
        }
      for (size_t i = region.size(); i < wider.size(); ++i) in_region[wider[i]] = 0;
      const FitData wider_points = all_points(wider);
      const double as_well = std::min(fits_below, disc_rms + noise);
      const SurfaceFit straight = fit_surface(SurfaceType::Cylinder, wider_points, fit_options, &feature.surface);
      if (straight.valid && straight.rms <= disc_rms + noise) return false;
      // Or a cone where it fits better than the torus: a cylinder grown on a slender cone tilts by
      // the half-angle and takes half of it, its axis along the cone's generators there (turned from
      // the cone's by up to twice the half-angle and 45°, not across a tube's bend that a flat cone fits).
      const SurfaceFit torus = fit_surface(SurfaceType::Torus, wider_points, fit_options);
      const SurfaceFit cone = fit_surface(SurfaceType::Cone, wider_points, fit_options);
      const bool torus_fits = torus.valid && torus.rms <= as_well && torus.surface.radius >= torus.surface.minor &&
                              std::abs(torus.surface.axis.dot(feature.surface.axis)) <= std::sqrt(0.5);
      const bool cone_fits = cone.valid && cone.rms <= as_well &&
                             std::abs(cone.surface.axis.dot(feature.surface.axis)) >=
                                 std::max(std::sqrt(0.5), std::cos(2.0 * cone.surface.half_angle));
      if (!torus_fits && !cone_fits) return false;
      const SurfaceFit& bent = cone_fits && (!torus_fits || cone.rms < torus.rms) ? cone : torus;
      feature.set_fit(bent);
      fitting = feature;
      fitted = fitting_size = region.size();
      overgrown = false;
      return true;
    };
    // When growth stops, the surface refitted to all it took may explain more (a disc across a
    // narrow fillet fixes its radius only roughly): growth resumes while refits add to it.
    for (bool growing = true; growing;) {
      for (size_t head = 0; head < region.size() && !overgrown; ++head) {
        progress.poll(++visited, 1 << 12);
        for (int c = 0; c < 3 && !overgrown; ++c) {
          const int g = topology.face_neighbor(region[head], c);
          if (g < 0 || labels[g] != patch || in_region[g] || !explains(g)) continue;
          in_region[g] = 1;
          region.push_back(g);
          if (region.size() >= 2 * fitted) refit();  // refit as the region doubles
        }
      }
      if (!overgrown && region.size() > fitted + fitted / 8) {  // (bounded rounds: each grows it by an eighth)
        refit();
        continue;
      }
      growing = generalize();
    }
    if (overgrown) {  // (breadth-first: the first faces of the region are connected)
      for (size_t i = fitting_size; i < region.size(); ++i) in_region[region[i]] = 0;
      region.resize(fitting_size);
      feature = fitting;
    }
    for (int f : region) in_region[f] = 0;
    if (static_cast<int>(region.size()) < min_region_faces) return;
    for (int f : region) labels[f] = next_id;
    if (feature.type != disc_type) tori.push_back({next_id, region, feature});
    ++next_id;
  };
  // A torus found late grows over what the cylinders grown before it left: once one did, the
  // patch is split again with the tori first.
  std::vector<int> first_labels;  // of the faces, after the first pass
  std::vector<Grown> first_tori;
  int first_next = next_id;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      if (tori.empty()) break;
      first_next = next_id;
      first_tori = std::move(tori);
      tori.clear();
      for (int f : faces) {
        first_labels.push_back(labels[f]);
        labels[f] = patch;
      }
      std::fill(tried.begin(), tried.end(), 0);
      next_id = first_id;
      for (const Grown& torus : first_tori) grow(torus.faces, torus.feature, SurfaceType::Cylinder);
    }
    for (int seed : seeds) {
      if (labels[seed] != patch || tried[seed]) continue;
      std::vector<int> region = disc(seed, disc_faces);
      const FitData disc_points = all_points(region);
      Feature feature;
      if (static_cast<int>(region.size()) == disc_faces) feature = identify_points(disc_points);
      if (static_cast<int>(region.size()) < disc_faces || !fits(feature)) {
        for (int f : region) tried[f] = 1;
        continue;
      }
      // Across a disc on a narrow fillet the surface may bend by less than the noise: the fit is then
      // any surface of little curvature (a cylinder of a hundred times the radius, which grows along
      // the fillet as a flat strip). A larger disc replaces it if its surface fits it and bends by
      // more than the noise; the disc doubles while it still fits.
      const bool flat = bend(feature.surface, disc_points) < noise;
      for (int size = 2 * disc_faces; flat && size <= static_cast<int>(faces.size()); size *= 2) {
        std::vector<int> larger = disc(seed, size);
        const FitData larger_points = all_points(larger);
        const Feature wider = identify_points(larger_points);
        if (!fits(wider) || wider.rms > std::max(feature.rms, noise)) break;  // it reached another surface
        if (bend(wider.surface, larger_points) < noise) continue;
        region = std::move(larger);
        feature = wider;
        break;
      }
      grow(std::move(region), feature, feature.type);
    }
  }
  if (!first_labels.empty()) {
    // The second pass stands where it explains the patch with no more regions and leaves no more of
    // its faces to the remainder (a round's torus grown first takes the sectors that cylinders had
    // cut off the plane beside it).
    auto left = [&] { return std::count_if(faces.begin(), faces.end(), [&](int f) { return labels[f] == patch; }); };
    if (next_id > first_next || left() > std::count(first_labels.begin(), first_labels.end(), patch)) {
      for (size_t i = 0; i < faces.size(); ++i) labels[faces[i]] = first_labels[i];
      tori = std::move(first_tori);
      next_id = first_next;
    }
  }
  for (const Grown& torus : tori) generalized[torus.id] = torus.feature.surface;
  if (next_id == first_id) return next_id;  // nothing split off: the patch stays whole
  std::vector<char> state(mesh.num_faces(), kOutside);
  for (int f : faces) state[f] = labels[f] == patch ? kUnvisited : kKept;
  return label_remainder(topology, faces, patch, true, state, labels, next_id, progress);
}

// On an exact tessellation, faces that the segmentation merged come apart into pieces that their
// surfaces fit exactly. Where most of a split patch ended in pieces that fit only approximately (to
// more than `exact` RMS) or in single triangles (which any plane fits), it was a freeform surface:
// the split is undone and the patch identified afresh.
void undo_inexact_splits(const TriangleMesh& mesh, const Eigen::VectorXd& area, const std::vector<int>& original,
                         const std::vector<char>& was_split, double exact,
                         const std::function<Feature(const PatchPoints&, const PatchCurvature&)>& identify_points,
                         const std::vector<PatchCurvature>& curvature, std::vector<Feature>& features,
                         std::vector<int>& labels) {
  std::vector<int> triangles(features.size(), 0);
  for (int l : labels)
    if (l >= 0) ++triangles[l];
  std::vector<double> total(was_split.size(), 0.0), fragmented(was_split.size(), 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int o = original[f], l = labels[f];
    if (o < 0 || was_split[o] != 1 || l < 0) continue;
    total[o] += area[f];
    if (features[l].type == SurfaceType::Freeform || features[l].rms > exact || triangles[l] == 1) fragmented[o] += area[f];
  }
  std::vector<char> undo(was_split.size(), 0);
  bool any = false;
  for (size_t o = 0; o < was_split.size(); ++o) any |= undo[o] = was_split[o] == 1 && fragmented[o] > 0.5 * total[o];
  if (!any) return;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (original[f] >= 0 && undo[original[f]]) labels[f] = original[f];
  const std::vector<PatchPoints> whole = patch_points(mesh, labels, static_cast<int>(features.size()));
  for (size_t o = 0; o < undo.size(); ++o)
    if (undo[o]) {
      const int id = features[o].id;
      features[o] = identify_points(whole[o], curvature[o]);
      features[o].id = id;
    }
}

// Drops features left without faces and renumbers the rest in order.
void compact_features(std::vector<int>& labels, std::vector<Feature>& features) {
  std::vector<int> used(features.size(), 0);
  for (int l : labels)
    if (l >= 0) used[l] = 1;
  std::vector<int> renumber(features.size(), kNone);
  std::vector<Feature> kept;
  for (size_t p = 0; p < features.size(); ++p)
    if (used[p]) {
      renumber[p] = static_cast<int>(kept.size());
      kept.push_back(features[p]);
      kept.back().id = renumber[p];
    }
  for (int& l : labels)
    if (l >= 0) l = renumber[l];
  features = std::move(kept);
}

// Moves every input vertex onto the surfaces of the features around it that explain it: onto the
// one surface inside a patch, onto the intersection of two or three along edges and at corners
// (alternating projections, which converge to the nearest common point of transversal surfaces).
// Area and triangle count of each feature from the labels.
void count_faces(const Eigen::VectorXd& area, const std::vector<int>& labels, std::vector<Feature>& features) {
  for (Feature& feature : features) {
    feature.area = 0.0;
    feature.triangles = 0;
  }
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] >= 0) {
      features[labels[f]].area += area[f];
      ++features[labels[f]].triangles;
    }
}

// A cylinder or cone beside a torus that explains its points about as well as its own surface does
// (spread and normal spread within `residual_ratio` times its own, as merging requires) is a piece of
// that torus (the half of a horn torus that touches no plane fitted a cone): its faces join the
// torus that explains it best. `beside`: pairs of adjacent features. Returns whether any joined.
bool join_torus_pieces(const std::vector<PatchPoints>& points, const std::vector<std::pair<int, int>>& beside,
                       double residual_ratio, double normal_floor, std::vector<Feature>& features,
                       std::vector<int>& labels) {
  std::vector<int> join(features.size(), kNone);
  std::vector<double> joined_spread(features.size(), 0.0);
  for (const auto& [x, y] : beside)
    for (const auto& [piece, torus] : {std::pair{x, y}, std::pair{y, x}}) {
      const Feature &p = features[piece], &t = features[torus];
      if (t.type != SurfaceType::Torus || (p.type != SurfaceType::Cylinder && p.type != SurfaceType::Cone)) continue;
      SurfaceFit fit = fit_of(t.surface, points[piece]);
      measure_spreads(points[piece], fit);
      if (fit.spread > residual_ratio * p.spread || fit.normal_spread > residual_ratio * p.normal_spread + normal_floor)
        continue;
      if (join[piece] == kNone || fit.spread < joined_spread[piece]) join[piece] = torus, joined_spread[piece] = fit.spread;
    }
  if (std::all_of(join.begin(), join.end(), [](int j) { return j == kNone; })) return false;
  for (int& l : labels)  // (a torus joins nothing: it stays what its pieces join)
    if (l >= 0 && join[l] != kNone) l = join[l];
  compact_features(labels, features);
  return true;
}

// Freeform features that meet smoothly are pieces of one surface (the curvature histogram cuts a
// freeform surface where its curvature passes a valley): adjacent freeform features join where the
// border between them turns (the median turn between facets across it) no more sharply than the
// facets inside either at their sharpest. So does a feature too small for its fit to say anything
// (fewer than kInteriorPoints vertices: a CAD export's slivers where the freeform face meets its
// neighbours) that meets a freeform one so. Returns whether any feature joined.
bool join_freeform_features(const TriangleMesh& mesh, const MeshTopology& topology, std::vector<int>& labels,
                            std::vector<Feature>& features) {
  const auto freeform = [&](int p) { return features[p].type == SurfaceType::Freeform; };
  const auto joins = [&](int p) { return freeform(p) || features[p].vertices < kInteriorPoints; };
  bool any = false;
  // Slivers lie in rows along a border: each pass takes the row beside the freeform feature.
  for (bool joined = true; joined;) {
    joined = false;
    std::vector<double> inside(features.size(), 0.0);
    std::map<std::pair<int, int>, std::vector<double>> across;
    for (int f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < f || labels[f] < 0 || labels[g] < 0) continue;
        const int a = labels[f], b = labels[g];
        if (!joins(a) || !joins(b)) continue;
        const double turn = facet_turn(mesh, f, g);
        if (a == b) inside[a] = std::max(inside[a], turn);
        else if (freeform(a) || freeform(b)) across[{std::min(a, b), std::max(a, b)}].push_back(turn);
      }
    std::vector<int> parent(features.size());
    std::iota(parent.begin(), parent.end(), 0);
    const std::function<int(int)> root = [&](int p) { return parent[p] == p ? p : parent[p] = root(parent[p]); };
    for (auto& [pair, turns] : across) {
      const auto [a, b] = pair;
      std::nth_element(turns.begin(), turns.begin() + turns.size() / 2, turns.end());
      if (turns[turns.size() / 2] > std::max(inside[a], inside[b])) continue;
      const int ra = root(a), rb = root(b);
      if (ra == rb) continue;
      // The larger freeform feature stands for the group.
      const bool a_stands = freeform(ra) && (!freeform(rb) || features[ra].area >= features[rb].area);
      if (a_stands) parent[rb] = ra; else parent[ra] = rb;
      joined = any = true;
    }
    if (!joined) break;
    for (int& l : labels)
      if (l >= 0) l = root(l);
    compact_features(labels, features);
  }
  return any;
}

// On an exact tessellation, a freeform face swept from a profile (a sketched spline pulled
// straight) falls apart into the surfaces that each fit a few of its facet strips exactly: cylinders
// of different radii about parallel axes, tangent to each other, and planes of one strip between
// them. Three or more such pieces meeting without a crease, each of fewer than kInteriorPoints
// vertices and too few to tell its surface from a spline's (a cylinder's on fewer rulings than a
// circle's parameters and three, as identification asks of an exact fit, or off it by more than
// the coordinates' rounding `floor`), through all of whose vertices one B-spline surface passes
// within the distance `tolerance`, are that face: they join as one freeform feature. (Not within
// the exact distance: a least-squares spline over a few dozen profile points leaves a few times
// that.) Returns whether any joined.
bool join_sampled_extrusions(const TriangleMesh& mesh, const MeshTopology& topology, double tolerance,
                             double exact_distance, double floor, double angle_tolerance, std::vector<int>& labels,
                             std::vector<Feature>& features) {
  const std::vector<PatchPoints> points = patch_points(mesh, labels, static_cast<int>(features.size()), -1);
  // The rulings of a cylinder: its vertices across the axis, those within the exact distance as one.
  const auto rulings = [&](int p) {
    const Surface& c = features[p].surface;
    std::vector<Eigen::Vector3d> distinct;
    for (Eigen::Index i = 0; i < points[p].points.rows(); ++i) {
      const Eigen::Vector3d v = points[p].points.row(i).transpose() - c.point;
      const Eigen::Vector3d across = v - v.dot(c.axis) * c.axis;
      const auto near = [&](const Eigen::Vector3d& q) { return (q - across).norm() <= exact_distance; };
      if (std::none_of(distinct.begin(), distinct.end(), near)) distinct.push_back(across);
    }
    return static_cast<int>(distinct.size());
  };
  std::vector<char> small(features.size(), 0);
  for (size_t p = 0; p < features.size(); ++p) {
    const Feature& f = features[p];
    if (points[p].points.rows() >= kInteriorPoints) continue;
    if (f.type == SurfaceType::Plane) small[p] = 1;
    else if (f.type == SurfaceType::Cylinder) small[p] = f.rms > 2.0 * floor || rulings(static_cast<int>(p)) < 3 + 3;
  }
  const std::map<std::pair<int, int>, double> turns = boundary_turns(mesh, topology, labels);
  std::vector<int> parent(features.size());
  const std::function<int(int)> root = [&](int p) { return parent[p] == p ? p : parent[p] = root(parent[p]); };
  // The small pieces that meet without a crease, in groups.
  const auto grouped = [&] {
    std::iota(parent.begin(), parent.end(), 0);
    for (const auto& [pair, turn] : turns)
      if (small[pair.first] && small[pair.second] && turn <= kLargestFacetTurn) parent[root(pair.first)] = root(pair.second);
    std::map<int, std::vector<int>> groups;
    for (size_t p = 0; p < features.size(); ++p)
      if (small[p]) groups[root(static_cast<int>(p))].push_back(static_cast<int>(p));
    return groups;
  };
  // One direction: the axis of the group's widest cylinder (-1: none).
  const auto widest_cylinder = [&](const std::vector<int>& members) {
    int widest = -1;
    for (int m : members)
      if (features[m].type == SurfaceType::Cylinder && (widest < 0 || features[m].area > features[widest].area)) widest = m;
    return widest;
  };
  // How far a piece reaches across the direction: the diameter of its vertices seen along it.
  const auto reach_across = [&](int p, const Eigen::Vector3d& direction) {
    double widest = 0.0;
    const MatrixX3d& v = points[p].points;
    for (Eigen::Index i = 0; i < v.rows(); ++i)
      for (Eigen::Index j = i + 1; j < v.rows(); ++j) {
        const Eigen::Vector3d d = (v.row(i) - v.row(j)).transpose();
        widest = std::max(widest, (d - d.dot(direction) * direction).norm());
      }
    return widest;
  };
  // A plane of the profile is a chord of it, no wider across the direction than its cylinders'
  // pieces; a plane tangent to the profile's end (as small a piece where the export gives it two
  // facets) reaches far beyond.
  for (const auto& [group_root, members] : grouped()) {
    const int widest = widest_cylinder(members);
    if (widest < 0) continue;
    const Eigen::Vector3d direction = features[widest].surface.axis;
    double reach = 0.0;
    for (int m : members)
      if (features[m].type == SurfaceType::Cylinder) reach = std::max(reach, reach_across(m, direction));
    for (int m : members)
      if (features[m].type == SurfaceType::Plane && reach_across(m, direction) > reach) small[m] = 0;
  }
  std::vector<int> faces;
  std::vector<int> slot(mesh.num_vertices(), -1);
  bool any = false;
  for (const auto& [group_root, members] : grouped()) {
    const int widest = widest_cylinder(members);
    const auto cylinders = std::count_if(members.begin(), members.end(),
                                         [&](int m) { return features[m].type == SurfaceType::Cylinder; });
    if (members.size() < 3 || cylinders < 2) continue;
    // The axis of every cylinder along the direction, every plane's normal across it.
    const Eigen::Vector3d direction = features[widest].surface.axis;
    const bool swept = std::all_of(members.begin(), members.end(), [&](int m) {
      const double along = std::abs(features[m].surface.axis.dot(direction));
      return features[m].type == SurfaceType::Cylinder ? along >= std::cos(angle_tolerance) : along <= std::sin(angle_tolerance);
    });
    if (!swept) continue;
    faces.clear();
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (labels[f] >= 0 && small[labels[f]] && root(labels[f]) == group_root) faces.push_back(f);
    const PatchPoints union_points = face_points(mesh, faces.data(), static_cast<int>(faces.size()), slot, [](int) { return true; });
    const BSplineSurfaceFit fit = fit_bspline_surface(union_points.points, union_points.weights, union_points.sample_normals);
    if (!fit.valid || !(fit.max_error <= tolerance)) continue;
    int largest = members.front();
    for (int m : members)
      if (features[m].area > features[largest].area) largest = m;
    for (int f : faces) labels[f] = largest;
    features[largest].type = SurfaceType::Freeform;
    any = true;
  }
  if (any) compact_features(labels, features);
  return any;
}

void project_vertices(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                      const std::vector<Feature>& features, double tolerance, FeatureLayer& layer,
                      const ProgressSpan& progress) {
  layer.idealized_vertices = mesh.V;
  double sum = 0.0;
  int measured = 0;
  layer.max_deviation = 0.0;
  layer.vertex_deviation = Eigen::VectorXd::Constant(mesh.num_vertices(), std::numeric_limits<double>::quiet_NaN());
  // How far noise alone takes a vertex of patch p from its surface, in units of the fit's spread: a
  // false alarm in a hundred patches among its n vertices (a patch has about half as many vertices as
  // faces) at sqrt(2 ln(100 n)).
  std::vector<double> reach(features.size());
  for (size_t p = 0; p < features.size(); ++p)
    reach[p] = std::sqrt(2.0 * std::log(std::max(1.0, 50.0 * features[p].triangles)));
  std::vector<int> around;
  std::vector<double> offsets;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    progress.tick(v, mesh.num_vertices());
    around.clear();
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
      const int p = labels[*f];
      if (p >= 0 && features[p].type != SurfaceType::Freeform &&
          std::find(around.begin(), around.end(), p) == around.end())
        around.push_back(p);
    }
    if (around.empty()) continue;
    const Eigen::Vector3d original = mesh.V.row(v);
    double nearest = std::numeric_limits<double>::infinity();
    for (int p : around) nearest = std::min(nearest, std::abs(signed_distance(features[p].surface, original)));
    layer.vertex_deviation[v] = nearest;
    sum += nearest * nearest;
    ++measured;
    layer.max_deviation = std::max(layer.max_deviation, nearest);

    // A surface that does not explain the vertex does not move it: beyond 3 σ of its fit the vertex
    // lies in a part of the patch the feature does not describe (a fillet too narrow to be found),
    // unless the noise put it there: within the patch's reach, with neighbours in the patch whose
    // median distance is within 3 σ of the median of as many (those in an undescribed part are off
    // together; those across a sharp edge are another surface's: a scan's vertex on a sharp edge
    // goes to the edge, a small face that no feature took is cut back to its neighbours' edge). The
    // median, not the mean: one of a few hundred noise outliers has another among its neighbours,
    // which alone took the mean of five beyond its limit (a box's scan). Off on the vertex's side
    // only: an undescribed part moves the vertex and its neighbours off together, while neighbours
    // that the noise put on the other side (a plane's vertex 3.3 σ below it, its neighbours' median
    // 1.6 σ above) say nothing against the vertex's being noise.
    auto noise_outlier = [&](int p, double sigma, double side) {
      offsets.clear();
      for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
        if (labels[*f] != p) continue;
        for (int c = 0; c < 3; ++c)
          if (mesh.F(*f, c) != v)  // each neighbour twice on a closed fan
            offsets.push_back(signed_distance(features[p].surface, mesh.V.row(mesh.F(*f, c)).transpose()));
      }
      if (offsets.empty()) return false;
      std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
      // The median of k samples spreads by sqrt(pi / 2) σ / sqrt(k).
      const double median_spread = std::sqrt(0.5 * M_PI) * sigma / std::sqrt(0.5 * offsets.size());
      return side * offsets[offsets.size() / 2] <= 3.0 * median_spread;
    };
    around.erase(std::remove_if(around.begin(), around.end(), [&](int p) {
                   const double sigma = features[p].spread + kExactFraction * tolerance;
                   const double offset = signed_distance(features[p].surface, original), d = std::abs(offset);
                   return d > 3.0 * sigma && (d > reach[p] * sigma || !noise_outlier(p, sigma, offset < 0.0 ? -1.0 : 1.0));
                 }), around.end());
    if (around.empty()) continue;
    Eigen::Vector3d x = original;
    const int rounds = around.size() == 1 ? 1 : 50;
    for (int r = 0; r < rounds; ++r) {
      const Eigen::Vector3d before = x;
      for (int p : around) x = closest_point(features[p].surface, x);
      if ((x - before).norm() < 1e-6 * tolerance) break;
    }
    // Nearly tangent surfaces intersect far from where they touch: never move a vertex further
    // than its own patch allows.
    if ((x - original).norm() > std::max(nearest, tolerance) * 10.0) x = closest_point(features[around[0]].surface, original);
    layer.idealized_vertices.row(v) = x;
  }
  layer.rms_deviation = measured > 0 ? std::sqrt(sum / measured) : 0.0;
}

}  // namespace

FeatureLayer identify_features(const TriangleMesh& mesh, const std::vector<int>& labels,
                               const std::vector<PatchCurvature>& patch_curvature,
                               const EffectiveZero& zero_mean_curvature, const FeatureOptions& options) {
  if (static_cast<int>(labels.size()) != mesh.num_faces())
    throw MeshError("the labels do not match the mesh (one label per triangle is needed)");
  const int num_patches = static_cast<int>(patch_curvature.size());
  for (int label : labels)
    if (label >= num_patches) throw MeshError("a triangle label names a patch that does not exist");

  FeatureLayer layer;
  // Shares of the whole run, as measured on a scan of a million triangles: refitting after each
  // change of the patches dominates.
  const ProgressSpan progress(options.progress, "fit");
  progress.step(0.0);  // a cancelled Progress stops here, before any work
  auto start = std::chrono::steady_clock::now();
  auto stage = [&](const char* name) {
    const auto now = std::chrono::steady_clock::now();
    layer.timings.emplace_back(name, std::chrono::duration<double>(now - start).count());
    start = now;
  };
  const double diagonal = bounding_box_diagonal(mesh);
  layer.distance_tolerance = options.distance_tolerance > 0.0 ? options.distance_tolerance : 1e-3 * diagonal;
  const double floor = coordinate_floor(mesh);
  // What an exact tessellation's vertices may deviate from their surface.
  const double exact_distance = std::max(kExactFraction * layer.distance_tolerance, 2.0 * floor);

  const MeshTopology topology(mesh);
  const Eigen::VectorXd area = face_areas(mesh);
  layer.labels = labels;
  std::vector<PatchCurvature> curvature = patch_curvature;  // grows with split patches
  std::vector<char> was_split(num_patches, 0);  // 1: split as an exact tessellation, 2: as a noisy mesh
  auto identify_points = [&](const PatchPoints& pp, const PatchCurvature& c) {
    return identify(pp, c, zero_mean_curvature, options, layer.distance_tolerance);
  };
  // Each patch's fit is its own: on two threads.
  auto identify_all = [&](const std::vector<PatchPoints>& points, const std::vector<char>& which,
                          const ProgressSpan& span) {
    layer.features.resize(points.size());
    on_two_threads(
        largest_first(points, which), [&](int p) { layer.features[p] = identify_points(points[p], curvature[p]); },
        span);
  };
  std::vector<PatchPoints> points = patch_points(mesh, layer.labels, num_patches);
  identify_all(points, std::vector<char>(num_patches, 1), progress.sub(0.01, 0.06));
  stage("fit");


  // Move rim faces to the neighbour that explains them, refine the surfaces of the patches that
  // changed (same type, starting from the previous fit), and finally identify those afresh. Runs
  // again after merging, which brings surfaces that explain more of their neighbours' rims.
  auto triangle_counts = [&] {
    std::vector<int> count(layer.features.size(), 0);
    for (int l : layer.labels)
      if (l >= 0) ++count[l];
    return count;
  };
  // Refits the surfaces of the patches that changed (same type, starting from the previous fit) to
  // `points`.
  auto refit_changed = [&](const std::vector<char>& changed, const ProgressSpan& span) {
    std::vector<char> which = changed;
    for (size_t p = 0; p < which.size(); ++p) which[p] &= layer.features[p].type != SurfaceType::Freeform;
    on_two_threads(
        largest_first(points, which),
        [&](int p) {
          Feature& f = layer.features[p];
          const SurfaceFit fit = fit_surface(f.type, points[p], options.fit, &f.surface);
          if (fit.valid) f.set_fit(fit);
        },
        span);
  };
  // Rounds stop early when nothing moves: each round takes its share of the span.
  auto reassign = [&](const ProgressSpan& span) {
    const int patches = static_cast<int>(layer.features.size());
    const std::vector<int> before = triangle_counts();
    const double share = 0.9 / std::max(options.reassignment_rounds, 1);
    for (int round = 0; round < options.reassignment_rounds; ++round) {
      const ProgressSpan this_round = span.sub(share * round, share * (round + 1));
      this_round.step(0.0);
      const std::vector<char> changed =
          reassign_faces(mesh, topology, layer.features, options, floor, layer.labels, this_round);
      if (std::find(changed.begin(), changed.end(), 1) == changed.end()) break;
      this_round.step(0.4);
      points = patch_points(mesh, layer.labels, patches);
      refit_changed(changed, this_round.sub(0.5, 1.0));
    }
    // A patch that lost or gained a good part of its faces may be of another type now (the rim of
    // a scan's patch changes by a few percent; a coarse CAD patch may lose half of its facets).
    const std::vector<int> after = triangle_counts();
    std::vector<char> reidentify(patches, 0);
    for (int p = 0; p < patches; ++p) reidentify[p] = std::abs(after[p] - before[p]) > before[p] / 4;
    identify_all(points, reidentify, span.sub(0.9, 1.0));
  };
  reassign(progress.sub("reassign", 0.06, 0.19));
  stage("reassign");
  bool exact_mesh = false;  // decided below
  double noise = floor;      // the typical patch's spread: decided below
  double normal_noise = options.normal_floor_degrees * M_PI / 180.0;  // and its normals' spread
  const ProgressSpan split = progress.sub("split", 0.19, 0.355);
  split.step(0.0);
  // Split what no surface fits into planar regions (and, on noisy meshes, the connected rest);
  // merging below joins pieces again where one surface fits them together. On exact
  // tessellations (the typical patch fits to a hundredth of the tolerance, as the vertices of a CAD
  // export lie on their faces) every planar facet is kept as a piece.
  {
    std::vector<double> rms, normal_rms;
    for (const Feature& f : layer.features)
      if (f.type != SurfaceType::Freeform) {
        rms.push_back(f.spread);
        normal_rms.push_back(f.normal_spread);
      }
    if (!rms.empty()) {
      // The lower median: of two patches, the one that fits shows the noise.
      const size_t middle = (rms.size() - 1) / 2;
      std::nth_element(rms.begin(), rms.begin() + middle, rms.end());
      std::nth_element(normal_rms.begin(), normal_rms.begin() + middle, normal_rms.end());
      exact_mesh = rms[middle] < kExactFraction * layer.distance_tolerance;
      noise = rms[middle] + floor;
      normal_noise += normal_rms[middle];
      int next_id = num_patches;
      // Measured on the benchmark: without the tolerance term, sculpted (undulating) patches split
      // into pieces that do not join again. An exact tessellation does not undulate: what does not
      // fit it exactly is split.
      const double split_above =
          options.split_ratio * noise + (exact_mesh ? kExactFraction : 1.0) * layer.distance_tolerance;
      // There normals count too: a patch fitted to its interior vertices does not see a whole coarse
      // face whose vertices all lie on its rim (a small CAD cylinder inside a plane's patch). On a
      // noisy mesh, where every face has interior vertices, this would split patches that merely
      // have a rough rim (measured on the benchmark). So does the farthest vertex: a step of two
      // sliver facets beside a plane moves its RMS and its normals' by less than their tiny area.
      const double split_normals_above =
          exact_mesh ? options.split_ratio * normal_noise : std::numeric_limits<double>::infinity();
      auto badly_fitting = [&](const Feature& f) {
        return f.type == SurfaceType::Freeform || f.rms > split_above || f.normal_rms > split_normals_above ||
               (exact_mesh && f.max_error > split_above);
      };
      // A dome revolved from an arc centred beyond its axis (a lemon) fits none of the surfaces that
      // identification seeds from its points; on an exact tessellation its torus may be a lemon.
      for (int p = 0; p < num_patches && exact_mesh; ++p) {
        if (!badly_fitting(layer.features[p]) || points[p].points.rows() < kInteriorPoints) continue;
        if (const std::optional<SurfaceFit> lemon = fit_lemon(points[p], options.fit, layer.distance_tolerance, exact_distance)) {
          Feature torus = layer.features[p];
          torus.set_fit(*lemon);
          if (!badly_fitting(torus)) layer.features[p] = torus;
        }
      }
      std::map<int, Surface> generalized;  // regions that grew on as tori (id -> torus)
      // Grows the surfaces that fit discs of patch p. A patch that the histograms call curved has no
      // planar regions: across a disc, the sag of a large fillet hides within the distance tolerance.
      auto grow_surfaces = [&](int p, std::vector<int>& into, int first_id, std::map<int, Surface>& tori,
                               const ProgressSpan& span) {
        const bool curved = curvature_type(curvature[p], zero_mean_curvature) != SurfaceType::Plane;
        return split_into_surfaces(
            mesh, topology, p, noise, normal_noise, split_above, 2 * kInteriorPoints,
            [&](const PatchPoints& pp) {
              return identify(pp, curvature[p], zero_mean_curvature, options, layer.distance_tolerance,
                              curved);
            },
            options.fit, into, first_id, tori, span);
      };
      // Identification takes the simplest surface within the tolerance, which on a sector of a
      // tube's bend is a cylinder: a region that grew as a torus (above) stays one where the torus
      // still fits it as a split requires.
      auto keep_generalized = [&] {
        for (const auto& [id, surface] : generalized) {
          Feature& f = layer.features[id];
          if (f.type != SurfaceType::Cylinder) continue;
          const SurfaceFit fit = fit_surface(surface.type, points[id], options.fit, &surface);
          if (fit.valid && fit.rms <= split_above) f.set_fit(fit);
        }
      };
      // On a noisy mesh, surfaces grow in a large patch first (fillets of one radius in a chain);
      // planar regions split the rest. A patch splits by its own faces alone (the others' labels
      // only tell them apart): on two threads, each into its copy of the labels with new ids from
      // next_id on (and its patch's faces set back after each); the pieces are then numbered on in
      // patch order, as splitting one patch after the other numbers them.
      struct Pieces {
        std::vector<std::pair<int, int>> faces;  // (face, its new label)
        int count = 0;                            // new ids
        std::map<int, Surface> tori;              // new id -> torus (generalized)
      };
      const std::vector<int> first_count = triangle_counts();
      std::vector<char> splitting(num_patches, 0);
      for (int p = 0; p < num_patches; ++p)
        if (badly_fitting(layer.features[p])) {
          splitting[p] = 1;
          was_split[p] = exact_mesh ? 1 : 2;
        }
      std::vector<Pieces> split_pieces(num_patches);
      std::vector<std::vector<int>> faces_of(num_patches);
      for (int f = 0; f < mesh.num_faces(); ++f)
        if (layer.labels[f] >= 0 && splitting[layer.labels[f]]) faces_of[layer.labels[f]].push_back(f);
      const int first_piece_id = next_id;
      const std::vector<int> order = largest_first(points, splitting);
      const ProgressSpan splitting_span = split.sub(0.0, 0.5);
      on_two_threads([&](size_t half) {
        std::vector<int> split_labels = layer.labels;
        for (size_t k = half; k < order.size(); k += 2) {
          if (half == 0) splitting_span.step(static_cast<double>(k) / order.size());
          const int p = order[k];
          int end = first_piece_id;
          if (!exact_mesh && first_count[p] >= 4 * kInteriorPoints)
            end = grow_surfaces(p, split_labels, first_piece_id, split_pieces[p].tori, ProgressSpan());
          if (end == first_piece_id)
            end = split_patch(mesh, topology, area, p, noise, normal_noise, exact_mesh ? 1 : 2 * kInteriorPoints,
                              split_labels, first_piece_id, ProgressSpan());
          split_pieces[p].count = end - first_piece_id;
          for (int f : faces_of[p]) {
            if (split_labels[f] != p) split_pieces[p].faces.push_back({f, split_labels[f]});
            split_labels[f] = p;
          }
        }
      });
      for (int p = 0; p < num_patches; ++p) {
        const int shift = next_id - first_piece_id;
        for (const auto& [f, id] : split_pieces[p].faces) layer.labels[f] = id >= first_piece_id ? id + shift : id;
        for (const auto& [id, torus] : split_pieces[p].tori) generalized[id + shift] = torus;
        next_id += split_pieces[p].count;
      }
      if (next_id > num_patches) {
        std::vector<char> which(next_id, 0);
        for (int l : layer.labels)
          if (l >= 0 && l < num_patches && layer.features[l].type == SurfaceType::Freeform) which[l] = 1;
        for (int p = 0; p < num_patches; ++p)
          if (badly_fitting(layer.features[p])) which[p] = 1;
        for (int p = num_patches; p < next_id; ++p) which[p] = 1;
        curvature.resize(next_id);
        for (int f = 0; f < mesh.num_faces(); ++f)  // a split region keeps the curvature of its patch
          if (layer.labels[f] >= num_patches) curvature[layer.labels[f]] = patch_curvature[labels[f]];
        split.step(0.5);
        points = patch_points(mesh, layer.labels, next_id);
        identify_all(points, which, split.sub(0.6, 0.8));
        keep_generalized();
      }
      // On a noisy mesh, a large piece that still no surface fits is split by growing surfaces.
      if (!exact_mesh) {
        const int pieces = next_id;
        const std::vector<int> count = triangle_counts();
        std::vector<char> which(pieces, 0);
        for (int p = 0; p < pieces; ++p) {
          if (count[p] < 4 * kInteriorPoints || !badly_fitting(layer.features[p])) continue;
          const int first_new = next_id;
          next_id = grow_surfaces(p, layer.labels, next_id, generalized, split.sub(0.8, 0.9));
          curvature.resize(next_id, curvature[p]);
          which.resize(next_id, 1);
          which[p] = next_id > first_new;
        }
        if (next_id > pieces) {
          points = patch_points(mesh, layer.labels, next_id);
          identify_all(points, which, split.sub(0.9, 1.0));
          keep_generalized();
        }
      }
    }
  }
  stage("split");
  reassign(progress.sub("reassign", 0.355, 0.5));
  const int patches = static_cast<int>(layer.features.size());
  stage("reassign_after_split");
  // The surfaces of the features with their spreads, at least the mesh's noise.
  auto flood_surfaces = [&] {
    std::vector<FloodSurface> surfaces(layer.features.size());
    for (size_t p = 0; p < surfaces.size(); ++p) {
      const Feature& f = layer.features[p];
      surfaces[p].surface = f.type == SurfaceType::Freeform ? nullptr : &f.surface;
      surfaces[p].distance_unit = std::max(noise, f.spread);
      surfaces[p].angle_unit = std::max(normal_noise, f.normal_spread);
    }
    return surfaces;
  };
  // On a noisy mesh, a patch that the surfaces around it explain adds nothing but edges: the strip
  // of chamfered facets along a sharp edge, fitted by a cylinder of about its width. Before the
  // relaxation, which then settles the borders the strips leave, and once more at the end for the
  // strips that splitting and merging leave. The changed patches are refitted without their rims,
  // as relaxing does; returns whether `points` are those rim-less points now.
  auto dissolve_strips = [&] {
    if (exact_mesh) return false;
    const std::vector<char> changed =
        dissolve_explained_patches(mesh, topology, flood_surfaces(), layer.labels, progress);
    if (std::find(changed.begin(), changed.end(), 1) == changed.end()) return false;
    points = patch_points(mesh, layer.labels, patches, 1);
    refit_changed(changed, ProgressSpan());
    return true;
  };
  bool rimless = dissolve_strips();
  stage("dissolve");
  // On a noisy mesh, the split pieces flood again from their surfaces: greedy growth left borders
  // where the first surface to grow stopped (the halves of a narrow fillet on the planes beside it).
  // The borders move, then the surfaces are refitted to what they took, before merging joins pieces.
  if (!exact_mesh) {
    for (int round = 0; round < options.relaxation_rounds; ++round) {
      const std::vector<char> changed =
          flood_labels(mesh, topology, flood_surfaces(), options.relaxation_band, layer.labels, progress);
      if (std::find(changed.begin(), changed.end(), 1) == changed.end()) break;
      rimless = true;
      // Each border went to the surface that the noise of its faces happened to favour: fitted to
      // them, a fillet's radius drifts from round to round (on the bracket's noisy scan one came
      // out 7 % large), so the refits leave out a ring of faces along every rim.
      points = patch_points(mesh, layer.labels, patches, 1);
      refit_changed(changed, ProgressSpan());
    }
    stage("relax");
  }
  if (rimless) points = patch_points(mesh, layer.labels, patches);  // what merging sees: the whole rim
  std::set<std::pair<int, int>> rejected;
  // Later passes refit fewer open pairs, and most runs stop early: each pass takes a third of
  // what is left of the span.
  const ProgressSpan merge = progress.sub("merge", 0.5, 0.87);
  double merged_so_far = 0.0;
  // Every merge removes a patch, so on an exact tessellation merging runs until nothing fits together.
  const int merge_passes = exact_mesh ? patches : options.merge_passes;
  int fragment_rounds = 3;
  bool shattered = false;
  for (int pass = 0; pass < merge_passes; ++pass) {
    const double share = (1.0 - merged_so_far) / 3.0;
    const ProgressSpan this_pass = merge.sub(merged_so_far, merged_so_far + share);
    merged_so_far += share;
    bool merged = merge_patches(mesh, topology, points, identify_points, options, layer.distance_tolerance, exact_mesh,
                                exact_distance, noise, layer.features, layer.labels, rejected, this_pass.sub(0.0, 0.9));
    // When no pair merges any more, the small pieces left may still make surfaces together (tried
    // a few times: each time merging may grow the surfaces next to them).
    if (!merged && exact_mesh && fragment_rounds-- > 0)
      merged = merge_fragments(mesh, topology, points, options, exact_distance, layer.features, layer.labels) ||
               absorb_fragments(mesh, topology, points, layer.distance_tolerance, layer.features, layer.labels);
    // Once, when nothing else places them, the pieces left fall apart into facets (and the fragment
    // passes get their rounds again).
    if (!merged && exact_mesh && !shattered) {
      shattered = merged = shatter_fragments(mesh, points, options, layer.features, layer.labels);
      fragment_rounds = 3;
    }
    if (!merged) break;
    this_pass.step(0.9);
    points = patch_points(mesh, layer.labels, patches);
  }
  merge.step(1.0);
  stage("merge");
  reassign(progress.sub("reassign", 0.87, 0.975));
  stage("reassign_after_merge");
  dissolve_strips();  // the stages after it gather their own points
  stage("dissolve_after_merge");
  progress.sub("classify", 0.975, 0.98).step(0.0);
  undo_inexact_splits(mesh, area, labels, was_split, kExactFraction * layer.distance_tolerance, identify_points, curvature,
                      layer.features, layer.labels);
  // On an exact tessellation the reassignment may have left a facet of a piece that merging placed
  // (a long facet beside a fillet's tangent border, whose piece's other facets went to the fillet):
  // it joins the neighbour whose surface passes through its vertices exactly. (After the undoing,
  // which counts such facets as a sign of a freeform surface; and not within the tolerance, which
  // would give the small pieces of a freeform surface to the planes beside it.)
  if (exact_mesh)
    absorb_fragments(mesh, topology, patch_points(mesh, layer.labels, static_cast<int>(layer.features.size())),
                     exact_distance, layer.features, layer.labels);
  compact_features(layer.labels, layer.features);
  count_faces(area, layer.labels, layer.features);

  // On an exact tessellation the rim vertices lie on the surface as well: the surfaces are fitted
  // once more to every vertex, where that fits them better. (The interior vertices alone leave a
  // narrow band undetermined: those of a chamfer cone one facet row wide lie on one circle, which
  // a cone of any half-angle passes through.)
  if (exact_mesh) {
    const std::vector<PatchPoints> whole = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()), -1);
    std::vector<char> which(layer.features.size(), 0);
    for (size_t p = 0; p < which.size(); ++p) which[p] = layer.features[p].type != SurfaceType::Freeform;
    on_two_threads(
        largest_first(whole, which),
        [&](int p) {
          Feature& f = layer.features[p];
          const SurfaceFit fit = fit_surface(f.type, whole[p], options.fit, &f.surface);
          if (fit.valid && fit.rms < fit_of(f.surface, whole[p]).rms) f.set_fit(fit);
        },
        ProgressSpan());
  }

  // On a noisy mesh, features whose own points cannot fix an axis take a related feature's.
  if (!exact_mesh) {
    SharedAxisOptions shared;
    shared.determined_points = 4 * kInteriorPoints;
    shared.angle_tolerance = options.angle_tolerance_degrees * M_PI / 180.0;
    shared.distance_tolerance = layer.distance_tolerance;
    shared.residual_ratio = options.residual_ratio;
    shared.normal_floor = options.normal_floor_degrees * M_PI / 180.0;
    const std::vector<PatchPoints> feature_points = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()));
    fit_about_shared_axes(feature_points, shared, layer.features);
    fillets_between_planes(feature_points, adjacent_pairs(mesh, topology, layer.labels), shared, layer.features);
    // Fillets too narrow for a patch of their own, which the features beside them took; cylinders and
    // planes that a torus took with it. The new features keep the surface the fit of the edge's
    // band or the torus's profile fixed, the others are refitted without the faces they gave.
    EdgeFilletOptions edges;
    edges.angle_tolerance = shared.angle_tolerance;
    edges.residual_ratio = options.residual_ratio;
    edges.radius_tolerance = options.radius_tolerance;
    // Features that a finder split into pieces (a fillet found on an edge takes faces from two
    // features that meet at an angle, which never merge again anyway: a cone that gave a fillet at
    // each end stays free to rejoin its other piece).
    std::vector<char> touched;
    for (auto find : {round_edges, split_tangent_continuations, split_cornered_tori, split_coaxial_steps}) {
      const size_t existing = layer.features.size();
      const std::vector<char> changed = find(mesh, topology, edges, layer.features, layer.labels);
      touched.resize(changed.size(), 0);
      if (find != round_edges)
        for (size_t p = 0; p < changed.size(); ++p) touched[p] |= changed[p];
      if (std::find(changed.begin(), changed.end(), 1) == changed.end()) continue;
      const std::vector<PatchPoints> now = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()));
      on_two_threads(
          largest_first(now, changed),
          [&](int p) {
            Feature& f = layer.features[p];
            SurfaceFit fit;
            if (static_cast<size_t>(p) < existing) fit = fit_surface(f.type, now[p], options.fit, &f.surface);
            if (!fit.valid) {
              fit = fit_of(f.surface, now[p]);
              measure_spreads(now[p], fit);
            }
            f.set_fit(fit);
            f.vertices = static_cast<int>(now[p].points.rows());
          },
          ProgressSpan());
      count_faces(area, layer.labels, layer.features);
    }
    // A surface that the stages between merging and here left in two pieces (a sculpted cylinder
    // whose pieces' fits differ by its undulation, a narrow piece whose rim went to a neighbour)
    // merges now where one surface fits both as merging requires. Only alike pieces are tried (one
    // type, parallel, radii that relations would take for equal), and not two that the finders
    // above just split apart.
    // The points and neighbours of the features, for the remerge and the tangent tori after it.
    std::vector<PatchPoints> settled = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()));
    std::vector<std::pair<int, int>> beside = adjacent_pairs(mesh, topology, layer.labels);
    {
      std::set<std::pair<int, int>> apart;
      touched.resize(layer.features.size(), 0);
      const double angle_tolerance = options.angle_tolerance_degrees * M_PI / 180.0;
      for (const auto& pair : beside)
        if ((touched[pair.first] && touched[pair.second]) ||
            !alike(layer.features[pair.first], layer.features[pair.second], angle_tolerance, layer.distance_tolerance,
                   options.radius_tolerance))
          apart.insert(pair);
      if (merge_patches(mesh, topology, settled, identify_points, options, layer.distance_tolerance, false, exact_distance,
                        noise, layer.features, layer.labels, apart, progress.sub("remerge", 0.98, 0.98))) {
        compact_features(layer.labels, layer.features);
        count_faces(area, layer.labels, layer.features);
        settled = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()));
        beside = adjacent_pairs(mesh, topology, layer.labels);
      }
    }
    // The features that the edge stages refitted freely (without the faces they gave a fillet, a
    // narrow band whose own axis tilts by a degree) take the part's axes again.
    SharedAxisOptions determined = shared;
    determined.only_determined = true;
    fit_about_shared_axes(settled, determined, layer.features);
    // The tori that the edge stages found or left, now that their neighbours are settled.
    tori_between_planes_and_walls(settled, beside, shared, layer.features);
    if (join_torus_pieces(settled, beside, options.residual_ratio, shared.normal_floor, layer.features, layer.labels))
      count_faces(area, layer.labels, layer.features);
    planes_on_curved_surfaces(patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()), -1), shared,
                              layer.features);
    stage("edge_fillets");
  }

  // On a noisy mesh, a cone whose radius changes across its patch by less than the distance
  // tolerance, and which a cylinder fits about as well (identification's rule), is a cylinder: the
  // undulation of a sculpted cylinder tilts its profile by a fraction of a degree, and merging or
  // the edge stages refit a cone as a cone.
  if (!exact_mesh && std::any_of(layer.features.begin(), layer.features.end(),
                                 [](const Feature& f) { return f.type == SurfaceType::Cone; })) {
    const std::vector<PatchPoints> cone_points = patch_points(mesh, layer.labels, static_cast<int>(layer.features.size()));
    const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
    for (size_t p = 0; p < layer.features.size(); ++p) {
      Feature& f = layer.features[p];
      if (f.type != SurfaceType::Cone) continue;
      const Eigen::VectorXd heights = (cone_points[p].points.rowwise() - f.surface.point.transpose()) * f.surface.axis;
      if (heights.size() == 0 ||
          (heights.maxCoeff() - heights.minCoeff()) * std::tan(f.surface.half_angle) > layer.distance_tolerance)
        continue;
      const SurfaceFit about = fit_about_axis(SurfaceType::Cylinder, cone_points[p], f.surface.point, f.surface.axis);
      if (!about.valid) continue;
      const SurfaceFit cylinder = fit_surface(SurfaceType::Cylinder, cone_points[p], options.fit, &about.surface);
      if (cylinder.valid && cylinder.spread <= options.residual_ratio * f.spread + layer.distance_tolerance &&
          cylinder.normal_spread <= options.residual_ratio * f.normal_spread + normal_floor)
        f.set_fit(cylinder);
    }
  }

  // Freeform: the best fit is much worse than the typical patch of this mesh (which takes a few
  // patches to tell; with fewer, the tolerances alone decide).
  std::vector<double> residuals;
  for (const Feature& f : layer.features)
    if (f.type != SurfaceType::Freeform) residuals.push_back(f.spread);
  double typical = floor;
  if (residuals.size() >= 3) {
    std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
    typical = std::max(residuals[residuals.size() / 2], floor);
  }
  // An exact tessellation has neither noise nor undulation: beyond the tolerance, a surface is not
  // the patch's, however large the patch.
  for (Feature& f : layer.features)
    if (f.spread > options.freeform_ratio * typical && f.spread > (exact_mesh ? exact_distance : layer.distance_tolerance) &&
        (exact_mesh || f.spread > options.freeform_relative_size * std::sqrt(f.area)))
      f.type = SurfaceType::Freeform;
  if (join_freeform_features(mesh, topology, layer.labels, layer.features)) count_faces(area, layer.labels, layer.features);
  // After the freeform features took their slivers: the planes tangent to a swept face's ends may be
  // as small in the export.
  if (exact_mesh && join_sampled_extrusions(mesh, topology, layer.distance_tolerance, exact_distance, floor,
                                             options.angle_tolerance_degrees * M_PI / 180.0, layer.labels, layer.features))
    count_faces(area, layer.labels, layer.features);
  stage("classify");
  progress.sub("relations", 0.98, 0.99).step(0.0);

  const double angle_tolerance = options.angle_tolerance_degrees * M_PI / 180.0;
  // The labels stay as they are from here on: each feature's interior points (what its fit saw) and
  // every vertex of its faces serve the steps below and idealization.
  const int feature_count = static_cast<int>(layer.features.size());
  points = patch_points(mesh, layer.labels, feature_count);
  const std::vector<PatchPoints> whole = patch_points(mesh, layer.labels, feature_count, -1);
  make_balls_of_corner_cylinders(mesh, topology, angle_tolerance, layer.distance_tolerance, options, layer.labels,
                                 points, layer.features);
  layer.form_deviation = form_deviation(mesh, layer.labels, layer.features);
  measure_radius_errors(whole, layer.form_deviation, layer.features);
  build_feature_graph(mesh, topology, layer.labels, layer.features, angle_tolerance, layer.distance_tolerance,
                      options.radius_tolerance, layer.adjacency, layer.relations);
  // On an exact tessellation a sphere band one facet row wide is a cone as much: any two coaxial
  // circles lie on both, and identification prefers the sphere. A chamfer meets its neighbours at
  // creases, while a sphere zone of a design (a ball between fillets, a rounded corner) is tangent
  // to some: a sphere that meets every neighbour at a crease, and that a cone explains as exactly,
  // is a cone (a screw's point).
  if (exact_mesh) {
    std::vector<char> tangent(layer.features.size(), 0), creased(layer.features.size(), 0);
    for (const FeatureAdjacency& a : layer.adjacency)
      for (int id : {a.a, a.b}) (a.continuity == Continuity::G1 ? tangent : creased)[id] = 1;
    const double normal_floor = options.normal_floor_degrees * M_PI / 180.0;
    bool retyped = false;
    for (Feature& f : layer.features) {
      if (f.type != SurfaceType::Sphere || tangent[f.id] || !creased[f.id]) continue;
      const SurfaceFit cone = fit_surface(SurfaceType::Cone, whole[f.id], options.fit);
      if (!cone.valid || !explains_every_point(cone.surface, whole[f.id], exact_distance,
                                               3.0 * f.normal_spread + normal_floor, kLargestFacetTurn))
        continue;
      f.set_fit(cone);
      retyped = true;
    }
    if (retyped)
      build_feature_graph(mesh, topology, layer.labels, layer.features, angle_tolerance, layer.distance_tolerance,
                          options.radius_tolerance, layer.adjacency, layer.relations);
  }
  stage("relations");
  if (options.idealize) {
    IdealizationOptions ideal;
    ideal.angle_tolerance_degrees = options.angle_tolerance_degrees;
    ideal.distance_tolerance = layer.distance_tolerance;
    const std::vector<Feature> fitted = layer.features;
    // On an exact tessellation, profiles are fitted again about the ideal axes (to every vertex, as
    // above). On a noisy mesh the fitted profiles stay (measured on the benchmark: refitted about
    // the ideal axes, the scans' median radius error grew from 0.38 % to 0.53 %).
    ideal.points = exact_mesh ? &whole : &points;
    ideal.refit_moved_profiles = exact_mesh;
    ideal.residual_ratio = options.residual_ratio;
    if (idealize_features(layer.features, layer.relations, ideal) > 0) {
      // An ideal surface must still describe its patch: where it fits clearly worse than the fitted
      // one (a direction that only looked ideal, radii that only looked equal), the fit stays. A
      // sculpted part's smooth undulation moves every fit a little (a fillet's axis by a degree or
      // two), which the ideal surface does not follow, and a fit that stays meets its tangent
      // neighbours nowhere: the more the mesh's residuals are correlated (the share of them that is
      // not independent noise), the more of the distance tolerance the ideal one may deviate by in
      // addition. (Measured on the benchmark's sculpted parts: 11 -> 12 of 23 solids with the true
      // surface types, and the scans' and CAD exports' solids unchanged.)
      const double share = exact_mesh ? 1.0 : independent_share(mesh, fitted, layer.labels);
      const double ideal_slack = (1.0 - share) * layer.distance_tolerance;
      auto rms_of = [&](size_t p, const Surface& surface) {
        double rms, max_error;
        fit_residuals(surface, points[p].points, points[p].weights, rms, max_error);
        return rms;
      };
      auto misfits = [&](size_t p, double rms) {
        // (The fit's spread: one σ of noise more; then the slack for correlated residuals.)
        return rms > options.residual_ratio * fitted[p].rms + fitted[p].spread + floor + ideal_slack;
      };
      auto misfit = [&](size_t p, const Surface& surface) { return misfits(p, rms_of(p, surface)); };
      // A direction that snapped to one of the part's ideal ones only by the angle tolerance (a face
      // designed at 25° snaps to 30°) moves the features tangent to it too: once more, with the
      // directions that alone (the fitted surface turned about its point nearest the patch's
      // centre) do not fit their patch as fitted, and that turned by more than three times the
      // part's median turn (a sculpted part's undulation tilts every fit a little), neither averaged
      // with their parallels nor snapped. (On an exact tessellation any turn misfits; the fits
      // that snapping spoils just stay, below.)
      auto turn = [&](size_t p) {
        return std::acos(std::min(1.0, std::abs(fitted[p].surface.axis.dot(layer.features[p].surface.axis))));
      };
      std::vector<double> turns;
      for (size_t p = 0; p < layer.features.size(); ++p)
        if (fitted[p].type != SurfaceType::Freeform && fitted[p].surface.has_direction()) turns.push_back(turn(p));
      double typical_turn = 0.0;
      if (!turns.empty()) {
        std::nth_element(turns.begin(), turns.begin() + turns.size() / 2, turns.end());
        typical_turn = turns[turns.size() / 2];
      }
      for (size_t p = 0; p < layer.features.size() && !exact_mesh; ++p) {
        if (fitted[p].type == SurfaceType::Freeform || !fitted[p].surface.has_direction() || turn(p) <= 3.0 * typical_turn)
          continue;
        // Turned about the point of its axis (or plane) nearest the patch's centre.
        Surface turned = fitted[p].surface;
        const Eigen::Vector3d centre = points[p].points.transpose() * points[p].weights / points[p].weights.sum();
        const Eigen::Vector3d& a = turned.axis;
        const double along = (centre - turned.point).dot(a);
        if (turned.type == SurfaceType::Plane) turned.point = centre - along * a;
        else if (turned.type != SurfaceType::Cone) turned.point += along * a;
        turned.axis = layer.features[p].surface.axis;
        // Beyond the misfit, a turn whose systematic deviation (RMS beyond the fit's) the noise
        // cannot explain: as much as the share of correlated residuals lets the whole face tilt,
        // and what its independent noise leaves of the fit's parameters. (A scanned face designed
        // at 11.6° fitted 11.5° about as well as 10° fits it by misfit's measure.)
        const double rms = rms_of(p, turned);
        const double excess = std::sqrt(std::max(0.0, rms * rms - fitted[p].rms * fitted[p].rms));
        const double sigma = fitted[p].spread, n = static_cast<double>(points[p].points.rows());
        const bool unexplained =
            excess > 3.0 * sigma * (std::sqrt(1.0 - share) + std::sqrt(3.0 / std::max(n, 1.0))) + ideal_slack;
        if (misfits(p, rms) || unexplained) ideal.unsnapped.push_back(static_cast<int>(p));
      }
      if (!ideal.unsnapped.empty()) {
        layer.features = fitted;
        idealize_features(layer.features, layer.relations, ideal);
      }
      // On a noisy mesh, planes whose turned direction misfits keep their fitted one, and the rest
      // is idealized once more about them: the features they define (a cylinder that touches a
      // plane) were placed against the turned plane, and misfit too. (A part whose faces meet at
      // 88° has its rounds' axes made parallel again, instead of all of them staying as fitted.)
      const size_t held = ideal.unsnapped.size();
      for (size_t p = 0; p < layer.features.size() && !exact_mesh; ++p)
        if (layer.features[p].type == SurfaceType::Plane && turn(p) > 0.0 && misfit(p, layer.features[p].surface))
          ideal.unsnapped.push_back(static_cast<int>(p));
      if (ideal.unsnapped.size() > held) {
        layer.features = fitted;
        idealize_features(layer.features, layer.relations, ideal);
      }
      for (size_t p = 0; p < layer.features.size(); ++p)
        if (layer.features[p].type != SurfaceType::Freeform && misfit(p, layer.features[p].surface)) layer.features[p] = fitted[p];
      build_feature_graph(mesh, topology, layer.labels, layer.features, angle_tolerance, layer.distance_tolerance,
                          options.radius_tolerance, layer.adjacency, layer.relations);  // the graph of the ideal surfaces
    }
    stage("idealize");
  }
  // The graph and the ideal surfaces stay as they are: refitting and idealizing the features whose
  // borders moved shifts the radii of a sculpted part's equal fillets apart.
  if (!exact_mesh && settle_tangent_boundaries(mesh, topology, layer.features, layer.relations, layer.labels) > 0)
    count_faces(area, layer.labels, layer.features);
  stage("tangent_boundaries");
  const ProgressSpan projection = progress.sub("projection", 0.99, 1.0);
  project_vertices(mesh, topology, layer.labels, layer.features, layer.distance_tolerance, layer, projection);
  stage("projection");
  projection.step(1.0);
  return layer;
}

}  // namespace idealize
