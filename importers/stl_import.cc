// STL into a Primitive (see stl_import.h).
#include "importers/stl_import.h"

#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/reader/STLReader.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <istream>
#include <locale>

#include "importers/openmesh_reader.h"
#include "importers/text_scan.h"
#include "importers/two_part_streambuf.h"

namespace meshstream {
namespace mesh_io {
namespace {

struct StlInfo {
  bool binary = false;
  uint64_t triangles = 0;
};

float ReadFloatLE(const uint8_t* p) {
  const uint32_t bits = static_cast<uint32_t>(ReadUnsigned(p, 4, false));
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

bool LooksLikeText(std::string_view data) {
  for (char ch : data) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x20 && c != '\n' && c != '\r' && c != '\t' && c != '\v' && c != '\f') return false;
  }
  return true;
}

// Binary: every corner coordinate of the `declared` records is finite (the
// size was checked by the caller; facet normals are not read).
StatusOr<StlInfo> CheckBinaryStl(const std::string& path, const uint8_t* bytes, uint64_t declared) {
  StlInfo info;
  info.binary = true;
  info.triangles = declared;
  for (uint64_t t = 0; t < declared; ++t) {
    const uint8_t* record = bytes + 84 + 50 * t;
    for (int c = 3; c < 12; ++c) {  // skip the facet normal (unused)
      const float value = ReadFloatLE(record + 4 * c);
      if (!std::isfinite(value)) {
        return Bad(path, "triangle " + Num(t) + ": corner " + Num(c / 3 - 1) +
                             " has a coordinate that is not a finite number");
      }
    }
  }
  return info;
}

// Ascii: OpenMesh takes a line containing "outer" (or "OUTER") as the start
// of a facet and reads the next three lines as "<word> x y z".
StatusOr<StlInfo> CheckAsciiStl(const std::string& path, std::string_view data) {
  StlInfo info;
  size_t pos = 0, line_no = 0;
  auto next_line = [&](std::string_view* line) {
    if (pos >= data.size()) return false;
    size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    *line = data.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    return true;
  };
  std::string_view line;
  while (next_line(&line)) {
    if (line.find("outer") == std::string_view::npos && line.find("OUTER") == std::string_view::npos) continue;
    for (int corner = 0; corner < 3; ++corner) {
      if (!next_line(&line)) {
        return Bad(path, "truncated: the file ends inside facet " + Num(info.triangles));
      }
      const std::vector<std::string_view> w = SplitWords(line);
      std::string keyword = w.empty() ? "" : std::string(w[0]);
      std::transform(keyword.begin(), keyword.end(), keyword.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (w.size() < 4 || keyword != "vertex") {
        return Bad(path, "STL line " + Num(line_no) + ": facet " + Num(info.triangles) +
                             ": expected 'vertex x y z'");
      }
      for (int k = 1; k < 4; ++k) {
        const NumberCheck check = CheckDecimal(w[static_cast<size_t>(k)]);
        if (check != NumberCheck::kOk) {
          return Bad(path, "STL line " + Num(line_no) + ": facet " + Num(info.triangles) + ": " +
                               DescribeBadNumber(check, w[static_cast<size_t>(k)]));
        }
      }
    }
    ++info.triangles;
  }
  return info;
}

// Binary when the size is exactly 84 + 50 n (as OpenMesh decides), ascii when
// the file is text starting with "solid", else an error naming the count.
StatusOr<StlInfo> CheckStl(const std::string& path, std::string_view data) {
  const uint8_t* bytes = reinterpret_cast<const uint8_t*>(data.data());
  uint64_t declared = 0;
  if (data.size() >= 84) declared = ReadUnsigned(bytes + 80, 4, false);
  if (data.size() >= 84 && data.size() == 84 + 50 * declared) return CheckBinaryStl(path, bytes, declared);
  std::string_view start = data;
  while (!start.empty() && IsSpaceChar(start.front())) start.remove_prefix(1);
  const bool ascii_like = start.substr(0, 5) == "solid" && LooksLikeText(data);
  if (!ascii_like) {
    if (data.size() < 84) return Bad(path, "not an STL file (too short for binary STL, and not ascii 'solid')");
    return Bad(path, "binary STL declares " + Num(declared) + " triangles, which need " +
                         Num(84 + 50 * declared) + " bytes, but the file has " + Num(data.size()));
  }
  return CheckAsciiStl(path, data);
}

}  // namespace

StatusOr<Primitive> ImportStl(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(StlInfo info, CheckStl(path, data));
  if (info.triangles == 0) return Bad(path, "no triangles: the STL file has no facets");
  MeshRecorder recorder(3 * info.triangles, info.triangles, 3 * info.triangles);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "STL", [&]() {
    TwoPartStreamBuf buffer(std::string_view(), data);
    std::istream in(&buffer);
    in.imbue(std::locale::classic());
    OpenMesh::IO::Options options;
    if (info.binary) options += OpenMesh::IO::Options::Binary;
    return OpenMesh::IO::STLReader().read(in, recorder, options);
  }));
  if (recorder.face_starts.size() < info.triangles) {
    warnings->push_back("STL: dropped " + Num(info.triangles - recorder.face_starts.size()) + " of " +
                        Num(info.triangles) + " triangles with two corners at the same position");
  }
  return PrimitiveFromRecorder(path, recorder, warnings);
}

}  // namespace mesh_io
}  // namespace meshstream
