// Identification of a patch's surface: the simplest type that fits about as well as the best one,
// how well a surface explains a face or every point, and the points that fix a fit.
#pragma once

#include "features/feature_layer.h"
#include "features/patch_points.h"

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace idealize {

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


// The thesis's identification (after Besl & Jain) from the signs of H and K.
SurfaceType curvature_type(const PatchCurvature& c, const EffectiveZero& zero_h);

// The simplest surface type that fits the points about as well as the best one; with `curved_only`
// planes are not candidates.
Feature identify(const PatchPoints& pp, const PatchCurvature& curvature, const EffectiveZero& zero_h,
                 const FeatureOptions& options, double tolerance, bool curved_only = false);

// How well `surface` explains face f: the largest of its vertices' distances in units of
// `distance_unit` and of its normal's angle from the surface's at its centroid in units of
// `angle_unit` (radians). At most 1 when the surface explains the face.
double face_misfit(const TriangleMesh& mesh, int f, const Surface& surface, double distance_unit, double angle_unit);

// face_misfit of a feature's surface in units of three times the fit's robust spread (3 σ) plus a
// floor; infinite for a freeform feature.
double misfit(const TriangleMesh& mesh, int f, const Feature& feature, double floor, double normal_floor);

// Whether `surface` explains every point of `data` to within `distance` and every facet normal (the
// samples are facets: centroid, normal, area) to within `angle` (radians) plus what the facet's
// chord allows: a facet whose corners lie on a surface of curvature k sags by about k w² / 2 at its
// centroid and turns by about k w across its width w, so by at most 4 sag / w from the surface
// normal there (up to `largest_chord_turn`). On an exact tessellation a merge must not hide one stray
// facet in an RMS over many.
bool explains_every_point(const Surface& surface, const PatchPoints& data, double distance, double angle,
                          double largest_chord_turn);

// Distinct points of `data` (pieces share their rim vertices).
int distinct_points(const PatchPoints& data);

// The number of parallels of a surface of revolution (heights along its axis more than `distance`
// apart) on which the points lie: a tessellation's vertices on k parallels only fix a meridian
// through k points, which a circle does for any three.
int distinct_parallels(const PatchPoints& data, const Surface& surface, double distance);

// A lemon (the inner part of a spindle torus) fitted to `data`, if its points fix one: on more than
// three parallels (see above; or it starts from `start`, a lemon fixed before), and with its centre
// circle off its axis by more than `tolerance` (else it is a sphere).
std::optional<SurfaceFit> fit_lemon(const PatchPoints& data, const FitOptions& options, double tolerance,
                                    double distance, const Surface* start = nullptr);

}  // namespace idealize
