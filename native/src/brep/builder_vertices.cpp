// Corner vertices: the point nearest to the surfaces that meet at a corner of the regions (builder.h).
#include "brep/builder.h"

namespace idealize {
namespace {

// The plane that stands in for one of two surfaces touching along `contact` at a corner: the
// plane of a circle of contact, or the plane through a line of contact square to `a` there (their
// common tangent plane). With the other surface it fixes the curve the corner lies on, which the
// two surfaces alone leave free across the zone where they are close.
Surface contact_plane(const Handle(Geom_Curve)& contact, const Surface& a) {
  Surface plane;
  plane.type = SurfaceType::Plane;
  if (const Handle(Geom_Circle) circle = Handle(Geom_Circle)::DownCast(contact)) {
    plane.point = to_vec(circle->Location());
    const gp_Dir n = circle->Axis().Direction();
    plane.axis = Vec3(n.X(), n.Y(), n.Z());
  } else {
    const Handle(Geom_Line) line = Handle(Geom_Line)::DownCast(contact);
    plane.point = to_vec(line->Position().Location());
    const gp_Dir d = line->Position().Direction();
    plane.axis = Vec3(d.X(), d.Y(), d.Z()).cross(surface_normal(a, plane.point));
  }
  plane.axis.normalize();
  return plane;
}

}  // namespace

void BrepBuilder::make_vertices(const MeshTopology& topology) {
  BRep_Builder builder;
  std::map<int, std::vector<int>> chains_at;  // corner -> the chains that end there
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    if (chain.closed || chain.right < 0) continue;
    chains_at[chain.vertices.front()].push_back(static_cast<int>(c));
    if (chain.vertices.back() != chain.vertices.front()) chains_at[chain.vertices.back()].push_back(static_cast<int>(c));
  }
  std::map<int, Handle(Geom_Curve)> contact_of;  // chain -> the curve its two surfaces touch along, or null
  std::map<int, std::vector<int>> plain_corners;  // corner -> its features, where their own surfaces fix it
  for (int v : topo_.corners) {
    progress_.check();
    std::vector<const Surface*> around;
    std::vector<int> around_features, freeform;
    std::set<int> seen;
    for (const int* f = topology.vertex_faces_begin(v); f != topology.vertex_faces_end(v); ++f) {
      const int feature = topo_.region_feature[topo_.face_region[*f]];
      if (!seen.insert(feature).second) continue;
      if (freeform_.count(feature)) {
        freeform.push_back(feature);
      } else if (surfaces_[feature].type != SurfaceType::Freeform) {
        around.push_back(&surfaces_[feature]);
        around_features.push_back(feature);
      }
    }
    const Vec3 x0 = mesh_.V.row(v).transpose();
    std::vector<Surface> constraints = corner_constraints(around, tol_);
    // Two surfaces that touch along the chain between them (a fillet and the plane it runs into)
    // meet the corner on their curve of contact: a contact plane stands in for one of them.
    std::vector<char> replaced(constraints.size(), 0);
    for (size_t i = 0; i < constraints.size(); ++i) replaced[i] = constraints[i].type != around[i]->type;
    for (int c : chains_at[v]) {
      const BoundaryChain& chain = topo_.chains[c];
      const auto index = [&](int region) {
        return std::find(around_features.begin(), around_features.end(), topo_.region_feature[region]) - around_features.begin();
      };
      const size_t ia = static_cast<size_t>(index(chain.left)), ib = static_cast<size_t>(index(chain.right));
      if (ia >= around.size() || ib >= around.size() || ia == ib || replaced[ia] || replaced[ib]) continue;
      const Surface &a = *around[ia], &b = *around[ib];
      // Once per chain: both its corners ask.
      const auto [known, first] = contact_of.try_emplace(c);
      Handle(Geom_Curve)& contact = known->second;
      if (first) {
        std::vector<Vec3> raw;
        for (int u : chain.vertices) raw.push_back(mesh_.V.row(u).transpose());
        const LocalSurface local_a = [&a](const Vec3&) { return a; }, local_b = [&b](const Vec3&) { return b; };
        const std::vector<Vec3> points = project_on_both(raw, local_a, &local_b);
        contact = closed_form_curve(a, b, points, {}, angle_eps_, tol_, nearly_parallel_);
        if (contact.IsNull())  // as make_edges
          contact = closed_form_curve(a, b, points, {}, nearly_parallel_, 5 * tol_, nearly_parallel_);
        if (contact && (!(contact->IsKind(STANDARD_TYPE(Geom_Circle)) || contact->IsKind(STANDARD_TYPE(Geom_Line))) ||
                        !tangent_along(contact, a, b, points, tangent_angle_)))
          contact.Nullify();
      }
      if (contact.IsNull()) continue;
      const size_t round = a.type == SurfaceType::Plane ? ib : ia;
      constraints[round] = contact_plane(contact, round == ia ? b : a);
      replaced[round] = 1;
    }
    std::vector<LocalSurface> meeting;
    for (const Surface& c : constraints) meeting.push_back([c](const Vec3&) { return c; });
    for (int feature : freeform) meeting.push_back(local_surface(feature));
    corner_points_[v] = meeting.empty() ? x0 : corner_point(meeting, x0, tol_);
    if (freeform.empty() && std::count(replaced.begin(), replaced.end(), 1) == 0) {
      std::sort(around_features.begin(), around_features.end());
      plain_corners[v] = around_features;
    }
  }
  // A straight chain between two planes whose corners each a third, round surface fixes: both
  // corners together (line_chain_ends).
  for (const BoundaryChain& chain : topo_.chains) {
    const int front = chain.vertices.front(), back = chain.vertices.back();
    if (chain.closed || chain.right < 0 || front == back) continue;
    const auto f = plain_corners.find(front), b = plain_corners.find(back);
    if (f == plain_corners.end() || b == plain_corners.end() || f->second.size() != 3 || b->second.size() != 3) continue;
    const int left = topo_.region_feature[chain.left], right = topo_.region_feature[chain.right];
    const Surface &a = surfaces_[left], &c = surfaces_[right];
    if (a.type != SurfaceType::Plane || c.type != SurfaceType::Plane) continue;
    const auto third = [&](const std::vector<int>& features) {  // the one besides the chain's two
      const bool both = std::count(features.begin(), features.end(), left) && std::count(features.begin(), features.end(), right);
      for (int f : features)
        if (both && f != left && f != right) return static_cast<const Surface*>(&surfaces_[f]);
      return static_cast<const Surface*>(nullptr);
    };
    const std::array<const Surface*, 2> thirds = {third(f->second), third(b->second)};
    if (!thirds[0] || !thirds[1] || thirds[0]->type == SurfaceType::Plane || thirds[1]->type == SurfaceType::Plane) continue;
    const auto ends = line_chain_ends(a, c, thirds, {mesh_.V.row(front).transpose(), mesh_.V.row(back).transpose()},
                                      {corner_points_[front], corner_points_[back]}, tol_, nearly_parallel_);
    if (!ends) continue;
    corner_points_[front] = ends->first;
    corner_points_[back] = ends->second;
  }
  // Corners that the surfaces put at one point (four features meeting where the mesh shows two
  // corners joined by a short chain) are one vertex, and the chain between them no edge.
  std::map<int, int> parent;
  const std::function<int(int)> root = [&](int v) {
    auto it = parent.find(v);
    return it == parent.end() || it->second == v ? v : (it->second = root(it->second));
  };
  collapsed_.assign(topo_.chains.size(), 0);
  for (size_t c = 0; c < topo_.chains.size(); ++c) {
    const BoundaryChain& chain = topo_.chains[c];
    const int front = chain.vertices.front(), back = chain.vertices.back();
    if (chain.closed || front == back || (corner_points_.at(front) - corner_points_.at(back)).norm() >= tol_) continue;
    collapsed_[c] = 1;
    const int a = root(front), b = root(back);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::map<int, std::pair<Vec3, int>> merged;  // root -> (sum of points, count)
  for (int v : topo_.corners) {
    auto& [sum, count] = merged.try_emplace(root(v), Vec3::Zero(), 0).first->second;
    sum += corner_points_[v];
    ++count;
  }
  std::map<int, TopoDS_Vertex> made;
  for (auto& [r, entry] : merged) {
    builder.MakeVertex(made[r], to_pnt(entry.first / entry.second), Precision::Confusion());
  }
  for (int v : topo_.corners) {
    vertices_[v] = made[root(v)];
    const auto& entry = merged[root(v)];
    corner_points_[v] = entry.first / entry.second;
  }
}

}  // namespace idealize
