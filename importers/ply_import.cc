// PLY into a Primitive (see ply_import.h).
#include "importers/ply_import.h"

#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/reader/PLYReader.hh>

#include <cstdint>
#include <istream>
#include <limits>
#include <locale>

#include "importers/openmesh_reader.h"
#include "importers/ply_header.h"
#include "importers/text_scan.h"
#include "importers/two_part_streambuf.h"

namespace meshstream {
namespace mesh_io {
namespace {

std::string RecordName(const PlyElement& e, uint64_t r) {
  return e.name + " " + Num(r) + " of " + Num(e.count);
}

// Marks a restart in PlyBodyStats::strips (never a valid vertex index: a
// PLY has at most 2^32 - 1 vertices).
constexpr uint32_t kStripRestart = std::numeric_limits<uint32_t>::max();

struct PlyBodyStats {
  uint64_t face_corners = 0;
  // Every tristrips entry in file order, kStripRestart for -1 and after each
  // record; every other entry is a checked vertex index.
  std::vector<uint32_t> strips;
};

// Checks one tristrips entry (entry k of record r) and appends it.
Status AddStripEntry(const std::string& path, const PlyElement& e, uint64_t r, uint64_t k, int64_t value,
                     uint64_t vertex_count, std::vector<uint32_t>* strips) {
  if (value == -1) {
    strips->push_back(kStripRestart);
    return Status::Ok();
  }
  if (value < 0) {
    return Bad(path, RecordName(e, r) + ": entry " + Num(k) + " is " + std::to_string(value) +
                         " (a strip index must be -1, a restart, or a vertex index)");
  }
  if (static_cast<uint64_t>(value) >= vertex_count) {
    return Bad(path, RecordName(e, r) + ": entry " + Num(k) + " names vertex " +
                         Num(static_cast<uint64_t>(value)) + ", out of range (the file has " +
                         Num(vertex_count) + " vertices)");
  }
  strips->push_back(static_cast<uint32_t>(value));
  return Status::Ok();
}

// glTF's TRIANGLE_STRIP within each run between restarts: triangle i is
// (v[i], v[i+1], v[i+2]) for even i, (v[i+1], v[i], v[i+2]) for odd i;
// triangles repeating a vertex (restart degenerates) are skipped.
void AppendStripTriangles(const std::vector<uint32_t>& strips, std::vector<uint32_t>* indices) {
  size_t run = 0;
  while (run < strips.size()) {
    size_t end = run;
    while (end < strips.size() && strips[end] != kStripRestart) ++end;
    for (size_t i = run; i + 2 < end; ++i) {
      const bool odd = (i - run) % 2 == 1;
      const uint32_t a = odd ? strips[i + 1] : strips[i];
      const uint32_t b = odd ? strips[i] : strips[i + 1];
      const uint32_t c = strips[i + 2];
      if (a == b || b == c || a == c) continue;
      indices->push_back(a);
      indices->push_back(b);
      indices->push_back(c);
    }
    run = end + 1;
  }
}

// Reads a list length of type `t`; negative lengths come back as < 0.
int64_t ReadListLength(const uint8_t* p, const PlyType* t, bool big_endian) {
  const uint64_t raw = ReadUnsigned(p, t->size, big_endian);
  if (!t->is_signed) return static_cast<int64_t>(raw);
  const uint64_t sign = uint64_t{1} << (8 * t->size - 1);
  if (raw & sign) return static_cast<int64_t>(raw) - static_cast<int64_t>(sign << 1);
  return static_cast<int64_t>(raw);
}

Status WalkPlyBinary(const std::string& path, const PlyHeader& h, const PlyLayout& layout,
                     std::string_view body, PlyBodyStats* stats) {
  const bool big = h.format == PlyFormat::kBinaryBigEndian;
  const uint8_t* data = reinterpret_cast<const uint8_t*>(body.data());
  const uint64_t size = body.size();
  // First the cheap bound: every record at its smallest (lists empty).
  uint64_t minimum = 0;
  for (const PlyElement& e : h.elements) {
    uint64_t record = 0;
    for (const PlyProperty& p : e.properties) record += p.is_list() ? p.count_type->size : p.type->size;
    if (!MulAdd(e.count, record, &minimum) || minimum > size) {
      return Bad(path, "PLY header declares " + Num(e.count) + " " + e.name + " records (at least " +
                           Num(record) + " bytes each), more than the " + Num(size) +
                           " bytes after the header can hold");
    }
  }
  uint64_t offset = 0;
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const PlyElement& e = h.elements[ei];
    bool has_list = false;
    uint64_t record = 0;
    for (const PlyProperty& p : e.properties) {
      has_list = has_list || p.is_list();
      record += p.is_list() ? 0 : p.type->size;
    }
    if (!has_list) {
      uint64_t need = 0;
      if (!MulAdd(e.count, record, &need) || need > size - offset) {
        return Bad(path, "truncated: the file ends inside " + RecordName(e, (size - offset) / record));
      }
      offset += need;
      continue;
    }
    for (uint64_t r = 0; r < e.count; ++r) {
      for (const PlyProperty& p : e.properties) {
        if (!p.is_list()) {
          if (static_cast<uint64_t>(p.type->size) > size - offset) {
            return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
          }
          offset += p.type->size;
          continue;
        }
        if (static_cast<uint64_t>(p.count_type->size) > size - offset) {
          return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
        }
        const int64_t length = ReadListLength(data + offset, p.count_type, big);
        offset += p.count_type->size;
        if (length < 0) {
          return Bad(path, RecordName(e, r) + ": list " + Quote(p.name) + " has negative length " +
                               std::to_string(length));
        }
        const bool indices = ei == layout.face && IsFaceIndexList(e, p);
        if (indices && length < 3) {
          return Bad(path, RecordName(e, r) + " has " + std::to_string(length) +
                               " corners (a face needs at least 3)");
        }
        const uint64_t bytes = static_cast<uint64_t>(length) * static_cast<uint64_t>(p.type->size);
        if (bytes > size - offset) {
          return Bad(path, "truncated: " + RecordName(e, r) + " declares " + Num(static_cast<uint64_t>(length)) +
                               " list entries, more than the file holds");
        }
        if (ei == layout.strips) {
          const uint64_t vertex_count = h.elements[layout.vertex].count;
          for (int64_t k = 0; k < length; ++k) {
            const int64_t value = ReadListLength(data + offset + static_cast<uint64_t>(k) * p.type->size,
                                                 p.type, big);
            MS_RETURN_IF_ERROR(AddStripEntry(path, e, r, static_cast<uint64_t>(k), value, vertex_count,
                                             &stats->strips));
          }
          stats->strips.push_back(kStripRestart);
        }
        offset += bytes;
        if (indices) stats->face_corners += static_cast<uint64_t>(length);
      }
    }
  }
  return Status::Ok();
}

Status WalkPlyAscii(const std::string& path, const PlyHeader& h, const PlyLayout& layout,
                    std::string_view body, PlyBodyStats* stats) {
  // The cheap bound first: a value takes at least two bytes (a digit and a
  // separator), a list at least its length.
  uint64_t minimum = 0;
  for (const PlyElement& e : h.elements) {
    if (!MulAdd(e.count, 2 * e.properties.size(), &minimum) || minimum > body.size() + 1) {
      return Bad(path, "PLY header declares " + Num(e.count) + " " + e.name + " records (" +
                           Num(e.properties.size()) + " values each, at least 2 bytes per value), more than "
                           "the " + Num(body.size()) + " bytes after the header can hold");
    }
  }
  Tokens tokens(body, h.header_lines + 1);
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const PlyElement& e = h.elements[ei];
    const bool read_by_openmesh = ei <= layout.last_checked();
    const bool strips = ei == layout.strips;
    for (uint64_t r = 0; r < e.count; ++r) {
      for (const PlyProperty& p : e.properties) {
        auto where = [&]() { return "line " + Num(tokens.line()) + ": " + RecordName(e, r) + ": "; };
        std::string_view t = tokens.Next();
        if (t.empty()) return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
        if (p.is_list()) {
          uint32_t length = 0;
          if (!ParseU32(t, &length)) {
            return Bad(path, where() + "list length " + Quote(t) + " is not a non-negative integer");
          }
          const bool indices = ei == layout.face && IsFaceIndexList(e, p);
          if (indices && length < 3) {
            return Bad(path, "line " + Num(tokens.line()) + ": " + RecordName(e, r) + " has " + Num(length) +
                                 " corners (a face needs at least 3)");
          }
          if (indices) stats->face_corners += length;
          for (uint32_t k = 0; k < length; ++k) {
            t = tokens.Next();
            if (t.empty()) return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
            uint32_t index = 0;
            if (indices && !ParseU32(t, &index)) {
              return Bad(path, where() + "vertex index " + Quote(t) + " is not a non-negative integer");
            }
            if (strips) {
              int64_t value = -1;
              if (t != "-1") {
                if (!ParseU32(t, &index)) {
                  return Bad(path, where() + "entry " + Num(k) + ": strip index " + Quote(t) +
                                       " is neither -1 nor a non-negative integer");
                }
                value = index;
              }
              MS_RETURN_IF_ERROR(AddStripEntry(path, e, r, k, value, h.elements[layout.vertex].count,
                                               &stats->strips));
            }
          }
          if (strips) stats->strips.push_back(kStripRestart);
          continue;
        }
        if (!read_by_openmesh) continue;
        const bool float_read = (e.name == "vertex" && IsVertexFloatProperty(p.name)) ||
                                (IsColorProperty(e.name, p.name) && p.type->is_float && p.type->size == 4);
        const bool int_read = IsColorProperty(e.name, p.name) && !float_read;
        if (float_read) {
          const NumberCheck check = CheckDecimal(t);
          if (check != NumberCheck::kOk) {
            return Bad(path, where() + "property " + Quote(p.name) + ": " + DescribeBadNumber(check, t));
          }
        } else if (int_read && !IsInt32Token(t)) {
          return Bad(path, where() + "property " + Quote(p.name) + ": " + Quote(t) + " is not an integer");
        }
      }
    }
  }
  return Status::Ok();
}

}  // namespace

StatusOr<Primitive> ImportPly(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(PlyHeader header, ParsePlyHeader(path, data, warnings));
  MS_ASSIGN_OR_RETURN(PlyLayout layout, CheckPlyForOpenMesh(path, header));
  const std::string_view body = data.substr(header.body_offset);
  PlyBodyStats stats;
  if (header.format == PlyFormat::kAscii) {
    MS_RETURN_IF_ERROR(WalkPlyAscii(path, header, layout, body, &stats));
  } else {
    MS_RETURN_IF_ERROR(WalkPlyBinary(path, header, layout, body, &stats));
  }
  const uint64_t vertex_count = header.elements[layout.vertex].count;
  const uint64_t face_count = layout.face != kNoElement ? header.elements[layout.face].count : 0;
  std::vector<uint32_t> strip_triangles;
  AppendStripTriangles(stats.strips, &strip_triangles);
  stats.strips = std::vector<uint32_t>();
  if (face_count == 0 && strip_triangles.empty()) {
    return Bad(path, "no triangles: the PLY file has " + Num(vertex_count) + " vertices but no faces" +
                         (layout.strips != kNoElement ? " and no non-degenerate strip triangles" : ""));
  }

  MeshRecorder recorder(vertex_count, face_count, stats.face_corners);
  const std::string head = CanonicalPlyHeader(header);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "PLY", [&]() {
    TwoPartStreamBuf buffer(head, body);
    std::istream in(&buffer);
    in.imbue(std::locale::classic());
    OpenMesh::IO::Options options;
    options += OpenMesh::IO::Options::VertexNormal;
    options += OpenMesh::IO::Options::VertexColor;
    options += OpenMesh::IO::Options::VertexTexCoord;
    return OpenMesh::IO::PLYReader().read(in, recorder, options);
  }));
  if (recorder.positions.size() != vertex_count || recorder.face_starts.size() != face_count) {
    return Bad(path, "OpenMesh's PLY reader delivered " + Num(recorder.positions.size()) + " of " +
                         Num(vertex_count) + " vertices and " + Num(recorder.face_starts.size()) + " of " +
                         Num(face_count) + " faces");
  }
  MS_ASSIGN_OR_RETURN(Primitive prim, PrimitiveFromRecorder(path, recorder, warnings));
  prim.indices.insert(prim.indices.end(), strip_triangles.begin(), strip_triangles.end());
  return prim;
}

}  // namespace mesh_io
}  // namespace meshstream
