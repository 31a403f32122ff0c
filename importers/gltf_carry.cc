#include "importers/gltf_carry.h"

#include <cmath>
#include <cstring>

namespace meshstream::gltf {

using json = nlohmann::json;

bool IsCarriedPrimitive(const tg::Primitive& tp) {
  const int mode = tp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : tp.mode;
  if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
      mode == TINYGLTF_MODE_LINE_STRIP) {
    return true;
  }
  if (!tp.targets.empty()) return true;
  for (const auto& [name, index] : tp.attributes) {
    (void)index;
    if (name.rfind("JOINTS_", 0) == 0 || name.rfind("WEIGHTS_", 0) == 0) return true;
  }
  return false;
}

namespace {

// Carries `attributes`, each with `count` elements (0: take the first one's).
Status CarryAttributes(const std::map<std::string, int>& attributes, const std::string& where, Carrier& carrier,
                       uint64_t& count, CarriedAttributes& out) {
  for (const auto& [name, index] : attributes) {
    MS_ASSIGN_OR_RETURN(int32_t id, carrier.Accessor(index, CarriedAccessor::Use::kVertex, where + "." + name));
    const uint64_t n = carrier.Get(id).count;
    if (count == 0) count = n;
    if (n != count) {
      return InvalidInput(where + ": " + name + " has " + std::to_string(n) + " elements but POSITION has " +
                          std::to_string(count));
    }
    out.emplace_back(name, id);
  }
  return Status::Ok();
}

}  // namespace

Status ReadCarriedPrimitive(const tg::Model& model, const json& raw_prim, const tg::Primitive& tp,
                            const std::string& where, Carrier& carrier, CarriedPrimitive& out) {
  if (raw_prim.is_object() && raw_prim.contains("extensions") && raw_prim["extensions"].is_object() &&
      raw_prim["extensions"].contains("KHR_draco_mesh_compression")) {
    return Unsupported(where + ": a Draco-compressed points, lines, skinned or morphed primitive is not "
                       "carried yet (see docs/spec/gltf-support.md)");
  }
  const int mode = tp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : tp.mode;
  if (mode > TINYGLTF_MODE_TRIANGLE_FAN) {
    return InvalidInput(where + ": mode " + std::to_string(mode) + " is not a glTF primitive mode");
  }
  out.mode = mode;
  auto position = tp.attributes.find("POSITION");
  if (position == tp.attributes.end()) return InvalidInput(where + " has no POSITION attribute");
  // POSITION first, so that every count is compared with it.
  uint64_t count = 0;
  MS_RETURN_IF_ERROR(CarryAttributes({*position}, where, carrier, count, out.attributes));
  std::map<std::string, int> others = tp.attributes;
  others.erase("POSITION");
  MS_RETURN_IF_ERROR(CarryAttributes(others, where, carrier, count, out.attributes));
  if (tp.indices >= 0) {
    const int ct = static_cast<size_t>(tp.indices) < model.accessors.size() ? model.accessors[tp.indices].componentType : 0;
    if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      return InvalidInput(where + ".indices: accessor " + std::to_string(tp.indices) +
                          " does not exist or is not unsigned byte, short or int");
    }
    MS_ASSIGN_OR_RETURN(out.indices, carrier.Accessor(tp.indices, CarriedAccessor::Use::kIndex, where + ".indices"));
    const CarriedAccessor& ia = carrier.Get(out.indices);
    if (ia.type != "SCALAR") return InvalidInput(where + ".indices: accessor type must be SCALAR");
    const size_t csize = ia.ComponentBytes();
    for (uint64_t i = 0; i < ia.count; ++i) {
      const double v = ReadComponent(ia.bytes.data() + i * csize, ia.component_type, false);
      if (v >= static_cast<double>(count)) {
        return InvalidInput(where + ": index " + std::to_string(static_cast<uint64_t>(v)) + " at position " +
                            std::to_string(i) + " is out of range (" + std::to_string(count) + " vertices)");
      }
    }
  }
  for (size_t t = 0; t < tp.targets.size(); ++t) {
    CarriedAttributes target;
    uint64_t target_count = count;
    MS_RETURN_IF_ERROR(CarryAttributes(tp.targets[t], where + ".targets[" + std::to_string(t) + "]", carrier,
                                       target_count, target));
    out.targets.push_back(std::move(target));
  }
  if (tp.material >= 0) {
    if (static_cast<size_t>(tp.material) >= model.materials.size()) {
      return InvalidInput(where + ".material " + std::to_string(tp.material) + " does not exist");
    }
    out.material = tp.material;
  }
  return Status::Ok();
}

Status ReadSkinsAndAnimations(const tg::Model& model, Carrier& carrier, Scene& scene) {
  const int node_count = static_cast<int>(model.nodes.size());
  for (size_t s = 0; s < model.skins.size(); ++s) {
    const tg::Skin& ts = model.skins[s];
    const std::string where = "skins[" + std::to_string(s) + "]";
    Skin skin;
    skin.name = ts.name;
    if (ts.joints.empty()) return InvalidInput(where + ".joints is empty");
    for (size_t j = 0; j < ts.joints.size(); ++j) {
      if (ts.joints[j] < 0 || ts.joints[j] >= node_count) {
        return InvalidInput(where + ".joints[" + std::to_string(j) + "] names node " + std::to_string(ts.joints[j]) +
                            ", which does not exist");
      }
    }
    skin.joints.assign(ts.joints.begin(), ts.joints.end());
    if (ts.skeleton < -1 || ts.skeleton >= node_count) {
      return InvalidInput(where + ".skeleton names node " + std::to_string(ts.skeleton) + ", which does not exist");
    }
    skin.skeleton = ts.skeleton;
    if (ts.inverseBindMatrices >= 0) {
      MS_ASSIGN_OR_RETURN(skin.inverse_bind_matrices,
                          carrier.Accessor(ts.inverseBindMatrices, CarriedAccessor::Use::kOther, where + ".inverseBindMatrices"));
      const CarriedAccessor& a = carrier.Get(skin.inverse_bind_matrices);
      if (a.type != "MAT4" || a.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT || a.count < ts.joints.size()) {
        return InvalidInput(where + ".inverseBindMatrices must be float MAT4 with at least one matrix per joint");
      }
    }
    scene.skins.push_back(std::move(skin));
  }
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const int skin = model.nodes[i].skin;
    if (skin < -1 || skin >= static_cast<int>(scene.skins.size())) {
      return InvalidInput("nodes[" + std::to_string(i) + "].skin " + std::to_string(skin) + " does not exist");
    }
    scene.nodes[i].skin = skin;
    scene.nodes[i].weights = model.nodes[i].weights;
  }
  for (size_t n = 0; n < model.animations.size(); ++n) {
    const tg::Animation& ta = model.animations[n];
    const std::string where = "animations[" + std::to_string(n) + "]";
    Animation anim;
    anim.name = ta.name;
    for (size_t s = 0; s < ta.samplers.size(); ++s) {
      const std::string ws = where + ".samplers[" + std::to_string(s) + "]";
      AnimationSampler sampler;
      MS_ASSIGN_OR_RETURN(sampler.input, carrier.Accessor(ta.samplers[s].input, CarriedAccessor::Use::kOther, ws + ".input"));
      MS_ASSIGN_OR_RETURN(sampler.output, carrier.Accessor(ta.samplers[s].output, CarriedAccessor::Use::kOther, ws + ".output"));
      const CarriedAccessor& input = carrier.Get(sampler.input);
      if (input.type != "SCALAR" || input.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT) {
        return InvalidInput(ws + ".input must be a float SCALAR accessor");
      }
      const std::string& interpolation = ta.samplers[s].interpolation;
      if (interpolation != "LINEAR" && interpolation != "STEP" && interpolation != "CUBICSPLINE") {
        return InvalidInput(ws + ".interpolation is not LINEAR, STEP or CUBICSPLINE");
      }
      sampler.interpolation = interpolation;
      anim.samplers.push_back(std::move(sampler));
    }
    for (size_t c = 0; c < ta.channels.size(); ++c) {
      const tg::AnimationChannel& tc = ta.channels[c];
      const std::string wc = where + ".channels[" + std::to_string(c) + "]";
      if (tc.sampler < 0 || static_cast<size_t>(tc.sampler) >= anim.samplers.size()) {
        return InvalidInput(wc + ".sampler " + std::to_string(tc.sampler) + " does not exist");
      }
      if (tc.target_node < 0 || tc.target_node >= node_count) {
        return InvalidInput(wc + ".target.node " + std::to_string(tc.target_node) + " does not exist");
      }
      if (tc.target_path != "translation" && tc.target_path != "rotation" && tc.target_path != "scale" &&
          tc.target_path != "weights") {
        return InvalidInput(wc + ".target.path \"" + tc.target_path + "\" is not translation, rotation, scale or weights");
      }
      anim.channels.push_back({tc.sampler, tc.target_node, tc.target_path});
    }
    scene.animations.push_back(std::move(anim));
  }
  return Status::Ok();
}

}  // namespace meshstream::gltf
