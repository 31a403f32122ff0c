#include "importers/gltf_accessors.h"

#include <cstring>

namespace meshstream::gltf {

int ComponentBytes(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

double ReadComponent(const uint8_t* p, int component_type, bool normalized) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p, 4); return f; }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const int8_t v = static_cast<int8_t>(p[0]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v; std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v; std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { uint32_t v; std::memcpy(&v, p, 4); return v; }
    case TINYGLTF_COMPONENT_TYPE_INT: { int32_t v; std::memcpy(&v, p, 4); return v; }
    default: return 0;
  }
}

// Returns a pointer to `bytes` bytes at `offset` of bufferView `view`, after
// checking every bound against the data really loaded.
StatusOr<const uint8_t*> ViewBytes(const tg::Model& model, int view, uint64_t offset, uint64_t bytes,
                                   const std::string& where) {
  if (view < 0 || static_cast<size_t>(view) >= model.bufferViews.size()) {
    return InvalidInput(where + ": bufferView " + std::to_string(view) + " does not exist");
  }
  const tg::BufferView& bv = model.bufferViews[view];
  if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= model.buffers.size()) {
    return InvalidInput(where + ": bufferViews[" + std::to_string(view) + "].buffer does not exist");
  }
  const std::vector<unsigned char>& data = model.buffers[bv.buffer].data;
  if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset ||
      offset > bv.byteLength || bytes > bv.byteLength - offset) {
    return InvalidInput(where + ": bytes " + std::to_string(offset) + "+" + std::to_string(bytes) +
                        " are outside bufferViews[" + std::to_string(view) + "]");
  }
  return data.data() + bv.byteOffset + offset;
}

// Reads accessor `index` as its elements tightly packed (stride removed,
// sparse substitution applied), after checking every bound against the data
// really loaded. `where_in` names the user of the accessor.
StatusOr<std::vector<uint8_t>> ReadAccessorBytes(const tg::Model& model, int index, const std::string& where_in,
                                                 DecodeBudget& budget) {
  const std::string where = where_in + " (accessors[" + std::to_string(index) + "])";
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return InvalidInput(where_in + ": accessor " + std::to_string(index) + " does not exist");
  }
  const tg::Accessor& a = model.accessors[index];
  const int components = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
  if (components <= 0) return InvalidInput(where + ": type is not valid");
  const int csize = ComponentBytes(a.componentType);
  if (csize == 0) return InvalidInput(where + ": componentType " + std::to_string(a.componentType) + " is not valid");
  const uint64_t element = uint64_t(csize) * components;
  const uint64_t count = a.count;
  if (count == 0 || count > (uint64_t{1} << 31)) {
    return InvalidInput(where + ": count " + std::to_string(count) + " is out of range");
  }
  if (a.bufferView < 0 && count > std::max(kMaxZeroFilledElementsFloor, budget.input_bytes())) {
    return ResourceExhausted(where + ": count " + std::to_string(count) +
                             " with no bufferView (all zeros) is more elements than the input has bytes");
  }
  MS_RETURN_IF_ERROR(budget.Spend(count * components, where));
  std::vector<uint8_t> out;
  if (a.bufferView >= 0) {
    if (static_cast<size_t>(a.bufferView) >= model.bufferViews.size()) {
      return InvalidInput(where + ": bufferView " + std::to_string(a.bufferView) + " does not exist");
    }
    const tg::BufferView& bv = model.bufferViews[a.bufferView];
    const uint64_t stride = bv.byteStride ? bv.byteStride : element;
    if (stride < element) return InvalidInput(where + ": byteStride is smaller than one element");
    MS_ASSIGN_OR_RETURN(const uint8_t* base,
                        ViewBytes(model, a.bufferView, a.byteOffset, stride * (count - 1) + element, where));
    out.resize(count * element);
    for (uint64_t i = 0; i < count; ++i) std::memcpy(out.data() + i * element, base + i * stride, element);
  } else {
    out.assign(count * element, 0);  // glTF: no bufferView means zeros
  }
  if (a.sparse.isSparse) {
    const uint64_t n = static_cast<uint64_t>(a.sparse.count);
    if (a.sparse.count <= 0 || n > count) return InvalidInput(where + ": sparse.count is out of range");
    const int icsize = ComponentBytes(a.sparse.indices.componentType);
    if (icsize == 0 || a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
        a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
        a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
      return InvalidInput(where + ": sparse.indices.componentType is not an unsigned integer type");
    }
    if (a.sparse.indices.byteOffset < 0 || a.sparse.values.byteOffset < 0) {
      return InvalidInput(where + ": negative sparse byteOffset");
    }
    MS_ASSIGN_OR_RETURN(const uint8_t* ibase, ViewBytes(model, a.sparse.indices.bufferView,
                                                        a.sparse.indices.byteOffset, n * icsize, where + ".sparse.indices"));
    MS_ASSIGN_OR_RETURN(const uint8_t* vbase, ViewBytes(model, a.sparse.values.bufferView,
                                                        a.sparse.values.byteOffset, n * element, where + ".sparse.values"));
    int64_t previous = -1;
    for (uint64_t i = 0; i < n; ++i) {
      const double target_d = ReadComponent(ibase + i * icsize, a.sparse.indices.componentType, false);
      const int64_t target = static_cast<int64_t>(target_d);
      if (target <= previous || static_cast<uint64_t>(target) >= count) {
        return InvalidInput(where + ": sparse index " + std::to_string(target) +
                            " is out of range or not increasing");
      }
      previous = target;
      std::memcpy(out.data() + target * element, vbase + i * element, element);
    }
  }
  return out;
}

// Reads accessor `index` as doubles, `components` per element, applying
// sparse substitution and normalization.
StatusOr<std::vector<double>> ReadAccessor(const tg::Model& model, int index, int components,
                                           const std::string& where_in, DecodeBudget& budget) {
  const std::string where = where_in + " (accessors[" + std::to_string(index) + "])";
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return InvalidInput(where_in + ": accessor " + std::to_string(index) + " does not exist");
  }
  const tg::Accessor& a = model.accessors[index];
  const int type_components = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
  if (type_components != components) {
    return InvalidInput(where + ": has " + std::to_string(type_components) + " components per element, expected " +
                        std::to_string(components));
  }
  MS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, ReadAccessorBytes(model, index, where_in, budget));
  const int csize = ComponentBytes(a.componentType);
  std::vector<double> out(bytes.size() / csize);
  for (size_t i = 0; i < out.size(); ++i) out[i] = ReadComponent(bytes.data() + i * csize, a.componentType, a.normalized);
  return out;
}

StatusOr<std::vector<uint32_t>> ReadIndices(const tg::Model& model, int index, const std::string& where,
                                            DecodeBudget& budget) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return InvalidInput(where + ": indices accessor " + std::to_string(index) + " does not exist");
  }
  const int ct = model.accessors[index].componentType;
  if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
    return InvalidInput(where + ": indices (accessors[" + std::to_string(index) +
                        "]) must be unsigned byte, short or int");
  }
  MS_ASSIGN_OR_RETURN(std::vector<double> values, ReadAccessor(model, index, 1, where + ".indices", budget));
  std::vector<uint32_t> out(values.size());
  for (size_t i = 0; i < values.size(); ++i) out[i] = static_cast<uint32_t>(values[i]);
  return out;
}

}  // namespace meshstream::gltf
