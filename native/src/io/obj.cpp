// OBJ: vertex positions and faces; every other kind of line is skipped.
#include "io/readers.h"

#include <charconv>
#include <climits>
#include <string>
#include <system_error>
#include <vector>

namespace idealize::io_detail {

namespace {

// "v x y z [w] [r g b]": only the position is used.
void read_obj_vertex(TextCursor& cursor, const std::string& name, MeshBuffer& buffer) {
  double c[3];
  for (double& value : c) {
    const string_view token = cursor.token_in_line();
    if (token.empty() || !parse_double(token, value))
      fail_at_line(name, cursor.line(),
                   token.empty() ? "a vertex needs three coordinates"
                                 : "expected a coordinate but found " + shown(token));
  }
  if (buffer.num_vertices() == INT_MAX) fail_too_large(name);
  buffer.add_vertex(c[0], c[1], c[2]);
}

// The largest positive index seen that points past the vertices read so far. OBJ lets faces
// refer to vertices defined further down, so such indices are only checked at the end.
struct ObjForwardReference {
  long long index = 0;
  long long line = 0;
};

// "f v1 v2 v3 ..." where each corner is "v", "v/t", "v//n" or "v/t/n"; only v is used.
// Indices count from 1; negative ones count back from the latest vertex (-1 = last).
void read_obj_face(TextCursor& cursor, const std::string& name, long long num_vertices,
                   std::vector<int>& polygon, ObjForwardReference& forward) {
  polygon.clear();
  for (string_view token = cursor.token_in_line(); !token.empty();
       token = cursor.token_in_line()) {
    long long index = 0;
    const char* last = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), last, index);
    if (ec != std::errc() || (ptr != last && *ptr != '/'))
      fail_at_line(name, cursor.line(), shown(token) + " is not a vertex reference");
    if (index == 0)
      fail_at_line(name, cursor.line(), "vertex index 0 is invalid (OBJ counts vertices from 1)");
    const long long vertex = index > 0 ? index - 1 : num_vertices + index;
    if (vertex < 0 || vertex >= INT_MAX)
      fail_bad_index(name, cursor.line(), std::to_string(index), num_vertices,
                     "OBJ counts vertices from 1");
    if (vertex >= num_vertices && index > forward.index) forward = {index, cursor.line()};
    polygon.push_back(static_cast<int>(vertex));
  }
  if (polygon.size() < 3)
    fail_at_line(name, cursor.line(),
                 "face has " + std::to_string(polygon.size()) +
                     " vertices; a face needs at least 3");
}

}  // namespace

TriangleMesh read_obj(string_view data, const std::string& name, MeshReadInfo& info) {
  require_text(data, name, "OBJ");
  TextCursor cursor(data, true);
  MeshBuffer buffer;
  std::vector<int> polygon;
  ObjForwardReference forward;
  while (!cursor.at_end()) {
    // Everything but positions and faces (vt, vn, g, o, s, usemtl, mtllib, l, p) is irrelevant.
    const string_view keyword = cursor.token_in_line();
    if (keyword == "v") {
      read_obj_vertex(cursor, name, buffer);
    } else if (keyword == "f") {
      read_obj_face(cursor, name, buffer.num_vertices(), polygon, forward);
      buffer.add_polygon(polygon);
      if (buffer.num_triangles() > INT_MAX) fail_too_large(name);
    }
    cursor.next_line();
  }
  if (forward.index > buffer.num_vertices())
    fail_bad_index(name, forward.line, std::to_string(forward.index), buffer.num_vertices(),
                   "OBJ counts vertices from 1");
  info.format = "obj";
  info.file_triangles = buffer.num_triangles();
  info.file_vertices = buffer.num_vertices();
  return finish(buffer, name, 1);
}

}  // namespace idealize::io_detail
