#include "features/section_profile.h"

#include <algorithm>

namespace idealize {
namespace detail {
namespace {

// The band's vertices are fitted on an even subsample of at most this many, about a hundred of them
// near the arc (half as many left the radius of one of the NIST parts' small fillets 15 % short).
constexpr int kSamplePoints = 400;

}  // namespace

std::vector<int> distinct_vertices(const TriangleMesh& mesh, const std::vector<int>& faces, std::vector<char>& seen) {
  std::vector<int> vertices;
  for (int f : faces)
    for (int k = 0; k < 3; ++k)
      if (!seen[mesh.F(f, k)]) {
        seen[mesh.F(f, k)] = 1;
        vertices.push_back(mesh.F(f, k));
      }
  for (int v : vertices) seen[v] = 0;
  return vertices;
}

std::vector<Vector2> even_sample(const std::vector<Vector2>& points) {
  const size_t step = std::max<size_t>(1, points.size() / kSamplePoints);
  std::vector<Vector2> sample;
  for (size_t i = 0; i < points.size(); i += step) sample.push_back(points[i]);
  return sample;
}

}  // namespace detail
}  // namespace idealize
