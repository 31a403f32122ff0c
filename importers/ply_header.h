// The PLY header: parsed strictly by us before OpenMesh sees the file,
// checked for what OpenMesh's reader would misread, loop on or silently drop,
// and rewritten canonically for it.
//
// Contract: ParsePlyHeader reads the lines up to end_header: 'ply', then
// 'format <ascii|binary_little_endian|binary_big_endian> <version>', then
// comment / obj_info / element / property lines and end_header. A line that
// is none of these keywords (old Blender exporters write "Created by
// Blender3D 247 - www.blender.org, source file: ..." as the third line) is
// ignored with a warning naming its line number and text; an element,
// property, format or end_header line with the wrong words is an error
// naming the line. CheckPlyForOpenMesh refuses the layouts OpenMesh's reader
// cannot read correctly (Unsupported) or that hold no mesh (InvalidInput).
// CanonicalPlyHeader writes the header OpenMesh will parse: one canonical
// line per element and property, no comments, stray lines, CRLF or
// 'tristrips' element.
// Safe on untrusted input: at most 100000 header lines are read; counts are
// parsed as 32-bit integers and nothing is allocated per declared record.
// Thread safety: pure functions.
#ifndef MESHSTREAM_IMPORTERS_PLY_HEADER_H_
#define MESHSTREAM_IMPORTERS_PLY_HEADER_H_

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {
namespace mesh_io {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyType {
  const char* name;
  int size;
  bool is_float;
  bool is_signed;
};

// The type names OpenMesh's PLY reader knows (get_property_type).

// The PLY type called `name` among the ones OpenMesh knows, or nullptr.
const PlyType* FindPlyType(std::string_view name);

struct PlyProperty {
  std::string name;
  const PlyType* type = nullptr;        // the value type (entry type of a list)
  const PlyType* count_type = nullptr;  // set for lists
  bool is_list() const { return count_type != nullptr; }
};

struct PlyElement {
  std::string name;
  uint32_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;   // first byte after the end_header line
  size_t header_lines = 0;  // lines up to and including end_header
};

const char* PlyFormatName(PlyFormat f);

// Parses the header of `data` (the whole file). Warnings (stray lines) are
// appended to `warnings`.
StatusOr<PlyHeader> ParsePlyHeader(const std::string& path, std::string_view data,
                                   std::vector<std::string>* warnings);

// The vertex properties OpenMesh reads as floats (coordinates, normals, uv).
bool IsVertexFloatProperty(const std::string& n);
// The properties OpenMesh reads as colours of `element`.
bool IsColorProperty(const std::string& element, const std::string& n);
// The face element's list of vertex indices.
bool IsFaceIndexList(const PlyElement& e, const PlyProperty& p);
// The element of triangle strips ('tristrips'), read by us, not OpenMesh.
bool IsStripsElement(const PlyElement& e);

constexpr size_t kNoElement = std::numeric_limits<size_t>::max();

struct PlyLayout {
  size_t vertex = 0;           // element indices
  size_t face = kNoElement;    // kNoElement: none (then there are strips)
  size_t strips = kNoElement;  // 'tristrips', always the last element
  // The last element whose values OpenMesh reads and we check.
  size_t last_checked() const { return face != kNoElement ? face : vertex; }
};


// Everything OpenMesh's PLY reader would misread, loop on, or silently drop.
StatusOr<PlyLayout> CheckPlyForOpenMesh(const std::string& path, const PlyHeader& h);

// The header as OpenMesh will parse it: one canonical line per item, so that
// OpenMesh's token-based header parser and its binary-offset arithmetic
// ("end_header" + newline, counted from the previous token) agree with ours.
// The tristrips element (the last one) is left out: OpenMesh would not read
// it, and stops before its bytes.
std::string CanonicalPlyHeader(const PlyHeader& h);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_PLY_HEADER_H_
