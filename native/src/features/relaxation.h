// Variational relabelling of the patches of a noisy mesh.
//
// D. Cohen-Steiner, P. Alliez and M. Desbrun, "Variational shape approximation", SIGGRAPH 2004:
// every patch floods again from the face its surface fits best, and faces go, cheapest first, to
// the surface that reaches them. Greedy region growing leaves the border between two surfaces
// where the first one to grow stopped (half of a narrow fillet on the plane beside it); flooding by
// cost moves it to where the surfaces fit equally well.
#pragma once

#include "core/mesh.h"
#include "core/progress.h"
#include "fit/surface.h"

#include <vector>

namespace idealize {

struct FloodSurface {
  const Surface* surface = nullptr;  // nullptr: the patch keeps its faces and does not grow
  double distance_unit = 1.0;        // the spread of its points' distances
  double angle_unit = 0.1;           // the spread of their normals' angles (radians)
};

// Relabels the faces near the borders of the patches that have a surface: labels (#F) holds a
// patch id per face (-1: none), surfaces (#patches) the surface of each patch with its spreads.
// Faces more than `band` edge steps from another label keep theirs and flood from there; a patch
// without such faces floods from its face of least cost whose neighbours all lie in it. A face
// costs a surface its negative log-likelihood under the surface's spreads (the mean squared
// distance of its vertices and its normal's squared angle, each in units of the spread, halved,
// plus the logarithms of the spreads), so that a loosely fitted surface does not take what a tight
// one explains. Faces that no surface reaches keep their label. Returns which patches (#patches)
// lost or gained faces. `progress` is polled for cancellation only.
std::vector<char> flood_labels(const TriangleMesh& mesh, const MeshTopology& topology,
                               const std::vector<FloodSurface>& surfaces, int band, std::vector<int>& labels,
                               const ProgressSpan& progress = ProgressSpan());

// Hands out the faces of the patches whose vertices the surfaces of the patches around them already
// explain (within noise, in units of each surface's distance spread) to those surfaces, cheapest
// first as flood_labels does: the strips that the chamfered sharp edges of a re-tessellated scan
// leave between two faces, which a cylinder of about their width fits as well as the two faces do.
// Smaller patches go first. Returns which patches (#patches) lost or gained faces; a dissolved patch
// keeps the faces that no surface reaches. `progress` is polled for cancellation only.
std::vector<char> dissolve_explained_patches(const TriangleMesh& mesh, const MeshTopology& topology,
                                             const std::vector<FloodSurface>& surfaces, std::vector<int>& labels,
                                             const ProgressSpan& progress = ProgressSpan());

}  // namespace idealize
