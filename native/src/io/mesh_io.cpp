// Mesh file readers.
//
// The whole file is read into memory once and parsed in place. Numbers go through
// std::from_chars, which is fast and ignores the locale (FreeCAD may run under a locale whose
// decimal separator is a comma). Every count a file announces is checked against the bytes that
// are actually there before anything is reserved, so a lying header cannot trigger a huge
// allocation or a read past the end.
#include "io/mesh_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

namespace idealize {

namespace {

using std::string_view;

// ---------------------------------------------------------------------------------------------
// Messages

std::string quote(string_view text) { return "'" + std::string(text) + "'"; }

// A token from the file as it may appear in a message: clipped, with control bytes replaced,
// since a corrupt file can put anything there.
std::string shown(string_view token) {
  constexpr size_t kMaxShown = 40;
  std::string out(token.substr(0, kMaxShown));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  if (token.size() > kMaxShown) out += "...";
  return quote(out);
}

std::string number_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

[[noreturn]] void fail(const std::string& name, const std::string& problem) {
  throw MeshError(quote(name) + " " + problem);
}

[[noreturn]] void fail_at_line(const std::string& name, long long line,
                               const std::string& problem) {
  throw MeshError(quote(name) + " line " + std::to_string(line) + ": " + problem);
}

[[noreturn]] void fail_too_large(const std::string& name) {
  fail(name, "has more vertices or triangles than Idealize supports (2147483647)");
}

[[noreturn]] void fail_bad_index(const std::string& name, long long line, const std::string& index,
                                 long long num_vertices, const char* counting) {
  fail_at_line(name, line,
               "face refers to vertex " + index + " but only " + std::to_string(num_vertices) +
                   " vertices are defined (" + counting + ")");
}

// ---------------------------------------------------------------------------------------------
// Text scanning

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

bool iequals(string_view a, string_view b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

// Mesh text files hold printable characters and line breaks; binary STL data contains control
// bytes almost at once (the high bytes of the triangle count, float bit patterns).
bool looks_like_text(string_view data) {
  const size_t n = std::min<size_t>(data.size(), 1024);
  for (size_t i = 0; i < n; ++i) {
    const char c = data[i];
    if (static_cast<unsigned char>(c) < 0x20 && c != '\n' && !is_blank(c)) return false;
  }
  return true;
}

// Walks text token by token, counting lines for error messages. With `hash_comments` (OBJ, OFF)
// a token starting with '#' begins a comment that runs to the end of the line.
class TextCursor {
 public:
  TextCursor(string_view text, bool hash_comments, long long first_line = 1)
      : p_(text.data()), end_(text.data() + text.size()), line_(first_line),
        hash_comments_(hash_comments) {}

  bool at_end() const { return p_ == end_; }
  long long line() const { return line_; }
  size_t remaining() const { return static_cast<size_t>(end_ - p_); }

  // The next token on the current line; empty at the end of the line.
  string_view token_in_line() {
    while (p_ != end_ && is_blank(*p_)) ++p_;
    if (p_ == end_ || *p_ == '\n') return {};
    if (hash_comments_ && *p_ == '#') {
      skip_to_line_end();
      return {};
    }
    const char* start = p_;
    while (p_ != end_ && !is_blank(*p_) && *p_ != '\n') ++p_;
    return string_view(start, static_cast<size_t>(p_ - start));
  }

  // The next token, crossing line ends; empty at the end of the text.
  string_view token() {
    for (;;) {
      const string_view t = token_in_line();
      if (!t.empty() || p_ == end_) return t;
      next_line();
    }
  }

  // Moves to the start of the next line, discarding the rest of the current one.
  void next_line() {
    skip_to_line_end();
    if (p_ != end_) {
      ++p_;
      ++line_;
    }
  }

 private:
  void skip_to_line_end() {
    if (p_ == end_) return;
    const void* newline = std::memchr(p_, '\n', remaining());
    p_ = newline ? static_cast<const char*>(newline) : end_;
  }

  const char* p_;
  const char* end_;
  long long line_;
  bool hash_comments_;
};

// Parses a whole token as a double. from_chars rejects a leading '+', which some writers emit,
// and reports values beyond double's range instead of rounding them: those become infinity
// (rejected later as non-finite) or, for a negative exponent, zero.
bool parse_double(string_view token, double& value) {
  const char* first = token.data();
  const char* last = first + token.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (ptr != last || ptr == first) return false;
  if (ec == std::errc::result_out_of_range) {
    const char* exponent = std::find_if(first, last, [](char c) { return c == 'e' || c == 'E'; });
    const bool underflow = exponent != last && exponent + 1 != last && exponent[1] == '-';
    value = underflow ? 0.0 : std::numeric_limits<double>::infinity();
    if (*first == '-') value = -value;
    return true;
  }
  return ec == std::errc();
}

bool parse_integer(string_view token, long long& value) {
  const char* last = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), last, value);
  return ec == std::errc() && ptr == last;
}

// Skips leading white space and compares the first word, case-insensitively.
bool starts_with_word(string_view data, string_view word) {
  size_t i = 0;
  while (i < data.size() && (is_blank(data[i]) || data[i] == '\n')) ++i;
  const string_view rest = data.substr(i);
  return rest.size() >= word.size() && iequals(rest.substr(0, word.size()), word) &&
         (rest.size() == word.size() || is_blank(rest[word.size()]) || rest[word.size()] == '\n');
}

// ---------------------------------------------------------------------------------------------
// Collecting the mesh

// Vertices and triangles as read, before the shared checks and the conversion to Eigen.
struct MeshBuffer {
  std::vector<double> xyz;  // 3 per vertex
  std::vector<int> tri;     // 3 per triangle

  long long num_vertices() const { return static_cast<long long>(xyz.size() / 3); }
  long long num_triangles() const { return static_cast<long long>(tri.size() / 3); }

  void add_vertex(double x, double y, double z) {
    xyz.push_back(x);
    xyz.push_back(y);
    xyz.push_back(z);
  }

  // Fan triangulation (v0, vi, vi+1) keeps the polygon's orientation and the file's face order.
  void add_polygon(const std::vector<int>& polygon) {
    for (size_t i = 1; i + 1 < polygon.size(); ++i) {
      tri.push_back(polygon[0]);
      tri.push_back(polygon[i]);
      tri.push_back(polygon[i + 1]);
    }
  }
};

// Checks shared by all formats, then the conversion. `first_index` is the number the format gives
// its first vertex (OBJ counts from 1, OFF and PLY from 0), so that messages match the file.
TriangleMesh finish(const MeshBuffer& buffer, const std::string& name, int first_index) {
  if (buffer.tri.empty()) fail(name, "contains no triangles");
  if (buffer.num_triangles() > INT_MAX || buffer.num_vertices() > INT_MAX) fail_too_large(name);
  for (size_t i = 0; i < buffer.xyz.size(); ++i)
    if (!std::isfinite(buffer.xyz[i]))
      throw MeshError(quote(name) + ": coordinates contain NaN or infinity (vertex " +
                      std::to_string(static_cast<long long>(i / 3) + first_index) + ")");
  TriangleMesh mesh;
  mesh.V = Eigen::Map<const MatrixX3d>(buffer.xyz.data(), buffer.num_vertices(), 3);
  mesh.F = Eigen::Map<const MatrixX3i>(buffer.tri.data(), buffer.num_triangles(), 3);
  return mesh;
}

// Reserves room for `count` items, but never more than `remaining` bytes could hold at
// `min_item_bytes` each: the count comes from a header that may lie.
template <class T>
void reserve_plausible(std::vector<T>& v, long long count, size_t per_item, size_t remaining,
                       size_t min_item_bytes) {
  const size_t plausible = remaining / std::max<size_t>(min_item_bytes, 1);
  v.reserve(per_item * std::min(static_cast<size_t>(count), plausible));
}

// ---------------------------------------------------------------------------------------------
// STL

// An unsigned integer type of N bytes.
template <size_t N>
using UIntOfSize = std::conditional_t<
    N == 1, uint8_t,
    std::conditional_t<N == 2, uint16_t, std::conditional_t<N == 4, uint32_t, uint64_t>>>;

uint64_t mix64(uint64_t h) {  // MurmurHash3's finaliser
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdULL;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  h ^= h >> 33;
  return h;
}

// A coordinate's bits for hashing; -0.0 == 0.0 compares equal, so both hash as +0.0.
template <class T>
uint64_t coordinate_bits(T v) {
  if (v == T(0)) v = T(0);
  UIntOfSize<sizeof(T)> bits;
  std::memcpy(&bits, &v, sizeof v);
  return bits;
}

// Merges STL corners with equal coordinates into one vertex, numbered in order of first
// occurrence; coordinates must be finite. T is float for binary STL, double for ASCII.
// An open-addressing table keeping the coordinates in its slots: every STL vertex recurs about
// six times, and a lookup then touches one cache line, which matters once the table outgrows
// the caches.
template <class T>
class VertexWelder {
 public:
  VertexWelder(std::vector<double>& xyz, size_t expected_vertices, const std::string& name)
      : xyz_(xyz), name_(name) {
    resize(2 * expected_vertices);
  }

  static uint64_t hash(T x, T y, T z) {
    return mix64(coordinate_bits(z) ^ mix64(coordinate_bits(y) ^ mix64(coordinate_bits(x))));
  }

  // Loads the slot of a coming lookup: with scattered triangles, waiting on memory at every
  // corner would otherwise dominate.
  void prefetch(uint64_t hash) const {
#if defined(__GNUC__)
    __builtin_prefetch(&slots_[hash & mask_]);
#else
    (void)hash;
#endif
  }

  int add(T x, T y, T z) { return add(x, y, z, hash(x, y, z)); }

  int add(T x, T y, T z, uint64_t hash) {
    size_t i = hash & mask_;
    for (; slots_[i].vertex >= 0; i = (i + 1) & mask_)
      if (slots_[i].x == x && slots_[i].y == y && slots_[i].z == z) return slots_[i].vertex;
    if (count_ == INT_MAX) fail_too_large(name_);
    const int vertex = count_++;
    slots_[i] = {x, y, z, vertex};
    xyz_.push_back(x);
    xyz_.push_back(y);
    xyz_.push_back(z);
    if (2 * static_cast<size_t>(count_) > slots_.size()) resize(2 * slots_.size());
    return vertex;
  }

 private:
  struct Slot {
    T x, y, z;
    int vertex;  // -1: empty
  };

  void resize(size_t min_slots) {
    size_t size = 64;
    while (size < min_slots) size *= 2;
    const std::vector<Slot> old = std::move(slots_);
    slots_.assign(size, Slot{0, 0, 0, -1});
    mask_ = size - 1;
    for (const Slot& s : old) {
      if (s.vertex < 0) continue;
      size_t i = hash(s.x, s.y, s.z) & mask_;
      while (slots_[i].vertex >= 0) i = (i + 1) & mask_;
      slots_[i] = s;
    }
  }

  std::vector<double>& xyz_;
  const std::string& name_;
  std::vector<Slot> slots_;
  size_t mask_ = 0;
  int count_ = 0;
};

constexpr size_t kStlHeaderBytes = 84;  // 80-byte comment + uint32 triangle count
constexpr size_t kStlTriangleBytes = 50;

// Reads a little- or big-endian scalar, independent of alignment and of the host's byte order.
template <class T>
T load(const unsigned char* p, bool big_endian) {
  using Bits = UIntOfSize<sizeof(T)>;
  Bits bits = 0;
  for (size_t i = 0; i < sizeof(T); ++i) {
    const size_t shift = 8 * (big_endian ? sizeof(T) - 1 - i : i);
    bits = static_cast<Bits>(bits | (static_cast<Bits>(p[i]) << shift));
  }
  T value;
  std::memcpy(&value, &bits, sizeof(T));
  return value;
}

const unsigned char* bytes_of(string_view data) {
  return reinterpret_cast<const unsigned char*>(data.data());
}

uint32_t stl_announced_triangles(string_view data) {
  return load<uint32_t>(bytes_of(data) + 80, false);
}

bool has_binary_stl_size(string_view data) {
  if (data.size() < kStlHeaderBytes) return false;
  const uint64_t count = stl_announced_triangles(data);
  return kStlHeaderBytes + kStlTriangleBytes * count == data.size();
}

// Corners are read and hashed kAhead triangles before they are welded, so that their table slots
// can be prefetched; the ring holds the corners in between.
void weld_binary_stl(const unsigned char* triangles, uint64_t count, const std::string& name,
                     MeshBuffer& buffer) {
  struct Corner {
    float x, y, z;
    uint64_t hash;
  };
  constexpr uint64_t kAhead = 8;
  std::array<Corner, 3 * kAhead> ring;
  // A closed mesh has about F/2 vertices; room for F keeps the table sparse.
  VertexWelder<float> welder(buffer.xyz, count, name);
  const auto fetch = [&](uint64_t t) {
    for (uint64_t corner = 0; corner < 3; ++corner) {
      // Each triangle: a 12-byte normal, three 12-byte corners, a 2-byte attribute.
      const unsigned char* p = triangles + kStlTriangleBytes * t + 12 * (corner + 1);
      Corner& c = ring[(3 * t + corner) % ring.size()];
      c = {load<float>(p, false), load<float>(p + 4, false), load<float>(p + 8, false), 0};
      c.hash = VertexWelder<float>::hash(c.x, c.y, c.z);
      welder.prefetch(c.hash);
    }
  };
  for (uint64_t t = 0; t < std::min(kAhead, count); ++t) fetch(t);
  for (uint64_t t = 0; t < count; ++t) {
    for (uint64_t corner = 0; corner < 3; ++corner) {
      const Corner c = ring[(3 * t + corner) % ring.size()];
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
        throw MeshError(quote(name) + ": coordinates contain NaN or infinity (triangle " +
                        std::to_string(t + 1) + ")");
      buffer.tri.push_back(welder.add(c.x, c.y, c.z, c.hash));
    }
    if (t + kAhead < count) fetch(t + kAhead);
  }
}

TriangleMesh read_binary_stl(string_view data, const std::string& name, MeshReadInfo& info) {
  const uint64_t count = stl_announced_triangles(data);
  const uint64_t present = (data.size() - kStlHeaderBytes) / kStlTriangleBytes;
  // Bytes after the announced triangles are ignored: some writers pad the file.
  if (count > present)
    fail(name, "is truncated: header announces " + std::to_string(count) + " triangles but only " +
                   std::to_string(present) + " are present");
  if (count > INT_MAX / 3) fail_too_large(name);

  MeshBuffer buffer;
  buffer.tri.reserve(3 * count);
  weld_binary_stl(bytes_of(data) + kStlHeaderBytes, count, name, buffer);
  info.format = "stl-binary";
  info.file_triangles = static_cast<long long>(count);
  info.file_vertices = 3 * info.file_triangles;
  return finish(buffer, name, 0);
}

string_view next_stl_token(TextCursor& cursor, const std::string& name) {
  const string_view token = cursor.token();
  if (token.empty())
    fail(name, "is truncated: the file ends inside a facet (line " + std::to_string(cursor.line()) +
                   ")");
  return token;
}

// Reads the next token of an ASCII STL and checks it is `keyword` (case-insensitive: some
// exporters write upper case).
void expect_stl_keyword(TextCursor& cursor, const std::string& name, string_view keyword) {
  const string_view token = next_stl_token(cursor, name);
  if (!iequals(token, keyword))
    fail_at_line(name, cursor.line(),
                 "expected " + quote(keyword) + " but found " + shown(token));
}

double read_stl_number(TextCursor& cursor, const std::string& name) {
  const string_view token = next_stl_token(cursor, name);
  double value;
  if (!parse_double(token, value))
    fail_at_line(name, cursor.line(), "expected a number but found " + shown(token));
  return value;
}

// "facet normal nx ny nz / outer loop / vertex x y z (3x) / endloop / endfacet", after "facet".
void read_stl_facet(TextCursor& cursor, const std::string& name, VertexWelder<double>& welder,
                    MeshBuffer& buffer) {
  expect_stl_keyword(cursor, name, "normal");
  // The normal is not used, and some exporters write it as "-1.#IND00": skip it unparsed.
  for (int i = 0; i < 3; ++i) next_stl_token(cursor, name);
  expect_stl_keyword(cursor, name, "outer");
  expect_stl_keyword(cursor, name, "loop");
  for (int corner = 0; corner < 3; ++corner) {
    expect_stl_keyword(cursor, name, "vertex");
    const double x = read_stl_number(cursor, name), y = read_stl_number(cursor, name),
                 z = read_stl_number(cursor, name);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      fail_at_line(name, cursor.line(), "coordinates contain NaN or infinity");
    buffer.tri.push_back(welder.add(x, y, z));
  }
  expect_stl_keyword(cursor, name, "endloop");
  expect_stl_keyword(cursor, name, "endfacet");
}

TriangleMesh read_ascii_stl(string_view data, const std::string& name, MeshReadInfo& info) {
  TextCursor cursor(data, false);
  MeshBuffer buffer;
  VertexWelder<double> welder(buffer.xyz, 0, name);
  for (string_view token = cursor.token(); !token.empty(); token = cursor.token()) {
    if (iequals(token, "solid") || iequals(token, "endsolid")) {
      cursor.next_line();  // the solid's name runs to the end of the line
    } else if (iequals(token, "facet")) {
      read_stl_facet(cursor, name, welder, buffer);
      if (buffer.num_triangles() > INT_MAX) fail_too_large(name);
    } else {
      fail_at_line(name, cursor.line(), "expected 'facet' or 'endsolid' but found " + shown(token));
    }
  }
  info.format = "stl-ascii";
  info.file_triangles = buffer.num_triangles();
  info.file_vertices = 3 * info.file_triangles;
  return finish(buffer, name, 0);
}

// Binary if the size matches the announced count (even when the header starts with "solid", as
// SolidWorks writes it); otherwise text starting with "solid" is ASCII; otherwise binary data
// that does not fit its header.
TriangleMesh read_stl(string_view data, const std::string& name, MeshReadInfo& info) {
  if (has_binary_stl_size(data)) return read_binary_stl(data, name, info);
  if (looks_like_text(data)) {
    if (starts_with_word(data, "solid")) return read_ascii_stl(data, name, info);
    fail(name, "is not an STL file: it is text but does not start with 'solid'");
  }
  if (data.size() < kStlHeaderBytes)
    fail(name, "is truncated or corrupt: " + std::to_string(data.size()) +
                   " bytes are too few for a binary STL, and it is not ASCII STL");
  return read_binary_stl(data, name, info);
}

// ---------------------------------------------------------------------------------------------
// OBJ

void require_text(string_view data, const std::string& name, const char* format) {
  if (!looks_like_text(data))
    fail(name, std::string("contains binary data, so it is not an ") + format + " file");
}

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

// ---------------------------------------------------------------------------------------------
// OFF

// "OFF" with optional prefixes: ST (texture coordinates), C (colours), N (normals). The extra
// per-vertex values are ignored. "4OFF" and "nOFF" (other dimensions) are not read.
bool is_off_keyword(string_view token) {
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF") return false;
  const string_view prefix = token.substr(0, token.size() - 3);
  return std::all_of(prefix.begin(), prefix.end(), [](char c) {
    return c == 'S' || c == 'T' || c == 'C' || c == 'N' || c == '4' || c == 'n';
  });
}

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

// ---------------------------------------------------------------------------------------------
// PLY

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

bool parse_ply_type(string_view text, PlyType& type) {
  static constexpr struct {
    string_view name;
    PlyType type;
  } kTypes[] = {{"char", PlyType::Int8},     {"int8", PlyType::Int8},
                {"uchar", PlyType::UInt8},   {"uint8", PlyType::UInt8},
                {"short", PlyType::Int16},   {"int16", PlyType::Int16},
                {"ushort", PlyType::UInt16}, {"uint16", PlyType::UInt16},
                {"int", PlyType::Int32},     {"int32", PlyType::Int32},
                {"uint", PlyType::UInt32},   {"uint32", PlyType::UInt32},
                {"float", PlyType::Float32}, {"float32", PlyType::Float32},
                {"double", PlyType::Float64}, {"float64", PlyType::Float64}};
  for (const auto& known : kTypes)
    if (known.name == text) {
      type = known.type;
      return true;
    }
  return false;
}

size_t ply_type_size(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8: return 1;
    case PlyType::Int16:
    case PlyType::UInt16: return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 8;
}

bool is_integer_type(PlyType type) { return type != PlyType::Float32 && type != PlyType::Float64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;  // the items' type for a list
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;

  int find(string_view property) const {
    for (size_t i = 0; i < properties.size(); ++i)
      if (properties[i].name == property) return static_cast<int>(i);
    return -1;
  }
  bool has_lists() const {
    return std::any_of(properties.begin(), properties.end(),
                       [](const PlyProperty& p) { return p.is_list; });
  }
  // The fewest bytes one row can take, with `min_list_items` items in each list: binary values
  // take their type's size, ASCII ones a character and a separator.
  size_t min_row_bytes(bool ascii, size_t min_list_items) const {
    size_t bytes = 0;
    for (const PlyProperty& p : properties) {
      if (ascii)
        bytes += 2 * (p.is_list ? 1 + min_list_items : 1);
      else if (p.is_list)
        bytes += ply_type_size(p.count_type) + min_list_items * ply_type_size(p.type);
      else
        bytes += ply_type_size(p.type);
    }
    return bytes;
  }
};

enum class PlyEncoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::Ascii;
  std::vector<PlyElement> elements;
  size_t data_offset = 0;   // first byte after "end_header\n"
  long long data_line = 0;  // line number of that byte, for ASCII messages
};

PlyEncoding parse_ply_format(TextCursor& cursor, const std::string& name) {
  const string_view format = cursor.token_in_line();
  if (format == "ascii") return PlyEncoding::Ascii;
  if (format == "binary_little_endian") return PlyEncoding::BinaryLittleEndian;
  if (format == "binary_big_endian") return PlyEncoding::BinaryBigEndian;
  fail_at_line(name, cursor.line(), "unknown PLY format " + shown(format));
}

PlyElement parse_ply_element(TextCursor& cursor, const std::string& name) {
  PlyElement element;
  element.name = std::string(cursor.token_in_line());
  const string_view count = cursor.token_in_line();
  if (element.name.empty() || !parse_integer(count, element.count) || element.count < 0)
    fail_at_line(name, cursor.line(), "expected 'element <name> <count>'");
  return element;
}

// "property <type> <name>" or "property list <count type> <item type> <name>".
PlyProperty parse_ply_property(TextCursor& cursor, const std::string& name) {
  PlyProperty property;
  string_view type = cursor.token_in_line();
  if (type == "list") {
    property.is_list = true;
    const string_view count_type = cursor.token_in_line();
    if (!parse_ply_type(count_type, property.count_type) || !is_integer_type(property.count_type))
      fail_at_line(name, cursor.line(), "unknown list count type " + shown(count_type));
    type = cursor.token_in_line();
  }
  if (!parse_ply_type(type, property.type))
    fail_at_line(name, cursor.line(), "unknown property type " + shown(type));
  property.name = std::string(cursor.token_in_line());
  if (property.name.empty()) fail_at_line(name, cursor.line(), "property without a name");
  return property;
}

PlyHeader parse_ply_header(string_view data, const std::string& name) {
  TextCursor cursor(data, false);
  if (cursor.token_in_line() != "ply")
    fail(name, "is not a PLY file: it does not start with 'ply'");
  cursor.next_line();
  PlyHeader header;
  bool has_format = false;
  for (;;) {
    if (cursor.at_end()) fail(name, "is truncated: its PLY header has no 'end_header' line");
    const string_view keyword = cursor.token_in_line();
    if (keyword == "end_header") {
      cursor.next_line();
      header.data_offset = data.size() - cursor.remaining();
      header.data_line = cursor.line();
      break;
    }
    if (keyword == "format") {
      header.encoding = parse_ply_format(cursor, name);
      has_format = true;
    } else if (keyword == "element") {
      header.elements.push_back(parse_ply_element(cursor, name));
    } else if (keyword == "property") {
      if (header.elements.empty())
        fail_at_line(name, cursor.line(), "property before any element");
      header.elements.back().properties.push_back(parse_ply_property(cursor, name));
    } else if (!keyword.empty() && keyword != "comment" && keyword != "obj_info") {
      fail_at_line(name, cursor.line(), "unknown PLY header keyword " + shown(keyword));
    }
    cursor.next_line();
  }
  if (!has_format) fail(name, "has no 'format' line in its PLY header");
  return header;
}

// Binary PLY data: scalars of the header's types in the file's byte order. `read` and `skip`
// return false when the data runs out.
class PlyBinarySource {
 public:
  static constexpr bool kAscii = false;

  PlyBinarySource(string_view data, bool big_endian)
      : p_(bytes_of(data)), end_(p_ + data.size()), big_endian_(big_endian) {}

  size_t remaining() const { return static_cast<size_t>(end_ - p_); }

  bool read(PlyType type, double& value) {
    const size_t size = ply_type_size(type);
    if (remaining() < size) return false;
    value = decode(type);
    p_ += size;
    return true;
  }

  bool skip(PlyType type, uint64_t count) { return skip_bytes(count, ply_type_size(type)); }

  bool skip_bytes(uint64_t count, size_t size) {
    if (size != 0 && count > remaining() / size) return false;
    p_ += count * size;
    return true;
  }

 private:
  double decode(PlyType type) const {
    switch (type) {
      case PlyType::Int8: return load<int8_t>(p_, big_endian_);
      case PlyType::UInt8: return load<uint8_t>(p_, big_endian_);
      case PlyType::Int16: return load<int16_t>(p_, big_endian_);
      case PlyType::UInt16: return load<uint16_t>(p_, big_endian_);
      case PlyType::Int32: return load<int32_t>(p_, big_endian_);
      case PlyType::UInt32: return load<uint32_t>(p_, big_endian_);
      case PlyType::Float32: return load<float>(p_, big_endian_);
      case PlyType::Float64: return load<double>(p_, big_endian_);
    }
    return 0.0;
  }

  const unsigned char* p_;
  const unsigned char* end_;
  bool big_endian_;
};

// ASCII PLY data: white-space separated numbers; rows need not follow line breaks.
class PlyAsciiSource {
 public:
  static constexpr bool kAscii = true;

  PlyAsciiSource(string_view data, long long first_line, const std::string& name)
      : cursor_(data, false, first_line), name_(name) {}

  size_t remaining() const { return cursor_.remaining(); }

  bool read(PlyType type, double& value) {
    const string_view token = cursor_.token();
    if (token.empty()) return false;
    if (!parse_double(token, value) || (is_integer_type(type) && value != std::trunc(value)))
      fail_at_line(name_, cursor_.line(),
                   std::string("expected ") + (is_integer_type(type) ? "an integer" : "a number") +
                       " but found " + shown(token));
    return true;
  }

  bool skip(PlyType type, uint64_t count) {
    double unused;
    for (uint64_t i = 0; i < count; ++i)
      if (!read(type, unused)) return false;
    return true;
  }

 private:
  TextCursor cursor_;
  const std::string& name_;
};

[[noreturn]] void fail_ply_truncated(const std::string& name, const PlyElement& element,
                                     long long rows_read) {
  fail(name, "is truncated: its header announces " + std::to_string(element.count) + " " +
                 quote(element.name) + " elements but the data runs out after " +
                 std::to_string(rows_read));
}

// Reads the items of a list whose length has been read; `items` null skips them.
template <class Source>
bool read_ply_list_items(Source& source, PlyType type, uint64_t length,
                         std::vector<double>* items) {
  if (!items) return source.skip(type, length);
  items->clear();
  for (uint64_t j = 0; j < length; ++j) {
    double item;
    if (!source.read(type, item)) return false;
    items->push_back(item);  // grows with the data actually present, not with the claim
  }
  return true;
}

// Reads every row of `element`: scalar properties land in `row` (by property position), the items
// of property `list_property` (if not -1) in `list`; other lists are skipped. Then calls
// on_row(row index, row, list).
template <class Source, class OnRow>
void read_ply_rows(Source& source, const PlyElement& element, int list_property,
                   const std::string& name, OnRow on_row) {
  std::vector<double> row(element.properties.size());
  std::vector<double> list;
  for (long long i = 0; i < element.count; ++i) {
    for (size_t k = 0; k < element.properties.size(); ++k) {
      const PlyProperty& property = element.properties[k];
      if (!property.is_list) {
        if (!source.read(property.type, row[k])) fail_ply_truncated(name, element, i);
        continue;
      }
      double length = 0;
      if (!source.read(property.count_type, length)) fail_ply_truncated(name, element, i);
      if (length < 0)
        throw MeshError(quote(name) + ": " + quote(element.name) + " element " +
                        std::to_string(i) + " has a list of negative length");
      // Every item takes at least one byte, which also makes the cast below safe.
      if (length > static_cast<double>(source.remaining()) ||
          !read_ply_list_items(source, property.type, static_cast<uint64_t>(length),
                               static_cast<int>(k) == list_property ? &list : nullptr))
        fail_ply_truncated(name, element, i);
    }
    on_row(i, row, list);
  }
}

template <class Source>
void read_ply_vertices(Source& source, const PlyElement& element, const std::string& name,
                       MeshBuffer& buffer) {
  int axis[3];
  for (int a = 0; a < 3; ++a) {
    const char* coordinate = a == 0 ? "x" : a == 1 ? "y" : "z";
    axis[a] = element.find(coordinate);
    if (axis[a] < 0 || element.properties[axis[a]].is_list)
      fail(name, "has no " + quote(coordinate) + " property in its 'vertex' element");
  }
  reserve_plausible(buffer.xyz, element.count, 3, source.remaining(),
                    element.min_row_bytes(Source::kAscii, 0));
  read_ply_rows(source, element, -1, name,
                [&](long long, const std::vector<double>& row, const std::vector<double>&) {
                  buffer.add_vertex(row[axis[0]], row[axis[1]], row[axis[2]]);
                });
}

// Checks one face's index list and converts it to vertex numbers.
void ply_face_polygon(const std::vector<double>& list, long long face, long long num_vertices,
                      const std::string& name, std::vector<int>& polygon) {
  if (list.size() < 3)
    throw MeshError(quote(name) + ": face " + std::to_string(face) + " has " +
                    std::to_string(list.size()) + " vertices; a face needs at least 3");
  polygon.clear();
  for (double index : list) {
    if (!(index >= 0 && index < static_cast<double>(num_vertices)) || index != std::trunc(index))
      throw MeshError(quote(name) + ": face " + std::to_string(face) + " refers to vertex " +
                      number_text(index) + " but only " + std::to_string(num_vertices) +
                      " vertices are defined (PLY counts vertices from 0)");
    polygon.push_back(static_cast<int>(index));
  }
}

template <class Source>
void read_ply_faces(Source& source, const PlyElement& element, long long num_vertices,
                    const std::string& name, MeshBuffer& buffer) {
  int indices = element.find("vertex_indices");
  if (indices < 0) indices = element.find("vertex_index");
  if (indices < 0 || !element.properties[indices].is_list)
    fail(name, "has no 'vertex_indices' list in its 'face' element");
  reserve_plausible(buffer.tri, element.count, 3, source.remaining(),
                    element.min_row_bytes(Source::kAscii, 3));
  std::vector<int> polygon;
  read_ply_rows(source, element, indices, name,
                [&](long long face, const std::vector<double>&, const std::vector<double>& list) {
                  ply_face_polygon(list, face, num_vertices, name, polygon);
                  buffer.add_polygon(polygon);
                  if (buffer.num_triangles() > INT_MAX) fail_too_large(name);
                });
}

// Elements other than vertices and faces (edges, materials, ...). Binary rows without lists
// have a fixed size and are skipped in one step.
void skip_ply_element(PlyBinarySource& source, const PlyElement& element,
                      const std::string& name) {
  if (!element.has_lists()) {
    const size_t row_bytes = element.min_row_bytes(false, 0);
    // skip_bytes cannot fail for empty rows, so the division is safe.
    if (!source.skip_bytes(static_cast<uint64_t>(element.count), row_bytes))
      fail_ply_truncated(name, element, static_cast<long long>(source.remaining() / row_bytes));
    return;
  }
  read_ply_rows(source, element, -1, name,
                [](long long, const std::vector<double>&, const std::vector<double>&) {});
}

void skip_ply_element(PlyAsciiSource& source, const PlyElement& element,
                      const std::string& name) {
  if (element.properties.empty()) return;  // rows without properties take no text
  read_ply_rows(source, element, -1, name,
                [](long long, const std::vector<double>&, const std::vector<double>&) {});
}

template <class Source>
void read_ply_data(Source& source, const PlyHeader& header, const std::string& name,
                   MeshBuffer& buffer) {
  long long num_vertices = 0;
  for (const PlyElement& element : header.elements)
    if (element.name == "vertex") num_vertices = element.count;
  if (num_vertices > INT_MAX) fail_too_large(name);
  for (const PlyElement& element : header.elements) {
    if (element.name == "vertex")
      read_ply_vertices(source, element, name, buffer);
    else if (element.name == "face")
      read_ply_faces(source, element, num_vertices, name, buffer);
    else
      skip_ply_element(source, element, name);
  }
}

TriangleMesh read_ply(string_view data, const std::string& name, MeshReadInfo& info) {
  const PlyHeader header = parse_ply_header(data, name);
  const string_view body = data.substr(header.data_offset);
  MeshBuffer buffer;
  if (header.encoding == PlyEncoding::Ascii) {
    PlyAsciiSource source(body, header.data_line, name);
    read_ply_data(source, header, name, buffer);
  } else {
    PlyBinarySource source(body, header.encoding == PlyEncoding::BinaryBigEndian);
    read_ply_data(source, header, name, buffer);
  }
  info.format = header.encoding == PlyEncoding::Ascii ? "ply-ascii" : "ply-binary";
  info.file_triangles = buffer.num_triangles();
  info.file_vertices = buffer.num_vertices();
  return finish(buffer, name, 0);
}

// ---------------------------------------------------------------------------------------------
// Choosing the reader

enum class Format { Stl, Obj, Off, Ply, Unknown };

Format format_from_extension(const std::string& name) {
  const size_t dot = name.find_last_of('.');
  const size_t separator = name.find_last_of("/\\");
  if (dot == std::string::npos || (separator != std::string::npos && dot < separator))
    return Format::Unknown;
  const string_view extension = string_view(name).substr(dot + 1);
  if (iequals(extension, "stl")) return Format::Stl;
  if (iequals(extension, "obj")) return Format::Obj;
  if (iequals(extension, "off")) return Format::Off;
  if (iequals(extension, "ply")) return Format::Ply;
  return Format::Unknown;
}

// An OBJ vertex line: "v" and three numbers.
bool has_obj_vertex_line(string_view data) {
  TextCursor cursor(data, true);
  for (; !cursor.at_end(); cursor.next_line()) {
    if (cursor.token_in_line() != "v") continue;
    double x, y, z;
    if (parse_double(cursor.token_in_line(), x) && parse_double(cursor.token_in_line(), y) &&
        parse_double(cursor.token_in_line(), z))
      return true;
  }
  return false;
}

// For a name without a known extension.
Format sniff_format(string_view data) {
  if (data.substr(0, 4) == "ply\n" || data.substr(0, 5) == "ply\r\n") return Format::Ply;
  if (!looks_like_text(data)) return Format::Unknown;
  if (starts_with_word(data, "solid")) return Format::Stl;
  TextCursor cursor(data, true);
  if (is_off_keyword(cursor.token())) return Format::Off;
  if (has_obj_vertex_line(data)) return Format::Obj;
  return Format::Unknown;
}

// A binary STL is recognised by its exact size whatever its name; otherwise the extension
// decides, and the content when the extension is unknown.
Format choose_format(string_view data, const std::string& name) {
  if (has_binary_stl_size(data)) return Format::Stl;
  const Format by_name = format_from_extension(name);
  return by_name != Format::Unknown ? by_name : sniff_format(data);
}

TriangleMesh read_bytes(string_view data, const std::string& name, MeshReadInfo* info) {
  if (data.empty()) fail(name, "is empty");
  MeshReadInfo unused;
  MeshReadInfo& out = info ? *info : unused;
  out = MeshReadInfo{};
  switch (choose_format(data, name)) {
    case Format::Stl: return read_stl(data, name, out);
    case Format::Obj: return read_obj(data, name, out);
    case Format::Off: return read_off(data, name, out);
    case Format::Ply: return read_ply(data, name, out);
    case Format::Unknown: break;
  }
  fail(name, "is not a mesh format Idealize reads (STL, OBJ, OFF, PLY)");
}

std::string read_file(const std::string& path) {
  std::error_code error;
  const uintmax_t size = std::filesystem::file_size(path, error);
  if (error) throw MeshError("cannot open " + quote(path) + ": " + error.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshError("cannot open " + quote(path) + ": " + std::strerror(errno));
  std::string data(static_cast<size_t>(size), '\0');
  in.read(data.data(), static_cast<std::streamsize>(size));
  if (static_cast<uintmax_t>(in.gcount()) != size)
    throw MeshError("cannot read " + quote(path) + ": the file changed while it was read");
  return data;
}

}  // namespace

TriangleMesh read_mesh(const std::string& path, MeshReadInfo* info) {
  return read_bytes(read_file(path), path, info);
}

TriangleMesh read_mesh_from_memory(const std::string& bytes, const std::string& name_hint,
                                   MeshReadInfo* info) {
  return read_bytes(bytes, name_hint, info);
}

}  // namespace idealize
