// PLY, ASCII and binary (either byte order): the header, then the vertex and face elements.
#include "io/readers.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace idealize::io_detail {

namespace {

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

}  // namespace

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

}  // namespace idealize::io_detail
