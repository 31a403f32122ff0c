// OFF into a Primitive (see off_import.h).
#include "importers/off_import.h"

#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/reader/OFFReader.hh>

#include <algorithm>
#include <cstdint>

#include "importers/openmesh_reader.h"
#include "importers/text_scan.h"

namespace meshstream {
namespace mesh_io {
namespace {

struct OffInfo {
  bool colors = false;
  bool normals = false;
  uint32_t vertices = 0;
  uint32_t faces = 0;
  uint64_t corners = 0;
};

// The first line: [C][N]OFF and nothing else (the counts come on the next
// line). Sets info->colors and info->normals.
Status CheckOffKeyword(const std::string& path, std::string_view first, OffInfo* info) {
  while (!first.empty() && IsSpaceChar(first.back())) first.remove_suffix(1);
  std::string_view keyword = first.substr(0, std::min(first.find_first_of(" \t"), first.size()));
  if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF") {
    return Bad(path, "not an OFF file (the first line does not start with OFF)");
  }
  std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  if (prefix.size() >= 2 && prefix.substr(0, 2) == "ST") {
    return Refuse(path, "OFF with texture coordinates (STOFF) is not supported");
  }
  if (!prefix.empty() && prefix[0] == 'C') {
    info->colors = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty() && prefix[0] == 'N') {
    info->normals = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty()) return Refuse(path, "OFF variant " + Quote(keyword) + " is not supported");
  if (first.size() > keyword.size()) {
    std::string_view rest = first.substr(keyword.size());
    while (!rest.empty() && IsSpaceChar(rest.front())) rest.remove_prefix(1);
    if (rest == "BINARY") return Refuse(path, "binary OFF is not supported");
    return Bad(path, "OFF line 1: the counts must be on the line after " + Quote(keyword));
  }
  return Status::Ok();
}

// The vertex, face and edge counts, checked against the bytes of `text`
// (everything after the first line): a vertex needs at least 3 values, a
// face 4 ("3 a b c"), each 2 bytes.
Status ReadOffCounts(const std::string& path, std::string_view text, uint64_t file_size, Tokens* tokens,
                     OffInfo* info) {
  uint32_t counts[3] = {0, 0, 0};
  const char* count_names[3] = {"vertex", "face", "edge"};
  for (int i = 0; i < 3; ++i) {
    std::string_view t = tokens->Next();
    if (t.empty()) return Bad(path, "OFF file ends before its vertex, face and edge counts");
    if (!ParseU32(t, &counts[i])) {
      return Bad(path, "OFF line " + Num(tokens->line()) + ": " + count_names[i] + " count " + Quote(t) +
                           " is not an integer between 0 and " + Num(kU32Max));
    }
  }
  info->vertices = counts[0];
  info->faces = counts[1];
  uint64_t minimum = 0;
  if (!MulAdd(info->vertices, 6, &minimum) || !MulAdd(info->faces, 8, &minimum) ||
      minimum > text.size() + 1) {
    return Bad(path, "OFF header declares " + Num(info->vertices) + " vertices and " + Num(info->faces) +
                         " faces, more than the " + Num(file_size) + " bytes of the file can hold");
  }
  return Status::Ok();
}

// COFF colour fields: OpenMesh counts them by single spaces; anything but
// 0, 3 or 4 plain numbers would be misread or reported on std::cerr.
Status CheckOffColour(const std::string& path, std::string_view rest, const std::string& what) {
  while (!rest.empty() && IsSpaceChar(rest.back())) rest.remove_suffix(1);
  while (!rest.empty() && IsSpaceChar(rest.front())) rest.remove_prefix(1);
  if (rest.empty()) return Status::Ok();
  const std::vector<std::string_view> words = SplitWords(rest);
  bool single_spaced = true;
  for (char c : rest) single_spaced = single_spaced && (c != '\t' && c != '\r' && c != '\v' && c != '\f');
  single_spaced = single_spaced && rest.find("  ") == std::string_view::npos;
  if ((words.size() != 3 && words.size() != 4) || !single_spaced) {
    return Bad(path, what + ": colour must be 3 or 4 numbers separated by single spaces");
  }
  for (std::string_view w : words) {
    if (CheckDecimal(w) != NumberCheck::kOk) {
      return Bad(path, what + ": colour " + DescribeBadNumber(CheckDecimal(w), w));
    }
  }
  return Status::Ok();
}

// Each vertex: 3 (6 with N) numbers, then the rest of its line (a COFF colour).
Status CheckOffVertices(const std::string& path, const OffInfo& info, Tokens* tokens) {
  const int values_per_vertex = info.normals ? 6 : 3;
  for (uint64_t v = 0; v < info.vertices; ++v) {
    for (int k = 0; k < values_per_vertex; ++k) {
      std::string_view t = tokens->Next();
      if (t.empty()) return Bad(path, "truncated: the file ends inside vertex " + Num(v) + " of " + Num(info.vertices));
      const NumberCheck check = CheckDecimal(t);
      if (check != NumberCheck::kOk) {
        return Bad(path, "OFF line " + Num(tokens->line()) + ": vertex " + Num(v) + ": " +
                             DescribeBadNumber(check, t));
      }
    }
    const size_t line = tokens->line();
    std::string_view rest = tokens->RestOfLine();
    if (info.colors) MS_RETURN_IF_ERROR(CheckOffColour(path, rest, "OFF line " + Num(line) + ": vertex " + Num(v)));
  }
  return Status::Ok();
}

// Each face: a corner count of at least 3, that many indices, then the rest
// of its line (a colour for COFF, nothing otherwise). Counts the corners.
Status CheckOffFaces(const std::string& path, Tokens* tokens, OffInfo* info) {
  for (uint64_t f = 0; f < info->faces; ++f) {
    std::string_view t = tokens->Next();
    if (t.empty()) return Bad(path, "truncated: the file ends before face " + Num(f) + " of " + Num(info->faces));
    uint32_t length = 0;
    if (!ParseU32(t, &length)) {
      return Bad(path, "OFF line " + Num(tokens->line()) + ": face " + Num(f) + ": corner count " + Quote(t) +
                           " is not a non-negative integer");
    }
    if (length < 3) {
      return Bad(path, "OFF line " + Num(tokens->line()) + ": face " + Num(f) + " of " + Num(info->faces) +
                           " has " + Num(length) + " corners (a face needs at least 3)");
    }
    for (uint32_t k = 0; k < length; ++k) {
      t = tokens->Next();
      if (t.empty()) return Bad(path, "truncated: the file ends inside face " + Num(f) + " of " + Num(info->faces));
      uint32_t index = 0;
      if (!ParseU32(t, &index)) {
        return Bad(path, "OFF line " + Num(tokens->line()) + ": face " + Num(f) + ": vertex index " + Quote(t) +
                             " is not a non-negative integer");
      }
    }
    info->corners += length;
    const size_t line = tokens->line();
    std::string_view rest = tokens->RestOfLine();
    const std::string what = "OFF line " + Num(line) + ": face " + Num(f);
    if (info->colors) {
      MS_RETURN_IF_ERROR(CheckOffColour(path, rest, what));
    } else if (!SplitWords(rest).empty()) {
      return Bad(path, what + ": unexpected values after its " + Num(length) +
                           " corners (face colours need a COFF header)");
    }
  }
  return Status::Ok();
}

// Mirrors OpenMesh's ascii OFF reader token by token: counts with `>>`, each
// vertex as 3 (6 with N) values with `>>` and then the rest of its line,
// each face as a length and that many indices with `>>` (then, for COFF, the
// rest of its line).
StatusOr<OffInfo> CheckOff(const std::string& path, std::string_view data) {
  OffInfo info;
  const size_t first_end = std::min(data.find('\n'), data.size());
  MS_RETURN_IF_ERROR(CheckOffKeyword(path, data.substr(0, first_end), &info));
  const std::string_view text = data.substr(std::min(first_end + 1, data.size()));
  const size_t hash = text.find('#');
  if (hash != std::string_view::npos) {
    const size_t line = 2 + static_cast<size_t>(std::count(text.begin(), text.begin() + hash, '\n'));
    return Refuse(path, "OFF line " + Num(line) + ": comments after the first line are not supported");
  }
  Tokens tokens(text, 2);
  MS_RETURN_IF_ERROR(ReadOffCounts(path, text, data.size(), &tokens, &info));
  MS_RETURN_IF_ERROR(CheckOffVertices(path, info, &tokens));
  MS_RETURN_IF_ERROR(CheckOffFaces(path, &tokens, &info));
  return info;
}

}  // namespace

StatusOr<Primitive> ImportOff(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(OffInfo info, CheckOff(path, data));
  if (info.faces == 0) {
    return Bad(path, "no triangles: the OFF file has " + Num(info.vertices) + " vertices but no faces");
  }
  MeshRecorder recorder(info.vertices, info.faces, info.corners);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "OFF", [&]() {
    OpenMesh::IO::Options options;
    options += OpenMesh::IO::Options::VertexNormal;
    options += OpenMesh::IO::Options::VertexColor;
    // By name: only can_u_read(filename) sets the reader's NOFF/COFF flags.
    if (!OpenMesh::IO::OFFReader().can_u_read(path)) return false;
    return OpenMesh::IO::OFFReader().read(path, recorder, options);
  }));
  if (recorder.positions.size() != info.vertices || recorder.face_starts.size() != info.faces) {
    return Bad(path, "OpenMesh's OFF reader delivered " + Num(recorder.positions.size()) + " of " +
                         Num(info.vertices) + " vertices and " + Num(recorder.face_starts.size()) + " of " +
                         Num(info.faces) + " faces (did the file change while it was read?)");
  }
  return PrimitiveFromRecorder(path, recorder, warnings);
}

}  // namespace mesh_io
}  // namespace meshstream
