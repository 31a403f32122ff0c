// Reading glTF accessors from a loaded tinygltf model, for the glTF importer
// (gltf_import.cc) and the carrying of what it does not refine (gltf_carry.h).
// Internal to importers/.
//
// Contract: safe on untrusted input. Every offset, length, stride, count and
// sparse index is checked against the bytes really loaded before it is read;
// a DecodeBudget caps how many values one import may decode, so accessors
// shared by many users cannot turn a small file into gigabytes. Errors name
// the user of the accessor and the accessor ("meshes[0].primitives[1].NORMAL
// (accessors[4]): ..."). Thread safety: none needed (no shared state).
#ifndef MESHSTREAM_IMPORTERS_GLTF_ACCESSORS_H_
#define MESHSTREAM_IMPORTERS_GLTF_ACCESSORS_H_

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "codec/core/status.h"

namespace meshstream::gltf {

namespace tg = ::tinygltf;

// How many values (attribute components and indices) one import may decode:
// a floor for small files plus a multiple of the input's size. Accessors can
// be shared by any number of primitives, so without this cap a few hundred
// kilobytes of JSON could decode to gigabytes.
constexpr uint64_t kDecodeBudgetFloor = uint64_t{1} << 24;
constexpr uint64_t kDecodeBudgetPerInputByte = 32;
// An accessor without bufferView is all zeros (plus sparse values); no bytes
// back its count, so it may not have more elements than this floor or the
// input has bytes.
constexpr uint64_t kMaxZeroFilledElementsFloor = uint64_t{1} << 16;

class DecodeBudget {
 public:
  explicit DecodeBudget(uint64_t input_bytes)
      : input_bytes_(input_bytes),
        limit_(kDecodeBudgetFloor + std::min<uint64_t>(input_bytes, uint64_t{1} << 40) * kDecodeBudgetPerInputByte) {}

  uint64_t input_bytes() const { return input_bytes_; }

  Status Spend(uint64_t values, const std::string& where) {
    if (values > limit_ - used_) {
      return ResourceExhausted(where + ": decoding would exceed " + std::to_string(limit_) +
                               " values for a " + std::to_string(input_bytes_) +
                               "-byte input (accessors shared by too many primitives?)");
    }
    used_ += values;
    return Status::Ok();
  }

 private:
  uint64_t input_bytes_;
  uint64_t limit_;
  uint64_t used_ = 0;
};

// Bytes per component of a glTF componentType; 0 for an invalid one.
int ComponentBytes(int component_type);
// One component at `p` as a double (normalized when asked, as glTF defines it).
double ReadComponent(const uint8_t* p, int component_type, bool normalized);
// A pointer to `bytes` bytes at `offset` of bufferView `view`, after checking
// every bound against the data really loaded.
StatusOr<const uint8_t*> ViewBytes(const tg::Model& model, int view, uint64_t offset, uint64_t bytes,
                                   const std::string& where);
// Accessor `index` as its elements tightly packed (stride removed, sparse
// substitution applied). `where_in` names the user of the accessor.
StatusOr<std::vector<uint8_t>> ReadAccessorBytes(const tg::Model& model, int index, const std::string& where_in,
                                                 DecodeBudget& budget);
// Accessor `index` as doubles, `components` per element (checked), sparse
// substitution and normalization applied.
StatusOr<std::vector<double>> ReadAccessor(const tg::Model& model, int index, int components,
                                           const std::string& where_in, DecodeBudget& budget);
// An indices accessor (unsigned byte, short or int) as 32-bit values.
StatusOr<std::vector<uint32_t>> ReadIndices(const tg::Model& model, int index, const std::string& where,
                                            DecodeBudget& budget);

}  // namespace meshstream::gltf

#endif  // MESHSTREAM_IMPORTERS_GLTF_ACCESSORS_H_
