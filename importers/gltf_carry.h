// What the glTF importer carries instead of refining (docs/spec/gltf-support.md,
// "Carried through"): points and lines primitives, triangle primitives with
// skinning attributes or morph targets, skins and animations. Their
// accessors are copied into Scene::carried_accessors as packed bytes, once
// per (source accessor, use), so that shared accessors stay shared.
// Internal to importers/.
//
// Contract: safe on untrusted input: every accessor goes through
// gltf_accessors.h; every index a carried object holds (nodes, joints,
// samplers, materials, vertex indices) is checked against what exists, and
// errors name the JSON path. Thread safety: none needed.
#ifndef MESHSTREAM_IMPORTERS_GLTF_CARRY_H_
#define MESHSTREAM_IMPORTERS_GLTF_CARRY_H_

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <vector>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"
#include "importers/gltf_accessors.h"

namespace meshstream::gltf {

// Carried data: accessors copied as packed bytes, once per (source accessor,
// use), so that shared accessors stay shared.
class Carrier {
 public:
  Carrier(const tg::Model& model, Scene& scene, DecodeBudget& budget) : model_(model), scene_(scene), budget_(budget) {}

  // The carried copy of accessor `index`; `where` names its user.
  StatusOr<int32_t> Accessor(int index, CarriedAccessor::Use use, const std::string& where) {
    const auto key = std::make_pair(index, static_cast<int>(use));
    if (auto it = cache_.find(key); it != cache_.end()) return it->second;
    MS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, ReadAccessorBytes(model_, index, where, budget_));
    const tg::Accessor& a = model_.accessors[index];
    const std::string at = where + " (accessors[" + std::to_string(index) + "])";
    CarriedAccessor out;
    out.component_type = a.componentType;
    out.type = TypeName(a.type);
    out.normalized = a.normalized;
    out.count = a.count;
    out.name = a.name;
    out.use = use;
    out.bytes = std::move(bytes);
    if (out.type.rfind("MAT", 0) == 0 && out.ComponentBytes() < 4) {
      return Unsupported(at + ": " + out.type + " with 8- or 16-bit components is not carried");
    }
    if (out.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT) {
      for (size_t i = 0; i + 4 <= out.bytes.size(); i += 4) {
        float f;
        std::memcpy(&f, out.bytes.data() + i, 4);
        if (!std::isfinite(f)) {
          return InvalidInput(at + ": element " + std::to_string(i / out.ElementBytes()) + " is not a finite number");
        }
      }
    }
    scene_.carried_accessors.push_back(std::move(out));
    const int32_t id = static_cast<int32_t>(scene_.carried_accessors.size()) - 1;
    cache_[key] = id;
    return id;
  }

  const CarriedAccessor& Get(int32_t id) const { return scene_.carried_accessors[id]; }

 private:
  static std::string TypeName(int type) {
    switch (type) {
      case TINYGLTF_TYPE_SCALAR: return "SCALAR";
      case TINYGLTF_TYPE_VEC2: return "VEC2";
      case TINYGLTF_TYPE_VEC3: return "VEC3";
      case TINYGLTF_TYPE_VEC4: return "VEC4";
      case TINYGLTF_TYPE_MAT2: return "MAT2";
      case TINYGLTF_TYPE_MAT3: return "MAT3";
      case TINYGLTF_TYPE_MAT4: return "MAT4";
      default: return "";
    }
  }

  const tg::Model& model_;
  Scene& scene_;
  DecodeBudget& budget_;
  std::map<std::pair<int, int>, int32_t> cache_;
};

// A primitive meshstream carries instead of refining: points and lines, and
// triangles with skinning attributes or morph targets.
bool IsCarriedPrimitive(const tg::Primitive& tp);

// Reads primitive `tp` (its raw JSON in `raw_prim`) as carried data.
Status ReadCarriedPrimitive(const tg::Model& model, const nlohmann::json& raw_prim, const tg::Primitive& tp,
                            const std::string& where, Carrier& carrier, CarriedPrimitive& out);

// Skins and animations, after the nodes: every index they hold is checked;
// fills Scene::skins, Scene::animations and the nodes' skins and weights.
Status ReadSkinsAndAnimations(const tg::Model& model, Carrier& carrier, Scene& scene);

}  // namespace meshstream::gltf

#endif  // MESHSTREAM_IMPORTERS_GLTF_CARRY_H_
