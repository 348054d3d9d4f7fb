// Feature groups from the orientation of the feature regions' border loops (see feature_groups.h).
#include "edit/feature_groups.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <utility>

namespace idealize {

namespace {

Eigen::Vector3d face_normal_of(const TriangleMesh& mesh, int f) {
  const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  return (b - a).cross(c - a);  // area-weighted
}

}  // namespace

double facing_side(const TriangleMesh& mesh, const std::vector<int>& region_faces, const Surface& surface) {
  double facing = 0.0;
  for (int f : region_faces) {
    if (surface.type == SurfaceType::Plane) {
      facing += face_normal_of(mesh, f).dot(surface.axis);
      continue;
    }
    const Eigen::Vector3d centroid =
        (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))).transpose() / 3.0;
    facing += face_normal_of(mesh, f).dot(axial_coordinates(surface.point, surface.axis, centroid).radial);
  }
  return facing >= 0.0 ? 1.0 : -1.0;
}

bool identical_regions(const TriangleMesh& mesh, const std::vector<int>& a, const Surface& sa,
                       const std::vector<int>& b, const Surface& sb, double tolerance) {
  if (sa.type != sb.type || (sa.type != SurfaceType::Plane && sa.type != SurfaceType::Cylinder)) return false;
  auto on = [&](const std::vector<int>& faces, const Surface& s) {
    for (int f : faces)
      for (int c = 0; c < 3; ++c)
        if (!(std::abs(signed_distance(s, mesh.V.row(mesh.F(f, c)).transpose())) <= tolerance)) return false;
    return true;
  };
  // Facing the same side of the shared surface: the two sides of a thin sheet are not one face.
  return on(a, sb) && on(b, sa) && facing_side(mesh, a, sb) == facing_side(mesh, b, sb);
}

std::vector<int> faces_labelled(const std::vector<int>& labels, int feature) {
  std::vector<int> faces;
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] == feature) faces.push_back(static_cast<int>(f));
  return faces;
}

Eigen::Vector3d outward_normal(const TriangleMesh& mesh, const std::vector<int>& labels, int feature,
                               const Surface& plane) {
  return facing_side(mesh, faces_labelled(labels, feature), plane) * plane.axis;
}

namespace {

// A chart of a plane or a cylinder: its frame about the axis, and the side the region faces (+1:
// along a plane's axis, away from a cylinder's axis). A plane's (u, v) = (e1, side e2) turns about
// the region's outward normal; a cylinder's (radius angle, side height), the angle growing along
// axis x radial, has as its normal (the angle's direction x the axis) the radial direction, times
// side: also the region's outward normal.
struct Chart {
  Eigen::Vector3d e1, e2;
  double side = 1.0;
};

Chart chart_of(const TriangleMesh& mesh, const std::vector<int>& region_faces, const Surface& surface) {
  Chart chart;
  orthonormal_frame(surface.axis, chart.e1, chart.e2);
  chart.side = facing_side(mesh, region_faces, surface);
  return chart;
}

double wrapped(double angle) { return angle - 2.0 * M_PI * std::round(angle / (2.0 * M_PI)); }  // in [-pi, pi]

}  // namespace

std::vector<Eigen::Vector2d> loop_chart(const TriangleMesh& mesh, const std::vector<int>& loop,
                                        const std::vector<int>& region_faces, const Surface& surface, bool& winds) {
  winds = false;
  const Chart c = chart_of(mesh, region_faces, surface);
  std::vector<Eigen::Vector2d> out;
  if (surface.type == SurfaceType::Plane) {
    for (int v : loop) {
      const Eigen::Vector3d q = mesh.V.row(v).transpose() - surface.point;
      out.emplace_back(q.dot(c.e1), c.side * q.dot(c.e2));
    }
    return out;
  }
  // A cylinder's angle unwrapped along the loop.
  double unwrapped = 0.0, previous = 0.0, turned = 0.0;
  for (size_t i = 0; i <= loop.size(); ++i) {  // the last step closes the loop
    const Eigen::Vector3d q = mesh.V.row(loop[i % loop.size()]).transpose() - surface.point;
    const double a = std::atan2(q.dot(c.e2), q.dot(c.e1));
    const double step = i == 0 ? a : wrapped(a - previous);
    unwrapped += step;
    if (i > 0) turned += step;
    previous = a;
    if (i < loop.size()) out.emplace_back(surface.radius * unwrapped, c.side * q.dot(surface.axis));
  }
  // Closed up, the angle has turned by a whole number of turns: any but zero winds round the axis.
  winds = std::abs(turned) > M_PI;
  return out;
}

std::vector<Eigen::Vector2d> points_chart(const TriangleMesh& mesh, const std::vector<int>& region_faces,
                                          const Surface& surface, double near) {
  const Chart c = chart_of(mesh, region_faces, surface);
  std::vector<Eigen::Vector2d> out;
  out.reserve(mesh.num_vertices());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    const Eigen::Vector3d q = mesh.V.row(v).transpose() - surface.point;
    if (surface.type == SurfaceType::Plane) {
      out.emplace_back(q.dot(c.e1), c.side * q.dot(c.e2));
    } else {
      const double angle = near + wrapped(std::atan2(q.dot(c.e2), q.dot(c.e1)) - near);
      out.emplace_back(surface.radius * angle, c.side * q.dot(surface.axis));
    }
  }
  return out;
}

namespace {

// The border loops of `feature`, whose faces are `faces` (border_loops); `used` (3 #F, zero) is
// scratch, left zero.
std::vector<BorderLoop> loops_of(const TriangleMesh& mesh, const MeshTopology& topology, const std::vector<int>& labels,
                                 int feature, const std::vector<int>& faces, std::vector<char>& used) {
  auto inside = [&](int f) { return f >= 0 && labels[f] == feature; };
  // The border edges: edge c of a region face (opposite corner c, from F(f, c+1) to F(f, c+2) in
  // the face's winding, so the region lies on its left) whose other side is not in the region.
  auto on_border = [&](int f, int c) { return !inside(topology.face_neighbor(f, c)); };
  // The border edge that follows edge c of face f: turning round its end vertex through the
  // region's faces to the first edge out of it that is on the border. Where the region touches
  // itself at a vertex, this keeps each wedge's loop apart, so that every loop is simple.
  auto following = [&](int f, int c) {
    const int b = mesh.F(f, (c + 2) % 3);
    for (int turns = 0; turns < mesh.num_faces(); ++turns) {
      const int k = (c + 1) % 3;  // the edge from b onwards in f
      if (on_border(f, k)) return 3 * f + k;
      const int g = topology.face_neighbor(f, k);
      const int x = mesh.F(f, c);  // the edge b -> x in f is x -> b in g
      int cg = 0;
      while (cg < 3 && !(mesh.F(g, (cg + 1) % 3) == x && mesh.F(g, (cg + 2) % 3) == b)) ++cg;
      if (cg == 3) return -1;  // inconsistently oriented: no further
      f = g;
      c = cg;
    }
    return -1;
  };
  std::vector<BorderLoop> loops;
  for (int f0 : faces) {
    for (int c0 = 0; c0 < 3; ++c0) {
      if (!on_border(f0, c0) || used[3 * f0 + c0]) continue;
      BorderLoop loop;
      for (int e = 3 * f0 + c0; e >= 0 && !used[e]; e = following(e / 3, e % 3)) {
        used[e] = 1;
        const int f = e / 3, c = e % 3, g = topology.face_neighbor(f, c);
        loop.vertices.push_back(mesh.F(f, (c + 1) % 3));
        loop.faces.push_back(f);
        loop.across.push_back(g >= 0 ? labels[g] : -1);
        double rise = 0.0;
        if (g >= 0) {
          const int far = mesh.F(g, 0) + mesh.F(g, 1) + mesh.F(g, 2) - mesh.F(f, (c + 1) % 3) - mesh.F(f, (c + 2) % 3);
          rise = face_normal_of(mesh, f).normalized().dot(mesh.V.row(far) - mesh.V.row(mesh.F(f, c)));
        }
        loop.rise.push_back(rise);
      }
      loops.push_back(std::move(loop));
    }
  }
  for (int f : faces) used[3 * f] = used[3 * f + 1] = used[3 * f + 2] = 0;
  return loops;
}

}  // namespace

std::vector<BorderLoop> border_loops(const TriangleMesh& mesh, const std::vector<int>& labels, int feature) {
  const MeshTopology topology(mesh);
  std::vector<int> faces;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] == feature) faces.push_back(f);
  std::vector<char> used(3 * static_cast<size_t>(mesh.num_faces()), 0);
  return loops_of(mesh, topology, labels, feature, faces, used);
}

bool BorderLoop::concave() const {
  double sum = 0.0;
  for (double r : rise) sum += r;
  return sum > 0.0;
}

bool is_inner_loop(const TriangleMesh& mesh, const std::vector<int>& loop, const std::vector<int>& region_faces,
                   const Surface& surface) {
  if ((surface.type != SurfaceType::Plane && surface.type != SurfaceType::Cylinder) || loop.size() < 3) return false;
  bool winds = false;
  const std::vector<Eigen::Vector2d> p = loop_chart(mesh, loop, region_faces, surface, winds);
  if (winds) return false;
  double twice_area = 0.0;  // shoelace: positive counter-clockwise
  for (size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d &a = p[i], &b = p[(i + 1) % p.size()];
    twice_area += a.x() * b.y() - a.y() * b.x();
  }
  return twice_area < 0.0;
}

namespace {

// The features that dent region h's outline `loop` (border_loops; h's faces `region_faces` on
// `surface`) along an edge: a run of the loop's arcs between two arcs along one feature y, or
// along two features y and z that `bound` a dent (that meet, and the dent takes a corner; or that
// are identical, and the dent ran across what joined them), that turns into h's region, by
// more than `tolerance` over its length (a notch in the edge, a boss against a wall, a boss over
// the edge). Measured in h's chart: the run closed by the straight way back from its end to its
// start turns clockwise, and encloses more than tolerance x its length.
std::set<int> edge_dents(const TriangleMesh& mesh, const BorderLoop& loop, const std::vector<int>& region_faces,
                         const Surface& surface, const std::function<bool(int, int)>& bound, double tolerance) {
  std::set<int> dents;
  const int n = static_cast<int>(loop.vertices.size());
  std::vector<int> arc_start;  // the loop's arcs along one feature each: their first edges
  for (int e = 0; e < n; ++e)
    if (loop.across[e] != loop.across[(e + n - 1) % n]) arc_start.push_back(e);
  const int k = static_cast<int>(arc_start.size());
  if (k < 3) return dents;
  // The loop turned to begin at an arc, in the chart, with prefix sums of the shoelace terms and
  // of the edge lengths.
  std::vector<int> loop_vertices(n);
  for (int i = 0; i < n; ++i) loop_vertices[i] = loop.vertices[(arc_start[0] + i) % n];
  bool winds = false;
  const std::vector<Eigen::Vector2d> p = loop_chart(mesh, loop_vertices, region_faces, surface, winds);
  std::vector<double> shoelace(n + 1, 0.0), length(n + 1, 0.0);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d &a = p[i], &b = p[(i + 1) % n];
    shoelace[i + 1] = shoelace[i] + (a.x() * b.y() - a.y() * b.x());
    length[i + 1] = length[i] + (b - a).norm();
  }
  std::vector<int> start(k + 1), feature(k);
  for (int a = 0; a < k; ++a) {
    start[a] = (arc_start[a] - arc_start[0] + n) % n;
    feature[a] = loop.across[arc_start[a]];
  }
  start[k] = n;
  for (int i = 0; i < k; ++i) {
    const int y = feature[i];
    if (y < 0) continue;
    std::set<int> run;
    // The run: arcs i + 1 .. j - 1 (cyclic, shorter than the loop), from the start of arc i + 1
    // to the start of arc j.
    for (int step = 2; step < k; ++step) {
      const int j = (i + step) % k, last = (i + step - 1) % k;
      run.insert(feature[last]);
      const int z = feature[j];
      if (z < 0 || run.count(y) || run.count(-1)) break;
      if (run.count(z) || (z != y && !bound(y, z))) continue;
      const int from = start[(i + 1) % k], to = start[j];
      // Shoelace over the run's edges, then the chord back.
      double twice = to >= from ? shoelace[to] - shoelace[from] : shoelace[n] - shoelace[from] + shoelace[to];
      const double along = to >= from ? length[to] - length[from] : length[n] - length[from] + length[to];
      twice += p[to % n].x() * p[from].y() - p[to % n].y() * p[from].x();
      if (-0.5 * twice > tolerance * along) dents.insert(run.begin(), run.end());
    }
  }
  return dents;
}

}  // namespace

FeatureGroup feature_group(const TriangleMesh& mesh, const std::vector<int>& labels,
                           const std::vector<Surface>& surfaces, int seed, double tolerance) {
  const int n = static_cast<int>(surfaces.size());
  if (seed < 0 || seed >= n) throw std::invalid_argument("the layer has no feature " + std::to_string(seed));
  std::vector<std::vector<int>> faces_of(n);
  std::vector<double> area(n, 0.0);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (labels[f] >= 0 && labels[f] < n) {
      faces_of[labels[f]].push_back(f);
      area[labels[f]] += 0.5 * face_normal_of(mesh, f).norm();
    }
  const MeshTopology topology(mesh);
  std::vector<char> used(3 * static_cast<size_t>(mesh.num_faces()), 0);
  // hosted[h]: the features that h's region holds on an inner loop, or that dent its outline along
  // an edge (edge_dents); floor[h]: h is sunk (every other loop of it concave) and has one inner
  // loop, a convex one.
  std::vector<std::set<int>> hosted(n), neighbours(n);
  std::vector<std::vector<BorderLoop>> outlines(n);
  std::vector<char> floor(n, 0);
  for (int h = 0; h < n; ++h) {
    if (faces_of[h].empty()) continue;
    int inner = 0, convex_inner = 0, outline = 0, concave_outline = 0;
    for (BorderLoop& loop : loops_of(mesh, topology, labels, h, faces_of[h], used)) {
      neighbours[h].insert(loop.across.begin(), loop.across.end());
      if (is_inner_loop(mesh, loop.vertices, faces_of[h], surfaces[h])) {
        hosted[h].insert(loop.across.begin(), loop.across.end());
        ++inner;
        convex_inner += !loop.concave();
      } else {
        ++outline;
        concave_outline += loop.concave();
        if (surfaces[h].type == SurfaceType::Plane || surfaces[h].type == SurfaceType::Cylinder)
          outlines[h].push_back(std::move(loop));
      }
    }
    neighbours[h].erase(-1);
    floor[h] = inner == 1 && convex_inner == 1 && outline > 0 && concave_outline == outline;
  }
  std::map<std::pair<int, int>, bool> identical;
  auto bound = [&](int y, int z) {
    if (neighbours[y].count(z)) return true;
    const auto key = std::make_pair(std::min(y, z), std::max(y, z));
    const auto known = identical.find(key);
    if (known != identical.end()) return known->second;
    return identical[key] = identical_regions(mesh, faces_of[y], surfaces[y], faces_of[z], surfaces[z], tolerance);
  };
  for (int h = 0; h < n; ++h)
    for (const BorderLoop& loop : outlines[h]) {
      const std::set<int> dents = edge_dents(mesh, loop, faces_of[h], surfaces[h], bound, tolerance);
      hosted[h].insert(dents.begin(), dents.end());
    }
  std::set<int> members{seed}, hosts;
  std::vector<int> open{seed};
  auto join = [&](int x) {
    members.insert(x);
    hosts.erase(x);
    open.push_back(x);
  };
  while (!open.empty()) {
    while (!open.empty()) {
      const int m = open.back();
      open.pop_back();
      for (int x : neighbours[m]) {
        if (members.count(x)) continue;
        if (hosted[x].count(m))
          hosts.insert(x);
        else
          join(x);
      }
    }
    for (int h : std::vector<int>(hosts.begin(), hosts.end()))
      if (floor[h]) join(h);
  }
  double inside = 0.0, total = 0.0;
  for (int f = 0; f < n; ++f) total += area[f];
  for (int m : members) inside += area[m];
  FeatureGroup group;
  if (2.0 * inside >= total || hosts.empty()) {  // no group of its own: the seed alone
    members = {seed};
    for (int x : neighbours[seed])
      if (hosted[x].count(seed)) group.hosts.push_back(x);
  } else {
    group.hosts.assign(hosts.begin(), hosts.end());
  }
  group.members.assign(members.begin(), members.end());
  // An island when each border loop of the group runs along one host.
  std::vector<int> group_labels = labels;
  for (int& l : group_labels)
    if (l >= 0 && l < n && members.count(l)) l = n;
  group.island = true;
  for (const BorderLoop& loop : loops_of(mesh, topology, group_labels, n, faces_labelled(group_labels, n), used))
    group.island &= std::set<int>(loop.across.begin(), loop.across.end()).size() == 1;
  return group;
}

}  // namespace idealize
