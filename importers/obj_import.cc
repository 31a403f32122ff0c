// OBJ into a Primitive (see obj_import.h).
#include "importers/obj_import.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <exception>
#include <istream>
#include <new>
#include <unordered_map>
#include <utility>

#include "codec/core/utf8.h"
#include "importers/srgb.h"
#include "importers/text_scan.h"
#include "importers/two_part_streambuf.h"
#include "importers/exception_boundary.h"

namespace meshstream {
namespace mesh_io {
namespace {

// What tinyobjloader does not guard: non-finite numbers (it reads "nan" as
// 0), "t" tag lines (each allocates ~300 KiB whatever its length).
Status PrescanObj(const std::string& path, std::string_view data) {
  size_t pos = 0, line_no = 0;
  while (pos < data.size()) {
    // Lines end at \n, \r or \r\n, as tinyobjloader's safeGetline reads them.
    size_t end = pos;
    while (end < data.size() && data[end] != '\n' && data[end] != '\r') ++end;
    std::string_view line = data.substr(pos, end - pos);
    pos = end + 1;
    if (end + 1 < data.size() && data[end] == '\r' && data[end + 1] == '\n') pos = end + 2;
    ++line_no;
    size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    line.remove_prefix(i);
    if (line.size() < 2) continue;
    const bool space1 = line[1] == ' ' || line[1] == '\t';
    const bool space2 = line.size() > 2 && (line[2] == ' ' || line[2] == '\t');
    if (line[0] == 't' && space1) {
      return Refuse(path, "OBJ line " + Num(line_no) + ": tag lines ('t') are not supported");
    }
    size_t skip = 0;
    if (line[0] == 'v' && space1) {
      skip = 2;
    } else if (line[0] == 'v' && (line[1] == 't' || line[1] == 'n') && space2) {
      skip = 3;
    } else {
      continue;
    }
    Tokens tokens(line.substr(skip), line_no);
    for (std::string_view t = tokens.Next(); !t.empty(); t = tokens.Next()) {
      if (t[0] == '#') break;  // a trailing comment
      const NumberCheck check = CheckDecimal(t);
      if (check != NumberCheck::kOk) {
        return Bad(path, "OBJ line " + Num(line_no) + ": " + DescribeBadNumber(check, t));
      }
    }
  }
  return Status::Ok();
}

// What tinyobjloader read.
struct ObjData {
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
};

// tinyobjloader's warnings that still matter once we checked every index,
// each once, made valid UTF-8 (they may quote names from the file).
void KeepTinyObjWarnings(const std::string& warn, std::vector<std::string>* warnings) {
  size_t begin = 0;
  while (begin < warn.size()) {
    size_t end = warn.find('\n', begin);
    if (end == std::string::npos) end = warn.size();
    std::string w = warn.substr(begin, end - begin);
    begin = end + 1;
    if (w.empty() || w == "." || w.rfind("material", 0) == 0 || w.find("out of bounds") != std::string::npos) {
      continue;
    }
    if (w.rfind("Degenerated face", 0) == 0) w = "OBJ: dropped a face with fewer than 3 corners";
    w = ToValidUtf8(w);
    if (std::find(warnings->begin(), warnings->end(), w) == warnings->end()) warnings->push_back(w);
  }
}

// Runs tinyobjloader over `data`, turning every exception into a Status.
StatusOr<ObjData> LoadWithTinyObj(const std::string& path, std::string_view data,
                                  std::vector<std::string>* warnings) {
  ObjData obj;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  MS_ASSIGN_OR_RETURN(const bool ok, CatchExceptions(path + ": tinyobjloader", [&]() -> StatusOr<bool> {
    TwoPartStreamBuf buffer(std::string_view(), data);
    std::istream in(&buffer);
    // No MaterialReader: mtllib names no file we open; faces keep corners
    // (triangulate = false) so that we fan them ourselves; vertex colours
    // only when every vertex has one.
    return tinyobj::LoadObj(&obj.attrib, &obj.shapes, &materials, &warn, &err, &in, nullptr,
                            /*triangulate=*/false, /*default_vcols_fallback=*/false);
  }));
  if (!ok || !err.empty()) {
    std::string message = ToValidUtf8(err.substr(0, err.find('\n')));
    if (message.empty()) message = "tinyobjloader could not read the file";
    return Bad(path, message);
  }
  KeepTinyObjWarnings(warn, warnings);
  return obj;
}

struct CornerKey {
  int position, texcoord, normal;
  bool operator==(const CornerKey& o) const {
    return position == o.position && texcoord == o.texcoord && normal == o.normal;
  }
};
struct CornerKeyHash {
  size_t operator()(const CornerKey& k) const {
    uint64_t h = static_cast<uint32_t>(k.position);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k.texcoord);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k.normal);
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

// Unifies (position, uv, normal) corners into vertices of `prim`: the first
// corner of position p becomes vertex p, other combinations are appended.
class CornerUnifier {
 public:
  CornerUnifier(const tinyobj::attrib_t& attrib, bool any_texcoord, bool any_normal, bool has_colors,
                Primitive* prim, std::vector<Vec2f>* uv)
      : attrib_(attrib), any_texcoord_(any_texcoord), any_normal_(any_normal), has_colors_(has_colors),
        prim_(prim), uv_(uv), claimed_(prim->positions.size(), 0) {}

  // The vertex of a corner whose indices were checked.
  uint32_t VertexFor(const tinyobj::index_t& i) {
    const CornerKey key{i.vertex_index, i.texcoord_index, i.normal_index};
    const size_t p = static_cast<size_t>(i.vertex_index);
    if (!claimed_[p]) {
      claimed_[p] = 1;
      vertex_of_.emplace(key, static_cast<uint32_t>(p));
      Fill(p, i);
      return static_cast<uint32_t>(p);
    }
    auto found = vertex_of_.find(key);
    if (found != vertex_of_.end()) return found->second;
    const size_t v = prim_->positions.size();
    prim_->positions.push_back(prim_->positions[p]);
    if (any_texcoord_) uv_->push_back({0.f, 0.f});
    if (any_normal_) prim_->normals.push_back({0.f, 0.f, 1.f});
    if (has_colors_) prim_->colors.push_back(prim_->colors[p]);
    Fill(v, i);
    vertex_of_.emplace(key, static_cast<uint32_t>(v));
    return static_cast<uint32_t>(v);
  }

 private:
  void Fill(size_t v, const tinyobj::index_t& i) {
    if (any_texcoord_ && i.texcoord_index >= 0) {
      const size_t t = static_cast<size_t>(i.texcoord_index);
      (*uv_)[v] = {attrib_.texcoords[2 * t], attrib_.texcoords[2 * t + 1]};
    }
    if (any_normal_ && i.normal_index >= 0) {
      const size_t n = static_cast<size_t>(i.normal_index);
      prim_->normals[v] = {attrib_.normals[3 * n], attrib_.normals[3 * n + 1], attrib_.normals[3 * n + 2]};
    }
  }

  const tinyobj::attrib_t& attrib_;
  const bool any_texcoord_, any_normal_, has_colors_;
  Primitive* prim_;
  std::vector<Vec2f>* uv_;
  std::vector<uint8_t> claimed_;
  std::unordered_map<CornerKey, uint32_t, CornerKeyHash> vertex_of_;
};

// Corner c of face f: every index within the file's arrays.
Status CheckCorner(const std::string& path, const tinyobj::index_t& i, uint64_t face, size_t c,
                   size_t position_count, size_t texcoord_count, size_t normal_count) {
  const std::string where = "face " + Num(face) + ": corner " + Num(c) + ": ";
  if (i.vertex_index < 0 || static_cast<size_t>(i.vertex_index) >= position_count) {
    return Bad(path, where + "vertex index " + std::to_string(i.vertex_index + 1) +
                         " is out of range (the file has " + Num(position_count) + " vertices)");
  }
  if (i.texcoord_index >= 0 && static_cast<size_t>(i.texcoord_index) >= texcoord_count) {
    return Bad(path, where + "texture coordinate index " + std::to_string(i.texcoord_index + 1) +
                         " is out of range (the file has " + Num(texcoord_count) + ")");
  }
  if (i.normal_index >= 0 && static_cast<size_t>(i.normal_index) >= normal_count) {
    return Bad(path, where + "normal index " + std::to_string(i.normal_index + 1) +
                         " is out of range (the file has " + Num(normal_count) + ")");
  }
  if (i.texcoord_index < -1 || i.normal_index < -1) {
    return Bad(path, where + "relative attribute index points before the first value");
  }
  return Status::Ok();
}

// Positions and colours of the file, one vertex per position; normals and
// uv filled with defaults when any corner has one.
Primitive PositionsOf(const tinyobj::attrib_t& attrib, bool any_texcoord, bool any_normal, bool has_colors,
                      std::vector<Vec2f>* uv) {
  Primitive prim;
  const size_t position_count = attrib.vertices.size() / 3;
  prim.positions.resize(position_count);
  for (size_t i = 0; i < position_count; ++i) {
    prim.positions[i] = {attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]};
  }
  if (any_texcoord) uv->assign(position_count, Vec2f{0.f, 0.f});
  if (any_normal) prim.normals.assign(position_count, Vec3f{0.f, 0.f, 1.f});
  if (has_colors) {
    prim.colors.resize(position_count);
    for (size_t i = 0; i < position_count; ++i) {
      prim.colors[i] = {SrgbToLinear(attrib.colors[3 * i]), SrgbToLinear(attrib.colors[3 * i + 1]),
                        SrgbToLinear(attrib.colors[3 * i + 2]), 1.f};
    }
  }
  return prim;
}

}  // namespace

StatusOr<Primitive> ImportObj(const std::string& path, std::string_view data, uint64_t* source_vertices,
                              std::vector<std::string>* warnings) {
  MS_RETURN_IF_ERROR(PrescanObj(path, data));
  MS_ASSIGN_OR_RETURN(ObjData obj, LoadWithTinyObj(path, data, warnings));
  const tinyobj::attrib_t& attrib = obj.attrib;
  const size_t position_count = attrib.vertices.size() / 3;
  const size_t texcoord_count = attrib.texcoords.size() / 2;
  const size_t normal_count = attrib.normals.size() / 3;
  const bool has_colors = !attrib.colors.empty() && attrib.colors.size() == attrib.vertices.size();
  if (position_count > kU32Max) return Bad(path, "more than 2^32 - 1 vertices");

  bool any_texcoord = false, any_normal = false;
  for (const tinyobj::shape_t& shape : obj.shapes) {
    uint64_t corners = 0;
    for (unsigned char n : shape.mesh.num_face_vertices) corners += n;
    if (corners != shape.mesh.indices.size()) {
      return Refuse(path, "a face has more than 255 corners");
    }
    for (const tinyobj::index_t& i : shape.mesh.indices) {
      any_texcoord = any_texcoord || i.texcoord_index >= 0;
      any_normal = any_normal || i.normal_index >= 0;
    }
  }

  std::vector<Vec2f> uv;
  Primitive prim = PositionsOf(attrib, any_texcoord, any_normal, has_colors, &uv);
  CornerUnifier unifier(attrib, any_texcoord, any_normal, has_colors, &prim, &uv);
  uint64_t face = 0;
  std::vector<uint32_t> polygon;
  for (const tinyobj::shape_t& shape : obj.shapes) {
    size_t offset = 0;
    for (unsigned char corner_count : shape.mesh.num_face_vertices) {
      polygon.clear();
      for (size_t c = 0; c < corner_count; ++c) {
        const tinyobj::index_t& i = shape.mesh.indices[offset + c];
        MS_RETURN_IF_ERROR(CheckCorner(path, i, face, c, position_count, texcoord_count, normal_count));
        polygon.push_back(unifier.VertexFor(i));
      }
      for (size_t c = 1; c + 1 < polygon.size(); ++c) {
        prim.indices.push_back(polygon[0]);
        prim.indices.push_back(polygon[c]);
        prim.indices.push_back(polygon[c + 1]);
      }
      offset += corner_count;
      ++face;
    }
  }
  if (prim.positions.size() > kU32Max) return Bad(path, "more than 2^32 - 1 vertices after splitting seams");
  if (any_texcoord) prim.texcoords.push_back(std::move(uv));
  *source_vertices = position_count;
  return prim;
}

}  // namespace mesh_io
}  // namespace meshstream
