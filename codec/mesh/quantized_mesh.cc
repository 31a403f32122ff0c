#include "codec/mesh/quantized_mesh.h"

namespace meshstream {

StatusOr<QuantizedMesh> QuantizePrimitive(const Primitive& p, const QuantizationParams& params) {
  MS_RETURN_IF_ERROR(ValidatePrimitive(p));
  MS_RETURN_IF_ERROR(CheckQuantizationBits(params.qn, "normal bits (--qn)"));
  if (p.face_count() == 0) return InvalidInput("the primitive has no triangle");
  QuantizedMesh q;
  MS_ASSIGN_OR_RETURN(q.position_grid, PositionGrid(p.positions, p.indices, params.qp));

  // Referenced vertices, in their original order.
  std::vector<uint32_t> remap(p.vertex_count(), UINT32_MAX);
  for (uint32_t i : p.indices) remap[i] = 0;
  std::vector<uint32_t> kept;
  for (uint32_t v = 0; v < p.vertex_count(); ++v) {
    if (remap[v] == 0) {
      remap[v] = static_cast<uint32_t>(kept.size());
      kept.push_back(v);
    }
  }

  AttributeLayout& layout = q.layout;
  layout.has_normals = !p.normals.empty();
  layout.qn = params.qn;
  layout.texcoord_sets = static_cast<int>(p.texcoords.size());
  layout.has_colors = !p.colors.empty();
  for (const auto& uv : p.texcoords) {
    MS_ASSIGN_OR_RETURN(QuantizationGrid g, GridOf(uv, params.qt));
    layout.texcoord_grids.push_back(g);
  }
  if (layout.has_colors) {
    MS_ASSIGN_OR_RETURN(layout.color_grid, GridOf(p.colors, params.qc));
  }

  const int channels = layout.channels();
  q.positions.reserve(kept.size());
  q.attributes.reserve(kept.size() * channels);
  for (uint32_t v : kept) {
    Vec3i pos;
    for (int c = 0; c < 3; ++c) pos[c] = static_cast<int32_t>(q.position_grid.Quantize(p.positions[v][c], c));
    q.positions.push_back(pos);
    if (layout.has_normals) {
      const auto n = QuantizeNormal(p.normals[v], params.qn);
      q.attributes.push_back(static_cast<int32_t>(n[0]));
      q.attributes.push_back(static_cast<int32_t>(n[1]));
    }
    for (int t = 0; t < layout.texcoord_sets; ++t) {
      for (int c = 0; c < 2; ++c) {
        q.attributes.push_back(static_cast<int32_t>(layout.texcoord_grids[t].Quantize(p.texcoords[t][v][c], c)));
      }
    }
    if (layout.has_colors) {
      for (int c = 0; c < 4; ++c) q.attributes.push_back(static_cast<int32_t>(layout.color_grid.Quantize(p.colors[v][c], c)));
    }
  }
  q.indices.reserve(p.indices.size());
  for (uint32_t i : p.indices) q.indices.push_back(remap[i]);
  return q;
}

StatusOr<QuantizedMesh> QuantizeOnto(const Primitive& p, const QuantizedMesh& grids) {
  const AttributeLayout& layout = grids.layout;
  if (layout.has_normals != !p.normals.empty() || layout.texcoord_sets != static_cast<int>(p.texcoords.size()) ||
      layout.has_colors != !p.colors.empty()) {
    return InvalidInput("the decoded mesh does not have the attributes its header announces");
  }
  MS_RETURN_IF_ERROR(ValidatePrimitive(p));
  QuantizedMesh q;
  q.position_grid = grids.position_grid;
  q.layout = layout;
  const size_t n = p.vertex_count();
  q.positions.resize(n);
  q.attributes.reserve(n * layout.channels());
  for (size_t v = 0; v < n; ++v) {
    for (int c = 0; c < 3; ++c) {
      q.positions[v][c] = static_cast<int32_t>(grids.position_grid.Quantize(p.positions[v][c], c));
    }
    if (layout.has_normals) {
      const auto nq = QuantizeNormal(p.normals[v], layout.qn);
      q.attributes.push_back(static_cast<int32_t>(nq[0]));
      q.attributes.push_back(static_cast<int32_t>(nq[1]));
    }
    for (int t = 0; t < layout.texcoord_sets; ++t)
      for (int c = 0; c < 2; ++c)
        q.attributes.push_back(static_cast<int32_t>(layout.texcoord_grids[t].Quantize(p.texcoords[t][v][c], c)));
    if (layout.has_colors)
      for (int c = 0; c < 4; ++c) q.attributes.push_back(static_cast<int32_t>(layout.color_grid.Quantize(p.colors[v][c], c)));
  }
  q.indices = p.indices;
  return q;
}

Primitive DequantizeMesh(const QuantizedMesh& q, int32_t material) {
  return DequantizeArrays(q.position_grid, q.layout, q.positions, q.attributes, q.indices.data(), q.indices.size(),
                          material);
}

namespace {

// QuantizationGrid::Dequantize with the step computed once: the same
// double expression, so the same floats.
struct Dequantizer {
  explicit Dequantizer(const QuantizationGrid& g) : step(g.step()) {
    for (int c = 0; c < 4; ++c) origin[c] = g.origin[c];
  }
  float operator()(int64_t q, int c) const { return static_cast<float>(origin[c] + static_cast<double>(q) * step); }
  double step;
  double origin[4];
};

}  // namespace

namespace {

// The attributes of vertices [first, first + count) into flat arrays (null:
// skipped); the one loop DequantizeArrays and DequantizeVerticesInto share.
void DequantizeRange(const QuantizationGrid& position_grid, const AttributeLayout& layout, const Vec3i* positions,
                     const int32_t* attributes, size_t first, size_t count, float* out_positions, float* out_normals,
                     int texcoord_set, float* out_texcoords, float* out_colors) {
  const size_t channels = static_cast<size_t>(layout.channels());
  if (out_positions != nullptr) {
    const Dequantizer dq(position_grid);
    for (size_t v = first; v < first + count; ++v)
      for (int c = 0; c < 3; ++c) out_positions[3 * v + c] = dq(positions[v][c], c);
  }
  if (out_normals != nullptr && layout.has_normals) {
    for (size_t v = first; v < first + count; ++v) {
      const int32_t* a = attributes + v * channels + layout.normal_offset();
      const Vec3f n = DequantizeNormal({static_cast<uint32_t>(a[0]), static_cast<uint32_t>(a[1])}, layout.qn);
      for (int c = 0; c < 3; ++c) out_normals[3 * v + c] = n[c];
    }
  }
  if (out_texcoords != nullptr && texcoord_set < layout.texcoord_sets) {
    const Dequantizer dq(layout.texcoord_grids[texcoord_set]);
    for (size_t v = first; v < first + count; ++v) {
      const int32_t* a = attributes + v * channels + layout.texcoord_offset(texcoord_set);
      for (int c = 0; c < 2; ++c) out_texcoords[2 * v + c] = dq(a[c], c);
    }
  }
  if (out_colors != nullptr && layout.has_colors) {
    const Dequantizer dq(layout.color_grid);
    for (size_t v = first; v < first + count; ++v) {
      const int32_t* a = attributes + v * channels + layout.color_offset();
      for (int c = 0; c < 4; ++c) out_colors[4 * v + c] = dq(a[c], c);
    }
  }
}

}  // namespace

Primitive DequantizeArrays(const QuantizationGrid& position_grid, const AttributeLayout& layout,
                           const std::vector<Vec3i>& positions, const std::vector<int32_t>& attributes,
                           const uint32_t* indices, size_t index_count, int32_t material) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float) && sizeof(Vec2f) == 2 * sizeof(float) &&
                    sizeof(Vec4f) == 4 * sizeof(float),
                "the vector types are packed arrays of floats");
  Primitive p;
  p.material = material;
  const size_t n = positions.size();
  p.positions.resize(n);
  if (layout.has_normals) p.normals.resize(n);
  if (layout.has_colors) p.colors.resize(n);
  p.texcoords.resize(static_cast<size_t>(layout.texcoord_sets));
  for (auto& uv : p.texcoords) uv.resize(n);
  if (n == 0) {
    p.indices.assign(indices, indices + index_count);
    return p;
  }
  DequantizeRange(position_grid, layout, positions.data(), attributes.data(), 0, n, p.positions.data()->data(),
                  layout.has_normals ? p.normals.data()->data() : nullptr, 0,
                  layout.texcoord_sets > 0 ? p.texcoords[0].data()->data() : nullptr,
                  layout.has_colors ? p.colors.data()->data() : nullptr);
  for (int t = 1; t < layout.texcoord_sets; ++t) {
    DequantizeRange(position_grid, layout, positions.data(), attributes.data(), 0, n, nullptr, nullptr, t,
                    p.texcoords[t].data()->data(), nullptr);
  }
  p.indices.assign(indices, indices + index_count);
  return p;
}

void DequantizeVerticesInto(const QuantizedMesh& mesh, size_t first, size_t count, const FlatVertexArrays& out) {
  DequantizeRange(mesh.position_grid, mesh.layout, mesh.positions.data(), mesh.attributes.data(), first, count,
                  out.positions, out.normals, 0, out.texcoords, out.colors);
}

}  // namespace meshstream
