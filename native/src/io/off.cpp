// OFF: the header's counts, then the vertices and the faces (polygons, fan-triangulated).
#include "io/readers.h"

#include <algorithm>
#include <climits>
#include <string>
#include <vector>

namespace idealize::io_detail {

namespace {

long long parse_off_count(string_view token, const TextCursor& cursor, const std::string& name,
                          const char* what, long long limit) {
  long long count = 0;
  if (!parse_integer(token, count) || count < 0)
    fail_at_line(name, cursor.line(),
                 std::string("expected the number of ") + what + " but found " +
                     (token.empty() ? std::string("the end of the file") : shown(token)));
  if (count > limit) fail_too_large(name);
  return count;
}

[[noreturn]] void fail_off_truncated(const std::string& name, long long announced, long long read,
                                     const char* what) {
  fail(name, "is truncated: its header announces " + std::to_string(announced) + " " + what +
                 " but the file ends after " + std::to_string(read));
}

void read_off_vertices(TextCursor& cursor, const std::string& name, long long count,
                       MeshBuffer& buffer) {
  constexpr size_t kMinVertexLine = 6;  // "0 0 0\n"
  reserve_plausible(buffer.xyz, count, 3, cursor.remaining(), kMinVertexLine);
  for (long long i = 0; i < count; ++i) {
    double c[3];
    for (int k = 0; k < 3; ++k) {
      const string_view token = k == 0 ? cursor.token() : cursor.token_in_line();
      if (k == 0 && token.empty()) fail_off_truncated(name, count, i, "vertices");
      if (token.empty() || !parse_double(token, c[k]))
        fail_at_line(name, cursor.line(),
                     token.empty() ? "a vertex needs three coordinates"
                                   : "expected a coordinate but found " + shown(token));
    }
    buffer.add_vertex(c[0], c[1], c[2]);
    cursor.next_line();  // colours, normals or texture coordinates
  }
}

// "n i0 i1 ... i(n-1) [colour]", indices counting from 0.
void read_off_face(TextCursor& cursor, const std::string& name, string_view size_token,
                   long long num_vertices, std::vector<int>& polygon) {
  long long size = 0;
  if (!parse_integer(size_token, size))
    fail_at_line(name, cursor.line(), "expected a face size but found " + shown(size_token));
  if (size < 3)
    fail_at_line(name, cursor.line(),
                 "face has " + std::to_string(size) + " vertices; a face needs at least 3");
  polygon.clear();
  for (long long k = 0; k < size; ++k) {
    const string_view token = cursor.token_in_line();
    long long index = 0;
    if (token.empty())
      fail_at_line(name, cursor.line(),
                   "face announces " + std::to_string(size) + " vertices but lists " +
                       std::to_string(k));
    if (!parse_integer(token, index))
      fail_at_line(name, cursor.line(), "expected a vertex index but found " + shown(token));
    if (index < 0 || index >= num_vertices)
      fail_bad_index(name, cursor.line(), std::to_string(index), num_vertices,
                     "OFF counts vertices from 0");
    polygon.push_back(static_cast<int>(index));
  }
}

}  // namespace

bool is_off_keyword(string_view token) {
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF") return false;
  const string_view prefix = token.substr(0, token.size() - 3);
  return std::all_of(prefix.begin(), prefix.end(), [](char c) {
    return c == 'S' || c == 'T' || c == 'C' || c == 'N' || c == '4' || c == 'n';
  });
}

TriangleMesh read_off(string_view data, const std::string& name, MeshReadInfo& info) {
  require_text(data, name, "OFF");
  TextCursor cursor(data, true);
  string_view token = cursor.token();
  if (is_off_keyword(token)) {  // optional; the counts follow on the same line or a later one
    if (token.find_first_of("4n") != string_view::npos)
      fail(name, "is a " + shown(token) + " file (not 3-D), which Idealize does not read");
    token = cursor.token();
    if (token == "BINARY") fail_at_line(name, cursor.line(), "binary OFF files are not supported");
  } else if (long long unused; !parse_integer(token, unused)) {
    fail(name, "is not an OFF file: expected 'OFF' or the vertex and face counts but found " +
                   shown(token));
  }
  const long long num_vertices = parse_off_count(token, cursor, name, "vertices", INT_MAX);
  const long long num_faces = parse_off_count(cursor.token(), cursor, name, "faces", LLONG_MAX);
  cursor.next_line();  // past the edge count, which is unused

  MeshBuffer buffer;
  read_off_vertices(cursor, name, num_vertices, buffer);
  constexpr size_t kMinFaceLine = 8;  // "3 0 0 0\n"
  reserve_plausible(buffer.tri, num_faces, 3, cursor.remaining(), kMinFaceLine);
  std::vector<int> polygon;
  for (long long f = 0; f < num_faces; ++f) {
    const string_view size_token = cursor.token();
    if (size_token.empty()) fail_off_truncated(name, num_faces, f, "faces");
    read_off_face(cursor, name, size_token, num_vertices, polygon);
    buffer.add_polygon(polygon);
    if (buffer.num_triangles() > INT_MAX) fail_too_large(name);
    cursor.next_line();  // past an optional colour
  }
  info.format = "off";
  info.file_triangles = buffer.num_triangles();
  info.file_vertices = num_vertices;
  return finish(buffer, name, 0);
}

}  // namespace idealize::io_detail
