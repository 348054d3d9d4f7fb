#include "edit/contacts.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace idealize {
namespace {

bool rolls(const Surface& s) {
  return s.type == SurfaceType::Cylinder || s.type == SurfaceType::Sphere || s.type == SurfaceType::Torus;
}

// The spine sample of a roller for the point p where it meets the other feature.
Eigen::Vector3d spine_sample(const Surface& roller, const Eigen::Vector3d& p) {
  switch (roller.type) {
    case SurfaceType::Cylinder: return Eigen::Vector3d((p - roller.point).dot(roller.axis), 0.0, 0.0);
    case SurfaceType::Torus: return axial_coordinates(roller.point, roller.axis, p).radial;
    default: return Eigen::Vector3d::Zero();
  }
}

// The spine point of a sample, on the roller as it is now; `before` is the roller the sample was
// taken on (its frame carries a torus's radial directions with the roller's rotation).
Eigen::Vector3d spine_point(const Surface& before, const Surface& roller, const Eigen::Vector3d& sample) {
  switch (roller.type) {
    case SurfaceType::Cylinder: return roller.point + sample.x() * roller.axis;
    case SurfaceType::Torus: {
      const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(before.axis, roller.axis);
      const Eigen::Vector3d radial = turn * sample;
      return roller.point + roller.radius * (radial - radial.dot(roller.axis) * roller.axis).normalized();
    }
    default: return roller.point;
  }
}

// The samples spread along the spine: a cylinder's by height, the others in mesh order.
std::vector<Eigen::Vector3d> spread(std::vector<Eigen::Vector3d> samples, SurfaceType type, int most) {
  if (static_cast<int>(samples.size()) <= most) return samples;
  if (type == SurfaceType::Cylinder)
    std::sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) { return a.x() < b.x(); });
  std::vector<Eigen::Vector3d> kept;
  for (int i = 0; i < most; ++i) kept.push_back(samples[i * (samples.size() - 1) / (most - 1)]);
  return kept;
}

// The rolling radius of `s`: what the contact's residuals subtract.
double roll_of(const Surface& s) { return s.type == SurfaceType::Torus ? s.minor : s.radius; }

// The nearest point to x on the spine of a round `other` (a cylinder's axis, a torus's centre
// circle) and the spine's direction there; false for other surfaces (or x on a torus's axis).
bool spine_foot(const Surface& other, const Eigen::Vector3d& x, Eigen::Vector3d& foot, Eigen::Vector3d& tangent) {
  if (other.type == SurfaceType::Cylinder) {
    foot = other.point + (x - other.point).dot(other.axis) * other.axis;
    tangent = other.axis;
    return true;
  }
  if (other.type != SurfaceType::Torus) return false;
  Eigen::Vector3d radial = (x - other.point) - (x - other.point).dot(other.axis) * other.axis;
  if (radial.norm() == 0.0) return false;
  radial.normalize();
  foot = other.point + other.radius * radial;
  tangent = other.axis.cross(radial);
  return true;
}

// Whether a ball `roller` sits on the spine of the round `other`: its centre within a millionth of
// its radius of it. Off the spine by δ, a ball touches at one point, and taking the circle's point
// instead (contact_point) errs by at most 2δ; the idealization puts the centre there to the
// rounding of its arithmetic (3e-10 on a 5 mm ball), far below what the layer calls an exact fit.
bool ball_on_spine(const Surface& roller, const Surface& other, Eigen::Vector3d& foot, Eigen::Vector3d& tangent) {
  return roller.type == SurfaceType::Sphere && spine_foot(other, roller.point, foot, tangent) &&
         (roller.point - foot).norm() <= 1e-6 * roller.radius;
}

// The unknowns of a pose: for a plane its offset along the normal; otherwise a rotation vector (3)
// about the surface's point and a translation (3); a torus also its major radius; with a free shape
// also the rolling radius.
int unknowns(const Surface& s, FreeShape free) {
  if (s.type == SurfaceType::Plane) return 1;
  const int rigid = s.type == SurfaceType::Sphere ? 3 : 6;
  return rigid + (s.type == SurfaceType::Torus) + (free == FreeShape::Radius && rolls(s));
}

Surface posed(const Surface& s, const Eigen::VectorXd& x, FreeShape free, Eigen::Isometry3d& motion) {
  Surface out = s;
  motion = Eigen::Isometry3d::Identity();
  if (s.type == SurfaceType::Plane) {
    out.point = s.point + x(0) * s.axis;
    motion.translation() = x(0) * s.axis;
    return out;
  }
  int next = 0;
  if (s.type != SurfaceType::Sphere) {
    const Eigen::Vector3d w = x.segment<3>(0);
    const double angle = w.norm();
    const Eigen::Matrix3d turn =
        angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    out.axis = (turn * s.axis).normalized();
    motion.linear() = turn;
    next = 3;
  }
  const Eigen::Vector3d t = x.segment<3>(next);
  out.point = s.point + t;
  motion.translation() = s.point + t - motion.linear() * s.point;  // the rotation is about s.point
  next += 3;
  if (s.type == SurfaceType::Torus) out.radius = s.radius + x(next++);
  if (free == FreeShape::Radius && rolls(s)) (s.type == SurfaceType::Torus ? out.minor : out.radius) += x(next++);
  return out;
}

}  // namespace

std::vector<std::vector<int>> features_around(const TriangleMesh& mesh, const std::vector<int>& labels) {
  std::vector<std::vector<int>> around(mesh.num_vertices());
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3 && labels[f] >= 0; ++c) {  // (-1: a triangle set aside, no feature)
      auto& a = around[mesh.F(f, c)];
      if (std::find(a.begin(), a.end(), labels[f]) == a.end()) a.push_back(labels[f]);
    }
  for (auto& a : around) std::sort(a.begin(), a.end());
  return around;
}

double rolling_radius(const Surface& surface) {
  return rolls(surface) ? roll_of(surface) : std::numeric_limits<double>::infinity();
}

Surface moved(const Surface& surface, const Eigen::Isometry3d& motion) {
  Surface out = surface;
  out.point = motion * surface.point;
  out.axis = (motion.linear() * surface.axis).normalized();
  return out;
}

int roller_of(const Surface& a, int ia, const Surface& b, int ib) {
  if (!rolls(a) && !rolls(b)) return -1;
  if (a.type == SurfaceType::Freeform || b.type == SurfaceType::Freeform) return -1;
  const double ra = rolling_radius(a), rb = rolling_radius(b);
  return ra < rb || (ra == rb && (a.type == SurfaceType::Sphere || b.type != SurfaceType::Sphere)) ? ia : ib;
}

Eigen::Vector3d contact_point(const Surface& roller, const Surface& other, const Eigen::Vector3d& p) {
  const Eigen::Vector3d spine = spine_point(roller, roller, spine_sample(roller, p));
  // A ball on a round's spine touches it along a circle, every point of which is nearest its
  // centre: the one nearest p.
  Eigen::Vector3d foot, tangent;
  if (ball_on_spine(roller, other, foot, tangent)) {
    const Eigen::Vector3d toward = (p - foot) - (p - foot).dot(tangent) * tangent;
    if (toward.norm() > 0.0) return foot + roll_of(other) * toward.normalized();
  }
  return closest_point(other, spine);
}

std::vector<Contact> tangent_contacts(const TriangleMesh& mesh, const std::vector<int>& labels,
                                      const std::vector<Surface>& surfaces,
                                      const std::vector<std::array<int, 2>>& pairs, int max_samples) {
  const std::vector<std::vector<int>> around = features_around(mesh, labels);
  // The vertices each pair shares, in one pass over the vertices.
  std::map<std::pair<int, int>, std::vector<int>> shared;
  for (const auto& [a, b] : pairs) shared[{std::min(a, b), std::max(a, b)}];
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    const auto& f = around[v];
    for (size_t i = 0; i < f.size(); ++i)
      for (size_t j = i + 1; j < f.size(); ++j) {
        const auto it = shared.find({std::min(f[i], f[j]), std::max(f[i], f[j])});
        if (it != shared.end()) it->second.push_back(v);
      }
  }
  std::vector<Contact> contacts;
  for (const auto& [a, b] : pairs) {
    const int roller_id = roller_of(surfaces[a], a, surfaces[b], b);
    if (roller_id < 0) continue;
    Contact contact;
    contact.roller = roller_id;
    contact.other = roller_id == a ? b : a;
    const Surface &roller = surfaces[contact.roller], &other = surfaces[contact.other];
    std::vector<Eigen::Vector3d> samples;
    for (int v : shared[{std::min(a, b), std::max(a, b)}]) samples.push_back(spine_sample(roller, mesh.V.row(v).transpose()));
    if (samples.empty()) continue;
    contact.samples = roller.type == SurfaceType::Sphere ? std::vector<Eigen::Vector3d>{Eigen::Vector3d::Zero()}
                                                          : spread(std::move(samples), roller.type, max_samples);
    Eigen::Vector3d foot, tangent;
    contact.on_spine = ball_on_spine(roller, other, foot, tangent);
    for (const auto& s : contact.samples) {
      const double d = signed_distance(other, spine_point(roller, roller, s));
      const double side = d < 0.0 ? -1.0 : 1.0;
      contact.sides.push_back(side);
      contact.offsets.push_back(d - side * roll_of(roller));
    }
    contacts.push_back(std::move(contact));
  }
  return contacts;
}

void contact_residuals(const Contact& contact, const Surface& roller_before, const Surface& roller,
                       const Surface& other, std::vector<double>& out) {
  Eigen::Vector3d foot, tangent;
  if (contact.on_spine && spine_foot(other, roller.point, foot, tangent)) {
    const Eigen::Vector3d off = roller.point - foot;  // smooth in the poses, unlike its length
    out.insert(out.end(), {off.x(), off.y(), off.z(), roll_of(other) - roll_of(roller)});
    return;
  }
  for (size_t i = 0; i < contact.samples.size(); ++i) {
    const double d = signed_distance(other, spine_point(roller_before, roller, contact.samples[i]));
    out.push_back(d - contact.sides[i] * roll_of(roller) - contact.offsets[i]);
  }
}

double solve_pose(int feature, const std::vector<Surface>& surfaces, const std::vector<Surface>& before,
                  const std::vector<const Contact*>& contacts, FreeShape free, double length, Surface& result,
                  Eigen::Isometry3d& motion) {
  const Surface& start = surfaces[feature];
  const int n = unknowns(start, free);
  auto residuals = [&](const Eigen::VectorXd& x) {
    Eigen::Isometry3d unused;
    const Surface s = posed(start, x, free, unused);
    std::vector<double> r;
    for (const Contact* c : contacts) {
      const bool rolling = c->roller == feature;
      contact_residuals(*c, before[c->roller], rolling ? s : surfaces[c->roller], rolling ? surfaces[c->other] : s, r);
    }
    return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size())).eval();
  };
  // Rotations count as the displacement they cause across the part; the pull towards the start is
  // far below what any contact asks (1e-6 of its weight: the solve's residual floor is about
  // 1e-6 of the pull's, well under a distance of 1e-9 of the part).
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  if (start.type != SurfaceType::Plane && start.type != SurfaceType::Sphere) scale.head<3>().setConstant(length);
  const double pull = 1e-12;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd r = residuals(x);
  // Central differences: the distances are smooth, and a step of 1e-7 of the part leaves an error
  // of about 1e-14 of it (rounding over the step).
  const double step = 1e-7 * length;
  for (int iteration = 0; iteration < 50 && r.size() > 0; ++iteration) {
    Eigen::MatrixXd J(r.size(), n);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd xp = x, xm = x;
      xp(j) += step / scale(j);
      xm(j) -= step / scale(j);
      J.col(j) = (residuals(xp) - residuals(xm)) / (2.0 * step / scale(j));
    }
    Eigen::MatrixXd A = J.transpose() * J;
    Eigen::VectorXd g = J.transpose() * r;
    for (int j = 0; j < n; ++j) {
      A(j, j) += pull * scale(j) * scale(j);
      g(j) += pull * scale(j) * scale(j) * x(j);
    }
    const Eigen::VectorXd dx = -A.ldlt().solve(g);
    if (!dx.allFinite()) break;
    const Eigen::VectorXd next_r = residuals(x + dx);
    if (next_r.squaredNorm() > r.squaredNorm() && iteration > 0) break;
    x += dx;
    r = next_r;
    if (dx.cwiseProduct(scale).norm() < 1e-15 * length) break;
  }
  result = posed(start, x, free, motion);
  return r.size() ? r.cwiseAbs().maxCoeff() : 0.0;
}

}  // namespace idealize
