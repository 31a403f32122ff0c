#include "codec/progressive/refinement_state.h"

#include <algorithm>
#include <string>

#include "codec/progressive/midpoint.h"

namespace meshstream {

Status RefinementState::Reset(const QuantizedMesh& base) {
  channels = base.layout.channels();
  positions = base.positions;
  attributes = base.attributes;
  reliable.assign(base.vertex_count(), 1);
  flags.assign(base.vertex_count(), 0);
  any_absent = false;
  any_inexact = false;
  twin.assign(base.vertex_count(), kNoTwin);
  return connectivity.Reset(static_cast<uint32_t>(base.vertex_count()), base.indices);
}

Status RefinementState::SetTwins(const std::vector<std::array<uint32_t, 2>>& pairs) {
  return TwinTable(pairs, connectivity.vertex_count(), &twin);
}

uint32_t RefinementState::NewTwin(const Refinement& r, size_t j) const {
  const uint32_t w = r.split_vertices[j];
  const uint32_t t = twin[w];
  if (t == kNoTwin || t > w) return kNoTwin;
  const auto it = std::lower_bound(r.split_vertices.begin(), r.split_vertices.end(), t);
  if (it == r.split_vertices.end() || *it != t) return kNoTwin;
  return r.vertices_before + static_cast<uint32_t>(it - r.split_vertices.begin());
}

void RefinementState::PushTwin(const Refinement& r, size_t j) {
  const uint32_t t = NewTwin(r, j);
  twin.push_back(t);
  if (t != kNoTwin) twin[t] = static_cast<uint32_t>(twin.size() - 1);
}

Status RefinementState::ApplySplit(const Refinement& r, size_t j) {
  const uint32_t w = r.split_vertices[j];
  if (w >= connectivity.vertex_count()) return InvalidInput("split vertex " + std::to_string(w) + " does not exist");
  std::vector<uint32_t>& ring = scratch_ring;
  if (twin[w] != kNoTwin) {
    if (!connectivity.OpenRing(w, ring)) {
      return InvalidInput("seam split vertex " + std::to_string(w) + " is not one open fan");
    }
    if (r.wings[j][0] >= ring.size()) {
      return InvalidInput("seam split of vertex " + std::to_string(w) + " names a wing beyond its " +
                          std::to_string(ring.size()) + " neighbours");
    }
    ApplySeamSplitAt(r, j, r.wings[j][0]);
    return Status::Ok();
  }
  if (!connectivity.CyclicRing(w, ring)) {
    return InvalidInput("split vertex " + std::to_string(w) + " is not a closed manifold fan");
  }
  size_t a_at = 0, b_at = 0;
  if (!WingPositions(ring, r.wings[j], &a_at, &b_at)) {
    return InvalidInput("split of vertex " + std::to_string(w) + " names a wing beyond its " +
                        std::to_string(ring.size()) + " neighbours");
  }
  ApplySplitAt(r, j, a_at, b_at);
  return Status::Ok();
}

void RefinementState::PrefetchSplits(const Refinement& r, size_t j) const {
  // A split costs mostly cache misses: w's slot, its triangle list, its
  // triangles, its values. Each stage is hinted kPrefetchDistance splits
  // before the one that needs it; the later stages read what the earlier
  // ones brought in.
  const std::vector<uint32_t>& sv = r.split_vertices;
  const size_t k = sv.size();
  if (j + kPrefetchDistance < k) {
    const uint32_t v = sv[j + kPrefetchDistance];
    connectivity.PrefetchFaces(v);
    if (v < positions.size()) {
      MESHSTREAM_PREFETCH(&positions[v]);
      MESHSTREAM_PREFETCH(&flags[v]);
      if (channels > 0) MESHSTREAM_PREFETCH(&attributes[size_t(v) * channels]);
    }
  }
  // The positions of the next split's ring (its triangles' corners), from
  // the triangles hinted kPrefetchDistance - 1 splits ago: RingGeometry's
  // reads, a third of the last-level misses at 557 k vertices.
  if (j + 1 < k) connectivity.PrefetchCorners(sv[j + 1], positions.data(), positions.size());
  if (j + 2 * kPrefetchDistance < k) connectivity.PrefetchList(sv[j + 2 * kPrefetchDistance]);
  if (j + 3 * kPrefetchDistance < k) connectivity.PrefetchSlot(sv[j + 3 * kPrefetchDistance]);
}

uint32_t RefinementState::ApplySeamSplitAt(const Refinement& r, size_t j, size_t a_at) {
  const uint32_t w = r.split_vertices[j];
  const uint32_t n = connectivity.SplitOpenAt(w, scratch_ring, a_at, /*tail=*/w < twin[w]);
  SetPair(r, j, w, n);
  PushTwin(r, j);
  return n;
}

uint32_t RefinementState::ApplySplitAt(const Refinement& r, size_t j, size_t a_at, size_t b_at) {
  PrefetchSplits(r, j);
  const uint32_t w = r.split_vertices[j];
  const uint32_t n = connectivity.SplitAt(w, scratch_ring, a_at, b_at);
  SetPair(r, j, w, n);
  twin.push_back(kNoTwin);
  return n;
}

void RefinementState::SetPair(const Refinement& r, size_t j, uint32_t w, uint32_t n) {
  const Vec3i& delta = r.position_delta[j];
  Vec3i u{}, v{};
  for (int k = 0; k < 3; ++k) {
    const std::array<int32_t, 2> uv = FromMidpointPair(positions[w][k], delta[k]);
    u[k] = uv[0];
    v[k] = uv[1];
  }
  positions[w] = u;
  positions.push_back(v);
  reliable.push_back(1);
  flags.push_back(0);
  if (channels > 0) {
    attributes.resize(attributes.size() + channels);
    int32_t* aw = attributes.data() + size_t(w) * channels;
    int32_t* an = attributes.data() + size_t(n) * channels;
    const int32_t* ad = r.attribute_delta.data() + j * channels;
    for (int k = 0; k < channels; ++k) {
      const std::array<int32_t, 2> uv = FromMidpointPair(aw[k], ad[k]);
      aw[k] = uv[0];
      an[k] = uv[1];
    }
  }
}

void RefinementState::AddPredictedDeltas(size_t j, uint32_t w, uint32_t n, size_t first, const int32_t* p,
                                          size_t count, Refinement* decoded) {
  const size_t ch = static_cast<size_t>(channels);
  for (size_t c = 0; c < count; ++c) {
    int32_t& aw = attributes[w * ch + first + c];
    int32_t& an = attributes[n * ch + first + c];
    const int32_t m = Midpoint(aw, an);
    const int32_t e = static_cast<int32_t>(std::clamp<int64_t>(int64_t{aw} - an + p[c], INT32_MIN, INT32_MAX));
    aw = FromMidpoint(m, e);
    an = static_cast<int32_t>(int64_t{aw} - e);
    if (decoded) decoded->attribute_delta[j * ch + first + c] = e;
  }
}

Status RefinementState::ApplyRefinement(const Refinement& r) {
  if (r.vertices_before != connectivity.vertex_count()) {
    return InvalidInput("refinement expects " + std::to_string(r.vertices_before) + " vertices, the mesh has " +
                        std::to_string(connectivity.vertex_count()));
  }
  ReserveSplits(r.split_count());
  for (size_t j = 0; j < r.split_count(); ++j) MS_RETURN_IF_ERROR(ApplySplit(r, j));
  return Status::Ok();
}

void RefinementState::ReserveSplits(size_t splits) {
  const size_t needed = positions.size() + splits;
  if (positions.capacity() < needed) Reserve(static_cast<uint32_t>(std::max(needed, 2 * positions.capacity())));
}

void RefinementState::Reserve(uint32_t final_vertices) {
  const size_t extra = final_vertices > positions.size() ? final_vertices - positions.size() : 0;
  connectivity.Reserve(final_vertices, connectivity.face_count() + 2 * extra);
  positions.reserve(final_vertices);
  reliable.reserve(final_vertices);
  twin.reserve(final_vertices);
  flags.reserve(final_vertices);
  attributes.reserve(size_t(final_vertices) * channels);
}

QuantizedMesh RefinementState::Snapshot(const QuantizedMesh& base_layout) const {
  QuantizedMesh out;
  SnapshotInto(base_layout, out);
  return out;
}

void RefinementState::SnapshotInto(const QuantizedMesh& base_layout, QuantizedMesh& out) const {
  out.position_grid = base_layout.position_grid;
  out.layout = base_layout.layout;
  connectivity.IndicesInto(out.indices);
  if (!any_absent) {
    out.positions.assign(positions.begin(), positions.end());
    out.attributes.assign(attributes.begin(), attributes.end());
    return;
  }
  // Leave out the vertices LwoP never created; the others keep their order.
  std::vector<uint32_t> remap(positions.size(), 0);
  uint32_t kept = 0;
  out.positions.clear();
  out.attributes.clear();
  for (size_t v = 0; v < positions.size(); ++v) {
    if (flags[v] & kAbsent) continue;
    remap[v] = kept++;
    out.positions.push_back(positions[v]);
    out.attributes.insert(out.attributes.end(), attributes.begin() + v * channels,
                          attributes.begin() + (v + 1) * channels);
  }
  for (uint32_t& i : out.indices) i = remap[i];
}

void RefinementState::BeginSplits(const Refinement& r) {
  stable_below = std::min<uint32_t>(r.vertices_before, connectivity.vertex_count());
  if (splitting.size() < stable_below) splitting.resize(stable_below, 0);
  for (uint32_t v : r.split_vertices)
    if (v < stable_below) splitting[v] = 1;
}

void RefinementState::EndSplits(const Refinement& r) {
  for (uint32_t v : r.split_vertices)
    if (v < splitting.size()) splitting[v] = 0;
  stable_below = 0;
}

}  // namespace meshstream
