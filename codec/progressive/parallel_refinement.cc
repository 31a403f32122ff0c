#include "codec/progressive/parallel_refinement.h"

#include <algorithm>

#include "codec/progressive/midpoint.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/texcoord_prediction.h"

namespace meshstream {

void RefinementPlan::PlanSplit(const Refinement& coded, const SplitCoding& coding, const RefinementState& state,
                               size_t j, Worker& worker, Task& task, Split& out, int32_t* mapped) const {
  out.kind = Kind::kStop;
  const uint32_t w = coded.split_vertices[j];
  if (w >= state.connectivity.vertex_count()) return;  // the serial path names the error
  if (state.twin[w] != kNoTwin) {
    out.kind = Kind::kSerial;
    return;
  }
  std::vector<uint32_t>& ring = worker.ring;
  if (!state.connectivity.CyclicRing(w, ring, worker.walk)) return;
  const size_t d = ring.size();
  // Every ring vertex must be one no split of the refinement changes: a
  // split neighbour (hostile split bits) would make the splits depend on
  // their order.
  for (uint32_t x : ring)
    if (!state.Stable(x)) return;
  std::vector<Vec3i>& rp = worker.ring_positions;
  RingGeometry(state, w, ring.data(), d, coding.tools, &rp, &worker.frame);
  size_t a_at = 0, b_at = 0;
  const bool ranked = (coding.tools & kToolWingRank) != 0;
  if (!CodedWingPositions(coded.wings[j], coding.tools, ring, state.positions[w], rp.data(), worker.frame,
                          &worker.ranking, &worker.crossings, &a_at, &b_at)) {
    return;
  }
  out.wings = ranked ? WingsOf(ring, a_at, b_at) : coded.wings[j];
  const Umbrella* umbrellas = nullptr;
  out.umbrellas = false;
  if (ReadsUmbrellas(coding)) {
    // A ring of more than 64 vertices has no ring feature (SplitFeatures),
    // so the umbrellas matter only below: their sizes fit one mask.
    if (d > kMaxPredictedValence) return;
    RingUmbrellas(state, ring.data(), d, &worker.umbrellas);
    umbrellas = worker.umbrellas.data();
    out.umbrellas = true;
    out.small = 0;
    for (size_t k = 0; k < d; ++k) {
      if (state.connectivity.faces_of(ring[k]).size() <= kMaxUmbrellaFaces) out.small |= uint64_t{1} << k;
    }
  }
  out.delta = coding.tools == 0 ? coded.position_delta[j]
                                : DecodeSplitVector(coding, coded.position_delta[j], rp.data(), d, a_at, b_at,
                                                    worker.frame, umbrellas);
  if (coding.mapped_count > 0) {
    // The values the split will give w and n (RefinementState::SetPair),
    // and from them the texture coordinate predictions.
    const Vec3i& s = state.positions[w];
    Vec3i u{}, v{};
    for (int k = 0; k < 3; ++k) {
      const std::array<int32_t, 2> uv = FromMidpointPair(s[k], out.delta[k]);
      u[k] = uv[0];
      v[k] = uv[1];
    }
    const size_t ch = static_cast<size_t>(state.channels);
    int32_t coarse[kMaxMappedChannels];
    for (int c = 0; c < coding.mapped_count; ++c) {
      const size_t at = static_cast<size_t>(coding.mapped_first + c);
      const std::array<int32_t, 2> uv =
          FromMidpointPair(state.attributes[w * ch + at], coded.attribute_delta[j * ch + at]);
      coarse[c] = Midpoint(uv[0], uv[1]);
    }
    PredictChannelDeltas(state.attributes.data(), ch, ring.data(), rp.data(), d, worker.frame, u, v, coarse,
                         coding.mapped_first, coding.mapped_count, mapped);
  }
  out.ring_at = static_cast<uint32_t>(task.rings.size());
  out.degree = static_cast<uint32_t>(d);
  out.a_at = static_cast<uint32_t>(a_at);
  out.b_at = static_cast<uint32_t>(b_at);
  task.rings.insert(task.rings.end(), ring.begin(), ring.end());
  task.faces.insert(task.faces.end(), worker.walk.faces.begin(), worker.walk.faces.end());
  out.kind = Kind::kPlanned;
}

void RefinementPlan::Plan(const Refinement& coded, const SplitCoding& coding, const RefinementState& state,
                          size_t first, size_t count, TaskRunner& runner) {
  first_ = first;
  count = std::min(count, kWindowSplits);
  plans_.resize(count);
  const size_t tasks = (count + kTaskSplits - 1) / kTaskSplits;
  if (tasks_.size() < tasks) tasks_.resize(tasks);
  const size_t workers = static_cast<size_t>(std::max(runner.workers(), 1));
  if (workers_.size() < workers) workers_.resize(workers);
  const size_t mc = static_cast<size_t>(std::max(coding.mapped_count, 0));
  mapped_.resize(count * mc);
  runner.Run(tasks, [&](size_t t, int worker) {
    Task& task = tasks_[t];
    task.rings.clear();
    task.faces.clear();
    Worker& scratch = workers_[static_cast<size_t>(worker)];
    const size_t end = std::min(count, (t + 1) * kTaskSplits);
    for (size_t k = t * kTaskSplits; k < end; ++k) {
      // The next splits' slots, lists, triangles and values, a few splits
      // ahead (the serial path's hints: a worker's cache starts cold).
      state.PrefetchSplits(coded, first + k);
      PlanSplit(coded, coding, state, first + k, scratch, task, plans_[k], mapped_.data() + k * mc);
    }
  });
}

bool RefinementPlan::Holds(size_t j, const RefinementState& state) const {
  const size_t k = j - first_;
  const Split& s = plans_[k];
  if (!s.umbrellas) return true;
  const uint32_t* ring = tasks_[k / kTaskSplits].rings.data() + s.ring_at;
  for (size_t i = 0; i < s.degree; ++i) {
    const bool small = state.connectivity.faces_of(ring[i]).size() <= kMaxUmbrellaFaces;
    if (small != (((s.small >> i) & 1) != 0)) return false;
  }
  return true;
}

void RefinementPlan::Apply(const Refinement& coded, size_t j, const SplitCoding& coding, RefinementState* state,
                           Refinement* decoded) const {
  const size_t k = j - first_;
  const Split& s = plans_[k];
  const Task& task = tasks_[k / kTaskSplits];
  state->PrefetchSplits(coded, j);
  const uint32_t w = coded.split_vertices[j];
  const uint32_t n = state->connectivity.SplitAt(w, task.rings.data() + s.ring_at, task.faces.data() + s.ring_at,
                                                 s.degree, s.a_at, s.b_at);
  const Refinement* apply = &coded;
  if (coding.tools != 0) {
    decoded->position_delta[j] = s.delta;
    if (coding.tools & kToolWingRank) decoded->wings[j] = s.wings;
    apply = decoded;
  }
  state->SetPair(*apply, j, w, n);
  state->twin.push_back(kNoTwin);
  AddPredictedNormals(coding.normal_bits, j, w, n, *state, decoded);
  const size_t mc = static_cast<size_t>(std::max(coding.mapped_count, 0));
  state->AddPredictedDeltas(j, w, n, static_cast<size_t>(coding.mapped_first), mapped_.data() + k * mc, mc, decoded);
}

}  // namespace meshstream
