// STL, binary and ASCII: corners welded into vertices where their coordinates are bit-identical.
#include "io/readers.h"

#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace idealize::io_detail {

namespace {

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

uint32_t stl_announced_triangles(string_view data) {
  return load<uint32_t>(bytes_of(data) + 80, false);
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

}  // namespace

bool has_binary_stl_size(string_view data) {
  if (data.size() < kStlHeaderBytes) return false;
  const uint64_t count = stl_announced_triangles(data);
  return kStlHeaderBytes + kStlTriangleBytes * count == data.size();
}

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

}  // namespace idealize::io_detail
