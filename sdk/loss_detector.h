// Loss detection by packet numbers on the receiver of a UDP session
// (docs/spec/streaming-protocol.md, "The client"; RFC 9002 section 6.1 seen
// from the receiving side): what a refinement misses counts as lost once a
// datagram numbered kPacketThreshold past its last data datagram arrived
// (the packet rule), or once the reorder window has passed since the first
// datagram numbered after its data arrived (the time rule). The window is
// an eighth of the HELLO round trip (at least kMinReorderWindowUs), widened
// at once by the reordering seen (how long a datagram came after a
// later-numbered one, with RFC 9002's 9/8 margin), doubled by each spurious
// declaration (a datagram declared lost that came after all; the packet
// rule then stops: section 6.1.2's adaptive thresholds), and never more
// than the straggler timeout, which is also the wait without an RTT sample
// (the rules are then off: active() is false).
//
// Which refinement waits for what stays with the session core
// (session_core.h); this class keeps the packet numbers and the window.
// Contract: deterministic (times are the caller's, in microseconds); packet
// numbers are untrusted (any value, any order); memory is bounded (the last
// kRiseHistory new highest numbers). Thread safety: none (the core's).
#ifndef MESHSTREAM_SDK_LOSS_DETECTOR_H_
#define MESHSTREAM_SDK_LOSS_DETECTOR_H_

#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>

namespace meshstream::sdk {

class LossDetector {
 public:
  static constexpr uint64_t kPacketThreshold = 3;
  static constexpr uint64_t kMinReorderWindowUs = 2000;
  static constexpr size_t kRiseHistory = 4096;

  // `straggler_us`: the window's cap, and the window without an RTT sample.
  explicit LossDetector(uint64_t straggler_us) : straggler_us_(straggler_us) {}

  // The HELLO's round trip (0: none; the rules are off).
  void SetRtt(uint64_t hello_rtt_us) { rtt_us_ = hello_rtt_us; }
  bool active() const { return rtt_us_ > 0; }

  // A UDP datagram numbered `packet_number` arrived at `at_us`: a new
  // highest number, or a reordered one (which widens the window, and stops
  // the packet rule when it came kPacketThreshold or more behind).
  void OnPacket(uint64_t packet_number, uint64_t at_us);
  // A datagram declared lost came after all: the packet rule stops and the
  // window doubles, up to the straggler timeout.
  void OnSpurious();

  // True when a datagram numbered `packet_number` or higher has arrived.
  bool Seen(uint64_t packet_number) const { return !rises_.empty() && rises_.back().first >= packet_number; }
  // The packet rule for data whose last datagram is numbered `last_data`.
  bool LostByPackets(uint64_t last_data) const { return packet_rule_ && Seen(last_data + kPacketThreshold); }
  // The time rule: `later_us` (0: nothing numbered after yet) is when the
  // first datagram numbered after the data arrived, `clock_us` now.
  bool LostByTime(uint64_t later_us, uint64_t clock_us) const {
    return later_us != 0 && clock_us >= later_us + WindowUs();
  }
  // The wait after a later datagram before what is missing counts as lost.
  uint64_t WindowUs() const;
  bool packet_rule() const { return packet_rule_; }
  // The longest a datagram came after a later-numbered one.
  uint64_t reorder_seen_us() const { return reorder_seen_us_; }

 private:
  uint64_t straggler_us_;
  uint64_t rtt_us_ = 0;
  bool packet_rule_ = true;       // off once reordering beyond it was seen
  uint64_t grown_window_us_ = 0;  // after spurious declarations: the window, doubled each time
  uint64_t reorder_seen_us_ = 0;
  // Each new highest packet number and when it arrived (increasing in both;
  // the last kRiseHistory): how late a reordered datagram is; its back is
  // the highest packet number seen (empty: no UDP datagram yet).
  std::deque<std::pair<uint64_t, uint64_t>> rises_;
  bool rises_forgotten_ = false;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_LOSS_DETECTOR_H_
