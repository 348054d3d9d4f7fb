// Clay-like sculpting brushes (thesis ch. 5, the free-form modification of the hybrid modeller;
// the brushes of Sculptris and Blender's sculpt mode): draw, inflate, flatten, smooth, pinch,
// crease and grab, applied in dabs along a stroke, each dab followed by dynamic topology
// (dynamic_topology.h) so that the triangles stay well shaped.
//
// A dab at point c moves the vertices within `radius` of c that the surface joins to it (reached
// from the vertex nearest c along edges, so that the far side of a thin wall stays), and facing
// the viewer, by a smooth falloff w = (1 - (d / radius)^2)^3 of their distance d (C2 at the rim).
// Per dab, with s the strength and D the dab spacing:
//   draw:    along the region's area-weighted normal, by s w D (a negative s digs);
//   inflate: along each vertex's own normal, by s w D;
//   flatten: towards the area's plane (across the mean normal, through the mean of the vertices
//            weighted towards the rim: the surface around what is flattened), by a share
//            s w D / radius of the distance (at most all of it);
//   smooth:  towards the centroid of its neighbours, by a share s w (at most all of it);
//   pinch:   towards c in the tangent plane, by a share s w D / radius;
//   crease:  pinch, and dig along the area normal by s w D;
//   grab:    the vertices under the first point follow the stroke: by w s times the way from its
//            first point to its last.
// Scaling by D makes a stroke's effect independent of how densely it is sampled.
#pragma once

#include "sculpt/sculpt_mesh.h"

#include <string>
#include <vector>

namespace idealize {

enum class Brush { Draw, Inflate, Flatten, Smooth, Pinch, Crease, Grab };

// The brush named `name` (draw, inflate, flatten, smooth, pinch, crease, grab); throws
// std::invalid_argument naming the brushes otherwise.
Brush brush_named(const std::string& name);

struct StrokeOptions {
  double radius = 0.0;    // the brush's radius (> 0)
  double strength = 0.5;  // see above; Sculptris's and Blender's default is one half
  // Dab spacing as a share of the radius: Blender's default stroke spacing is 10 % of the brush's
  // diameter, 1/5 of its radius.
  double spacing = 0.2;
  // The edge length dynamic topology keeps; 0: the median length of the edges under the first dab
  // before the stroke (the region's own resolution). Never finer than 1/32 of the radius (a dab's
  // disc then holds at most about 7,400 triangles; see brushes.cpp).
  double target_edge_length = 0.0;
  bool dynamic_topology = true;
};

struct StrokeReport {
  int dabs = 0;
  int moved_vertices = 0;      // counted once per dab that moved them
  double target_edge_length = 0.0;
};

// A stroke under way, dab by dab as its points come (a drag in the 3D view): the first dab at the
// first point, then one every options.spacing * radius along the polyline of the points given
// since. The dabs, and so the mesh, are the same however the points are handed in: all at once
// (sculpt_stroke) or one by one as the pointer moves. Faces changed are marked in the mesh
// (SculptMesh::modified). The mesh must not change otherwise while the stroke is under way.
class Stroke {
 public:
  // Starts at `point`, seen along `view` (into the scene; vertices facing away are left alone;
  // zero: from every side), with the first dab. Throws std::invalid_argument for a radius or a
  // spacing that is not positive.
  Stroke(SculptMesh& mesh, Brush brush, const Eigen::Vector3d& point, const Eigen::Vector3d& view,
         const StrokeOptions& options);
  // Continues to `point`: the dabs on the way (a grab moves what it holds by the way).
  void extend(const Eigen::Vector3d& point, const Eigen::Vector3d& view);
  // Ends the stroke: a grab's mesh catches up (remeshed around what it moved). Returns the report.
  StrokeReport finish();

 private:
  void dab(const Eigen::Vector3d& centre, const Eigen::Vector3d& view);
  void remesh(const std::vector<int>& vertices, int rounds);

  SculptMesh& mesh_;
  Brush brush_;
  StrokeOptions options_;
  double step_;
  Eigen::Vector3d point_, view_;  // where the stroke is
  double carried_ = 0.0;          // the distance since the last dab
  std::vector<int> stamp_;        // per vertex slot: scratch of the regions' gathering
  int mark_ = 0;
  std::vector<char> active_;      // per vertex slot: what dynamic topology works on
  std::vector<int> held_;         // a grab's vertices, with their weights
  std::vector<double> held_weights_;
  StrokeReport report_;
  bool finished_ = false;
};

// Applies `brush` along a stroke: `points` (#S x 3) on or near the surface, `directions` (#S x 3,
// or 0 rows) the view direction at each (see Stroke). Throws std::invalid_argument for a radius
// that is not positive or mismatched arrays.
StrokeReport sculpt_stroke(SculptMesh& mesh, Brush brush, const MatrixX3d& points, const MatrixX3d& directions,
                           const StrokeOptions& options);

}  // namespace idealize
