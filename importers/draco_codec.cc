#include "importers/draco_codec.h"

#include <cstring>
#include <memory>
#include <string>

#include "codec/mesh/quantization.h"
#include "draco/compression/decode.h"
#include "draco/compression/expert_encode.h"
#include "draco/mesh/mesh.h"
#include "importers/exception_boundary.h"

namespace meshstream {

namespace {

// Adds a float attribute with one value per point (identity mapping) and
// returns its id.
template <size_t N>
int AddFloatAttribute(draco::Mesh& mesh, draco::GeometryAttribute::Type type,
                      const std::vector<std::array<float, N>>& values) {
  draco::GeometryAttribute ga;
  ga.Init(type, nullptr, static_cast<uint8_t>(N), draco::DT_FLOAT32, false,
          sizeof(float) * N, 0);
  const int att_id = mesh.AddAttribute(ga, true, static_cast<uint32_t>(values.size()));
  draco::PointAttribute* att = mesh.attribute(att_id);
  // The unique id (named by the glTF extension) is the attribute id, which
  // is what ExpertEncoder's per-attribute options take.
  att->set_unique_id(static_cast<uint32_t>(att_id));
  for (size_t i = 0; i < values.size(); ++i) {
    att->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), values[i].data());
  }
  return att_id;
}

std::string DracoError(const draco::Status& s) { return s.error_msg_string(); }

template <size_t N>
Status ReadAttribute(const draco::Mesh& mesh, int unique_id, const char* name,
                     std::vector<std::array<float, N>>& out) {
  const draco::PointAttribute* att = mesh.GetAttributeByUniqueId(static_cast<uint32_t>(unique_id));
  if (att == nullptr) {
    return InvalidInput(std::string("Draco stream has no attribute with id ") +
                        std::to_string(unique_id) + " for " + name);
  }
  if (att->num_components() < 1 || att->num_components() > N) {
    return InvalidInput(std::string(name) + " has " + std::to_string(att->num_components()) +
                        " components in the Draco stream, expected " + std::to_string(N));
  }
  const uint32_t n = mesh.num_points();
  out.assign(n, std::array<float, N>{});
  for (uint32_t i = 0; i < n; ++i) {
    const draco::AttributeValueIndex avi = att->mapped_index(draco::PointIndex(i));
    if (avi.value() >= att->size()) {
      return InvalidInput(std::string(name) + ": Draco point " + std::to_string(i) +
                          " maps to a missing value");
    }
    std::array<float, N> v{};
    if (N == 4) v[3] = 1.0f;  // colours without alpha are opaque
    if (!att->ConvertValue<float>(avi, att->num_components(), v.data())) {
      return InvalidInput(std::string(name) + ": Draco value cannot be converted to float");
    }
    out[i] = v;
  }
  return Status::Ok();
}

}  // namespace

namespace {

StatusOr<DracoEncoded> EncodeDracoPrimitiveUnguarded(const Primitive& p, const DracoEncodeOptions& options) {
  MS_RETURN_IF_ERROR(CheckQuantizationBits(options.qp, "--qp"));
  MS_RETURN_IF_ERROR(CheckQuantizationBits(options.qn, "--qn"));
  MS_RETURN_IF_ERROR(CheckQuantizationBits(options.qt, "--qt"));
  MS_RETURN_IF_ERROR(CheckQuantizationBits(options.qc, "--qc"));
  if (options.compression_level < 0 || options.compression_level > 10) {
    return InvalidArgument("compression level must be between 0 and 10");
  }
  MS_RETURN_IF_ERROR(ValidatePrimitive(p));
  if (p.face_count() == 0) return InvalidInput("a primitive without triangles cannot be Draco-compressed");

  QuantizationGrid grid;
  if (options.position_grid) {
    grid = *options.position_grid;
  } else {
    MS_ASSIGN_OR_RETURN(grid, PositionGrid(p.positions, p.indices, options.qp));
  }
  if (options.texcoord_grids && options.texcoord_grids->size() != p.texcoords.size()) {
    return InvalidArgument("one texture coordinate grid per TEXCOORD set is needed");
  }
  // Snap to the cell centres first: Draco's float quantizer then lands on the
  // same integer as ours even where a value sits on a rounding boundary.
  std::vector<Vec3f> snapped = p.positions;
  SnapToGrid(snapped, grid);

  draco::Mesh mesh;
  mesh.set_num_points(static_cast<uint32_t>(p.vertex_count()));
  DracoEncoded result;
  result.ids.position = AddFloatAttribute<3>(mesh, draco::GeometryAttribute::POSITION, snapped);
  if (!p.normals.empty()) {
    result.ids.normal = AddFloatAttribute<3>(mesh, draco::GeometryAttribute::NORMAL, p.normals);
  }
  for (const auto& uv : p.texcoords) {
    result.ids.texcoords.push_back(AddFloatAttribute<2>(mesh, draco::GeometryAttribute::TEX_COORD, uv));
  }
  if (!p.colors.empty()) {
    result.ids.color = AddFloatAttribute<4>(mesh, draco::GeometryAttribute::COLOR, p.colors);
  }
  for (size_t f = 0; f < p.face_count(); ++f) {
    const uint32_t a = p.indices[3 * f], b = p.indices[3 * f + 1], c = p.indices[3 * f + 2];
    if (a == b || b == c || a == c) {
      ++result.dropped_faces;
      continue;
    }
    mesh.AddFace({draco::PointIndex(a), draco::PointIndex(b), draco::PointIndex(c)});
  }
  if (mesh.num_faces() == 0) return InvalidInput("every triangle repeats a vertex; nothing to compress");

  draco::ExpertEncoder encoder(mesh);
  const int speed = 10 - options.compression_level;
  encoder.SetSpeedOptions(speed, speed);
  if (options.encoding_method >= 0) {
    encoder.SetEncodingMethod(options.encoding_method == 0 ? draco::MESH_SEQUENTIAL_ENCODING
                                                           : draco::MESH_EDGEBREAKER_ENCODING);
  }
  encoder.SetAttributeExplicitQuantization(result.ids.position, grid.bits, 3, grid.origin.data(), grid.range);
  if (result.ids.normal >= 0) encoder.SetAttributeQuantization(result.ids.normal, options.qn);
  // Texture coordinates and colours always get explicit grids (their own
  // bounding box unless the caller gives one): Draco's automatic range
  // crashes on values whose span overflows a float, GridOf refuses them.
  for (size_t t = 0; t < result.ids.texcoords.size(); ++t) {
    QuantizationGrid g;
    if (options.texcoord_grids) {
      g = (*options.texcoord_grids)[t];
    } else {
      auto own = GridOf(p.texcoords[t], options.qt);
      if (!own.ok()) return own.status().WithContext("TEXCOORD_" + std::to_string(t));
      g = own.value();
    }
    encoder.SetAttributeExplicitQuantization(result.ids.texcoords[t], g.bits, 2, g.origin.data(), g.range);
  }
  if (result.ids.color >= 0) {
    QuantizationGrid g;
    if (options.color_grid) {
      g = *options.color_grid;
    } else {
      auto own = GridOf(p.colors, options.qc);
      if (!own.ok()) return own.status().WithContext("COLOR_0");
      g = own.value();
    }
    encoder.SetAttributeExplicitQuantization(result.ids.color, g.bits, 4, g.origin.data(), g.range);
  }
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeToBuffer(&buffer);
  if (!status.ok()) return Internal("Draco encoding failed: " + DracoError(status));
  result.bytes.assign(reinterpret_cast<const uint8_t*>(buffer.data()),
                      reinterpret_cast<const uint8_t*>(buffer.data()) + buffer.size());
  return result;
}

}  // namespace

StatusOr<DracoEncoded> EncodeDracoPrimitive(const Primitive& p, const DracoEncodeOptions& options) {
  return CatchExceptions(std::string("Draco encode"), [&] { return EncodeDracoPrimitiveUnguarded(p, options); });
}

namespace {

StatusOr<Primitive> DecodeDracoPrimitiveUnguarded(const uint8_t* data, size_t size, const DracoAttributeIds& ids) {
  if (size == 0) return InvalidInput("empty Draco buffer");
  if (ids.position < 0) return InvalidInput("the Draco extension names no POSITION attribute");
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) return InvalidInput("Draco decoding failed: " + DracoError(decoded.status()));
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (!mesh) return InvalidInput("Draco decoding produced no mesh");

  Primitive p;
  MS_RETURN_IF_ERROR(ReadAttribute<3>(*mesh, ids.position, "POSITION", p.positions));
  if (ids.normal >= 0) MS_RETURN_IF_ERROR(ReadAttribute<3>(*mesh, ids.normal, "NORMAL", p.normals));
  for (size_t t = 0; t < ids.texcoords.size(); ++t) {
    p.texcoords.emplace_back();
    const std::string name = "TEXCOORD_" + std::to_string(t);
    MS_RETURN_IF_ERROR(ReadAttribute<2>(*mesh, ids.texcoords[t], name.c_str(), p.texcoords.back()));
  }
  if (ids.color >= 0) MS_RETURN_IF_ERROR(ReadAttribute<4>(*mesh, ids.color, "COLOR_0", p.colors));
  p.indices.reserve(size_t{3} * mesh->num_faces());
  for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f) {
    const draco::Mesh::Face& face = mesh->face(f);
    for (int k = 0; k < 3; ++k) {
      if (face[k].value() >= mesh->num_points()) {
        return InvalidInput("Draco face " + std::to_string(f.value()) + " names point " +
                            std::to_string(face[k].value()) + " of " + std::to_string(mesh->num_points()));
      }
      p.indices.push_back(face[k].value());
    }
  }
  return p;
}

}  // namespace

StatusOr<Primitive> DecodeDracoPrimitive(const uint8_t* data, size_t size, const DracoAttributeIds& ids) {
  return CatchExceptions(std::string("Draco decode"), [&] { return DecodeDracoPrimitiveUnguarded(data, size, ids); });
}

std::map<std::string, int> DracoAttributeNames(const DracoAttributeIds& ids) {
  std::map<std::string, int> names;
  if (ids.position >= 0) names["POSITION"] = ids.position;
  if (ids.normal >= 0) names["NORMAL"] = ids.normal;
  for (size_t k = 0; k < ids.texcoords.size(); ++k) {
    if (ids.texcoords[k] >= 0) names["TEXCOORD_" + std::to_string(k)] = ids.texcoords[k];
  }
  if (ids.color >= 0) names["COLOR_0"] = ids.color;
  return names;
}

Status AddDracoAttribute(const std::string& semantic, int id, DracoAttributeIds& ids) {
  if (semantic == "POSITION") {
    ids.position = id;
  } else if (semantic == "NORMAL") {
    ids.normal = id;
  } else if (semantic == "COLOR_0") {
    ids.color = id;
  } else if (semantic.rfind("TEXCOORD_", 0) == 0) {
    const std::string index = semantic.substr(9);
    if (index.empty() || index.size() > 2 || index.find_first_not_of("0123456789") != std::string::npos) {
      return InvalidInput("Draco attribute " + semantic);
    }
    const size_t k = static_cast<size_t>(std::stoi(index));
    if (ids.texcoords.size() <= k) ids.texcoords.resize(k + 1, -1);
    ids.texcoords[k] = id;
  }
  return Status::Ok();
}

}  // namespace meshstream
