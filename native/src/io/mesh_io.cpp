// Mesh file readers: the format chosen by extension or content, and read_mesh (mesh_io.h).
#include "io/mesh_io.h"

#include "io/readers.h"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

namespace idealize {

namespace {

using namespace io_detail;  // the readers and their helpers (readers.h)

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
