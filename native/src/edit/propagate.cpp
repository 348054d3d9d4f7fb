#include "edit/propagate.h"

#include "edit/contacts.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <sstream>
#include <string>

namespace idealize {
namespace {

double signed_volume(const TriangleMesh& mesh) {
  double volume = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    volume += a.dot(b.cross(c)) / 6.0;
  }
  return volume;
}

bool is_identity(const Eigen::Isometry3d& m) { return m.matrix() == Eigen::Matrix4d::Identity(); }

std::string describe(int feature, const std::vector<Surface>& surfaces) {
  return "feature " + std::to_string(feature) + " (" + surface_type_name(surfaces[feature].type) + ")";
}

double& rolling_radius_of(Surface& s) { return s.type == SurfaceType::Torus ? s.minor : s.radius; }

// The surface with the user's parameter change; `side`: outward_side of the feature.
Surface with_parameter(const Surface& s, EditParameter parameter, double value, double side, int feature) {
  Surface out = s;
  auto refuse = [&](const std::string& why) {
    throw std::invalid_argument("cannot edit feature " + std::to_string(feature) + " (" + surface_type_name(s.type) +
                                "): " + why);
  };
  if (!std::isfinite(value)) refuse("the value is not a finite number");
  switch (parameter) {
    case EditParameter::None: return out;
    case EditParameter::Offset:
      switch (s.type) {
        case SurfaceType::Plane: out.point = s.point + side * value * s.axis; break;
        case SurfaceType::Cylinder:
        case SurfaceType::Sphere: out.radius = s.radius + side * value; break;
        case SurfaceType::Torus: out.minor = s.minor + side * value; break;
        // A cone offset along its normal: its apex moves along the axis by the offset over the
        // sine of the half-angle (the normal makes that angle's complement with the axis).
        case SurfaceType::Cone: out.point = s.point - side * value / std::sin(s.half_angle) * s.axis; break;
        case SurfaceType::Freeform: refuse("a freeform surface has no offset");
      }
      break;
    case EditParameter::Radius:
      if (s.type != SurfaceType::Cylinder && s.type != SurfaceType::Sphere && s.type != SurfaceType::Torus)
        refuse("it has no radius");
      out.radius = value;
      break;
    case EditParameter::MinorRadius:
      if (s.type != SurfaceType::Torus) refuse("only a torus has a minor radius");
      out.minor = value;
      break;
    case EditParameter::HalfAngle:
      if (s.type != SurfaceType::Cone) refuse("only a cone has a half-angle");
      if (!(value > 0.0 && value < M_PI / 2)) refuse("a cone's half-angle lies between 0 and 90 degrees");
      out.half_angle = value;
      break;
  }
  // A push/pull that shrinks a round past nothing asks for a shape that cannot be: a conflict, as
  // any edit no configuration satisfies. A value given outright is an argument that does not apply.
  auto impossible = [&](const std::string& why) {
    if (parameter != EditParameter::Offset) refuse(why);
    throw EditConflict("pushing feature " + std::to_string(feature) + " (" + surface_type_name(s.type) + ") by " +
                       std::to_string(value) + ": " + why + "; the layer is unchanged");
  };
  if (s.type != SurfaceType::Plane && s.type != SurfaceType::Cone && !(out.radius > 0.0))
    impossible("its radius would be " + std::to_string(out.radius) + ", not positive");
  if (s.type == SurfaceType::Torus && !(out.minor > 0.0 && out.minor < out.radius))
    impossible("its tube radius must stay between 0 and its major radius");
  return out;
}

// The rigid motion that carries `before` onto `after` without sliding along the surface.
Eigen::Isometry3d motion_between(const Surface& before, const Surface& after) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  if (after.has_direction()) m.linear() = Eigen::Quaterniond::FromTwoVectors(before.axis, after.axis).toRotationMatrix();
  Eigen::Vector3d t = after.point - m.linear() * before.point;
  if (after.type == SurfaceType::Plane) t = t.dot(after.axis) * after.axis;
  if (after.type == SurfaceType::Cylinder) t -= t.dot(after.axis) * after.axis;
  m.translation() = t;
  return m;
}

struct Propagator {
  const TriangleMesh& mesh;
  const std::vector<int>& labels;
  const std::vector<Surface>& before;
  const std::vector<FeatureRelation>& relations;
  const FeatureEdit& edit;
  const EditOptions& options;
  Propagation out;
  std::vector<char> determined, driven;
  std::vector<Contact> contacts;
  std::vector<std::vector<int>> contacts_of;
  double length = 0.0, settle = 0.0, conflict = 0.0;

  Propagator(const TriangleMesh& m, const std::vector<int>& l, const std::vector<Surface>& s,
             const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& r, const FeatureEdit& e,
             const EditOptions& o)
      : mesh(m), labels(l), before(s), relations(r), edit(e), options(o) {
    const size_t n = before.size();
    out.surfaces = before;
    out.motions.assign(n, Eigen::Isometry3d::Identity());
    out.changed.assign(n, 0);
    determined.assign(n, 0);
    driven.assign(n, 0);
    length = std::max(bounding_box_diagonal(mesh), 1e-300);
    // A contact untouched by the edit holds to the rounding of its distances (about 1e-15 of the
    // part); 1e-9 of it tells it from one the edit moved by any length worth a vertex.
    settle = 1e-9 * length;
    conflict = std::max(kExactFraction * options.distance_tolerance, settle);
    std::vector<std::array<int, 2>> pairs;
    for (const FeatureAdjacency& a : adjacency)
      if (a.continuity == Continuity::G1) pairs.push_back({a.a, a.b});
    contacts = tangent_contacts(mesh, labels, before, pairs);
    contacts_of.assign(n, {});
    for (size_t c = 0; c < contacts.size(); ++c) {
      contacts_of[contacts[c].roller].push_back(static_cast<int>(c));
      contacts_of[contacts[c].other].push_back(static_cast<int>(c));
    }
  }

  int partner(const Contact& c, int f) const { return c.roller == f ? c.other : c.roller; }

  double residual(const Contact& c) const {
    std::vector<double> r;
    contact_residuals(c, before[c.roller], out.surfaces[c.roller], out.surfaces[c.other], r);
    double worst = 0.0;
    for (double x : r) worst = std::max(worst, std::abs(x));
    return worst;
  }

  void set(int f, const Surface& s, const Eigen::Isometry3d& motion) {
    out.surfaces[f] = s;
    out.motions[f] = motion;
    out.changed[f] = 1;
  }

  void apply_user_edit() {
    for (int f : edit.features) {
      if (f < 0 || f >= static_cast<int>(before.size()))
        throw std::invalid_argument("no feature " + std::to_string(f) + " in the layer");
      if (before[f].type == SurfaceType::Freeform)
        throw std::invalid_argument("feature " + std::to_string(f) + " is freeform: it has no parameters to edit");
      const Surface carried = moved(before[f], edit.motion);
      const double side = edit.parameter == EditParameter::Offset ? outward_side(mesh, labels, f, before[f]) : 1.0;
      const Surface s = with_parameter(carried, edit.parameter, edit.value, side, f);
      Eigen::Isometry3d motion = edit.motion;
      if (edit.parameter == EditParameter::Offset && s.type == SurfaceType::Plane)
        motion = Eigen::Translation3d(s.point - carried.point) * motion;
      set(f, s, motion);
      determined[f] = driven[f] = 1;
    }
  }

  // Related features take the change of a driven member (coplanar: its plane; coaxial and
  // concentric: its motion; equal radius: its rolling radius), until nothing more changes.
  void follow_relations() {
    const KeepRelations& keep = options.keep;
    for (bool more = true; more;) {
      more = false;
      for (const FeatureRelation& r : relations) {
        const bool coplanar = r.kind == "coplanar" && keep.coplanar;
        const bool axial = (r.kind == "coaxial" && keep.coaxial) || (r.kind == "concentric" && keep.concentric);
        const bool radial = r.kind == "equal_radius" && keep.equal_radius;
        if (!coplanar && !axial && !radial) continue;
        int source = -1;
        for (int m : r.features)
          if (driven[m]) source = source < 0 ? m : source;
        if (source < 0) continue;
        for (int m : r.features) {
          if (driven[m]) continue;
          Surface s = out.surfaces[m];
          Eigen::Isometry3d motion = out.motions[m];
          if (coplanar) {
            const double same = before[m].axis.dot(before[source].axis) < 0.0 ? -1.0 : 1.0;
            s.axis = same * out.surfaces[source].axis;
            s.point = out.surfaces[source].point;
            motion = motion_between(before[m], s);
          } else if (axial) {
            if (is_identity(out.motions[source])) continue;
            s = moved(before[m], out.motions[source]);
            motion = out.motions[source];
          } else {
            const double radius = rolling_radius(out.surfaces[source]);
            if (radius == rolling_radius(before[source])) continue;
            rolling_radius_of(s) = radius;
          }
          set(m, s, motion);
          determined[m] = driven[m] = 1;
          more = true;
        }
      }
    }
  }

  // The constraints of f: its contacts whose partner is determined or larger than f (f rolls on it).
  std::vector<const Contact*> constraints_of(int f) const {
    std::vector<const Contact*> kept;
    for (int c : contacts_of[f]) {
      const Contact& contact = contacts[c];
      if (determined[partner(contact, f)] || contact.roller == f) kept.push_back(&contact);
    }
    return kept;
  }

  double worst(const std::vector<const Contact*>& cs) const {
    double w = 0.0;
    for (const Contact* c : cs) w = std::max(w, residual(*c));
    return w;
  }

  [[noreturn]] void refuse(int f, const std::vector<const Contact*>& cs, const std::string& why) const {
    std::ostringstream msg;
    msg << "the edit cannot keep " << describe(f, before) << " tangent to ";
    for (size_t i = 0; i < cs.size(); ++i) msg << (i ? ", " : "") << describe(partner(*cs[i], f), before);
    msg << ": " << why << "; the layer is unchanged";
    throw EditConflict(msg.str());
  }

  // A roller whose radius the user (or an equal-radius relation) changed takes the pose that keeps
  // it on its walls: a fillet of a new radius between the same planes. Repeated, so that a roller
  // resting on another edited roller (a corner's ball on its fillets) follows it.
  void resolve_edited_rollers() {
    std::vector<int> edited;
    for (size_t f = 0; f < before.size(); ++f)
      if (driven[f] && is_identity(out.motions[f]) && rolling_radius(out.surfaces[f]) != rolling_radius(before[f]))
        edited.push_back(static_cast<int>(f));
    // A roller that finds no pose in one pass may in the next, once the rollers it rests on moved
    // (a corner's ball is solved before the fillets of higher ids it sits in): it is refused only
    // when a pass moves nothing more.
    std::vector<int> failed;
    for (size_t pass = 0; pass <= edited.size(); ++pass) {
      bool moved_any = false;
      failed.clear();
      for (int f : edited) {
        std::vector<const Contact*> walls = walls_of(f);
        if (walls.empty() || worst(walls) <= settle) continue;
        Surface s;
        Eigen::Isometry3d motion;
        const double left = solve_pose(f, out.surfaces, before, walls, FreeShape::None, length, s, motion);
        if (left > conflict) {
          failed.push_back(f);
          continue;
        }
        out.surfaces[f] = s;
        out.motions[f] = motion_between(before[f], s);  // as in ring_by_ring: no slide along itself
        moved_any = true;
      }
      if (!moved_any) break;
    }
    if (!failed.empty())
      refuse(failed.front(), walls_of(failed.front()),
             "no position of its new radius touches them all (is it larger than its wall?)");
  }

  // The contacts a roller rolls on (it is their roller).
  std::vector<const Contact*> walls_of(int f) const {
    std::vector<const Contact*> walls;
    for (int c : contacts_of[f])
      if (contacts[c].roller == f) walls.push_back(&contacts[c]);
    return walls;
  }

  // Ring by ring from the changed features, each feature whose contact broke takes the pose that
  // restores it: its rigid pose first, its radius too if that is not enough.
  void ring_by_ring() {
    std::deque<int> queue;
    for (size_t f = 0; f < before.size(); ++f)
      if (out.changed[f]) queue.push_back(static_cast<int>(f));
    while (!queue.empty()) {
      const int c = queue.front();
      queue.pop_front();
      for (int ci : contacts_of[c]) {
        const int p = partner(contacts[ci], c);
        if (determined[p]) continue;
        const std::vector<const Contact*> cs = constraints_of(p);
        determined[p] = 1;
        if (worst(cs) <= settle) continue;
        Surface s;
        Eigen::Isometry3d motion;
        double left = solve_pose(p, out.surfaces, before, cs, FreeShape::None, length, s, motion);
        if (left > conflict && std::isfinite(rolling_radius(before[p])))
          left = solve_pose(p, out.surfaces, before, cs, FreeShape::Radius, length, s, motion);
        if (left > conflict) refuse(p, cs, "no pose of it touches them all");
        if (s.type != SurfaceType::Plane && !(rolling_radius(s) > 0.0)) refuse(p, cs, "its radius would vanish");
        // The solve's pose may slide a cylinder along its axis or spin a round about it, which
        // the contacts do not see: its vertices follow the motion that changes the surface only.
        set(p, s, motion_between(before[p], s));
        queue.push_back(p);
      }
    }
  }

  void check_contacts() const {
    for (const Contact& c : contacts)
      if (residual(c) > conflict) {
        const int f = out.changed[c.roller] ? c.roller : c.other;
        refuse(f, {&c}, "their contact would open by " + std::to_string(residual(c)));
      }
  }
};

}  // namespace

double outward_side(const TriangleMesh& mesh, const std::vector<int>& labels, int feature, const Surface& surface) {
  double facing = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (labels[f] != feature) continue;
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d area_normal = 0.5 * (b - a).cross(c - a);
    facing += area_normal.dot(surface_normal(surface, (a + b + c) / 3.0));
  }
  const double orientation = signed_volume(mesh) < 0.0 ? -1.0 : 1.0;
  return facing * orientation < 0.0 ? -1.0 : 1.0;
}

Propagation propagate_edit(const TriangleMesh& mesh, const std::vector<int>& labels, const std::vector<Surface>& surfaces,
                           const std::vector<FeatureAdjacency>& adjacency, const std::vector<FeatureRelation>& relations,
                           const FeatureEdit& edit, const EditOptions& options) {
  if (edit.features.empty()) throw std::invalid_argument("the edit names no feature");
  Propagator p(mesh, labels, surfaces, adjacency, relations, edit, options);
  p.apply_user_edit();
  p.follow_relations();
  if (options.keep.tangent) {
    p.resolve_edited_rollers();
    p.ring_by_ring();
    p.check_contacts();
  }
  return std::move(p.out);
}

}  // namespace idealize
