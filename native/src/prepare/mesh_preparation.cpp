#include "prepare/mesh_preparation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>

namespace idealize {

namespace {

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

// Refuses coordinates at scales no unit of a mechanical part produces (see mesh_preparation.h);
// returns the bounding-box diagonal of the vertices the triangles use.
double check_scale(const TriangleMesh& input) {
  Eigen::RowVector3d low = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::RowVector3d high = -low;
  for (int f = 0; f < input.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto p = input.V.row(input.F(f, c));
      low = low.cwiseMin(p);
      high = high.cwiseMax(p);
    }
  const double largest = std::max(low.cwiseAbs().maxCoeff(), high.cwiseAbs().maxCoeff());
  const double diagonal = (high - low).norm();
  if (!std::isfinite(diagonal) || largest > kMaxCoordinate)
    throw MeshError("coordinates reach " + number(largest) + ", beyond " + number(kMaxCoordinate) +
                    ": no unit of a real part gives such numbers, and their products overflow double "
                    "precision; the file is probably corrupt or was written with a wrong scale factor");
  if (!(diagonal >= kMinDiagonal))
    throw MeshError("the mesh is only " + number(diagonal) + " units across (bounding-box diagonal; below " +
                    number(kMinDiagonal) + "): its triangles have collapsed to a point, probably a wrong "
                    "scale factor (a unit conversion applied twice?); rescale the mesh");
  if (largest > kMaxOffsetRatio * diagonal)
    throw MeshError("the part is " + number(diagonal) + " units across but lies " + number(largest) +
                    " units from the origin (" + number(largest / diagonal) + " times its size, above " +
                    number(kMaxOffsetRatio) + "): at that offset the coordinates cannot resolve its "
                    "triangles; the coordinates probably carry a large offset (georeferenced, or a "
                    "unit mix-up between part and placement); move the part near the origin");
  return diagonal;
}

// Position of the point along a Z-order (Morton) curve through the box: 16 bits of each
// coordinate, interleaved. Points close in space are mostly close along the curve.
uint64_t morton_key(const Eigen::RowVector3d& p, const Eigen::RowVector3d& low, double scale) {
  uint64_t key = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double cell = std::clamp((p[axis] - low[axis]) * scale, 0.0, 65535.0);
    const uint64_t bits = static_cast<uint64_t>(cell);
    for (int b = 0; b < 16; ++b) key |= ((bits >> b) & 1u) << (3 * b + axis);
  }
  return key;
}

// The kept faces in Z-order of their centroids (ties in input order): the analysis visits every
// face's neighbours, and on a large mesh in the order a remesher left them those are scattered in
// memory (a million-triangle scan segments 1.6 times faster in this order).
void in_spatial_order(const TriangleMesh& input, std::vector<int>& kept) {
  std::vector<Eigen::RowVector3d> centroid(kept.size());
  Eigen::RowVector3d low = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::RowVector3d high = -low;
  for (size_t i = 0; i < kept.size(); ++i) {
    const int f = kept[i];
    centroid[i] = (input.V.row(input.F(f, 0)) + input.V.row(input.F(f, 1)) + input.V.row(input.F(f, 2))) / 3.0;
    low = low.cwiseMin(centroid[i]);
    high = high.cwiseMax(centroid[i]);
  }
  const double extent = (high - low).maxCoeff();
  const double scale = extent > 0.0 ? 65535.0 / extent : 0.0;
  std::vector<std::pair<uint64_t, int>> keyed(kept.size());
  for (size_t i = 0; i < kept.size(); ++i) keyed[i] = {morton_key(centroid[i], low, scale), static_cast<int>(i)};
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> ordered(kept.size());
  for (size_t i = 0; i < keyed.size(); ++i) ordered[i] = kept[keyed[i].second];
  kept.swap(ordered);
}

}  // namespace

PreparedMesh prepare_mesh(const TriangleMesh& input, const ProgressSpan& progress) {
  const int nv = input.num_vertices();
  const int nf = input.num_faces();
  if (nf == 0) throw MeshError("the mesh has no triangles");
  if (!input.V.allFinite()) throw MeshError("vertex coordinates contain NaN or infinity");
  for (int f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c)
      if (input.F(f, c) < 0 || input.F(f, c) >= nv)
        throw MeshError("triangle " + std::to_string(f) + " refers to vertex " +
                        std::to_string(input.F(f, c)) + ", but the mesh has " + std::to_string(nv) +
                        " vertices");

  // Measured on the vertices the triangles use: a stray unused vertex far away must not make
  // every triangle look degenerate.
  const double diagonal = check_scale(input);

  PreparedMesh out;
  // A triangle is degenerate when its area vanishes at the precision of the coordinates.
  const double zero_area = 1e-14 * diagonal * diagonal;
  // Sorted vertex triples, bucketed by their smallest vertex: a face repeats the first face of its
  // bucket with the same triple (linear apart from small per-bucket sorts, and in input order).
  std::vector<std::array<int, 3>> triple(nf);
  std::vector<int> smallest(nf, -1);  // a degenerate face has none: it joins no bucket
  for (int f = 0; f < nf; ++f) {
    progress.tick(f, nf);
    const int a = input.F(f, 0), b = input.F(f, 1), c = input.F(f, 2);
    const Eigen::Vector3d pa = input.V.row(a), pb = input.V.row(b), pc = input.V.row(c);
    if (a == b || b == c || a == c || 0.5 * (pb - pa).cross(pc - pa).norm() <= zero_area) {
      ++out.removed_degenerate;
      continue;
    }
    triple[f] = {a, b, c};
    std::sort(triple[f].begin(), triple[f].end());
    smallest[f] = triple[f][0];
  }
  std::vector<int> bucket_offsets, bucketed;
  group_by_key(smallest.data(), smallest.size(), nv, bucket_offsets, bucketed);
  std::vector<int> first(nf, -1);  // input face -> the input face it repeats (itself if kept)
  for (int f : bucketed) first[f] = f;
  for (int v = 0; v < nv; ++v) {
    progress.poll(v);
    const auto begin = bucketed.begin() + bucket_offsets[v], end = bucketed.begin() + bucket_offsets[v + 1];
    if (end - begin < 2) continue;
    std::sort(begin, end, [&](int f, int g) { return std::tie(triple[f], f) < std::tie(triple[g], g); });
    for (auto it = begin + 1; it != end; ++it)
      if (triple[*it] == triple[*(it - 1)]) first[*it] = first[*(it - 1)];
  }
  std::vector<int> kept;
  kept.reserve(nf);
  for (int f = 0; f < nf; ++f) {
    if (first[f] == f) kept.push_back(f);
    else if (first[f] >= 0) ++out.removed_duplicate;
  }
  if (kept.empty()) throw MeshError("every triangle of the mesh is degenerate (zero area)");
  in_spatial_order(input, kept);
  std::vector<int> working_face(nf, -1);
  for (size_t i = 0; i < kept.size(); ++i) working_face[kept[i]] = static_cast<int>(i);
  out.input_face.assign(nf, -1);
  for (int f = 0; f < nf; ++f)
    if (first[f] >= 0) out.input_face[f] = working_face[first[f]];

  std::vector<int> new_index(nv, -1);
  int used = 0;
  for (int f : kept)
    for (int c = 0; c < 3; ++c)
      if (new_index[input.F(f, c)] < 0) new_index[input.F(f, c)] = used++;
  out.removed_unused_vertices = nv - used;

  out.mesh.V.resize(used, 3);
  for (int v = 0; v < nv; ++v)
    if (new_index[v] >= 0) out.mesh.V.row(new_index[v]) = input.V.row(v);
  out.mesh.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t i = 0; i < kept.size(); ++i)
    for (int c = 0; c < 3; ++c) out.mesh.F(i, c) = new_index[input.F(kept[i], c)];
  out.face_origin = std::move(kept);
  progress.step(1.0);
  return out;
}

}  // namespace idealize
