// Features whose profile through their axis is that of two or three surfaces, split apart again:
// a torus that also holds the cylinder or plane it runs into, or that bends over sharp corners; a
// cylinder or cone that steps to another radius or angle. The passes after round_edges; each split
// is kept only where the Bayesian information criterion over the independent residuals
// (independent_share) prefers it.
#pragma once

#include "features/edge_fillets.h"

#include <vector>

namespace idealize {

// A torus feature that also holds the cylinder or plane it runs into tangentially (segmentation
// smoothed their curvatures together over a narrow band; a free torus bends to fit both within the
// noise): through the axis, the profile of its vertices is a circle continued by its tangent line.
// That fit has as many parameters as the circle alone (the choice of the tangent point among four
// and of the side is counted as one more in the BIC, over the independent residuals); where it is
// preferred, the faces past the tangent point become the cylinder (line along the axis) or plane
// (across it), and the torus takes the continued fit's circle. Returns, per feature after the call,
// whether it changed.
std::vector<char> split_tangent_continuations(const TriangleMesh& mesh, const MeshTopology& topology,
                                              const EdgeFilletOptions& options, std::vector<Feature>& features,
                                              std::vector<int>& labels);

// A torus feature that holds cylinders and planes across its axis meeting at sharp corners (a
// cylinder and the plane at its end; a step: cylinder, annulus, cylinder), which a free torus bends
// to fit only roughly. Where the torus fits its profile worse than the mesh's features fit theirs,
// through the axis its vertices fit two or three lines along and across the axis in turn, each
// point on the nearest: the lines' positions and one more parameter per corner, against the
// circle's three, kept where the BIC over the independent residuals prefers them and each line
// runs longer than a rounded-off edge. The faces nearest each line become its cylinder or plane
// (the torus feature takes the first). Returns, per feature after the call, whether it changed.
std::vector<char> split_cornered_tori(const TriangleMesh& mesh, const MeshTopology& topology,
                                      const EdgeFilletOptions& options, std::vector<Feature>& features,
                                      std::vector<int>& labels);

// A cylinder or cone feature that holds coaxial surfaces of another radius or angle (a
// counterbore's two cylinders, a cone running into a cylinder: at a scan's resolution their
// curvatures differ little): through the axis, its vertices' profile (distance from the axis,
// height) is one line, or two that meet at a height. The two have three parameters more (a line and
// the height), kept where the BIC over the independent residuals prefers them to the one line and
// to a parabola (a smooth bend: undulation, a torus taken for a cylinder), both parts are longer
// than a rounded-off edge, and one is a cylinder, the other a cone or a cylinder of a clearly
// different radius. The faces above that
// height (or that only the upper line explains) become a feature of their own, and each part may
// step again. Returns, per feature after the call, whether it changed.
std::vector<char> split_coaxial_steps(const TriangleMesh& mesh, const MeshTopology& topology,
                                      const EdgeFilletOptions& options, std::vector<Feature>& features,
                                      std::vector<int>& labels);

}  // namespace idealize
