// libFuzzer target for the mesh readers (mesh_io.h), compiled once per format.
//
// IDEALIZE_FUZZ_HINT is the file name handed to read_mesh_from_memory (its extension chooses the
// reader unless the bytes have the exact size of a binary STL). IDEALIZE_FUZZ_MODE adjusts the
// bytes so that each target stays on its reader:
//   1 (binary STL): when the first byte is odd, the triangle count in the header is rewritten to
//     match the size (the input is cut to 84 + 50 k bytes), so the triangle parser is exercised;
//     otherwise the bytes go in unchanged (header/size mismatch paths).
//   2 (ASCII STL): "solid " is prepended unless the input already starts with "solid".
//   0: the bytes go in unchanged.
// Only idealize::MeshError may leave the reader; a mesh it returns must satisfy the reader's
// contract (finite coordinates, indices in range, at least one triangle), otherwise we abort.
#include "io/mesh_io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#ifndef IDEALIZE_FUZZ_HINT
#define IDEALIZE_FUZZ_HINT "input.stl"
#endif
#ifndef IDEALIZE_FUZZ_MODE
#define IDEALIZE_FUZZ_MODE 0
#endif

namespace {

void check(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "reader contract violated: %s\n", what);
    std::abort();
  }
}

std::string prepare(const uint8_t* data, size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
#if IDEALIZE_FUZZ_MODE == 1
  if (size >= 84 && (data[0] & 1)) {
    const size_t triangles = (size - 84) / 50;
    bytes.resize(84 + 50 * triangles);
    const uint32_t n = static_cast<uint32_t>(triangles);
    for (int i = 0; i < 4; ++i) bytes[80 + i] = static_cast<char>((n >> (8 * i)) & 0xff);
  }
#elif IDEALIZE_FUZZ_MODE == 2
  if (bytes.compare(0, 5, "solid") != 0) bytes.insert(0, "solid ");
#endif
  return bytes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes = prepare(data, size);
  idealize::TriangleMesh mesh;
  idealize::MeshReadInfo info;
  try {
    mesh = idealize::read_mesh_from_memory(bytes, IDEALIZE_FUZZ_HINT, &info);
  } catch (const idealize::MeshError&) {
    return 0;
  }
  check(mesh.num_faces() > 0, "no triangles returned without MeshError");
  check(mesh.F.cols() == 3 && mesh.V.cols() == 3, "matrix shapes");
  for (int v = 0; v < mesh.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c) check(std::isfinite(mesh.V(v, c)), "non-finite coordinate");
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c)
      check(mesh.F(f, c) >= 0 && mesh.F(f, c) < mesh.num_vertices(), "face index out of range");
  check(!info.format.empty(), "no format reported");
  return 0;
}
