#include "brep/topology.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace idealize {

namespace {

// Half-edge h = 3 f + c is the edge opposite corner c of face f, directed from F(f, c+1) to
// F(f, c+2): counter-clockwise around f seen from outside.
int from_vertex(const TriangleMesh& mesh, int h) { return mesh.F(h / 3, (h % 3 + 1) % 3); }
int to_vertex(const TriangleMesh& mesh, int h) { return mesh.F(h / 3, (h % 3 + 2) % 3); }

// The opposite half-edge of every half-edge (-1 on open and non-manifold edges); throws where two
// neighbouring faces disagree on the orientation.
std::vector<int> twin_halfedges(const TriangleMesh& mesh, const MeshTopology& topology) {
  std::vector<int> twin(3 * mesh.num_faces(), -1);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int g = topology.face_neighbor(f, c);
      if (g < 0) continue;
      const int h = 3 * f + c, a = from_vertex(mesh, h), b = to_vertex(mesh, h);
      for (int k = 0; k < 3; ++k) {
        const int t = 3 * g + k;
        if (from_vertex(mesh, t) == b && to_vertex(mesh, t) == a) twin[h] = t;
      }
      if (twin[h] < 0) {
        throw MeshError("the mesh is not consistently oriented: triangles " + std::to_string(f) + " and " +
                        std::to_string(g) + " list their common edge in the same direction");
      }
    }
  }
  return twin;
}

double surface_gap(const Surface& surface, const Eigen::Vector3d& p) {
  if (surface.type == SurfaceType::Freeform) return std::numeric_limits<double>::max();
  return std::abs(signed_distance(surface, p));
}

}  // namespace

std::vector<int> complete_face_features(const TriangleMesh& mesh, const MeshTopology& topology,
                                        const std::vector<int>& labels,
                                        const std::vector<Surface>& surfaces, double tolerance,
                                        double island_fraction, int unexplained) {
  const int nf = mesh.num_faces();
  std::vector<int> feature(labels);
  // Grow the labelled faces into the unlabelled ones, one ring per round.
  std::vector<int> next;
  for (bool changed = true; changed;) {
    changed = false;
    next = feature;
    for (int f = 0; f < nf; ++f) {
      if (feature[f] >= 0) continue;
      const Eigen::Vector3d centre = face_centroid(mesh, f);
      double best = std::numeric_limits<double>::infinity();
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || feature[g] < 0) continue;
        const double gap = surface_gap(surfaces[feature[g]], centre);
        if (gap < best || (gap == best && feature[g] < next[f])) {
          best = gap;
          next[f] = feature[g];
        }
      }
      changed |= next[f] >= 0;
    }
    feature.swap(next);
  }
  if (std::any_of(feature.begin(), feature.end(), [](int l) { return l < 0; })) {
    if (unexplained < 0) throw MeshError("a part of the mesh has no feature at all: it cannot become a B-rep face");
    for (int& l : feature)
      if (l < 0) l = unexplained;
  }

  // Small detached pieces of a feature join the neighbour they share most boundary with.
  std::vector<int> component;
  const int count = face_components(topology, feature, component);
  const Eigen::VectorXd areas = face_areas(mesh);
  std::vector<double> component_area(count, 0.0);
  std::vector<std::vector<int>> component_faces(count);
  for (int f = 0; f < nf; ++f) {
    component_area[component[f]] += areas[f];
    component_faces[component[f]].push_back(f);
  }
  std::vector<double> largest(std::max<size_t>(surfaces.size(), unexplained + 1), 0.0);
  for (int k = 0; k < count; ++k) {
    const int l = feature[component_faces[k][0]];
    largest[l] = std::max(largest[l], component_area[k]);
  }
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return component_area[a] < component_area[b]; });
  for (int k : order) {
    const int l = feature[component_faces[k][0]];
    if (component_area[k] >= island_fraction * largest[l]) continue;
    std::vector<std::pair<int, int>> shared;  // (feature, edges)
    for (int f : component_faces[k]) {
      for (int c = 0; c < 3; ++c) {
        const int g = topology.face_neighbor(f, c);
        if (g < 0 || component[g] == k || feature[g] == l) continue;
        auto it = std::find_if(shared.begin(), shared.end(), [&](const auto& s) { return s.first == feature[g]; });
        if (it == shared.end()) shared.emplace_back(feature[g], 1);
        else ++it->second;
      }
    }
    // A piece that lies on its own surface within the tolerance, and on a neighbour's beyond it, is
    // a face that a hole or a notch cut off (one side of a plane, on a coarse CAD tessellation; it
    // lies as far from the perpendicular face beside it as it is wide): only a neighbour whose
    // surface passes its vertices within twice the tolerance (one on either side of the border
    // between them) takes it. (On a scan the noise puts a rim off both surfaces; there the
    // neighbour it shares most border with takes it, whichever.)
    const auto gap_to = [&](int of) {
      double gap = 0.0;
      for (int f : component_faces[k])
        for (int c = 0; c < 3; ++c)
          gap = std::max(gap, surface_gap(surfaces[of], mesh.V.row(mesh.F(f, c)).transpose()));
      return gap;
    };
    if (gap_to(l) <= tolerance)
      shared.erase(std::remove_if(shared.begin(), shared.end(),
                                  [&](const auto& s) { return !(gap_to(s.first) <= 2.0 * tolerance); }),
                   shared.end());
    if (shared.empty()) continue;
    const auto best = std::max_element(shared.begin(), shared.end(), [](const auto& a, const auto& b) {
      return a.second < b.second || (a.second == b.second && a.first > b.first);
    });
    for (int f : component_faces[k]) feature[f] = best->first;
  }
  return feature;
}

BoundaryTopology trace_boundaries(const TriangleMesh& mesh, const MeshTopology& topology,
                                  const std::vector<int>& face_feature) {
  BoundaryTopology result;
  const int nf = mesh.num_faces();
  const int regions = face_components(topology, face_feature, result.face_region);
  result.region_feature.assign(regions, -1);
  for (int f = 0; f < nf; ++f) result.region_feature[result.face_region[f]] = face_feature[f];
  result.region_loops.resize(regions);

  const std::vector<int> twin = twin_halfedges(mesh, topology);
  const auto region_across = [&](int h) { return twin[h] < 0 ? -1 : result.face_region[twin[h] / 3]; };
  const auto is_boundary = [&](int h) { return region_across(h) != result.face_region[h / 3]; };
  // The boundary half-edge that follows h on its region's loop: turn around h's end vertex
  // through the faces of the same region.
  const auto next_boundary = [&](int h) {
    const int region = result.face_region[h / 3];
    int candidate = 3 * (h / 3) + (h % 3 + 1) % 3;
    for (int guard = 0; guard <= nf; ++guard) {
      if (twin[candidate] < 0 || result.face_region[twin[candidate] / 3] != region) return candidate;
      const int t = twin[candidate];
      candidate = 3 * (t / 3) + (t % 3 + 1) % 3;
    }
    throw MeshError("the mesh's faces around a vertex do not form a fan");
  };

  // Corners: vertices with other than two boundary half-edges leaving them, or where a loop's
  // neighbouring region changes.
  std::vector<int> leaving(mesh.num_vertices(), 0);
  std::vector<char> corner(mesh.num_vertices(), 0);
  for (int h = 0; h < 3 * nf; ++h) {
    if (!is_boundary(h)) continue;
    ++leaving[from_vertex(mesh, h)];
    if (region_across(h) != region_across(next_boundary(h))) corner[to_vertex(mesh, h)] = 1;
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (leaving[v] != 0 && leaving[v] != 2) corner[v] = 1;
  }

  std::vector<char> visited(3 * nf, 0);
  std::vector<int> chain_of(3 * nf, -1);
  std::vector<int> loop;
  for (int f = 0; f < nf; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int start = 3 * f + c;
      if (visited[start] || !is_boundary(start)) continue;
      loop.clear();
      for (int h = start; !visited[h]; h = next_boundary(h)) {
        visited[h] = 1;
        loop.push_back(h);
      }
      const int n = static_cast<int>(loop.size());
      // Start at a corner, or at the smallest vertex of a loop without corners (the same vertex
      // for the region on either side).
      int first = -1;
      for (int i = 0; i < n && first < 0; ++i) {
        if (corner[from_vertex(mesh, loop[i])]) first = i;
      }
      const bool closed = first < 0;
      if (closed) {
        first = 0;
        for (int i = 1; i < n; ++i) {
          if (from_vertex(mesh, loop[i]) < from_vertex(mesh, loop[first])) first = i;
        }
      }
      std::rotate(loop.begin(), loop.begin() + first, loop.end());
      const int region = result.face_region[f];
      std::vector<ChainUse> uses;
      for (int i = 0; i < n;) {
        int j = i + 1;
        while (j < n && !corner[from_vertex(mesh, loop[j])]) ++j;
        const int h = loop[i];
        if (twin[h] >= 0 && chain_of[twin[h]] >= 0) {
          uses.push_back({chain_of[twin[h]], false});
        } else {
          BoundaryChain chain;
          chain.left = region;
          chain.right = region_across(h);
          chain.closed = closed;
          for (int k = i; k < j; ++k) chain.vertices.push_back(from_vertex(mesh, loop[k]));
          chain.vertices.push_back(to_vertex(mesh, loop[j - 1]));
          const int id = static_cast<int>(result.chains.size());
          for (int k = i; k < j; ++k) chain_of[loop[k]] = id;
          result.chains.push_back(std::move(chain));
          uses.push_back({id, true});
        }
        i = j;
      }
      result.region_loops[region].push_back(std::move(uses));
    }
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (corner[v] && leaving[v] > 0) result.corners.push_back(v);
  }
  return result;
}

}  // namespace idealize
