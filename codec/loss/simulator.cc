#include "codec/loss/simulator.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <deque>
#include <utility>

#include "codec/loss/parity.h"
#include "codec/loss/protection.h"

namespace meshstream {
namespace {

// A double in [0, 1) from the top 53 bits of one draw: the same on every
// standard library (std::uniform_real_distribution is not).
double Uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

Status CheckFraction(double value, const char* field) {
  if (!(value >= 0.0 && value <= 1.0)) {
    return InvalidArgument(std::string("loss model: ") + field + " = " + std::to_string(value) +
                           " is not in [0, 1]");
  }
  return Status::Ok();
}

// a + b and a * b for simulated times; hostile timings are refused rather than wrapped.
bool AddOverflows(uint64_t a, uint64_t b, uint64_t* out) { return __builtin_add_overflow(a, b, out); }
bool MulOverflows(uint64_t a, uint64_t b, uint64_t* out) { return __builtin_mul_overflow(a, b, out); }

// Which datagrams the network drops: independent (burst <= 1) or a
// Gilbert-Elliott chain (good: delivered, bad: lost) whose stationary loss is
// `loss` and whose bad runs last `burst` datagrams on average. When `loss` is
// so high that good runs would have to average less than one datagram
// (loss > burst / (1 + burst)), good runs last exactly one datagram and bad
// runs grow to keep the loss rate.
class LossChain {
 public:
  explicit LossChain(const LossModel& m) : loss_(m.loss), bursty_(m.burst > 1.0) {
    if (bursty_ && loss_ > 0.0 && loss_ < 1.0) {
      good_to_bad_ = loss_ / (m.burst * (1.0 - loss_));
      bad_to_good_ = 1.0 / m.burst;
      if (good_to_bad_ > 1.0) {
        good_to_bad_ = 1.0;
        bad_to_good_ = (1.0 - loss_) / loss_;
      }
    }
  }
  // The initial state, drawn from the stationary distribution.
  void Start(double u) { bad_ = u < loss_; }
  // With bursts: whether the chain is in its bad state for the next
  // datagram (a parity sent just before it shares its burst); otherwise
  // `u` < loss. Does not advance the chain.
  bool Peek(double u) const {
    if (!bursty_ || loss_ <= 0.0 || loss_ >= 1.0) return u < loss_;
    return bad_;
  }
  // Whether the next datagram is lost; `u` is one uniform draw.
  bool Next(double u) {
    if (!bursty_ || loss_ <= 0.0 || loss_ >= 1.0) return u < loss_;
    const bool lost = bad_;
    bad_ = bad_ ? !(u < bad_to_good_) : u < good_to_bad_;
    return lost;
  }

 private:
  double loss_;
  bool bursty_;
  double good_to_bad_ = 0, bad_to_good_ = 1;
  bool bad_ = false;
};

}  // namespace

Status LossModel::Validate() const {
  MS_RETURN_IF_ERROR(CheckFraction(loss, "loss"));
  if (!(burst >= 0.0 && std::isfinite(burst))) {
    return InvalidArgument("loss model: burst = " + std::to_string(burst) + " is not a finite value >= 0");
  }
  MS_RETURN_IF_ERROR(CheckFraction(reorder, "reorder"));
  MS_RETURN_IF_ERROR(CheckFraction(duplicate, "duplicate"));
  return Status::Ok();
}

StatusOr<Transmission> SimulateTransmission(const ProgressiveStream& stream, uint32_t stream_id, size_t refinements,
                                            const LossModel& model, const LinkTiming& timing,
                                            const std::vector<uint32_t>& reliable, const SimulatedParity* parity) {
  MS_RETURN_IF_ERROR(model.Validate());
  if (refinements > stream.control.size() || refinements > stream.datagrams.size()) {
    return InvalidArgument("cannot send " + std::to_string(refinements) + " refinements: the stream has " +
                           std::to_string(std::min(stream.control.size(), stream.datagrams.size())));
  }
  Transmission t;
  // All END datagrams first: events point into them, so the outer vector must not grow later.
  t.end_datagrams.reserve(refinements);
  for (size_t i = 0; i < refinements; ++i) {
    if (stream.datagrams[i].size() > UINT32_MAX) return InvalidArgument("too many datagrams in one refinement");
    t.end_datagrams.push_back(MakeEndDatagram(stream_id, static_cast<uint32_t>(i),
                                              static_cast<uint32_t>(stream.datagrams[i].size()), stream.version));
  }

  std::mt19937_64 rng(model.seed);
  LossChain chain(model);
  chain.Start(Uniform(rng));
  const Status too_late = InvalidArgument("link timing: simulated times exceed 64 bits");

  // One datagram on the unreliable channel. Every datagram consumes the same
  // five draws whatever the model, so for one seed the loss pattern does not
  // change with the reorder and duplicate fractions.
  // A datagram of the reliable cut takes the same draws and advances the
  // loss chain, but arrives whatever they say.
  // `dropped_out`: whether the network dropped it (a reliable one never is).
  auto send = [&](const std::vector<uint8_t>& bytes, uint64_t send_us, bool end, bool on_reliable) -> Status {
    const double u_loss = Uniform(rng), u_reorder = Uniform(rng), u_delay = Uniform(rng);
    const double u_duplicate = Uniform(rng), u_copy_delay = Uniform(rng);
    (end ? t.stats.ends_sent : t.stats.datagrams_sent) += 1;
    const bool dropped = chain.Next(u_loss);
    if (on_reliable && !end) {
      ++t.stats.reliable_datagrams;
      t.stats.reliable_bytes += bytes.size();
    }
    if (dropped && !on_reliable) {
      (end ? t.stats.ends_lost : t.stats.datagrams_lost) += 1;
      if (!end) t.stats.lost_bytes += bytes.size();
      return Status::Ok();
    }
    uint64_t arrival = 0;
    if (AddOverflows(send_us, on_reliable ? timing.reliable_latency_us : timing.unreliable_latency_us, &arrival)) {
      return too_late;
    }
    if (!on_reliable && u_reorder < model.reorder && timing.reorder_delay_us > 0) {
      // Uniform in (0, reorder_delay_us].
      const uint64_t extra =
          1 + std::min<uint64_t>(timing.reorder_delay_us - 1,
                                 static_cast<uint64_t>(u_delay * static_cast<double>(timing.reorder_delay_us)));
      if (AddOverflows(arrival, extra, &arrival)) return too_late;
      ++t.stats.reordered;
    }
    ChannelEvent e;
    e.kind = ChannelEvent::Kind::kDatagram;
    e.time_us = arrival;
    e.data = bytes.data();
    e.size = bytes.size();
    t.events.push_back(e);
    if (!on_reliable && u_duplicate < model.duplicate) {
      // The copy follows within one datagram interval.
      const uint64_t span = std::max<uint64_t>(1, timing.datagram_interval_us);
      const uint64_t extra =
          1 + std::min<uint64_t>(span - 1, static_cast<uint64_t>(u_copy_delay * static_cast<double>(span)));
      if (AddOverflows(arrival, extra, &e.time_us)) return too_late;
      t.events.push_back(e);
      ++t.stats.duplicated;
    }
    return Status::Ok();
  };

  for (size_t k = 0; k < reliable.size(); ++k) {
    if (reliable[k] >= stream.control.size() || (k > 0 && reliable[k] <= reliable[k - 1])) {
      return InvalidArgument("reliable cut: refinement " + std::to_string(reliable[k]) +
                             " is out of range or out of order");
    }
  }
  // Parity: every block's datagrams made up front (events point into them,
  // so the vector must not grow later), each due after a position in the
  // sequence of data datagrams sent.
  struct DueParity {
    uint64_t after;  // send after this many data datagrams
    size_t index;    // into t.parity_datagrams
  };
  std::deque<DueParity> due;
  std::vector<bool> parity_follows(refinements, false);
  if (parity != nullptr && parity->code != nullptr && parity->loss > 0.0) {
    std::vector<uint8_t> protect = parity->protect;
    if (protect.empty()) protect.assign(refinements, kStrongParity);
    for (uint32_t r : reliable) {
      if (r < protect.size()) protect[r] = 0;
    }
    // Position in the send sequence of each refinement's first data datagram.
    std::vector<uint64_t> first_position(refinements + 1, 0);
    for (size_t i = 0; i < refinements; ++i) first_position[i + 1] = first_position[i] + stream.datagrams[i].size();
    const uint32_t interleave = std::max<uint32_t>(1, parity->plan.interleave);
    std::vector<std::pair<uint64_t, std::vector<uint8_t>>> made;
    for (const ParityBlockPlan& block : PlanParityBlocks(stream, refinements, protect, parity->plan)) {
      std::vector<const std::vector<uint8_t>*> members;
      std::vector<uint32_t> lengths;
      for (const auto& [r, d] : block.members) {
        members.push_back(&stream.datagrams[r][d]);
        lengths.push_back(static_cast<uint32_t>(stream.datagrams[r][d].size()));
      }
      const ParityShape shape = ShapeFor(lengths, parity->loss, parity->burst, parity->plan, block.tier, block.stride);
      if (shape.m == 0) continue;
      for (const auto& member : block.members) parity_follows[member.first] = true;
      MS_ASSIGN_OR_RETURN(std::vector<std::vector<uint8_t>> rows, EncodeParity(*parity->code, stream_id, members, shape));
      ++t.stats.parity_blocks;
      const auto& [last_r, last_d] = block.members.back();
      const uint64_t last = first_position[last_r] + last_d + 1;  // data datagrams sent with the last member
      for (size_t j = 0; j < rows.size(); ++j) made.push_back({last + uint64_t(j + 1) * interleave, std::move(rows[j])});
    }
    std::stable_sort(made.begin(), made.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    t.parity_datagrams.reserve(made.size());
    for (auto& [after, bytes] : made) {
      due.push_back({after, t.parity_datagrams.size()});
      t.parity_datagrams.push_back(std::move(bytes));
    }
  }
  // The parity datagrams' own draws, apart from the data datagrams' sequence.
  std::mt19937_64 parity_rng(model.seed ^ 0x9e3779b97f4a7c15ull);
  uint64_t data_sent = 0;
  uint64_t last_send_us = 0;
  auto send_parity = [&](uint64_t send_us) -> Status {
    while (!due.empty() && due.front().after <= data_sent) {
      const std::vector<uint8_t>& bytes = t.parity_datagrams[due.front().index];
      due.pop_front();
      ++t.stats.parity_datagrams;
      t.stats.parity_bytes += bytes.size();
      if (chain.Peek(Uniform(parity_rng))) {
        ++t.stats.parity_lost;
        continue;
      }
      ChannelEvent e;
      e.kind = ChannelEvent::Kind::kDatagram;
      if (AddOverflows(send_us, timing.unreliable_latency_us, &e.time_us)) return too_late;
      e.data = bytes.data();
      e.size = bytes.size();
      t.events.push_back(e);
    }
    return Status::Ok();
  };
  size_t next_reliable = 0;
  // Events are created in send order; the stable sort by arrival time then
  // orders ties by that sequence.
  for (size_t i = 0; i < refinements; ++i) {
    while (next_reliable < reliable.size() && reliable[next_reliable] < i) ++next_reliable;
    const bool on_reliable = next_reliable < reliable.size() && reliable[next_reliable] == i;
    uint64_t start = 0, control_arrival = 0;
    if (MulOverflows(i, timing.refinement_interval_us, &start) ||
        AddOverflows(start, timing.reliable_latency_us, &control_arrival)) {
      return too_late;
    }
    ChannelEvent control;
    control.kind = ChannelEvent::Kind::kControl;
    control.time_us = control_arrival;
    control.refinement = static_cast<uint32_t>(i);
    control.data = stream.control[i].data();
    control.size = stream.control[i].size();
    control.parity_follows = parity_follows[i];
    t.events.push_back(control);
    const auto& datagrams = stream.datagrams[i];
    const uint64_t lost_before = t.stats.datagrams_lost;
    for (size_t d = 0; d <= datagrams.size(); ++d) {
      uint64_t offset = 0, send_us = 0;
      if (MulOverflows(d, timing.datagram_interval_us, &offset) || AddOverflows(start, offset, &send_us)) {
        return too_late;
      }
      const bool end = d == datagrams.size();
      MS_RETURN_IF_ERROR(send(end ? t.end_datagrams[i] : datagrams[d], send_us, end, on_reliable));
      last_send_us = send_us;
      if (!end) {
        t.stats.datagram_bytes += datagrams[d].size();
        ++data_sent;
        MS_RETURN_IF_ERROR(send_parity(send_us));
      }
    }
    if (t.stats.datagrams_lost > lost_before) ++t.stats.refinements_with_loss;
  }
  // What is still due goes out after the last datagram, one interval apart.
  while (!due.empty()) {
    data_sent = due.front().after;
    if (AddOverflows(last_send_us, timing.datagram_interval_us, &last_send_us)) return too_late;
    MS_RETURN_IF_ERROR(send_parity(last_send_us));
  }
  std::stable_sort(t.events.begin(), t.events.end(),
                   [](const ChannelEvent& a, const ChannelEvent& b) { return a.time_us < b.time_us; });
  // Moved, not copied: a copy would point its events at the ENDs of `t`.
  return StatusOr<Transmission>(std::move(t));
}

}  // namespace meshstream
