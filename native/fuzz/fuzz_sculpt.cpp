// libFuzzer target for sculpting: brushes with dynamic topology on a closed mesh.
//
// Input layout (missing bytes read as zero):
//   byte 0      octahedron subdivisions (0 .. 3) of the start mesh, a closed genus-0 mesh of
//               8 * 4^k triangles on the unit sphere
//   then        per vertex: 1 byte of radial jitter (the radius times 1 + (byte - 128) / 512)
//   then        strokes, 12 bytes each, as long as bytes remain (at most 16):
//                 brush (byte % 7), radius (0.05 + byte / 255), strength ((byte - 128) / 128),
//                 two points (3 bytes each, coordinates (byte - 128) / 100), a view direction
//                 (2 bytes: spherical angles; or none when the first is 0)
// sculpt_stroke runs each stroke on a SculptMesh of it; only std::invalid_argument may leave it.
// After every stroke the mesh must stay closed, consistently oriented and of genus 0, with finite
// vertices: anything else, a crash, or another exception is a finding.
#include "sculpt/brushes.h"
#include "sculpt/sculpt_mesh.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

struct Reader {
  const uint8_t* data;
  size_t size, pos = 0;
  uint8_t byte() { return pos < size ? data[pos++] : 0; }
  bool left() const { return pos < size; }
};

// An octahedron subdivided k times, its vertices pushed onto the unit sphere.
idealize::TriangleMesh sphere(int k) {
  std::vector<Eigen::Vector3d> V{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<int, 3>> F{{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int level = 0; level < k; ++level) {
    std::map<std::pair<int, int>, int> middle;
    auto mid = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = middle.find(key);
      if (it != middle.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      return middle[key] = static_cast<int>(V.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& t : F) {
      const int ab = mid(t[0], t[1]), bc = mid(t[1], t[2]), ca = mid(t[2], t[0]);
      next.insert(next.end(), {{t[0], ab, ca}, {ab, t[1], bc}, {ca, bc, t[2]}, {ab, bc, ca}});
    }
    F = std::move(next);
  }
  idealize::TriangleMesh mesh;
  mesh.V.resize(static_cast<int>(V.size()), 3);
  mesh.F.resize(static_cast<int>(F.size()), 3);
  for (size_t v = 0; v < V.size(); ++v) mesh.V.row(static_cast<int>(v)) = V[v].transpose();
  for (size_t f = 0; f < F.size(); ++f)
    for (int c = 0; c < 3; ++c) mesh.F(static_cast<int>(f), c) = F[f][c];
  return mesh;
}

void check(const idealize::SculptMesh& sculpted) {
  std::vector<int> labels;
  std::vector<char> modified;
  const idealize::TriangleMesh mesh = sculpted.compacted(labels, modified);
  std::set<std::pair<int, int>> directed;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = mesh.F(f, c), b = mesh.F(f, (c + 1) % 3);
      if (a == b || !directed.insert({a, b}).second) {
        std::fprintf(stderr, "face %d: a repeated vertex or an edge used twice one way\n", f);
        std::abort();
      }
    }
  for (const auto& [a, b] : directed)
    if (!directed.count({b, a})) {
      std::fprintf(stderr, "edge %d-%d has one face: the mesh opened\n", a, b);
      std::abort();
    }
  const long euler = mesh.num_vertices() - static_cast<long>(directed.size()) / 2 + mesh.num_faces();
  if (euler != 2 || !mesh.V.allFinite()) {
    std::fprintf(stderr, "Euler characteristic %ld (2 expected) or a vertex not finite\n", euler);
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader in{data, size};
  idealize::TriangleMesh mesh = sphere(in.byte() % 4);
  for (int v = 0; v < mesh.num_vertices(); ++v) mesh.V.row(v) *= 1.0 + (in.byte() - 128) / 512.0;
  idealize::SculptMesh sculpted(mesh, {});
  for (int stroke = 0; stroke < 16 && in.left(); ++stroke) {
    const idealize::Brush brush = static_cast<idealize::Brush>(in.byte() % 7);
    idealize::StrokeOptions options;
    options.radius = 0.05 + in.byte() / 255.0;
    options.strength = (in.byte() - 128) / 128.0;
    idealize::MatrixX3d points(2, 3);
    for (int p = 0; p < 2; ++p)
      for (int c = 0; c < 3; ++c) points(p, c) = (in.byte() - 128) / 100.0;
    const int theta = in.byte(), phi = in.byte();
    idealize::MatrixX3d directions(theta ? 2 : 0, 3);
    for (int p = 0; p < directions.rows(); ++p)
      directions.row(p) << std::sin(theta / 40.0) * std::cos(phi / 40.0), std::sin(theta / 40.0) * std::sin(phi / 40.0),
          std::cos(theta / 40.0);
    try {
      idealize::sculpt_stroke(sculpted, brush, points, directions, options);
    } catch (const std::invalid_argument&) {
      return 0;
    }
    check(sculpted);
  }
  return 0;
}
