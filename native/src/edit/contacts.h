// Tangent contacts between features and the poses that restore them (thesis 6.1.1: "where
// features are not orthogonal, compute the dependent parameters directly").
//
// A tangent (G1) contact between two features is kept by a rolling-ball condition. Of the two, the
// one with the smaller rolling radius is the *roller* (a fillet's cylinder, a blend's torus tube, a
// corner's ball); its *spine* (the cylinder's axis, the torus's centre circle, the sphere's centre)
// stays at the roller's radius from the other surface, on the side it was. Each contact is sampled
// where the two features meet on the mesh, so that a bounded contact (a fillet's stretch of a wall)
// is what is kept, not the infinite surfaces'.
#pragma once

#include "core/mesh.h"
#include "fit/surface.h"

#include <Eigen/Geometry>

#include <vector>

namespace idealize {

// One tangent contact. The samples are the spine's points where the two features meet, in the
// roller's own frame: a cylinder's heights along its axis, a torus's unit radial directions
// (3 numbers each), nothing for a sphere (its spine is its centre).
struct Contact {
  int roller = -1, other = -1;
  std::vector<Eigen::Vector3d> samples;
  // Signed distance of each spine sample from the other surface, less the side times the roller's
  // radius, as the layer had it (0 on an exact layer): what the edit keeps.
  std::vector<double> offsets;
  std::vector<double> sides;  // +1 or -1: which side of the other surface the spine lies on
  // A ball whose centre lies on the other's spine (a corner's ball in a round of its own radius): it
  // touches along a circle, and what is kept is its centre on that spine and its radius the round's.
  // (The distance from the round, the usual condition, has a kink there that no solver converges on.)
  bool on_spine = false;
};

// The features around each vertex of `mesh` (its faces' labels; -1, a triangle set aside, is no
// feature), sorted.
std::vector<std::vector<int>> features_around(const TriangleMesh& mesh, const std::vector<int>& labels);

// The rolling radius of a surface: a cylinder's or sphere's radius, a torus's tube radius; infinite
// for planes and cones, which never roll.
double rolling_radius(const Surface& surface);

// The tangent contacts of the G1 pairs `pairs` (feature ids a, b) of a labelled mesh whose
// features lie on `surfaces`. A pair without a roller (two planes, plane and cone) or without a
// shared vertex gives no contact. At most `max_samples` spine samples per contact, spread along it.
std::vector<Contact> tangent_contacts(const TriangleMesh& mesh, const std::vector<int>& labels,
                                      const std::vector<Surface>& surfaces,
                                      const std::vector<std::array<int, 2>>& pairs, int max_samples = 8);

// Of two tangent surfaces a (feature ia) and b (feature ib), the feature that rolls on the other: the
// smaller rolling radius, of equal ones a sphere; -1 when neither rolls (two planes, plane and cone).
int roller_of(const Surface& a, int ia, const Surface& b, int ib);

// The point where the roller touches the other surface nearest to p: the foot on `other` of the
// roller's spine point nearest to p. It lies on both surfaces when they are tangent.
Eigen::Vector3d contact_point(const Surface& roller, const Surface& other, const Eigen::Vector3d& p);

// The residuals of `contact` (one per sample) with its roller on `roller` and its other feature on
// `other`: 0 where the contact holds as the layer had it.
void contact_residuals(const Contact& contact, const Surface& roller_before, const Surface& roller,
                       const Surface& other, std::vector<double>& out);

// A surface moved rigidly: its point by `motion`, its axis by the rotation.
Surface moved(const Surface& surface, const Eigen::Isometry3d& motion);

// What a pose solve may change of a surface besides its position: nothing, or also its rolling
// radius (a slot's end between two planes that moved apart).
enum class FreeShape { None, Radius };

// The pose of `surface` (a rigid motion; a torus also its major radius; with FreeShape::Radius its
// rolling radius) that best keeps `contacts`, in which it takes part as roller or other, the other
// features fixed at `surfaces`. Planes move only along their normal. Levenberg-Marquardt with a
// small pull towards the starting pose, so that directions the contacts do not fix stay put
// (`length`: the part's size, which scales rotations against translations). Returns the largest
// residual left; `result` receives the surface and `motion` the rigid part of the change.
double solve_pose(int feature, const std::vector<Surface>& surfaces, const std::vector<Surface>& before,
                  const std::vector<const Contact*>& contacts, FreeShape free, double length, Surface& result,
                  Eigen::Isometry3d& motion);

}  // namespace idealize
