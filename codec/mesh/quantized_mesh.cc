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

Primitive DequantizeArrays(const QuantizationGrid& position_grid, const AttributeLayout& layout,
                           const std::vector<Vec3i>& positions, const std::vector<int32_t>& attributes,
                           const uint32_t* indices, size_t index_count, int32_t material) {
  Primitive p;
  p.material = material;
  const size_t n = positions.size();
  const size_t channels = static_cast<size_t>(layout.channels());
  const int32_t* attr = attributes.data();
  p.positions.resize(n);
  {
    const Dequantizer dq(position_grid);
    for (size_t v = 0; v < n; ++v)
      for (int c = 0; c < 3; ++c) p.positions[v][c] = dq(positions[v][c], c);
  }
  if (layout.has_normals) {
    p.normals.resize(n);
    for (size_t v = 0; v < n; ++v) {
      const int32_t* a = attr + v * channels + layout.normal_offset();
      p.normals[v] = DequantizeNormal({static_cast<uint32_t>(a[0]), static_cast<uint32_t>(a[1])}, layout.qn);
    }
  }
  for (int t = 0; t < layout.texcoord_sets; ++t) {
    const Dequantizer dq(layout.texcoord_grids[t]);
    std::vector<Vec2f> uv(n);
    for (size_t v = 0; v < n; ++v) {
      const int32_t* a = attr + v * channels + layout.texcoord_offset(t);
      for (int c = 0; c < 2; ++c) uv[v][c] = dq(a[c], c);
    }
    p.texcoords.push_back(std::move(uv));
  }
  if (layout.has_colors) {
    const Dequantizer dq(layout.color_grid);
    p.colors.resize(n);
    for (size_t v = 0; v < n; ++v) {
      const int32_t* a = attr + v * channels + layout.color_offset();
      for (int c = 0; c < 4; ++c) p.colors[v][c] = dq(a[c], c);
    }
  }
  p.indices.assign(indices, indices + index_count);
  return p;
}

}  // namespace meshstream
