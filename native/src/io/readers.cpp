// What the mesh readers share (readers.h): messages, text scanning, collecting the mesh.
#include "io/readers.h"

#include <cctype>
#include <charconv>
#include <climits>
#include <cmath>
#include <limits>
#include <system_error>

namespace idealize::io_detail {

// ---------------------------------------------------------------------------------------------
// Messages

std::string quote(string_view text) { return "'" + std::string(text) + "'"; }

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

bool iequals(string_view a, string_view b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

bool looks_like_text(string_view data) {
  const size_t n = std::min<size_t>(data.size(), 1024);
  for (size_t i = 0; i < n; ++i) {
    const char c = data[i];
    if (static_cast<unsigned char>(c) < 0x20 && c != '\n' && !is_blank(c)) return false;
  }
  return true;
}

void require_text(string_view data, const std::string& name, const char* format) {
  if (!looks_like_text(data))
    fail(name, std::string("contains binary data, so it is not an ") + format + " file");
}

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

bool starts_with_word(string_view data, string_view word) {
  size_t i = 0;
  while (i < data.size() && (is_blank(data[i]) || data[i] == '\n')) ++i;
  const string_view rest = data.substr(i);
  return rest.size() >= word.size() && iequals(rest.substr(0, word.size()), word) &&
         (rest.size() == word.size() || is_blank(rest[word.size()]) || rest[word.size()] == '\n');
}

// ---------------------------------------------------------------------------------------------
// Collecting the mesh

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

// ---------------------------------------------------------------------------------------------
// Binary data

const unsigned char* bytes_of(string_view data) {
  return reinterpret_cast<const unsigned char*>(data.data());
}

}  // namespace idealize::io_detail
