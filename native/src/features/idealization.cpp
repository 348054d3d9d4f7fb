#include "features/idealization.h"
#include "fit/fits_as_well.h"

#include <Eigen/Dense>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <array>
#include <cmath>

namespace idealize {

namespace {

Eigen::Vector3d aligned(const Eigen::Vector3d& d, const Eigen::Vector3d& reference) {
  return d.dot(reference) < 0.0 ? Eigen::Vector3d(-d) : d;
}

bool analytic(const Feature& f) { return f.type != SurfaceType::Freeform; }

int largest(const std::vector<int>& group, const std::vector<Feature>& features) {
  int best = group.front();
  for (int m : group)
    if (features[m].area > features[best].area) best = m;
  return best;
}

// Area-weighted mean direction of a group, signs aligned with its largest member.
Eigen::Vector3d mean_direction(const std::vector<int>& group, const std::vector<Feature>& features) {
  const Eigen::Vector3d reference = features[largest(group, features)].surface.axis;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int m : group) sum += features[m].area * aligned(features[m].surface.axis, reference);
  return sum.norm() > 0.0 ? Eigen::Vector3d(sum.normalized()) : reference;
}

struct Frame {
  Eigen::Vector3d x, y, z;
};

// Z: the best-determined direction of the part, the one that the most area shares (a parallel
// group's members share their mean direction by now); X: the largest feature direction orthogonal
// to it; neither from the features whose directions stay as fitted (`unsnapped`). (Not the largest
// plane's normal: the walls of a screw's slot, tilted by the noise, tilted the axis of its shank,
// head and dome with them, and the dome's halves no longer met.)
bool part_frame(const std::vector<Feature>& features, const std::vector<char>& unsnapped, double sin_tolerance,
                Frame& frame) {
  const double cos_tolerance = std::sqrt(1.0 - sin_tolerance * sin_tolerance);
  std::vector<int> directed;
  for (const Feature& f : features)
    if (analytic(f) && f.surface.has_direction() && !unsnapped[f.id]) directed.push_back(f.id);
  if (directed.empty()) return false;
  int z = -1;
  double most = 0.0;
  for (int f : directed) {
    double along = 0.0;
    for (int g : directed)
      if (std::abs(features[f].surface.axis.dot(features[g].surface.axis)) >= cos_tolerance) along += features[g].area;
    if (z < 0 || along > most) z = f, most = along;
  }
  frame.z = features[z].surface.axis;
  int second = -1;
  for (int f : directed)
    if (std::abs(features[f].surface.axis.dot(frame.z)) <= sin_tolerance &&
        (second < 0 || features[f].area > features[second].area))
      second = f;
  if (second >= 0) {
    const Eigen::Vector3d d = features[second].surface.axis;
    frame.x = (d - d.dot(frame.z) * frame.z).normalized();
    frame.y = frame.z.cross(frame.x);
  } else {
    orthonormal_frame(frame.z, frame.x, frame.y);
  }
  return true;
}

// The thesis's ideal angles from the frame's axes, and their supplements.
constexpr std::array<double, 12> kDegrees = {0, 10, 30, 45, 60, 80, 90, 100, 120, 135, 150, 170};

// Directions in the coordinate planes of the frame at the ideal angles from its axes.
std::vector<Eigen::Vector3d> ideal_directions(const Frame& frame) {
  const std::array<std::pair<Eigen::Vector3d, Eigen::Vector3d>, 3> planes = {
      std::make_pair(frame.x, frame.y), std::make_pair(frame.y, frame.z), std::make_pair(frame.z, frame.x)};
  std::vector<Eigen::Vector3d> out;
  for (const auto& [a, b] : planes)
    for (double degrees : kDegrees) {
      const double t = degrees * M_PI / 180.0;
      out.push_back(std::cos(t) * a + std::sin(t) * b);
    }
  return out;
}

Eigen::Vector3d snapped(const Eigen::Vector3d& d, const std::vector<Eigen::Vector3d>& ideals, double cos_tolerance) {
  const Eigen::Vector3d* best = nullptr;
  double best_cos = cos_tolerance;
  for (const Eigen::Vector3d& i : ideals)
    if (std::abs(i.dot(d)) >= best_cos) {
      best_cos = std::abs(i.dot(d));
      best = &i;
    }
  return best ? aligned(*best, d) : d;
}

double& tube_radius(Feature& f) { return f.type == SurfaceType::Torus ? f.surface.minor : f.surface.radius; }

// How far `point` moves along `plane`'s normal to lie `distance` from it, on the side it is on now.
double to_distance_from(const Surface& plane, const Eigen::Vector3d& point, double distance) {
  const double height = (point - plane.point).dot(plane.axis);
  return (height >= 0.0 ? 1.0 : -1.0) * distance - height;
}

// The features of `type` in a tangent relation with feature `id` (ids, in the relations' order).
std::vector<int> tangent_features(int id, SurfaceType type, const std::vector<FeatureRelation>& relations,
                                  const std::vector<Feature>& features) {
  std::vector<int> out;
  for (const FeatureRelation& r : relations) {
    if (r.kind != "tangent" || (r.features[0] != id && r.features[1] != id)) continue;
    const int other = r.features[0] == id ? r.features[1] : r.features[0];
    if (features[other].type == type) out.push_back(other);
  }
  return out;
}

// Their surfaces.
std::vector<const Surface*> tangent_surfaces(int id, SurfaceType type, const std::vector<FeatureRelation>& relations,
                                             const std::vector<Feature>& features) {
  std::vector<const Surface*> out;
  for (int m : tangent_features(id, type, relations, features)) out.push_back(&features[m].surface);
  return out;
}

// A cone's generator is a direction too: a cone about one of the part's ideal directions whose
// half-angle is within the angle tolerance of an ideal angle takes it, and the apex moves so that
// the profile line passes through the weighted mean of the points' heights and distances (the
// least-squares apex for that angle).
void snap_half_angle(Surface& cone, const FitData& data, const std::vector<Eigen::Vector3d>& ideals,
                     double angle_tolerance, double residual_ratio) {
  if (std::none_of(ideals.begin(), ideals.end(), [&](const Eigen::Vector3d& d) { return std::abs(d.dot(cone.axis)) > 1.0 - 1e-12; }))
    return;
  const double* ideal = nullptr;
  for (const double& degrees : kDegrees)
    if (degrees > 0.0 && degrees < 90.0 && std::abs(degrees * M_PI / 180.0 - cone.half_angle) <= angle_tolerance) ideal = &degrees;
  const double total = data.weights.sum();
  if (!ideal || !(total > 0.0)) return;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();  // height along the axis from the apex, distance from it
  for (Eigen::Index i = 0; i < data.points.rows(); ++i) {
    const AxialCoordinates c = axial_coordinates(cone.point, cone.axis, data.points.row(i).transpose());
    mean += data.weights[i] * Eigen::Vector2d(c.height, c.distance);
  }
  mean /= total;
  Surface snapped = cone;
  snapped.half_angle = *ideal * M_PI / 180.0;
  snapped.point += (mean.x() - mean.y() / std::tan(snapped.half_angle)) * snapped.axis;
  double rms, snapped_rms, max_error;
  fit_residuals(cone, data.points, data.weights, rms, max_error);
  fit_residuals(snapped, data.points, data.weights, snapped_rms, max_error);
  if (fits_as_well(snapped_rms, rms, residual_ratio)) cone = snapped;
}

// 4b. Pieces of one cone: the coaxial cones that open the same way and whose union one cone
// about their axis fits about as well as each piece its own (RMS within the residual ratio times
// its own, plus the spread of its few points) take that cone, its half-angle snapped. A chamfer
// round a hexagon's corners comes as six pieces of a narrow band, each too short in profile to fix
// its half-angle (a bolt's 60° chamfer fitted 58-68°), whose circles then missed the flats they
// touch.
void one_cone_per_surface(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                          const std::vector<FitData>& points, const std::vector<Eigen::Vector3d>& ideals,
                          double angle_tolerance, double residual_ratio) {
  std::vector<std::vector<int>> groups;  // the cones of each coaxial group, then each other cone alone
  std::vector<char> grouped(features.size(), 0), taken(features.size(), 0);
  for (const FeatureRelation& r : relations)
    if (r.kind == "coaxial") {
      groups.emplace_back(r.features);
      for (int m : r.features) grouped[m] = 1;
    }
  for (const Feature& f : features)
    if (!grouped[f.id]) groups.push_back({f.id});
  for (const std::vector<int>& group : groups) {
    std::vector<int> cones;
    for (int m : group)
      if (features[m].type == SurfaceType::Cone && static_cast<size_t>(m) < points.size() && points[m].points.rows() > 0)
        cones.push_back(m);
    std::sort(cones.begin(), cones.end(), [&](int x, int y) { return features[x].area > features[y].area; });
    for (int seed : cones) {
      if (taken[seed]) continue;
      std::vector<int> members = {seed};
      FitData data = points[seed];
      Surface joint = features[seed].surface;
      for (int m : cones) {
        if (m == seed || taken[m] || features[m].surface.axis.dot(joint.axis) <= 0.0) continue;
        const FitData both = concatenate(data, points[m]);
        const SurfaceFit fit = fit_about_axis(SurfaceType::Cone, both, joint.point, joint.axis);
        if (!fit.valid || fit.surface.axis.dot(joint.axis) <= 0.0) continue;
        const auto explains = [&](int n) {
          double rms, max_error;
          fit_residuals(fit.surface, points[n].points, points[n].weights, rms, max_error);
          return fits_as_well(rms, features[n].rms, residual_ratio, features[n].spread);
        };
        if (!explains(m) || !std::all_of(members.begin(), members.end(), explains)) continue;
        members.push_back(m);
        data = both;
        joint = fit.surface;
      }
      snap_half_angle(joint, data, ideals, angle_tolerance, residual_ratio);
      for (int m : members) {
        taken[m] = 1;
        features[m].surface = joint;
      }
    }
  }
}

// 6b. Tori whose tube radius or centre the relations set: the tube radius is the median of its
// group's and the centre the mean of its concentric group's, while on a band that does not go
// round its tube the two correlate (a washer's bead fitted over its top, only the cylinder below
// it: one torus came out with a tube too large and its centre too low, the other the other way
// round, and the median of one with the mean of the other dropped the tops of both by 2 % of the
// tube). The tori of each concentric group (each other torus alone) are fitted again about their
// axis by Gauss–Newton: one centre height for the group, each torus's circle radius, and the tube
// radius where no torus outside the group shares it. A coaxial cylinder tangent to a torus, whose
// radius no other feature shares, is fitted with it as the circle radius less or plus the tube
// (step 9 would make it so): its points fix where the tube meets it, which the torus's own points
// near that tangent border hardly do. Kept where the RMS over all their points drops from what
// step 9 would make of the fits.
void refit_related_tori(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                        const std::vector<FitData>& points, double cos_tolerance, double distance_tolerance) {
  std::vector<int> group_of(features.size(), -1);
  std::vector<std::vector<int>> groups;
  std::vector<char> related(features.size(), 0), radius_shared_beyond(features.size(), 0), equal_radius(features.size(), 0);
  auto has_points = [&](int m) { return static_cast<size_t>(m) < points.size() && points[m].points.rows() > 0; };
  auto is_torus = [&](int m) {
    return features[m].type == SurfaceType::Torus && has_points(m) && features[m].surface.radius > features[m].surface.minor;
  };
  for (const FeatureRelation& r : relations) {
    if (r.kind != "concentric" && r.kind != "equal_radius") continue;
    for (int m : r.features) {
      related[m] = 1;
      if (r.kind == "equal_radius") equal_radius[m] = 1;
    }
    if (r.kind != "concentric" || !std::all_of(r.features.begin(), r.features.end(), is_torus)) continue;
    for (int m : r.features) group_of[m] = static_cast<int>(groups.size());
    groups.push_back(r.features);
  }
  for (const Feature& f : features)
    if (related[f.id] && is_torus(f.id) && group_of[f.id] < 0) {
      group_of[f.id] = static_cast<int>(groups.size());
      groups.push_back({f.id});
    }
  for (const FeatureRelation& r : relations)
    if (r.kind == "equal_radius")
      for (int m : r.features)
        for (int n : r.features)
          if (group_of[m] < 0 || group_of[m] != group_of[n]) radius_shared_beyond[m] = radius_shared_beyond[n] = 1;

  // What the fit sees of one feature: heights along the group's axis and distances from it; a
  // cylinder's radius is its torus's circle radius less `side` times the tube.
  struct Piece {
    int feature, torus;  // the feature, and the group's torus it belongs to (index)
    bool cylinder;
    double side;
    Eigen::MatrixX2d profile;
  };
  std::vector<char> taken(features.size(), 0);
  for (const std::vector<int>& group : groups) {
    const Surface& first = features[group.front()].surface;
    const Eigen::Vector3d axis = first.axis, centre = first.point;
    bool one_axis = true, free_tube = true;
    for (int m : group) {
      const Surface& s = features[m].surface;
      one_axis &= std::abs(s.axis.dot(axis)) >= cos_tolerance && (s.point - centre).norm() <= 1e-9 * (1.0 + centre.norm());
      free_tube &= !radius_shared_beyond[m];
    }
    if (!one_axis) continue;
    const int k = static_cast<int>(group.size());
    // x = (centre height, tube radius, circle radius of each torus).
    Eigen::VectorXd x(2 + k);
    x[0] = 0.0;
    x[1] = first.minor;
    for (int i = 0; i < k; ++i) x[2 + i] = features[group[i]].surface.radius;
    std::vector<Piece> pieces;
    for (int i = 0; i < k; ++i) {
      pieces.push_back({group[i], i, false, 0.0, {}});
      for (int c : tangent_features(group[i], SurfaceType::Cylinder, relations, features)) {
        const Surface& cylinder = features[c].surface;
        if (taken[c] || equal_radius[c] || !has_points(c) ||
            std::abs(cylinder.axis.dot(axis)) < cos_tolerance ||
            axial_coordinates(cylinder.point, cylinder.axis, centre).distance > distance_tolerance)
          continue;
        taken[c] = 1;
        const double side = x[2 + i] >= cylinder.radius ? 1.0 : -1.0;
        x[2 + i] = cylinder.radius + side * x[1];  // as step 9 would have it
        pieces.push_back({c, i, true, side, {}});
        break;
      }
    }
    for (Piece& piece : pieces) {
      const MatrixX3d& p = points[piece.feature].points;
      piece.profile.resize(p.rows(), 2);
      for (Eigen::Index j = 0; j < p.rows(); ++j) {
        const AxialCoordinates c = axial_coordinates(centre, axis, p.row(j).transpose());
        piece.profile.row(j) << c.height, c.distance;
      }
    }
    const int unknowns = 2 + k;
    // Residual of point j of a piece and its gradient with respect to x.
    auto residual = [&](const Piece& piece, Eigen::Index j, const Eigen::VectorXd& y, Eigen::VectorXd* gradient) {
      const double dz = piece.profile(j, 0) - y[0], dr = piece.profile(j, 1) - y[2 + piece.torus];
      if (gradient) gradient->setZero(unknowns);
      if (piece.cylinder) {
        if (gradient) {
          (*gradient)[1] = piece.side;
          (*gradient)[2 + piece.torus] = -1.0;
        }
        return dr + piece.side * y[1];
      }
      const double d = std::hypot(dz, dr);
      if (gradient && d > 0.0) {
        (*gradient)[0] = -dz / d;
        (*gradient)[1] = -1.0;
        (*gradient)[2 + piece.torus] = -dr / d;
      }
      return d - y[1];
    };
    auto squared_error = [&](const Eigen::VectorXd& y) {
      double sum = 0.0;
      for (const Piece& piece : pieces)
        for (Eigen::Index j = 0; j < piece.profile.rows(); ++j) {
          const double e = residual(piece, j, y, nullptr);
          sum += points[piece.feature].weights[j] * e * e;
        }
      return sum;
    };
    const double initial = squared_error(x);
    Eigen::VectorXd g;
    for (int iteration = 0; iteration < 20; ++iteration) {
      Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(unknowns, unknowns);
      Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
      for (const Piece& piece : pieces) {
        const Eigen::VectorXd& w = points[piece.feature].weights;
        for (Eigen::Index j = 0; j < piece.profile.rows(); ++j) {
          const double e = residual(piece, j, x, &g);
          normal += w[j] * g * g.transpose();
          rhs -= w[j] * e * g;
        }
      }
      if (!free_tube) {  // the tube radius stays as its equal-radius group has it
        normal.row(1).setZero();
        normal.col(1).setZero();
        normal(1, 1) = 1.0;
        rhs[1] = 0.0;
      }
      const Eigen::VectorXd step = normal.ldlt().solve(rhs);
      if (!step.allFinite()) break;
      x += step;
      if (step.norm() <= 1e-12 * (1.0 + x.norm())) break;
    }
    bool ring = x[1] > 0.0;
    for (int i = 0; i < k; ++i) ring &= x[2 + i] > x[1];
    for (const Piece& piece : pieces) ring &= !piece.cylinder || x[2 + piece.torus] - piece.side * x[1] > 0.0;
    if (!x.allFinite() || !ring || !(squared_error(x) < initial)) continue;
    for (const Piece& piece : pieces) {
      Surface& s = features[piece.feature].surface;
      if (piece.cylinder) {
        s.radius = x[2 + piece.torus] - piece.side * x[1];
        continue;
      }
      s.point = centre + x[0] * axis;
      s.minor = x[1];
      s.radius = x[2 + piece.torus];
    }
  }
}

// The area of a group of features.
double group_area(const std::vector<int>& group, const std::vector<Feature>& features) {
  double area = 0.0;
  for (int m : group) area += features[m].area;
  return area;
}

// 1. Directions: parallel groups share their mean direction, then every direction snaps to the
// part's ideal directions (returned; none without a frame); those that must stay as fitted
// (options.unsnapped) do neither.
std::vector<Eigen::Vector3d> align_directions(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                                              const IdealizationOptions& options, double angle, double cos_tolerance) {
  std::vector<char> unsnapped(features.size(), 0);
  for (int id : options.unsnapped)
    if (id >= 0 && id < static_cast<int>(features.size())) unsnapped[id] = 1;
  for (const FeatureRelation& r : relations)
    if (r.kind == "parallel") {
      std::vector<int> group;
      for (int m : r.features)
        if (!unsnapped[m]) group.push_back(m);
      if (group.empty()) continue;
      const Eigen::Vector3d d = mean_direction(group, features);
      for (int m : group) features[m].surface.axis = aligned(d, features[m].surface.axis);
    }
  Frame frame;
  std::vector<Eigen::Vector3d> ideals;
  if (options.snap_to_frame && part_frame(features, unsnapped, std::sin(angle), frame)) {
    ideals = ideal_directions(frame);
    for (Feature& f : features)
      if (analytic(f) && f.surface.has_direction() && !unsnapped[f.id])
        f.surface.axis = snapped(f.surface.axis, ideals, cos_tolerance);
  }
  return ideals;
}

// 2. Coplanar groups take one offset along the shared normal; 3. coaxial groups one axis line,
// their members keeping their place along it.
void share_planes_and_axes(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations) {
  for (const FeatureRelation& r : relations) {
    const std::vector<int>& group = r.features;
    const double area = group_area(group, features);
    if (!(area > 0.0)) continue;
    if (r.kind == "coplanar") {  // 2. one offset along the shared normal
      const Eigen::Vector3d n = features[largest(group, features)].surface.axis;
      double offset = 0.0;
      for (int m : group) offset += features[m].area * n.dot(features[m].surface.point) / area;
      for (int m : group) {
        Surface& s = features[m].surface;
        s.axis = aligned(n, s.axis);
        s.point -= (n.dot(s.point) - offset) * n;
      }
    } else if (r.kind == "coaxial") {  // 3. one axis line; members keep their place along it
      const Eigen::Vector3d a = features[largest(group, features)].surface.axis;
      Eigen::Vector3d across = Eigen::Vector3d::Zero();
      for (int m : group) {
        const Eigen::Vector3d& p = features[m].surface.point;
        across += features[m].area * (p - p.dot(a) * a) / area;
      }
      for (int m : group) {
        Surface& s = features[m].surface;
        s.axis = aligned(a, s.axis);
        s.point = across + s.point.dot(a) * a;
      }
    }
  }
}

void refit_moved_profiles(std::vector<Feature>& features, const std::vector<Feature>& before,
                          const IdealizationOptions& options) {
  // 4. Profiles: a cylinder or cone whose axis moved is fitted again about its ideal axis (the
  // radius of a cylinder, apex and half-angle of a cone), where that fits its points.
  if (options.points && options.refit_moved_profiles)
    for (Feature& f : features) {
      const Surface& was = before[f.id].surface;
      if ((f.type != SurfaceType::Cylinder && f.type != SurfaceType::Cone) ||
          (f.surface.axis == was.axis && f.surface.point == was.point) ||
          static_cast<size_t>(f.id) >= options.points->size())
        continue;
      const FitData& data = (*options.points)[f.id];
      const SurfaceFit profile = fit_about_axis(f.type, data, f.surface.point, f.surface.axis);
      if (profile.valid && profile.surface.axis.dot(f.surface.axis) > 0.0) f.surface = profile.surface;
    }
}

// 5. Equal-radius groups take one radius, 6. concentric groups one centre.
void share_radii_and_centres(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations) {
  for (const FeatureRelation& r : relations) {
    const std::vector<int>& group = r.features;
    const double area = group_area(group, features);
    if (!(area > 0.0)) continue;
    if (r.kind == "equal_radius") {  // 5. one radius: the area-weighted median, blind to a poor fit
      std::vector<std::pair<double, double>> radii;
      for (int m : group) radii.emplace_back(tube_radius(features[m]), features[m].area);
      std::sort(radii.begin(), radii.end());
      double running = 0.0, radius = radii.back().first;
      for (const auto& [value, weight] : radii)
        if ((running += weight) >= 0.5 * area) {
          radius = value;
          break;
        }
      for (int m : group) tube_radius(features[m]) = radius;
    } else if (r.kind == "concentric") {  // 6. one centre
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (int m : group) centre += features[m].area * features[m].surface.point / area;
      for (int m : group) features[m].surface.point = centre;
    }
  }
}

void touch_tangent_planes(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations, double angle) {
  // 7. Tangency (thesis 4.3): a cylinder tangent to planes parallel to its axis keeps its radius
  // (possibly just made equal to others) and moves its axis so that it touches them: one plane
  // fixes the axis's distance from it, two fix the axis.
  for (Feature& cylinder : features) {
    if (cylinder.type != SurfaceType::Cylinder) continue;
    Surface& c = cylinder.surface;
    std::vector<const Surface*> planes = tangent_surfaces(cylinder.id, SurfaceType::Plane, relations, features);
    planes.erase(std::remove_if(planes.begin(), planes.end(),
                                [&](const Surface* plane) { return std::abs(plane->axis.dot(c.axis)) > std::sin(angle); }),
                 planes.end());
    // Each plane n·x = n·o must lie at distance R from the axis, on the side the axis is now.
    if (planes.size() == 1) {
      c.point += to_distance_from(*planes[0], c.point, c.radius) * planes[0]->axis;
    } else if (planes.size() >= 2) {
      // The first two planes that are not parallel to each other.
      const Surface* second = nullptr;
      for (size_t i = 1; i < planes.size() && !second; ++i)
        if (std::abs(planes[i]->axis.dot(planes[0]->axis)) < std::cos(angle)) second = planes[i];
      if (!second) continue;
      Eigen::Vector3d e1, e2;
      orthonormal_frame(c.axis, e1, e2);
      Eigen::Matrix2d a;
      Eigen::Vector2d b;
      int row = 0;
      for (const Surface* plane : {planes[0], second}) {
        a.row(row) << plane->axis.dot(e1), plane->axis.dot(e2);
        b[row] = to_distance_from(*plane, c.point, c.radius);
        ++row;
      }
      const Eigen::Vector2d shift = a.colPivHouseholderQr().solve(b);
      if (shift.allFinite()) c.point += shift[0] * e1 + shift[1] * e2;
    }
  }
}

void spheres_from_cylinders(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations) {
  // 8. A sphere tangent to cylinders (the ball in the corner where fillets meet, thesis 4.3 case 2)
  // is completely defined by them: its centre is the point nearest to their axes (on the axis for
  // one), its radius theirs.
  for (Feature& sphere : features) {
    if (sphere.type != SurfaceType::Sphere) continue;
    const std::vector<const Surface*> cylinders = tangent_surfaces(sphere.id, SurfaceType::Cylinder, relations, features);
    if (cylinders.empty()) continue;
    double radius = 0.0;
    for (const Surface* c : cylinders) radius += c->radius / cylinders.size();
    // Along a single axis (or nearly parallel ones, within 8°) the sphere keeps its place.
    Eigen::Vector3d& centre = sphere.surface.point;
    const AxesMeeting meeting = point_nearest_to_axes(cylinders);
    if (meeting.fixed > 1e-2) {
      centre = meeting.point;
    } else {
      const Surface& c = *cylinders.front();
      centre = c.point + (centre - c.point).dot(c.axis) * c.axis;
    }
    sphere.surface.radius = radius;
  }
}

void tori_on_plane_and_wall(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                            const IdealizationOptions& options, double cos_tolerance) {
  // 9. A torus tangent to a plane across its axis and to a coaxial cylinder or cone (the fillet at
  // the foot of a boss, the rim of a bore, between a cone and the face across it) keeps its tube
  // radius and touches both: its centre lies the tube radius from the plane, its circle the tube
  // radius from the wall, about the wall's axis (coaxial with it, or within the distance tolerance
  // of it).
  auto coaxial = [&](int id, const Surface& surface) {
    return std::any_of(relations.begin(), relations.end(), [&](const FeatureRelation& r) {
      return r.kind == "coaxial" && std::find(r.features.begin(), r.features.end(), id) != r.features.end() &&
             std::any_of(r.features.begin(), r.features.end(), [&](int m) { return &features[m].surface == &surface; });
    });
  };
  for (Feature& torus : features) {
    if (torus.type != SurfaceType::Torus) continue;
    Surface& t = torus.surface;
    for (const Surface* plane : tangent_surfaces(torus.id, SurfaceType::Plane, relations, features)) {
      if (std::abs(plane->axis.dot(t.axis)) < cos_tolerance) continue;
      t.point += to_distance_from(*plane, t.point, t.minor) * plane->axis;
      break;
    }
    std::vector<const Surface*> walls = tangent_surfaces(torus.id, SurfaceType::Cylinder, relations, features);
    for (const Surface* cone : tangent_surfaces(torus.id, SurfaceType::Cone, relations, features)) walls.push_back(cone);
    for (const Surface* wall : walls) {
      const AxialCoordinates centre = axial_coordinates(wall->point, wall->axis, t.point);
      if (std::abs(wall->axis.dot(t.axis)) < cos_tolerance ||
          (centre.distance > options.distance_tolerance && !coaxial(torus.id, *wall)))
        continue;
      // On the wall's axis, which a cylinder's tangent planes may have moved (step 7).
      t.axis = aligned(wall->axis, t.axis);
      t.point = wall->point + centre.height * wall->axis;
      const double side = t.radius >= touching_circle_radius(*wall, centre.height, 0.0, 1.0) ? 1.0 : -1.0;
      t.radius = touching_circle_radius(*wall, centre.height, t.minor, side);
      break;
    }
  }
}

}  // namespace

int idealize_features(std::vector<Feature>& features, const std::vector<FeatureRelation>& relations,
                      const IdealizationOptions& options) {
  // Points of another layer (or of none) would refit profiles to the wrong feature, or to nothing,
  // without a sound: one set per feature or none.
  if (options.points && options.points->size() != features.size())
    throw std::invalid_argument("idealization needs the points of every feature (" +
                                std::to_string(options.points->size()) + " sets for " +
                                std::to_string(features.size()) + " features)");
  const std::vector<Feature> before = features;
  const double angle = options.angle_tolerance_degrees * M_PI / 180.0;
  const double cos_tolerance = std::cos(angle);
  const std::vector<Eigen::Vector3d> ideals = align_directions(features, relations, options, angle, cos_tolerance);
  share_planes_and_axes(features, relations);
  refit_moved_profiles(features, before, options);
  if (options.points) one_cone_per_surface(features, relations, *options.points, ideals, angle, options.residual_ratio);
  share_radii_and_centres(features, relations);
  if (options.points) refit_related_tori(features, relations, *options.points, cos_tolerance, options.distance_tolerance);
  touch_tangent_planes(features, relations, angle);
  spheres_from_cylinders(features, relations);
  tori_on_plane_and_wall(features, relations, options, cos_tolerance);
  int changed = 0;
  for (size_t i = 0; i < features.size(); ++i) {
    const Surface &a = before[i].surface, &b = features[i].surface;
    changed += a.point != b.point || a.axis != b.axis || a.radius != b.radius || a.minor != b.minor;
  }
  return changed;
}

}  // namespace idealize
