// Copying a feature group as a decal onto another place of its host planes (see copy_features.h).
#include "edit/copy_features.h"

#include "edit/contacts.h"
#include "edit/decals.h"
#include "edit/delete_features.h"
#include "edit/feature_groups.h"
#include "edit/gaps.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>

namespace idealize {

namespace {

using Polygon = std::vector<Eigen::Vector2d>;

double orientation(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Whether segments ab and cd meet (touching counts).
bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d) {
  const double d1 = orientation(c, d, a), d2 = orientation(c, d, b), d3 = orientation(a, b, c), d4 = orientation(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  auto on = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, double o) {
    return o == 0.0 && std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4);
}

bool inside(const Polygon& polygon, const Eigen::Vector2d& p) {  // crossing number
  bool in = false;
  for (size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Eigen::Vector2d &a = polygon[i], &b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

// Whether a triangle (its corners in the chart) and a polygon overlap.
bool overlaps(const std::array<Eigen::Vector2d, 3>& t, const Polygon& polygon) {
  for (const Eigen::Vector2d& p : t)
    if (inside(polygon, p)) return true;
  const Polygon triangle(t.begin(), t.end());
  if (inside(triangle, polygon.front())) return true;
  for (size_t i = 0; i < polygon.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (segments_meet(polygon[i], polygon[(i + 1) % polygon.size()], t[k], t[(k + 1) % 3])) return true;
  return false;
}

// Throws EditConflict unless `motion` carries host `from` (a plane or a cylinder) onto `to`
// (feature `id`; the same surface for a group that stays on its host).
void check_carries_host(const Surface& from, const Surface& to, int id, const Eigen::Isometry3d& motion,
                        double diagonal) {
  // Rounding of a placement given along the host: a billionth of the part, and of a radian.
  const double tolerance = 1e-9 * diagonal;
  const Eigen::Vector3d axis = motion.linear() * from.axis, point = motion * from.point;
  bool on = std::abs(axis.dot(to.axis)) >= 1.0 - 1e-9;
  if (to.type == SurfaceType::Plane)
    on &= std::abs((point - to.point).dot(to.axis)) <= tolerance;
  else
    on &= axial_coordinates(to.point, to.axis, point).distance <= tolerance;
  if (!on)
    throw EditConflict("the new place is off the " + std::string(surface_type_name(to.type)) + " of feature " +
                       std::to_string(id) + (to.type == SurfaceType::Plane
                                                 ? ": translate along that plane and turn about its normal only"
                                                 : ": translate along its axis and turn about it only"));
}

// The host faces (labelled `host` in `labels`) that the new outline `outline` (chart of the host)
// covers, and one ring of host faces around them, so that the gap's border keeps a triangle's
// width from the outline. `chart_of_vertex`: every vertex's point in the host's chart; triangles
// with an edge longer than `widest` there are skipped.
std::vector<int> faces_to_open(const TriangleMesh& mesh, const std::vector<int>& labels, int host,
                               const std::vector<int>& host_faces, const Polygon& outline,
                               const std::vector<Eigen::Vector2d>& chart_of_vertex, double widest,
                               const MeshTopology& topology) {
  std::set<int> covered;
  for (int f : host_faces) {
    const std::array<Eigen::Vector2d, 3> t{chart_of_vertex[mesh.F(f, 0)], chart_of_vertex[mesh.F(f, 1)],
                                           chart_of_vertex[mesh.F(f, 2)]};
    // A cylinder's triangle across the chart's seam (half a turn from the outline) spans it.
    if ((t[1] - t[0]).norm() > widest || (t[2] - t[1]).norm() > widest || (t[0] - t[2]).norm() > widest) continue;
    if (overlaps(t, outline)) covered.insert(f);
  }
  std::set<int> opened = covered;
  for (int f : covered)
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      for (const int* g = topology.vertex_faces_begin(v); g != topology.vertex_faces_end(v); ++g)
        if (labels[*g] == host) opened.insert(*g);
    }
  return {opened.begin(), opened.end()};
}

// The rigid motion of `placement` for the group labelled `group`, whose first host is `host`.
Eigen::Isometry3d placement_motion(const TriangleMesh& mesh, const std::vector<int>& labels, int group,
                                   const std::vector<Surface>& surfaces, int host, const Placement& placement) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::set<int> vertices;
  for (int f : faces_labelled(labels, group))
    for (int c = 0; c < 3; ++c) vertices.insert(mesh.F(f, c));
  for (int v : vertices) centroid += mesh.V.row(v).transpose();
  centroid /= static_cast<double>(std::max<size_t>(vertices.size(), 1));
  const Surface& plane = surfaces[host];
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  if (plane.type == SurfaceType::Cylinder) {  // turned about the cylinder's axis
    motion.linear() = Eigen::AngleAxisd(placement.rotation, plane.axis).toRotationMatrix();
    motion.translation() = plane.point - motion.linear() * plane.point + placement.translation;
    return motion;
  }
  const Eigen::Vector3d normal = outward_normal(mesh, labels, host, plane);
  if (placement.onto < 0 || placement.onto == host) {
    motion.linear() = Eigen::AngleAxisd(placement.rotation, normal).toRotationMatrix();
    motion.translation() = centroid - motion.linear() * centroid + placement.translation;
    return motion;
  }
  // Onto another plane: the centre on the host goes to the nearest point of the target's plane,
  // the host's outward normal onto the target's.
  const Surface& target = surfaces[placement.onto];
  const Eigen::Vector3d to = outward_normal(mesh, labels, placement.onto, target);
  const Eigen::Vector3d from = centroid - (centroid - plane.point).dot(plane.axis) * plane.axis;
  const Eigen::Vector3d anchor = from - (from - target.point).dot(target.axis) * target.axis;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(placement.rotation, to).toRotationMatrix() *
                               Eigen::Quaterniond::FromTwoVectors(normal, to).toRotationMatrix();
  motion.linear() = turn;
  motion.translation() = anchor + placement.translation - turn * from;
  return motion;
}

Decal lift_decal(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                 const std::vector<int>& features, const Placement& placement) {
  const int n = static_cast<int>(surfaces.size());
  Decal decal;
  decal.member.assign(n, 0);
  for (int f : features) {
    if (f < 0 || f >= n) throw std::invalid_argument("the layer has no feature " + std::to_string(f));
    decal.member[f] = 1;
  }
  if (features.empty()) throw std::invalid_argument("no feature to copy or move");
  // The group (label n), its loops and their hosts, as for a deletion.
  std::vector<int> group_labels = labels;
  for (int& l : group_labels)
    if (l >= 0 && decal.member[l]) l = n;
  take_rim_triangles(mesh, n, group_labels);
  const std::vector<BorderLoop> loops = border_loops(mesh, group_labels, n);
  if (loops.empty()) throw std::invalid_argument("the features to copy or move have no triangles");
  decal.hosts = gap_hosts(mesh, group_labels, n, surfaces, loops);
  const double diagonal = bounding_box_diagonal(mesh);
  decal.motion = placement_motion(mesh, group_labels, n, surfaces, decal.hosts.front(), placement);
  if (placement.onto >= 0 && placement.onto != decal.hosts.front()) {
    for (int h : decal.hosts)
      if (surfaces[h].type != SurfaceType::Plane)
        throw EditConflict("the group sits on feature " + std::to_string(h) + ", a " +
                           surface_type_name(surfaces[h].type) + ": it goes onto another face from a plane only");
    if (placement.onto >= n) throw std::invalid_argument("the layer has no feature " + std::to_string(placement.onto));
    if (surfaces[placement.onto].type != SurfaceType::Plane)
      throw EditConflict("feature " + std::to_string(placement.onto) + " is a " +
                         surface_type_name(surfaces[placement.onto].type) + ": a group goes onto a plane only");
    if (std::any_of(decal.hosts.begin(), decal.hosts.end(), [&](int h) { return h != decal.hosts.front(); }))
      throw EditConflict("the group sits on several faces (a through hole): it moves along them only");
    if (decal.member[placement.onto]) throw EditConflict("feature " + std::to_string(placement.onto) + " is in the group");
  }
  for (int& h : decal.hosts) {
    const int to = placement.onto >= 0 ? placement.onto : h;
    check_carries_host(surfaces[h], surfaces[to], to, decal.motion, diagonal);
    h = to;
  }
  const MeshTopology topology(mesh);
  std::vector<int> index(mesh.num_vertices(), -1);
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (group_labels[f] != n) continue;
    std::array<int, 3> t;
    for (int c = 0; c < 3; ++c) {
      int& v = index[mesh.F(f, c)];
      if (v < 0) {
        v = static_cast<int>(points.size());
        points.push_back(decal.motion * Eigen::Vector3d(mesh.V.row(mesh.F(f, c)).transpose()));
      }
      t[c] = v;
    }
    faces.push_back(t);
    decal.labels.push_back(labels[f]);
    // A host's rim triangle inside the outline goes with the member it borders most: it lies off
    // the host (its corners on the group's side of the edge), and placed elsewhere it is part of
    // the group, not of the host around it.
    if (!decal.member[labels[f]]) {
      std::map<int, int> beside;
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g >= 0 && labels[g] >= 0 && decal.member[labels[g]]) ++beside[labels[g]];
      }
      if (!beside.empty())
        decal.labels.back() = std::max_element(beside.begin(), beside.end(), [](const auto& x, const auto& y) {
                                return x.second < y.second;
                              })->first;
    }
  }
  decal.mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t v = 0; v < points.size(); ++v) decal.mesh.V.row(static_cast<Eigen::Index>(v)) = points[v];
  decal.mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c) decal.mesh.F(static_cast<Eigen::Index>(f), c) = faces[f][c];
  for (const BorderLoop& loop : loops) {
    decal.loops.emplace_back();
    for (int v : loop.vertices) decal.loops.back().push_back(index[v]);
  }
  return decal;
}

}  // namespace

// Placing a decal (see decals.h).
void place_decal(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<char>& created,
                 const std::vector<Surface>& surfaces, const Decal& decal, const std::vector<int>& label_of,
                 const std::vector<char>& own, TriangleMesh& out, std::vector<int>& out_labels,
                 std::vector<char>& out_created) {
  TriangleMesh placed;
  placed.F = mesh.F;
  placed.V.resize(mesh.num_vertices() + decal.mesh.num_vertices(), 3);
  placed.V << mesh.V, decal.mesh.V;
  const int shift = mesh.num_vertices();
  const MeshTopology topology(mesh);
  const int n = static_cast<int>(surfaces.size());
  std::vector<std::vector<int>> host_faces(n);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] >= 0) host_faces[labels[f]].push_back(f);
  std::vector<char> removed(mesh.num_faces(), 0);
  std::vector<std::array<int, 3>> faces;
  for (size_t i = 0; i < decal.loops.size(); ++i) {
    const int h = decal.hosts[i];
    bool winds = false;
    std::vector<int> outline_ids;
    for (int v : decal.loops[i]) outline_ids.push_back(shift + v);
    const Polygon outline = loop_chart(placed, outline_ids, host_faces[h], surfaces[h], winds);
    const bool round = surfaces[h].type == SurfaceType::Cylinder;
    double middle = 0.0;  // the outline's mean angle on a cylinder
    for (const Eigen::Vector2d& p : outline) middle += p.x();
    middle /= static_cast<double>(outline.size()) * (round ? surfaces[h].radius : 1.0);
    const Polygon chart_of_vertex = points_chart(placed, host_faces[h], surfaces[h], middle);
    const double widest = round ? M_PI * surfaces[h].radius : std::numeric_limits<double>::infinity();
    const std::vector<int> open =
        faces_to_open(mesh, labels, h, host_faces[h], outline, chart_of_vertex, widest, topology);
    if (open.empty())
      throw EditConflict("the group's new place is not on feature " + std::to_string(h) + ": it would leave that face");
    std::vector<int> gap_labels = labels;
    for (int f : open) {
      if (removed[f]) throw EditConflict("the group's outlines on feature " + std::to_string(h) + " overlap each other");
      removed[f] = 1;
      gap_labels[f] = n;
    }
    const std::vector<BorderLoop> gap = border_loops(mesh, gap_labels, n);
    std::set<int> along;
    for (const BorderLoop& g : gap) along.insert(g.across.begin(), g.across.end());
    along.erase(h);
    if (!along.empty()) {
      const int x = *along.begin();
      throw EditConflict("the group's new place on feature " + std::to_string(h) + " reaches " +
                         (x >= 0 && own[x] ? std::string("the group's own place") : "feature " + std::to_string(x)) +
                         ": place it further from that face's edges and from other features");
    }
    if (gap.size() != 1)
      throw EditConflict("the group's new place on feature " + std::to_string(h) + " surrounds another feature");
    const Polygon outer = loop_chart(placed, gap[0].vertices, host_faces[h], surfaces[h], winds);
    const Polygon inner(outline.rbegin(), outline.rend());
    for (const std::array<int, 3>& t : fill_ring(outer, inner)) {
      std::array<int, 3> face;
      for (int k = 0; k < 3; ++k)
        face[k] = t[k] < static_cast<int>(outer.size())
                      ? gap[0].vertices[t[k]]
                      : outline_ids[outline_ids.size() - 1 - (t[k] - outer.size())];
      faces.push_back(face);
      out_labels.push_back(h);
      out_created.push_back(1);
    }
  }
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (!removed[f]) {
      faces.push_back({mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)});
      out_labels.push_back(labels[f]);
      out_created.push_back(created.empty() ? 0 : created[f]);
    }
  for (int f = 0; f < decal.mesh.num_faces(); ++f) {
    faces.push_back({shift + decal.mesh.F(f, 0), shift + decal.mesh.F(f, 1), shift + decal.mesh.F(f, 2)});
    out_labels.push_back(label_of[decal.labels[f]]);
    out_created.push_back(0);
  }
  if (is_closed(mesh)) check_closed(faces);
  out = compact_mesh(placed.V, faces);
}

namespace {

// The faces the edit made remeshed at their features' targets (result.target_edge_lengths), the
// deviations measured; the tangent pairs are the layer's and their copies' (label_of).
void remesh_hosts(const std::vector<FeatureAdjacency>& adjacency, const std::vector<int>& label_of,
                  const EditOptions& options, CopyResult& result) {
  std::vector<int> same(label_of.size());
  for (size_t f = 0; f < same.size(); ++f) same[f] = static_cast<int>(f);
  std::set<std::pair<int, int>> g1 = tangent_pairs(adjacency, same);
  const std::set<std::pair<int, int>> copied = tangent_pairs(adjacency, label_of);
  g1.insert(copied.begin(), copied.end());
  result.vertex_deviation = finish_created(result.mesh, result.labels, result.created, result.surfaces,
                                           result.target_edge_lengths, g1, options.remesh, result.remeshing_problem);
}

}  // namespace

CopyResult copy_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<int>& features,
                         const Placement& placement, const EditOptions& options) {
  check_layer(mesh, labels, surfaces, adjacency, {});
  const Decal decal = lift_decal(mesh, labels, surfaces, features, placement);
  const int n = static_cast<int>(surfaces.size());
  CopyResult result;
  result.surfaces = surfaces;
  const std::vector<double> before =
      remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths, options.distance_tolerance);
  result.target_edge_lengths = before;
  std::vector<int> label_of(n);
  for (int f = 0; f < n; ++f) {
    label_of[f] = f;
    if (!decal.member[f]) continue;
    label_of[f] = static_cast<int>(result.surfaces.size());
    result.surfaces.push_back(moved(surfaces[f], decal.motion));
    result.target_edge_lengths.push_back(before[f]);
  }
  for (int f : features) result.copies.push_back(label_of[f]);
  place_decal(mesh, labels, {}, surfaces, decal, label_of, decal.member, result.mesh, result.labels, result.created);
  result.hosts = decal.hosts;
  std::sort(result.hosts.begin(), result.hosts.end());
  result.hosts.erase(std::unique(result.hosts.begin(), result.hosts.end()), result.hosts.end());
  remesh_hosts(adjacency, label_of, options, result);
  return result;
}

CopyResult move_features(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                         const std::vector<FeatureAdjacency>& adjacency, const std::vector<int>& features,
                         const Placement& placement, const EditOptions& options) {
  check_layer(mesh, labels, surfaces, adjacency, {});
  const Decal decal = lift_decal(mesh, labels, surfaces, features, placement);
  const int n = static_cast<int>(surfaces.size());
  // The group deleted (its gaps closed, not yet remeshed), under the layer's ids again.
  EditOptions unremeshed = options;
  unremeshed.remesh = false;
  const DeleteResult gone = delete_features(mesh, labels, surfaces, adjacency, features, unremeshed);
  std::vector<int> without = gone.labels;
  for (int& l : without)
    if (l >= 0) l = gone.kept[l];
  CopyResult result;
  result.surfaces = surfaces;
  std::vector<int> same(n);
  for (int f = 0; f < n; ++f) {
    same[f] = f;
    if (decal.member[f]) result.surfaces[f] = moved(surfaces[f], decal.motion);
  }
  result.copies = features;
  place_decal(gone.mesh, without, gone.created, surfaces, decal, same, std::vector<char>(n, 0), result.mesh,
              result.labels, result.created);
  result.hosts = decal.hosts;
  std::sort(result.hosts.begin(), result.hosts.end());
  result.hosts.erase(std::unique(result.hosts.begin(), result.hosts.end()), result.hosts.end());
  result.target_edge_lengths =
      remeshing_targets(mesh, labels, surfaces, options.target_edge_lengths, options.distance_tolerance);
  remesh_hosts(adjacency, same, options, result);
  return result;
}

}  // namespace idealize
