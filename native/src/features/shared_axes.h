// Semi-defined features (J. S.-S. Chen, "Hybrid CAD modeler", thesis 4.3): a feature whose own
// points cannot fix its axis takes the axis of a feature that can. A narrow piece of a cone (the
// chamfer of a hexagon nut, cut into six by the flats) fits a plane or a tilted cylinder about as
// well as its cone; about the bore's axis, only the cone fits.
#pragma once

#include "features/feature_layer.h"
#include "fit/surface_fitting.h"

#include <utility>
#include <vector>

namespace idealize {

struct SharedAxisOptions {
  // A cylinder, cone or torus fitted to at least this many points, whose normals turn by about a
  // right angle or more, has an axis others may share (a sliver's axis is a guess).
  int determined_points = 96;
  // Axes within this angle (radians) and distance are one axis; a cone closer than the angle to a
  // cylinder or a plane is one of those, and a surface that turns by less across a patch is flat.
  double angle_tolerance = 5.0 * 3.14159265358979323846 / 180.0;
  double distance_tolerance = 0.0;
  // As in identification (FeatureOptions): a surface fits as well as another when its spread is at
  // most residual_ratio times the other's plus the distance tolerance, and its normal spread at
  // most residual_ratio times the other's plus normal_floor (radians).
  double residual_ratio = 1.5;
  double normal_floor = 2.0 * 3.14159265358979323846 / 180.0;
  // Refit only the features whose axes are determined (a pass after the others were settled).
  bool only_determined = false;
};

// Refits the planes, spheres, cylinders and cones of `features` (`points`: what the fits see of
// each, by feature id) about the determined axes of the part's other features. A cylinder or cone
// whose own axis is none of them, or a sphere (a narrow band of a cone fits one as well), takes the
// coaxial cylinder or cone that fits as well as its own surface (the one of least spread). A plane takes one only where its points fit it better than the plane
// (and its normals as well) and it turns across the patch by more than the angle tolerance. A
// cylinder or cone whose own axis is determined but on no other feature's takes the other axis of
// the same type where the BIC does not need the four parameters of an axis of its own.
// Returns the number of features that changed.
int fit_about_shared_axes(const std::vector<FitData>& points, const SharedAxisOptions& options,
                          std::vector<Feature>& features);

// Fillets between planes that a plane fits: across a strip of a fillet that turns by a few tens of
// degrees a radius of forty times the noise sags by about twice the noise, within what identification
// allows a plane, and the planes beside it take its flanks. The cylinder tangent to two adjacent
// planes has one free parameter, its radius (its axis runs along their line of intersection, the
// radius from each); a plane between them (its normal between theirs) whose points that cylinder
// fits better than the plane becomes it, with the radius of the cylinder fitted freely to its points
// (the planes still hold its flanks, which pull the tangent one's radius short by a few percent).
// A chamfer's points fit no such cylinder better than their plane. A cylinder along two adjacent
// planes takes the cylinder against both of the radius fitted to the whole arc (its points and the
// planes' flanks), where that fits the arc better than its own and its points about as well
// (spread within residual_ratio times): reassignment gives a fillet's flanks to the planes beside
// it, and a fit to the narrower arc left drifts from the fillet's radius by a tenth. `adjacent`:
// pairs of features sharing a border. Returns the number of features changed.
int fillets_between_planes(const std::vector<FitData>& points, const std::vector<std::pair<int, int>>& adjacent,
                           const SharedAxisOptions& options, std::vector<Feature>& features);

// Fillets at the foot of a boss, the rim of a bore or between a cone and the face across it: a
// torus beside a plane across its axis and a coaxial wall (cylinder or cone), both tangent to it, has
// one free parameter, its tube radius (the centre lies that far from the plane, the tube's circle
// that far from the wall). A narrow fillet's own fit of seven parameters takes its tube radius and
// place from a few degrees of arc, and a quarter of a noisy tube tilts its axis by degrees. Every
// plane and wall beside the feature, the plane across the wall's axis, are tried (on the sides of
// them its points lie); the tangent torus of least RMS
// distance replaces its own fit where it fits about as well (spread within residual_ratio times,
// without the distance tolerance, which on a sculpted part would let in a torus that the undulation
// of its neighbours puts off its patch; normal spread as identification requires). A cylinder or
// cone (what such a blend passes for) becomes that torus where it fits at least as well, unless it
// is a spindle torus. `adjacent`: pairs of features sharing a border. Returns the number of features
// changed.
int tori_between_planes_and_walls(const std::vector<FitData>& points, const std::vector<std::pair<int, int>>& adjacent,
                                  const SharedAxisOptions& options, std::vector<Feature>& features);

// Pieces of a curved surface that fit a plane: a chamfer cone cut into six narrow pieces by a
// hexagon's flats has pieces whose interior vertices a plane fits as well as the cone. Over all
// the vertices of its faces, rim included, a plane that another feature's surface (as fitted, no
// parameter free) fits better than the best plane, with normals that fit about as well, and that
// turns across the patch by more than the angle tolerance, takes that surface. `points`: every
// vertex of each feature's faces. Returns the number of features changed.
int planes_on_curved_surfaces(const std::vector<FitData>& points, const SharedAxisOptions& options,
                              std::vector<Feature>& features);

}  // namespace idealize
