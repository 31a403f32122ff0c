#include "codec/progressive/split_bits_connected.h"

#include <algorithm>
#include <string>

#include "codec/progressive/seam_twins.h"

namespace meshstream {

void ConnectedSplitBits::Reset(const SplitConnectivity& base) {
  models_ = Models{};
  const uint32_t n = base.vertex_count();
  since_.assign(n, 2);
  boundary_.assign(n, 0);
  std::vector<uint32_t> ring;
  for (uint32_t v = 0; v < n; ++v) boundary_[v] = base.CyclicRing(v, ring) ? 0 : 1;
}

int ConnectedSplitBits::Context(uint32_t v, const SplitConnectivity& mesh, const std::vector<uint8_t>& hits) const {
  const uint32_t faces = mesh.faces_of(v).size();
  const int hit = hits[v] == 0 ? 0 : hits[v] <= 2 ? 1 : 2;
  const int degree = faces <= 5 ? 0 : faces == 6 ? 1 : 2;
  return (hit * 3 + since_[v]) * 3 + degree;
}

void ConnectedSplitBits::Hit(uint32_t v, const SplitConnectivity& mesh, std::vector<uint8_t>& hits) {
  for (uint32_t f : mesh.faces_of(v)) {
    for (uint32_t x : mesh.faces()[f]) {
      if (x > v && hits[x] < 255) ++hits[x];
    }
  }
}

void ConnectedSplitBits::Step(const std::vector<uint8_t>& bits) {
  const uint32_t n = static_cast<uint32_t>(since_.size());
  for (uint32_t v = 0; v < n; ++v) since_[v] = bits[v] ? 0 : static_cast<uint8_t>(std::min(since_[v] + 1, 2));
  for (uint32_t v = 0; v < n; ++v) {
    if (!bits[v]) continue;
    since_.push_back(0);
    boundary_.push_back(boundary_[v]);
  }
}

std::vector<uint8_t> ConnectedSplitBits::Encode(const std::vector<uint8_t>& bits, const SplitConnectivity& mesh,
                                                const std::vector<uint32_t>* twins) {
  const uint32_t n = static_cast<uint32_t>(since_.size());
  hits_.assign(n, 0);
  RangeEncoder enc;
  for (uint32_t v = 0; v < n; ++v) {
    const uint32_t twin = twins != nullptr ? (*twins)[v] : kNoTwin;
    const bool bit = bits[v] != 0;
    if (twin != kNoTwin && twin < v) {
      // The twin's bit (not coded).
    } else if (boundary_[v] && twin == kNoTwin) {
      // Inferred 0: the writer's hierarchy never splits such a vertex.
    } else {
      enc.EncodeBit(models_[static_cast<size_t>(Context(v, mesh, hits_))], bit ? 1 : 0);
    }
    if (bit) Hit(v, mesh, hits_);
  }
  Step(bits);
  return enc.Finish();
}

StatusOr<ConnectedSplitBits::Decoded> ConnectedSplitBits::Decode(const uint8_t* data, size_t size,
                                                                 const SplitConnectivity& mesh,
                                                                 const std::vector<uint32_t>* twins) const {
  const uint32_t n = static_cast<uint32_t>(since_.size());
  if (mesh.vertex_count() != n) return Internal("split bits: the coder is out of step with the mesh");
  Decoded out;
  out.models = models_;
  out.bits.assign(n, 0);
  hits_.assign(n, 0);
  RangeDecoder dec(data, size);
  for (uint32_t v = 0; v < n; ++v) {
    const uint32_t twin = twins != nullptr ? (*twins)[v] : kNoTwin;
    int bit = 0;
    if (twin != kNoTwin && twin < v) {
      bit = out.bits[twin];
    } else if (boundary_[v] && twin == kNoTwin) {
      bit = 0;
    } else {
      bit = dec.DecodeBit(out.models[static_cast<size_t>(Context(v, mesh, hits_))]);
    }
    out.bits[v] = static_cast<uint8_t>(bit);
    if (bit) Hit(v, mesh, hits_);
  }
  if (dec.overran()) return InvalidInput("split bits: the block ends before its " + std::to_string(n) + " bits");
  if (!dec.ended_exactly()) {
    return InvalidInput("split bits: the block's " + std::to_string(size) + " bytes do not end with its last bit");
  }
  return out;
}

std::vector<int> ConnectedSplitBits::Contexts(const std::vector<uint8_t>& bits, const SplitConnectivity& mesh,
                                              const std::vector<uint32_t>* twins) const {
  const uint32_t n = static_cast<uint32_t>(since_.size());
  std::vector<int> out(n, -1);
  hits_.assign(n, 0);
  for (uint32_t v = 0; v < n && v < bits.size(); ++v) {
    const uint32_t twin = twins != nullptr ? (*twins)[v] : kNoTwin;
    if (!(twin != kNoTwin && twin < v) && !(boundary_[v] && twin == kNoTwin)) out[v] = Context(v, mesh, hits_);
    if (bits[v]) Hit(v, mesh, hits_);
  }
  return out;
}

void ConnectedSplitBits::Advance(Decoded&& decoded) {
  models_ = decoded.models;
  Step(decoded.bits);
}

}  // namespace meshstream
