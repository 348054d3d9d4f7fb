// The mesh readers' internals: one reader per format, and what they share.
//
//   mesh_io.cpp   the format chosen by extension or content; read_mesh, read_mesh_from_memory
//   readers.cpp   messages, text scanning, the mesh buffer and the checks every format ends with
//   stl.cpp       binary and ASCII STL
//   obj.cpp       OBJ
//   off.cpp       OFF
//   ply.cpp       PLY, ASCII and binary
//
// The whole file is read into memory once and parsed in place. Numbers go through
// std::from_chars, which is fast and ignores the locale (FreeCAD may run under a locale whose
// decimal separator is a comma). Every count a file announces is checked against the bytes that
// are actually there before anything is reserved, so a lying header cannot trigger a huge
// allocation or a read past the end.
//
// Internal to native/src/io/.
#pragma once

#include "io/mesh_io.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace idealize::io_detail {

using std::string_view;

// ---------------------------------------------------------------------------------------------
// Messages

std::string quote(string_view text);

// A token from the file as it may appear in a message: clipped, with control bytes replaced,
// since a corrupt file can put anything there.
std::string shown(string_view token);

std::string number_text(double value);

[[noreturn]] void fail(const std::string& name, const std::string& problem);

[[noreturn]] void fail_at_line(const std::string& name, long long line,
                               const std::string& problem);

[[noreturn]] void fail_too_large(const std::string& name);

[[noreturn]] void fail_bad_index(const std::string& name, long long line, const std::string& index,
                                 long long num_vertices, const char* counting);

// ---------------------------------------------------------------------------------------------
// Text scanning

inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

bool iequals(string_view a, string_view b);

// Mesh text files hold printable characters and line breaks; binary STL data contains control
// bytes almost at once (the high bytes of the triangle count, float bit patterns).
bool looks_like_text(string_view data);

void require_text(string_view data, const std::string& name, const char* format);

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
bool parse_double(string_view token, double& value);

bool parse_integer(string_view token, long long& value);

// Skips leading white space and compares the first word, case-insensitively.
bool starts_with_word(string_view data, string_view word);

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
TriangleMesh finish(const MeshBuffer& buffer, const std::string& name, int first_index);

// Reserves room for `count` items, but never more than `remaining` bytes could hold at
// `min_item_bytes` each: the count comes from a header that may lie.
template <class T>
void reserve_plausible(std::vector<T>& v, long long count, size_t per_item, size_t remaining,
                       size_t min_item_bytes) {
  const size_t plausible = remaining / std::max<size_t>(min_item_bytes, 1);
  v.reserve(per_item * std::min(static_cast<size_t>(count), plausible));
}

// ---------------------------------------------------------------------------------------------
// Binary data

// An unsigned integer type of N bytes.
template <size_t N>
using UIntOfSize = std::conditional_t<
    N == 1, uint8_t,
    std::conditional_t<N == 2, uint16_t, std::conditional_t<N == 4, uint32_t, uint64_t>>>;

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

const unsigned char* bytes_of(string_view data);

// ---------------------------------------------------------------------------------------------
// The readers: each parses the whole file `data` (`name` for messages), fills `info` and returns
// the mesh, or throws MeshError.

// Binary if the size matches the announced count (even when the header starts with "solid", as
// SolidWorks writes it); otherwise text starting with "solid" is ASCII; otherwise binary data
// that does not fit its header.
TriangleMesh read_stl(string_view data, const std::string& name, MeshReadInfo& info);

TriangleMesh read_obj(string_view data, const std::string& name, MeshReadInfo& info);
TriangleMesh read_off(string_view data, const std::string& name, MeshReadInfo& info);
TriangleMesh read_ply(string_view data, const std::string& name, MeshReadInfo& info);

// For the choice of format (mesh_io.cpp): the size is that of a binary STL with as many
// triangles as its header announces.
bool has_binary_stl_size(string_view data);

// "OFF" with optional prefixes: ST (texture coordinates), C (colours), N (normals). The extra
// per-vertex values are ignored. "4OFF" and "nOFF" (other dimensions) are not read.
bool is_off_keyword(string_view token);

}  // namespace idealize::io_detail
