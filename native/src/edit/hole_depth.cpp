// A hole made afresh at another depth (see hole_depth.h).
#include "edit/hole_depth.h"

#include "core/ray.h"
#include "edit/decals.h"
#include "edit/feature_groups.h"
#include "edit/gaps.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>

namespace idealize {

namespace {

std::string named(int id, const Surface& s) {
  return "feature " + std::to_string(id) + " (" + surface_type_name(s.type) + ")";
}

// The nearest triangle the ray from `origin` along `direction` (unit) meets beyond `skip`, and the
// distance to it (core/ray.h); -1 when it meets none.
int first_hit(const TriangleMesh& mesh, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double skip,
              double& distance) {
  int best = -1;
  distance = std::numeric_limits<double>::infinity();
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const double t = ray_triangle(origin, direction, mesh.V.row(mesh.F(f, 0)), mesh.V.row(mesh.F(f, 1)),
                                  mesh.V.row(mesh.F(f, 2)));
    if (t > skip && t < distance) {
      distance = t;
      best = f;
    }
  }
  return best;
}

// How far along `a` from `from` the plane `plane` lies (the line meets it there).
double along_to(const Surface& plane, const Eigen::Vector3d& from, const Eigen::Vector3d& a) {
  return (plane.point - from).dot(plane.axis) / a.dot(plane.axis);
}

// The hole of radius r along `a` from `p0` (on the entry plane), `depth` deep, as a decal: a strip
// of the wall in rows about `edge` long, ending on `exit` when given (a through hole), else closed
// by a floor disc. Loops on the entry host (and the exit's), each walked counter-clockwise about its
// host's outward normal (`entry_out`, `exit_out`).
Decal hole_decal(const Eigen::Vector3d& p0, const Eigen::Vector3d& a, double r, double depth, double edge,
                 const Surface& entry_plane, const Eigen::Vector3d& entry_out, const Surface* exit_plane,
                 const Eigen::Vector3d& exit_out, int entry, int exit, int wall, int floor) {
  Eigen::Vector3d e1, e2;
  orthonormal_frame(a, e1, e2);  // e1 x e2 = a
  // At least a hexagon round, so that the chords stay within a quarter of the radius.
  const int sectors = std::max(6, static_cast<int>(std::ceil(2.0 * M_PI * r / edge)));
  const int rows = std::max(1, static_cast<int>(std::ceil(depth / edge)));
  Decal decal;
  decal.motion = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> points;
  for (int j = 0; j <= rows; ++j)
    for (int k = 0; k < sectors; ++k) {
      const double angle = 2.0 * M_PI * k / sectors;
      const Eigen::Vector3d base = p0 + r * (std::cos(angle) * e1 + std::sin(angle) * e2);
      double s = depth * j / rows;
      if (j == 0) s = along_to(entry_plane, base, a);
      if (j == rows && exit_plane) s = along_to(*exit_plane, base, a);
      points.push_back(base + s * a);
    }
  auto at = [&](int j, int k) { return j * sectors + (k % sectors); };
  std::vector<std::array<int, 3>> faces;
  for (int j = 0; j < rows; ++j)
    for (int k = 0; k < sectors; ++k) {
      // Along a, then back against the turn about a: the normal points to the axis.
      faces.push_back({at(j, k), at(j + 1, k + 1), at(j, k + 1)});
      faces.push_back({at(j, k), at(j + 1, k), at(j + 1, k + 1)});
      decal.labels.insert(decal.labels.end(), {wall, wall});
    }
  if (!exit_plane) {  // the floor faces back along a, to the hole's opening
    std::vector<Eigen::Vector2d> disc;
    for (int k = 0; k < sectors; ++k) disc.emplace_back(std::cos(2.0 * M_PI * k / sectors), std::sin(2.0 * M_PI * k / sectors));
    for (const std::array<int, 3>& t : fill_ring(disc, {})) {
      faces.push_back({at(rows, t[0]), at(rows, t[2]), at(rows, t[1])});
      decal.labels.push_back(floor);
    }
  }
  decal.mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t v = 0; v < points.size(); ++v) decal.mesh.V.row(static_cast<Eigen::Index>(v)) = points[v];
  decal.mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c) decal.mesh.F(static_cast<Eigen::Index>(f), c) = faces[f][c];
  // Increasing k turns counter-clockwise about a.
  auto loop = [&](int j, const Eigen::Vector3d& out) {
    std::vector<int> l;
    for (int k = 0; k < sectors; ++k) l.push_back(at(j, a.dot(out) > 0.0 ? k : sectors - k));
    return l;
  };
  decal.loops.push_back(loop(0, entry_out));
  decal.hosts.push_back(entry);
  if (exit_plane) {
    decal.loops.push_back(loop(rows, exit_out));
    decal.hosts.push_back(exit);
  }
  return decal;
}

// Throws EditConflict unless the group of `wall` is a plain hole: a cylinder facing its axis, with
// at most flat floors across the axis; returns the group (`tolerance`: feature_group's).
FeatureGroup plain_hole(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                        int wall, double tolerance) {
  const Surface& cylinder = surfaces[wall];
  if (cylinder.type != SurfaceType::Cylinder) throw EditConflict(named(wall, cylinder) + " is not a hole's wall");
  if (facing_side(mesh, faces_labelled(labels, wall), cylinder) > 0.0) throw EditConflict(named(wall, cylinder) + " faces away from its axis: it is a boss, not a hole");
  FeatureGroup group = feature_group(mesh, labels, surfaces, wall, tolerance);
  if (group.hosts.empty()) throw EditConflict(named(wall, cylinder) + " is not a hole in a face");
  // Floors: planes across the axis to rounding (a billionth of a radian).
  std::vector<const Surface*> plain{&cylinder};
  for (int h : group.hosts) plain.push_back(&surfaces[h]);
  for (int m : group.members)
    if (surfaces[m].type == SurfaceType::Plane && std::abs(surfaces[m].axis.dot(cylinder.axis)) >= 1.0 - 1e-9)
      plain.push_back(&surfaces[m]);
  // Any other member must be a tessellation's facet in the hole's rim: its corners on the wall, a
  // floor or a host (to a millionth of the part, an exact layer's deviation).
  const double on = 1e-6 * bounding_box_diagonal(mesh);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const int m = labels[f];
    if (m < 0 || m == wall || std::find(group.members.begin(), group.members.end(), m) == group.members.end()) continue;
    if (std::find(plain.begin(), plain.end(), &surfaces[m]) != plain.end()) continue;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d v = mesh.V.row(mesh.F(f, c)).transpose();
      if (std::none_of(plain.begin(), plain.end(), [&](const Surface* s) { return std::abs(signed_distance(*s, v)) <= on; }))
        throw EditConflict("the hole of " + named(wall, cylinder) + " also has " + named(m, surfaces[m]) +
                           ": only a plain hole (a wall and a flat floor) is given a depth");
    }
  }
  for (int h : group.hosts)
    if (surfaces[h].type != SurfaceType::Plane)
      throw EditConflict("the hole of " + named(wall, cylinder) + " opens in " + named(h, surfaces[h]) +
                         ": a hole's depth is set in planes only");
  return group;
}

}  // namespace

HoleResult set_hole_depth(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                          const std::vector<FeatureAdjacency>& adjacency, int wall, double depth, int entry,
                          const EditOptions& options) {
  check_layer(mesh, labels, surfaces, adjacency, {});
  const int n = static_cast<int>(surfaces.size());
  if (wall < 0 || wall >= n) throw std::invalid_argument("the layer has no feature " + std::to_string(wall));
  if (!(depth > 0.0) || !std::isfinite(depth)) throw std::invalid_argument("a hole's depth must be a positive number");
  const FeatureGroup group = plain_hole(mesh, labels, surfaces, wall, options.distance_tolerance);
  if (entry < 0) {  // the one host, or the larger
    std::vector<double> area(n, 0.0);
    for (int f = 0; f < mesh.num_faces(); ++f)
      if (labels[f] >= 0) {
        const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
        area[labels[f]] += (b - a).cross(c - a).norm();
      }
    entry = *std::max_element(group.hosts.begin(), group.hosts.end(), [&](int x, int y) { return area[x] < area[y]; });
  } else if (std::find(group.hosts.begin(), group.hosts.end(), entry) == group.hosts.end()) {
    throw std::invalid_argument("feature " + std::to_string(entry) + " is not a face the hole opens in");
  }
  const Surface& cylinder = surfaces[wall];
  const Eigen::Vector3d entry_out = outward_normal(mesh, labels, entry, surfaces[entry]);
  const Eigen::Vector3d a = cylinder.axis.dot(entry_out) < 0.0 ? cylinder.axis : Eigen::Vector3d(-cylinder.axis);
  if (std::abs(a.dot(entry_out)) < 1e-9)
    throw EditConflict("the hole's axis lies along " + named(entry, surfaces[entry]));
  const Eigen::Vector3d p0 = cylinder.point + along_to(surfaces[entry], cylinder.point, a) * a;
  const std::vector<double> targets =
      remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths, options.distance_tolerance);

  // The hole deleted (its places closed, not remeshed), then the thickness along its axis.
  EditOptions unremeshed = options;
  unremeshed.remesh = false;
  const DeleteResult gone = delete_features(mesh, labels, surfaces, adjacency, group.members, unremeshed);
  HoleResult result;
  for (int f : gone.kept) result.surfaces.push_back(surfaces[f]);
  result.kept = gone.kept;
  double thickness = 0.0;
  const int hit = first_hit(gone.mesh, p0, a, 1e-9 * bounding_box_diagonal(mesh), thickness);
  if (hit < 0) throw EditConflict("the hole's axis does not leave the part: its mesh is open there");
  const int exit = gone.labels[hit];
  result.through = depth >= thickness - options.distance_tolerance;
  result.depth = result.through ? thickness : depth;
  if (result.through && (exit < 0 || result.surfaces[exit].type != SurfaceType::Plane))
    throw EditConflict("the hole would come out through " +
                       (exit < 0 ? std::string("no feature") : named(gone.kept[exit], surfaces[gone.kept[exit]])) +
                       ": a hole is made through planes only");
  const int entry_new = static_cast<int>(std::find(gone.kept.begin(), gone.kept.end(), entry) - gone.kept.begin());
  result.wall = static_cast<int>(result.surfaces.size());
  result.surfaces.push_back(cylinder);
  result.kept.push_back(-1);
  if (!result.through) {
    Surface floor;
    floor.type = SurfaceType::Plane;
    floor.point = p0 + result.depth * a;
    floor.axis = -a;
    result.floor = static_cast<int>(result.surfaces.size());
    result.surfaces.push_back(floor);
    result.kept.push_back(-1);
  }
  const Eigen::Vector3d exit_out =
      result.through ? outward_normal(gone.mesh, gone.labels, exit, result.surfaces[exit]) : Eigen::Vector3d::Zero();
  const Decal decal = hole_decal(p0, a, cylinder.radius, result.depth, targets[wall], surfaces[entry], entry_out,
                                 result.through ? &result.surfaces[exit] : nullptr, exit_out, entry_new, exit,
                                 result.wall, result.floor);
  std::vector<int> same(result.surfaces.size());
  for (size_t f = 0; f < same.size(); ++f) same[f] = static_cast<int>(f);
  place_decal(gone.mesh, gone.labels, gone.created, result.surfaces, decal, same,
              std::vector<char>(result.surfaces.size(), 0), result.mesh, result.labels, result.created);
  for (size_t f = 0; f < result.labels.size(); ++f)
    if (result.labels[f] == result.wall || result.labels[f] == result.floor) result.created[f] = 1;
  result.hosts = {entry_new};
  if (result.through) result.hosts.push_back(exit);
  result.target_edge_lengths = gone.target_edge_lengths;
  result.target_edge_lengths.resize(result.surfaces.size(), targets[wall]);
  std::vector<int> new_id(n, -1);
  for (size_t k = 0; k < gone.kept.size(); ++k) new_id[gone.kept[k]] = static_cast<int>(k);
  result.vertex_deviation = finish_created(result.mesh, result.labels, result.created, result.surfaces,
                                           result.target_edge_lengths, tangent_pairs(adjacency, new_id),
                                           options.remesh, result.remeshing_problem);
  return result;
}

}  // namespace idealize
