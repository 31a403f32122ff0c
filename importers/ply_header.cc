// PLY header parsing and checking (see ply_header.h).
#include "importers/ply_header.h"

#include <algorithm>
#include <utility>

#include "codec/core/utf8.h"
#include "importers/text_scan.h"

namespace meshstream {
namespace mesh_io {
namespace {

// The type names OpenMesh's PLY reader knows (get_property_type).
const PlyType kPlyTypes[] = {
    {"char", 1, false, true},     {"int8", 1, false, true},    {"uchar", 1, false, false},
    {"uint8", 1, false, false},   {"short", 2, false, true},   {"int16", 2, false, true},
    {"ushort", 2, false, false},  {"uint16", 2, false, false}, {"int", 4, false, true},
    {"int32", 4, false, true},    {"uint", 4, false, false},   {"uint32", 4, false, false},
    {"float", 4, true, true},     {"float32", 4, true, true},  {"double", 8, true, true},
    {"float64", 8, true, true},
};

}  // namespace

const PlyType* FindPlyType(std::string_view name) {
  for (const PlyType& t : kPlyTypes) {
    if (name == t.name) return &t;
  }
  return nullptr;
}

const char* PlyFormatName(PlyFormat f) {
  switch (f) {
    case PlyFormat::kAscii: return "ascii";
    case PlyFormat::kBinaryLittleEndian: return "binary_little_endian";
    case PlyFormat::kBinaryBigEndian: return "binary_big_endian";
  }
  return "ascii";
}

namespace {

// Line 2: 'format <ascii|binary_little_endian|binary_big_endian> <version>'.
Status ParseFormatLine(const std::string& path, const std::string& where,
                       const std::vector<std::string_view>& w, PlyFormat* format) {
  if (w.size() != 3 || w[0] != "format") {
    return Bad(path, where + "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
  }
  if (w[1] == "ascii") {
    *format = PlyFormat::kAscii;
  } else if (w[1] == "binary_little_endian") {
    *format = PlyFormat::kBinaryLittleEndian;
  } else if (w[1] == "binary_big_endian") {
    *format = PlyFormat::kBinaryBigEndian;
  } else {
    return Bad(path, where + "unknown format " + Quote(w[1]));
  }
  if (CheckDecimal(w[2]) != NumberCheck::kOk) return Bad(path, where + "bad version " + Quote(w[2]));
  return Status::Ok();
}

// 'element <name> <count>'.
StatusOr<PlyElement> ParseElementLine(const std::string& path, const std::string& where,
                                      const std::vector<std::string_view>& w) {
  if (w.size() != 3) return Bad(path, where + "expected 'element <name> <count>'");
  PlyElement element;
  element.name = std::string(w[1]);
  if (!ParseU32(w[2], &element.count)) {
    return Bad(path, where + "element " + Quote(w[1]) + " has count " + Quote(w[2]) +
                         ", not an integer between 0 and " + Num(kU32Max));
  }
  return element;
}

// 'property <type> <name>' or 'property list <count type> <type> <name>',
// appended to `element`.
Status ParsePropertyLine(const std::string& path, const std::string& where,
                         const std::vector<std::string_view>& w, PlyElement* element) {
  PlyProperty property;
  std::string_view type_name;
  if (w.size() == 5 && w[1] == "list") {
    property.count_type = FindPlyType(w[2]);
    type_name = w[3];
    property.name = std::string(w[4]);
    // OpenMesh's reader accepts only these list length types.
    if (w[2] != "uchar" && w[2] != "uint8" && w[2] != "uint16" && w[2] != "int") {
      return Refuse(path, where + "list length type " + Quote(w[2]) +
                              " is not supported (use uchar, uint8, uint16 or int)");
    }
  } else if (w.size() == 3 && w[1] != "list") {
    type_name = w[1];
    property.name = std::string(w[2]);
  } else {
    return Bad(path, where + "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
  }
  property.type = FindPlyType(type_name);
  if (property.type == nullptr) {
    return Refuse(path, where + "property " + Quote(property.name) + " has type " + Quote(type_name) +
                            ", which is not supported");
  }
  if (FindPlyType(property.name) != nullptr || property.name == "list") {
    return Bad(path, where + "property name " + Quote(property.name) + " is a type name");
  }
  for (const PlyProperty& other : element->properties) {
    if (other.name == property.name) {
      return Bad(path, where + "element " + Quote(element->name) + " has property " + Quote(property.name) +
                           " twice");
    }
  }
  element->properties.push_back(std::move(property));
  return Status::Ok();
}

// Stray lines are warned about one by one up to this many, then counted.
constexpr size_t kMaxStrayLineWarnings = 5;
// Characters of a stray line quoted in its warning.
constexpr size_t kStrayLineQuote = 80;

std::string StrayLineWarning(size_t line_no, std::string_view line) {
  while (!line.empty() && IsSpaceChar(line.back())) line.remove_suffix(1);
  const bool cut = line.size() > kStrayLineQuote;
  std::string text = ToValidUtf8(line.substr(0, kStrayLineQuote));
  for (char& c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  }
  return "PLY header line " + Num(line_no) + ": ignored a line that is neither a keyword nor a comment: '" +
         text + (cut ? "...'" : "'");
}

}  // namespace

// Line by line: 'ply', the format line, then keyword lines up to end_header;
// lines that start with no keyword are skipped with a warning.
StatusOr<PlyHeader> ParsePlyHeader(const std::string& path, std::string_view data,
                                   std::vector<std::string>* warnings) {
  PlyHeader header;
  size_t pos = 0;
  size_t line_no = 0;
  size_t stray_lines = 0;
  bool have_format = false;
  auto where = [&]() { return "PLY header line " + Num(line_no) + ": "; };
  while (true) {
    if (pos >= data.size()) return Bad(path, "PLY header has no end_header line");
    size_t end = data.find('\n', pos);
    const bool last = end == std::string_view::npos;
    if (last) end = data.size();
    std::string_view line = data.substr(pos, end - pos);
    pos = last ? data.size() : end + 1;
    ++line_no;
    if (line_no > 100000) return Bad(path, "PLY header is longer than 100000 lines");
    const std::vector<std::string_view> w = SplitWords(line);
    if (line_no == 1) {
      if (w.size() != 1 || w[0] != "ply") return Bad(path, "not a PLY file (the first line is not 'ply')");
      continue;
    }
    if (line_no == 2) {
      MS_RETURN_IF_ERROR(ParseFormatLine(path, where(), w, &header.format));
      have_format = true;
      continue;
    }
    if (w.empty()) continue;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") {
      if (w.size() != 1) return Bad(path, where() + "'end_header' must stand alone");
      header.body_offset = pos;
      header.header_lines = line_no;
      break;
    }
    if (w[0] == "element") {
      MS_ASSIGN_OR_RETURN(PlyElement element, ParseElementLine(path, where(), w));
      header.elements.push_back(std::move(element));
      continue;
    }
    if (w[0] == "property") {
      if (header.elements.empty()) return Bad(path, where() + "property before any element");
      MS_RETURN_IF_ERROR(ParsePropertyLine(path, where(), w, &header.elements.back()));
      continue;
    }
    if (w[0] == "format" || w[0] == "ply") {
      return Bad(path, where() + Quote(w[0]) + " may only stand on line " + (w[0] == "ply" ? "1" : "2"));
    }
    if (++stray_lines <= kMaxStrayLineWarnings) warnings->push_back(StrayLineWarning(line_no, line));
  }
  if (stray_lines > kMaxStrayLineWarnings) {
    warnings->push_back("PLY header: ignored " + Num(stray_lines - kMaxStrayLineWarnings) +
                        " more lines that are neither keywords nor comments");
  }
  if (!have_format) return Bad(path, "PLY header has no format line");
  return header;
}

bool IsVertexFloatProperty(const std::string& n) {
  return n == "x" || n == "y" || n == "z" || n == "nx" || n == "ny" || n == "nz" || n == "u" ||
         n == "v" || n == "s" || n == "t";
}
bool IsColorProperty(const std::string& element, const std::string& n) {
  if (n == "red" || n == "green" || n == "blue" || n == "alpha") return true;
  return element == "vertex" && (n == "diffuse_red" || n == "diffuse_green" || n == "diffuse_blue");
}
bool IsFaceIndexList(const PlyElement& e, const PlyProperty& p) {
  return e.name == "face" && p.is_list() && (p.name == "vertex_indices" || p.name == "vertex_index");
}

bool IsStripsElement(const PlyElement& e) { return e.name == "tristrips"; }

StatusOr<PlyLayout> CheckPlyForOpenMesh(const std::string& path, const PlyHeader& h) {
  int vertex = -1, face = -1, strips = -1;
  for (size_t i = 0; i < h.elements.size(); ++i) {
    const PlyElement& e = h.elements[i];
    if (e.count > 0 && e.properties.empty()) {
      return Bad(path, "PLY element " + Quote(e.name) + " has " + Num(e.count) + " records but no properties");
    }
    if (e.name == "vertex" || e.name == "face" || IsStripsElement(e)) {
      int& slot = e.name == "vertex" ? vertex : e.name == "face" ? face : strips;
      if (slot >= 0) return Bad(path, "PLY header declares element " + Quote(e.name) + " twice");
      slot = static_cast<int>(i);
    }
  }
  if (vertex < 0) return Bad(path, "PLY file has no 'vertex' element");
  if (face < 0 && strips < 0) {
    return Bad(path, "no triangles: the PLY file has no 'face' or 'tristrips' element");
  }
  if (face >= 0 && face < vertex) {
    return Refuse(path, "PLY 'face' element before the 'vertex' element is not supported");
  }
  if (strips >= 0) {
    const PlyElement& e = h.elements[static_cast<size_t>(strips)];
    if (static_cast<size_t>(strips) + 1 != h.elements.size()) {
      // OpenMesh reads every element of the header it is given; the strips
      // are hidden from it, which works only when nothing follows them.
      return Refuse(path, "PLY element 'tristrips' must be the last element (element " +
                              Quote(h.elements[static_cast<size_t>(strips) + 1].name) + " follows it)");
    }
    if (e.properties.size() != 1 || !e.properties[0].is_list() || e.properties[0].name != "vertex_indices") {
      return Refuse(path, "PLY element 'tristrips' must have exactly one property, the list "
                          "'vertex_indices'");
    }
    if (e.properties[0].type->is_float) {
      return Refuse(path, "PLY tristrips property 'vertex_indices' has float entries; vertex indices "
                          "must be integers");
    }
  }
  const bool binary = h.format != PlyFormat::kAscii;
  const size_t last_checked = static_cast<size_t>(face >= 0 ? face : vertex);
  for (size_t i = 0; i <= last_checked; ++i) {
    const PlyElement& e = h.elements[i];
    bool has_indices = false;
    for (const PlyProperty& p : e.properties) {
      const std::string what = "PLY " + e.name + " property " + Quote(p.name);
      if (IsFaceIndexList(e, p)) {
        if (has_indices) return Bad(path, "PLY face element has two vertex index lists");
        if (&p != &e.properties.front()) {
          // OpenMesh forgets the properties declared before the index list
          // and would read the face records misaligned.
          return Refuse(path, "PLY face properties before 'vertex_indices' are not supported (" +
                                  Quote(e.properties.front().name) + " comes first)");
        }
        has_indices = true;
        if (p.type->is_float) return Refuse(path, what + " has float entries; vertex indices must be integers");
        continue;
      }
      if (p.is_list()) {
        return Refuse(path, what + " is a list; OpenMesh's PLY reader supports lists only for face "
                                   "vertex_indices");
      }
      if (!binary) continue;
      // Binary: OpenMesh reads these with type-specific code that skips no
      // bytes for other types, which would shift everything after.
      if (e.name == "vertex" && IsVertexFloatProperty(p.name) && !p.type->is_float) {
        return Refuse(path, what + " has type " + p.type->name + "; binary PLY coordinates, normals "
                                   "and texture coordinates must be float or double");
      }
      if ((e.name == "vertex" || e.name == "face") && IsColorProperty(e.name, p.name) && p.type->size == 8) {
        return Refuse(path, what + " has type double; colours must be integers or float");
      }
    }
    if (i == static_cast<size_t>(face) && !has_indices) {
      return Bad(path, "PLY face element has no 'vertex_indices' list");
    }
  }
  const PlyElement& v = h.elements[static_cast<size_t>(vertex)];
  for (const char* axis : {"x", "y", "z"}) {
    bool found = false;
    for (const PlyProperty& p : v.properties) found = found || p.name == axis;
    if (!found) return Bad(path, std::string("PLY vertex element has no '") + axis + "' property");
  }
  PlyLayout layout;
  layout.vertex = static_cast<size_t>(vertex);
  if (face >= 0) layout.face = static_cast<size_t>(face);
  if (strips >= 0) layout.strips = static_cast<size_t>(strips);
  return layout;
}

// The header as OpenMesh will parse it: one canonical line per item, so that
// OpenMesh's token-based header parser and its binary-offset arithmetic
// ("end_header" + newline, counted from the previous token) agree with ours.
// The tristrips element (the last one) is left out: OpenMesh would not read
// it, and stops before its bytes.
std::string CanonicalPlyHeader(const PlyHeader& h) {
  std::string s = "ply\nformat ";
  s += PlyFormatName(h.format);
  s += " 1.0\n";
  for (const PlyElement& e : h.elements) {
    if (IsStripsElement(e)) continue;
    s += "element " + e.name + " " + Num(e.count) + "\n";
    for (const PlyProperty& p : e.properties) {
      if (p.is_list()) {
        s += std::string("property list ") + p.count_type->name + " " + p.type->name + " " + p.name + "\n";
      } else {
        s += std::string("property ") + p.type->name + " " + p.name + "\n";
      }
    }
  }
  s += "end_header\n";
  return s;
}

}  // namespace mesh_io
}  // namespace meshstream
