// libFuzzer target for feature-based editing: random edits of generated parts' feature layers.
//
// The parts are boxes of 60 x 40 x 30 with their edges rounded (r 5) along every edge (planes,
// cylinders and corner balls), along the vertical edges only, or not at all; each gridded
// isotropically (about 2.5 mm) or as a CAD export is (one long span across each flat face, so long
// thin triangles). A part's feature layer is made once per process.
//
// Input layout (missing bytes read as zero):
//   byte 0      the part (byte % 6)
//   then        edits, 6 bytes each, as long as bytes remain (at most 4), each on the result of the
//               one before when it was made:
//                 operation (byte % 5): push/pull, radius, move, delete, copy
//                 feature (byte % number of features)
//                 value (byte - 128) / 128: the distance as a share of 30 mm, the radius as
//                 1 + 0.75 * value times the old one
//                 a direction (3 bytes, (byte - 128) / 128 each) for a move or copy, 20 mm long
// A refusal (EditConflict) or an edit that does not apply (std::invalid_argument) ends the input.
// After every edit made, the mesh must be closed, consistently oriented and finite, and its labels
// name features of the result: anything else, a crash, or another exception is a finding.
#include "core/mesh.h"
#include "edit/copy_features.h"
#include "edit/delete_features.h"
#include "edit/edit.h"
#include "features/feature_layer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

using idealize::FeatureAdjacency;
using idealize::FeatureRelation;
using idealize::Surface;
using idealize::TriangleMesh;

struct Reader {
  const uint8_t* data;
  size_t size, pos = 0;
  uint8_t byte() { return pos < size ? data[pos++] : 0; }
  bool left() const { return pos < size; }
};

// The grid coordinates along one axis of half extent h with rounds of radius r at both ends (0: a
// sharp edge): about `step` apart over each round, and over the flat span between them either as
// well (isotropic) or in one piece (as a CAD export).
std::vector<double> axis_grid(double h, double r, double step, bool cad) {
  std::vector<double> at{-h};
  auto span = [&](double from, double to, int pieces) {
    for (int i = 1; i <= pieces; ++i) at.push_back(i == pieces ? to : from + (to - from) * i / pieces);
  };
  const int round = std::max(2, static_cast<int>(std::ceil(r * M_PI / 2.0 / step)));
  if (r > 0.0) span(-h, -(h - r), round);
  span(at.back(), h - r, cad ? 1 : std::max(1, static_cast<int>(std::ceil(2.0 * (h - r) / step))));
  if (r > 0.0) span(h - r, h, round);
  return at;
}

// A box of half extents `half`, its edges along the axes in `rounded` (x, y, z) rounded with radius
// r: each point of the gridded box surface is pushed from the box shrunk by r along those axes by
// r (a Minkowski sum with a ball, or with a disc across the vertical edges only). `labels` receives
// each triangle's face of the part: a plane, an edge's cylinder or a corner's ball.
TriangleMesh rounded_box(const Eigen::Vector3d& half, double r, const std::array<bool, 3>& rounded, bool cad,
                         std::vector<int>& labels) {
  std::map<std::array<int, 3>, int> face_of;  // per axis: the side of the box the face lies on, or 0
  std::array<std::vector<double>, 3> grid;
  for (int a = 0; a < 3; ++a) grid[a] = axis_grid(half[a], rounded[a] ? r : 0.0, 2.5, cad);
  std::map<std::array<double, 3>, int> index;  // the box's grid points are exact: shared edges weld
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 3>> faces;
  auto vertex = [&](const Eigen::Vector3d& p) {
    const auto [it, added] = index.emplace(std::array<double, 3>{p.x(), p.y(), p.z()}, static_cast<int>(points.size()));
    if (added) points.push_back(p);
    return it->second;
  };
  for (int a = 0; a < 3; ++a)
    for (int side : {-1, 1}) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;  // b x c = a: counter-clockwise seen from +a
      for (size_t i = 0; i + 1 < grid[b].size(); ++i)
        for (size_t j = 0; j + 1 < grid[c].size(); ++j) {
          std::array<int, 4> q;
          const size_t di[4] = {0, 1, 1, 0}, dj[4] = {0, 0, 1, 1};
          for (int k = 0; k < 4; ++k) {
            Eigen::Vector3d p;
            p[a] = side * half[a];
            p[b] = grid[b][i + di[k]];
            p[c] = grid[c][j + dj[k]];
            q[k] = vertex(p);
          }
          // Which face of the part: the box face's own side, and the sides of the rounds it lies on.
          std::array<int, 3> key{0, 0, 0};
          key[a] = side;
          for (int k : {b, c}) {
            const double centre = 0.5 * (grid[k][k == b ? i : j] + grid[k][(k == b ? i : j) + 1]);
            if (rounded[a] && rounded[k] && std::abs(centre) > half[k] - r) key[k] = centre > 0 ? 1 : -1;
          }
          const int label = face_of.emplace(key, static_cast<int>(face_of.size())).first->second;
          labels.push_back(label);
          labels.push_back(label);
          if (side > 0) {
            faces.push_back({q[0], q[1], q[2]});
            faces.push_back({q[0], q[2], q[3]});
          } else {
            faces.push_back({q[0], q[2], q[1]});
            faces.push_back({q[0], q[3], q[2]});
          }
        }
    }
  TriangleMesh mesh;
  mesh.V.resize(static_cast<int>(points.size()), 3);
  for (size_t v = 0; v < points.size(); ++v) {
    const Eigen::Vector3d& p = points[v];
    Eigen::Vector3d core = p;
    for (int a = 0; a < 3; ++a)
      if (rounded[a]) core[a] = std::clamp(p[a], -(half[a] - r), half[a] - r);
    const Eigen::Vector3d d = p - core;
    const Eigen::Vector3d q = d.norm() > 0.0 ? Eigen::Vector3d(core + r * d.normalized()) : p;
    mesh.V.row(static_cast<int>(v)) = q.transpose();
  }
  mesh.F.resize(static_cast<int>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) mesh.F(static_cast<int>(f), k) = faces[f][k];
  return mesh;
}

struct Layer {
  TriangleMesh mesh;
  std::vector<int> labels;
  std::vector<Surface> surfaces;
  std::vector<FeatureAdjacency> adjacency;
  std::vector<FeatureRelation> relations;
  double distance_tolerance = 0.0;
};

// The feature layer of part `k` (of 6), made once. Its faces are the patches identified (the
// segmentation's job on a user's mesh, whose cost under the sanitizers would leave no time to edit),
// with no curvature guess: every surface type is fitted to each.
const Layer& part(int k) {
  static std::array<std::unique_ptr<Layer>, 6> parts;
  if (!parts[k]) {
    const std::array<std::array<bool, 3>, 3> rounding{{{true, true, true}, {true, true, false}, {false, false, false}}};
    std::vector<int> faces;
    const TriangleMesh mesh = rounded_box({30.0, 20.0, 15.0}, 5.0, rounding[k % 3], k >= 3, faces);
    const int patches = *std::max_element(faces.begin(), faces.end()) + 1;
    const idealize::FeatureLayer layer = idealize::identify_features(
        mesh, faces, std::vector<idealize::PatchCurvature>(patches), idealize::EffectiveZero{0.0, 0.0}, {});
    auto out = std::make_unique<Layer>();
    out->mesh.V = layer.idealized_vertices;
    out->mesh.F = mesh.F;
    out->labels = layer.labels;
    for (const auto& f : layer.features) out->surfaces.push_back(f.surface);
    out->adjacency = layer.adjacency;
    out->relations = layer.relations;
    out->distance_tolerance = layer.distance_tolerance;
    parts[k] = std::move(out);
  }
  return *parts[k];
}

[[noreturn]] void finding(const char* what, long where) {
  std::fprintf(stderr, "%s (%ld)\n", what, where);
  std::abort();
}

// The mesh must be closed, consistently oriented and finite; its labels must name its surfaces.
void check(const TriangleMesh& mesh, const std::vector<int>& labels, size_t features) {
  if (!mesh.V.allFinite()) finding("a vertex is not finite", -1);
  if (labels.size() != static_cast<size_t>(mesh.num_faces())) finding("labels and faces differ in number", labels.size());
  for (int l : labels)
    if (l < -1 || l >= static_cast<int>(features)) finding("a label names no feature", l);
  std::set<std::pair<int, int>> directed;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = mesh.F(f, c), b = mesh.F(f, (c + 1) % 3);
      if (a < 0 || a >= mesh.num_vertices()) finding("a face names no vertex", f);
      if (a == b || !directed.insert({a, b}).second) finding("a repeated vertex or an edge used twice one way", f);
    }
  for (const auto& [a, b] : directed)
    if (!directed.count({b, a})) finding("an edge has one face: the mesh opened", a);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader in{data, size};
  Layer layer = part(in.byte() % 6);
  for (int step = 0; step < 4 && in.left(); ++step) {
    const int operation = in.byte() % 5;
    const int feature = in.byte() % static_cast<int>(layer.surfaces.size());
    const double value = (in.byte() - 128) / 128.0;
    Eigen::Vector3d direction;
    for (int c = 0; c < 3; ++c) direction[c] = (in.byte() - 128) / 128.0;
    if (direction.norm() > 0.0) direction = 20.0 * direction.normalized();
    idealize::EditOptions options;
    options.distance_tolerance = layer.distance_tolerance;
    try {
      if (operation <= 2) {
        idealize::FeatureEdit edit;
        edit.features = {feature};
        if (operation == 0) {
          edit.parameter = idealize::EditParameter::Offset;
          edit.value = 30.0 * value;
        } else if (operation == 1) {
          edit.parameter = idealize::EditParameter::Radius;
          edit.value = layer.surfaces[feature].radius * (1.0 + 0.75 * value);
        } else {
          edit.motion.translation() = direction;
        }
        idealize::EditResult r = idealize::edit_features(layer.mesh, layer.labels, layer.surfaces, layer.adjacency,
                                                         layer.relations, edit, options);
        check(r.mesh, r.labels, r.surfaces.size());
        layer.mesh = std::move(r.mesh);
        layer.labels = std::move(r.labels);
        layer.surfaces = std::move(r.surfaces);
      } else if (operation == 3) {
        const idealize::DeleteResult r =
            idealize::delete_features(layer.mesh, layer.labels, layer.surfaces, layer.adjacency, {feature}, options);
        check(r.mesh, r.labels, r.kept.size());
        return 0;  // the graph changed: the edits after a delete would need it rebuilt
      } else {
        idealize::Placement placement;
        placement.translation = direction;
        const idealize::CopyResult r = idealize::copy_features(layer.mesh, layer.labels, layer.surfaces,
                                                               layer.adjacency, {feature}, placement, options);
        check(r.mesh, r.labels, r.surfaces.size());
        return 0;  // as after a delete
      }
    } catch (const idealize::EditConflict&) {
      return 0;
    } catch (const std::invalid_argument&) {
      return 0;
    }
  }
  return 0;
}
