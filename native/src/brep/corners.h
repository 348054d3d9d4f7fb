// Corner vertices of the B-rep: the point nearest to all the surfaces that meet at a corner of the
// mesh's regions (thesis 4.3: vertices where three or more features meet).
#pragma once

#include "fit/surface.h"
#include "brep/curves.h"

#include <array>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

namespace idealize {

// The point closest (least squares) to all `surfaces`, starting from `x0` (damped Gauss-Newton:
// the damping keeps the point near the mesh where tangent surfaces leave a direction free); `tol`
// sets when a step is small enough to stop.
Vec3 corner_point(const std::vector<LocalSurface>& surfaces, const Vec3& x0, double tol);

// Where a line meets a surface near the parameter range [low, high], given the surface's signed
// `distance` at a parameter: its crossings, or, where it crosses nowhere there but passes within
// `tol`, the point where it touches (comes nearest).
std::vector<double> line_meets(const std::function<double(double)>& distance, double low, double high, double tol);

// The corners at both ends of a straight chain between planes `a` and `b`, each where their line
// meets the `third` surface at that end: the points nearest to the mesh's corners that keep the
// chain's order with no crossing of either surface between them. Null where no such pair is found,
// or where the planes are parallel to within `nearly_parallel` (a sine).
std::optional<std::pair<Vec3, Vec3>> line_chain_ends(const Surface& a, const Surface& b,
                                                     const std::array<const Surface*, 2>& third,
                                                     const std::array<Vec3, 2>& mesh_corners,
                                                     const std::array<Vec3, 2>& fitted, double tol,
                                                     double nearly_parallel);

// What fixes a corner: the surfaces that meet there, a cylinder tangent to a sphere of its radius
// replaced by the plane through the sphere's centre normal to its axis.
std::vector<Surface> corner_constraints(const std::vector<const Surface*>& surfaces, double tol);

}  // namespace idealize
