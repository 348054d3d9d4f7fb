// libFuzzer target for segmentation and feature identification on small decoded meshes.
//
// Input layout (missing bytes read as zero):
//   byte 0      number of vertices - 3   (3 .. 66, modulo 64)
//   byte 1      number of faces - 1      (1 .. 128, modulo 128)
//   byte 2      scale exponent: coordinates are int16 * 2^-(byte % 16)
//   then        vertices: 3 little-endian int16 each
//   then        faces: 3 bytes each, vertex index = byte % number of vertices
// segment_mesh and then identify_features (as idealize.idealize calls them from Python) run on it.
// Only idealize::MeshError may leave them; any other exception or a crash is a finding.
#include "features/feature_layer.h"
#include "segment/segmentation.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

namespace {

struct Reader {
  const uint8_t* data;
  size_t size, pos = 0;
  uint8_t byte() { return pos < size ? data[pos++] : 0; }
  int16_t int16() {
    const uint16_t lo = byte(), hi = byte();
    return static_cast<int16_t>(lo | (hi << 8));
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  Reader in{data, size};
  const int nv = 3 + in.byte() % 64;
  const int nf = 1 + in.byte() % 128;
  const double scale = std::ldexp(1.0, -(in.byte() % 16));
  idealize::TriangleMesh mesh;
  mesh.V.resize(nv, 3);
  mesh.F.resize(nf, 3);
  for (int v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) mesh.V(v, c) = in.int16() * scale;
  for (int f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) mesh.F(f, c) = in.byte() % nv;

  // A tenth of the default sampling, and at most 50000 refined faces: under the sanitizers a refined
  // face costs about 0.4 ms, and every input must finish well inside the 30 s timeout. The code
  // paths are the same; tests/test_fuzz_regressions.py runs the inputs with the defaults.
  idealize::SegmentationOptions options;
  options.refinement.min_samples = 2000;
  options.refinement.max_triangles = 50000;
  try {
    const idealize::Segmentation s = idealize::segment_mesh(mesh, options);
    if (s.labels.size() != static_cast<size_t>(nf)) {
      std::fprintf(stderr, "segment_mesh: %zu labels for %d faces\n", s.labels.size(), nf);
      std::abort();
    }
    std::vector<idealize::PatchCurvature> curvature(s.patches.size());
    for (size_t p = 0; p < s.patches.size(); ++p)
      curvature[p] = {s.patches[p].mean_curvature, s.patches[p].mean_gaussian};
    const idealize::FeatureLayer layer = idealize::identify_features(
        mesh, s.labels, curvature, idealize::EffectiveZero{s.zero_low, s.zero_high});
    if (layer.labels.size() != static_cast<size_t>(nf)) {
      std::fprintf(stderr, "identify_features: %zu labels for %d faces\n", layer.labels.size(), nf);
      std::abort();
    }
  } catch (const idealize::MeshError&) {
  }
  return 0;
}
