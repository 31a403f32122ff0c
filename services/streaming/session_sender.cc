#include "services/streaming/session_sender.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include <cmath>

#include "codec/bitstream/format.h"
#include "codec/loss/parity.h"
#include "codec/loss/protection.h"
#include "codec/loss/reliable_cut.h"
#include "net/packet_header.h"

namespace meshstream {

namespace {

// The codec's END datagram of refinement `r` carrying `count` data
// datagrams, with its stream's version (the first byte of the stream header;
// docs/spec/progressive-format.md, sections 3 and 6). The server builds it here
// and nowhere else.
std::vector<uint8_t> ServerEndDatagram(const SessionPlan& plan, const std::vector<uint8_t>& artifact,
                                       const PlannedRefinement& r, uint32_t count) {
  const PlannedPrimitive& p = plan.primitives[r.primitive];
  return MakeStreamEndDatagram(artifact.data() + p.header.offset, static_cast<size_t>(p.header.length), p.stream,
                               r.refinement, count);
}

}  // namespace

double ReportedLoss(uint64_t received, uint64_t missing, double expected_loss) {
  const uint64_t reported = received + missing;
  if (reported < SessionSender::kMinReportedForCut) {
    return expected_loss >= 0 ? std::min(1.0, expected_loss) : kReferenceLoss;
  }
  return static_cast<double>(missing) / static_cast<double>(reported);
}

double ParityLossFor(uint64_t received, uint64_t missing, uint64_t runs, double expected_loss, double* burst) {
  *burst = 0;
  const uint64_t reported = received + missing;
  if (reported < SessionSender::kMinReportedForCut) {
    // Too few reports for a rate: what the client stated, and nothing while
    // it stated nothing and has reported no loss; once it has reported a
    // loss, at least the reference loss (a statement of none was wrong).
    const double stated = expected_loss > 0 ? std::min(1.0, expected_loss) : 0.0;
    return missing == 0 ? stated : std::max(stated, kReferenceLoss);
  }
  if (missing == 0) return 0;
  const double p = ReportedLoss(received, missing, expected_loss);
  const double n = static_cast<double>(reported);
  if (runs > 0) *burst = static_cast<double>(missing) / static_cast<double>(runs);
  // One-sided 95 % upper bound of the rate (normal approximation); with
  // bursts the losses are not independent: the effective count is n / burst.
  const double effective = *burst > 1 ? n / *burst : n;
  return std::min(1.0, p + 1.645 * std::sqrt(p * (1 - p) / effective));
}

std::string DescribeSession(const SessionSenderStats& st) {
  std::ostringstream out;
  out << (st.transport == SessionTransport::kUdp ? "udp" : "grpc") << ", " << st.datagrams_sent << " datagrams sent, "
      << st.reports << " reports, " << st.reported_missing << " missing, rate " << std::fixed << std::setprecision(1)
      << st.final_rate_bps / 1e6 << " Mbit/s, " << st.rate_decreases << " decreases, srtt " << std::setprecision(2)
      << st.srtt_us / 1000.0 << " ms, " << st.early_refinements << " refinements before the proof (" << st.early_bytes
      << " bytes), " << st.reliable_refinements << " refinements reliable (" << st.reliable_bytes
      << " bytes, for loss " << std::setprecision(3) << st.cut_loss << "), " << st.parity_datagrams
      << " parity datagrams (" << st.parity_bytes << " bytes, for loss " << st.parity_loss << "), " << st.repaired
      << " repaired";
  return out.str();
}

SessionSender::SessionSender(const SessionPlan& plan, const std::vector<uint8_t>& artifact, int32_t max_level,
                             SessionSenderOptions options, uint64_t now_us)
    : plan_(&plan), artifact_(artifact), max_level_(max_level), options_(std::move(options)),
      transport_(options_.transport),
      pacer_(options_.rate.initial_bps, std::max<size_t>(1, options_.burst_datagrams) * kMaxDatagramBytes),
      controller_(options_.rate), last_heard_us_(now_us) {
  options_.burst_datagrams = std::max<size_t>(1, options_.burst_datagrams);
  // Parity: each primitive's tiers from its delivery record, and where its
  // last protected refinement lies in the plan (its block closes there).
  tiers_.resize(plan_->primitives.size());
  open_blocks_.resize(plan_->primitives.size());
  if (options_.erasure != nullptr) {
    for (size_t i = 0; i < plan_->primitives.size(); ++i) {
      const DeliveryRecord& d = plan_->primitives[i].delivery;
      tiers_[i] = ProtectionTiers(d.parity, d.harm, plan_->primitives[i].refinement_bytes.size());
    }
  }
  FindLastProtected();
}

void SessionSender::FindLastProtected() {
  last_protected_.assign(plan_->primitives.size(), SIZE_MAX);
  if (options_.erasure == nullptr) return;
  for (size_t k = 0; k < plan_->refinements.size(); ++k) {
    const PlannedRefinement& r = plan_->refinements[k];
    const auto& t = tiers_[r.primitive];
    if (r.refinement < t.size() && t[r.refinement] != kUnprotected) last_protected_[r.primitive] = k;
  }
}

void SessionSender::OnView(uint64_t now_us, const View& view) {
  OnClientMessage(now_us);
  if (!ViewCanOrder(*plan_)) return;
  pending_view_ = view;
}

uint32_t SessionSender::ApplyView(uint64_t now_us) {
  const View view = *pending_view_;
  pending_view_.reset();
  view_applied_us_ = now_us;
  uint32_t first_changed = 0;
  std::optional<SessionPlan> ordered = OrderByView(*plan_, index_, view, &first_changed);
  if (!ordered) return 0;  // the view changes nothing: no new plan, no LevelPlan
  own_plan_ = std::make_unique<SessionPlan>(std::move(*ordered));
  plan_ = own_plan_.get();
  FindLastProtected();
  return first_changed;
}

void SessionSender::OnClientMessage(uint64_t now_us) { last_heard_us_ = std::max(last_heard_us_, now_us); }

void SessionSender::OnReport(uint64_t now_us, const ClientReportInfo& report) {
  OnClientMessage(now_us);
  ++stats_.reports;
  stats_.reported_received += report.received;
  stats_.reported_missing += report.missing;
  for (uint64_t sample : report.rtt_samples_us) {
    if (sample > 0 && sample < 60000000) controller_.OnRttSample(sample);
  }
  auto it = end_sent_us_.find({report.stream, report.refinement});
  if (it == end_sent_us_.end()) return;  // not a refinement this session sent over UDP (or reported twice)
  uint64_t rtt = 0;
  if (report.end_received && now_us > it->second + report.hold_us) rtt = now_us - it->second - report.hold_us;
  end_sent_us_.erase(it);
  udp_reported_received_ += report.received;
  udp_reported_missing_ += report.missing;
  udp_reported_runs_ += std::min(report.missing_runs, report.missing);
  if (report.arrival_span_us > 0 && report.span_bytes > 0) {
    controller_.OnDeliverySample(now_us, 8e6 * static_cast<double>(report.span_bytes) /
                                             static_cast<double>(report.arrival_span_us));
  }
  controller_.OnReport(now_us, report.received, report.missing, rtt);
}

void SessionSender::OnRepair(uint64_t now_us, const std::vector<RepairItem>& items) {
  OnClientMessage(now_us);
  if (repair_received_) return;  // the driver reads nothing after the first
  repair_received_ = true;
  if (!options_.repair) {
    repair_status_ = InvalidArgument("repair: the session was not opened with repair");
    return;
  }
  auto ranges = RepairDatagrams(*plan_, items);
  if (!ranges.ok()) {
    repair_status_ = ranges.status();
    return;
  }
  repair_payloads_.reserve(ranges->size());
  for (const ByteRange& d : ranges.value()) {
    repair_payloads_.emplace_back(artifact_.data() + d.offset, static_cast<size_t>(d.length));
  }
}

void SessionSender::OnClientClosed(uint64_t now_us, bool done) {
  if (done) OnClientMessage(now_us);
  client_closed_ = true;
  client_done_ = client_done_ || done;
}

void SessionSender::OnHello(uint64_t last_hello_us, bool proven) {
  last_hello_us_ = std::max(last_hello_us_, last_hello_us);
  proven_ = proven_ || proven;
}

void SessionSender::Cancel(Status status, std::string reason) {
  if (cancelled_ || phase_ == Phase::kFinished) return;
  cancelled_ = true;
  cancel_status_ = std::move(status);
  end_reason_ = std::move(reason);
}

uint64_t SessionSender::idle_deadline_us() const {
  if (options_.idle_timeout_us == 0 || phase_ == Phase::kFinished) return SenderAction::kNever;
  return last_heard_us_ + options_.idle_timeout_us;
}

SessionSenderStats SessionSender::stats() const {
  SessionSenderStats s = stats_;  // its transport and rate fields are filled here
  s.transport = transport_;
  s.final_rate_bps = controller_.rate_bps();
  s.rate_decreases = controller_.decreases();
  s.min_rtt_us = controller_.min_rtt_us();
  s.srtt_us = controller_.srtt_us();
  return s;
}

SenderAction SessionSender::Finish(Status status, std::string reason) {
  phase_ = Phase::kFinished;
  end_reason_ = std::move(reason);
  SenderAction a;
  a.kind = SenderAction::kFinish;
  a.status = std::move(status);
  return a;
}

SenderAction SessionSender::Next(uint64_t now_us) {
  if (phase_ == Phase::kFinished) return SenderAction{};
  if (cancelled_) return Finish(cancel_status_, end_reason_);
  if (now_us >= idle_deadline_us()) {
    return Finish(DeadlineExceeded("the session was idle for " + std::to_string(options_.idle_timeout_us / 1000000) +
                                   " s"),
                  "timeout");
  }
  // The driver reads nothing after a repair request: in a session without
  // repair nothing can make it end otherwise than refused, so it ends now
  // rather than after every refinement (or at the idle timeout).
  if (repair_received_ && !options_.repair) {
    return Finish(repair_status_, end_reason_.empty() ? "unasked repair" : end_reason_);
  }
  const bool before_end = phase_ == Phase::kStart || phase_ == Phase::kRefinements;
  if (client_done_ && before_end) return Finish(Cancelled("the client went away"), "client done");
  SenderAction a;
  switch (phase_) {
    case Phase::kStart:
      phase_ = Phase::kRefinements;
      a.kind = SenderAction::kStart;
      a.transport = transport_;
      return a;
    case Phase::kRefinements:
      a = NextRefinementStep(now_us);
      break;
    default:
      a = AfterEnd(now_us);
      break;
  }
  if (a.kind == SenderAction::kWait) a.due_us = std::min(a.due_us, idle_deadline_us());
  return a;
}

bool SessionSender::HelloWaitOver(uint64_t now_us) {
  if (!hello_started_) {
    // From when the start has been handed to the transport (a large start
    // on a slow link takes a while to write), not from before it.
    hello_started_ = true;
    hello_registered_us_ = last_hello_us_;
    hello_deadline_us_ = now_us + options_.hello_timeout_us;
    hello_last_deadline_us_ = hello_deadline_us_ + 2 * options_.hello_timeout_us;
  }
  // An authenticated HELLO that has not proven the address yet means the
  // round trip is under way (a lost HELLO_ACK, a slow path): the wait is
  // extended from it, up to three timeouts in all.
  if (last_hello_us_ > hello_registered_us_) {
    hello_deadline_us_ =
        std::min(hello_last_deadline_us_, std::max(hello_deadline_us_, last_hello_us_ + options_.hello_timeout_us));
  }
  return now_us >= hello_deadline_us_;
}

bool SessionSender::InReliableCut(const PlannedRefinement& r) {
  if (!options_.reliable_cut) return false;
  const double loss = ReportedLoss(udp_reported_received_, udp_reported_missing_, options_.expected_loss);
  stats_.cut_loss = loss;
  const std::vector<uint32_t> cut = ReliableCutFor(plan_->primitives[r.primitive], loss);
  return std::binary_search(cut.begin(), cut.end(), r.refinement);
}

double SessionSender::ParityLossNow(double* burst) const {
  return ParityLossFor(udp_reported_received_, udp_reported_missing_, udp_reported_runs_, options_.expected_loss, burst);
}

void SessionSender::CloseParityBlock(uint32_t primitive) {
  OpenBlock& b = open_blocks_[primitive];
  if (b.members.empty()) return;
  double burst = 0;
  const double loss = ParityLossNow(&burst);
  stats_.parity_loss = loss;
  stats_.parity_burst = burst;
  std::vector<uint32_t> lengths;
  std::vector<std::vector<uint8_t>> copies;
  for (const ByteRange& d : b.members) {
    lengths.push_back(static_cast<uint32_t>(d.length));
    copies.emplace_back(artifact_.begin() + static_cast<std::ptrdiff_t>(d.offset),
                        artifact_.begin() + static_cast<std::ptrdiff_t>(d.offset + d.length));
  }
  const ParityShape shape = ShapeFor(lengths, loss, burst, options_.parity_plan, b.tier);
  b = OpenBlock{};
  if (shape.m == 0) return;
  std::vector<const std::vector<uint8_t>*> members;
  for (const auto& c : copies) members.push_back(&c);
  auto parity = EncodeParity(*options_.erasure, plan_->primitives[primitive].stream, members, shape);
  if (!parity.ok()) return;  // the artifact's datagrams are the store's: not reached
  ++stats_.parity_blocks;
  for (auto& d : parity.value()) parity_due_.push_back(std::move(d));
}

bool SessionSender::JoinParityBlock(const PlannedRefinement& r) {
  const auto& tiers = tiers_[r.primitive];
  const uint8_t tier = r.refinement < tiers.size() ? tiers[r.refinement] : static_cast<uint8_t>(kUnprotected);
  if (tier == kUnprotected || r.datagrams.empty()) return false;
  OpenBlock& b = open_blocks_[r.primitive];
  const ParityPlanOptions& o = options_.parity_plan;
  if (!b.members.empty() && (b.tier != tier || r.refinement - b.first_refinement >= std::max<uint32_t>(1, o.max_span) ||
                             b.members.size() + r.datagrams.size() > std::max<uint32_t>(1, o.block_datagrams))) {
    CloseParityBlock(r.primitive);
  }
  if (b.members.empty()) {
    b.tier = tier;
    b.first_refinement = r.refinement;
  }
  b.members.insert(b.members.end(), r.datagrams.begin(), r.datagrams.end());
  return true;
}

SenderAction SessionSender::NextRefinementStep(uint64_t now_us) {
  SenderAction a;
  if (index_ >= plan_->refinements.size() && transport_ == SessionTransport::kUdp && !trailing_parity_) {
    // The parity still due, and that of the blocks still open, goes out now
    // (over UDP, paced): after it, the end.
    trailing_parity_ = true;
    for (uint32_t p = 0; p < open_blocks_.size(); ++p) CloseParityBlock(p);
    if (!parity_due_.empty()) {
      parity_sent_ = std::move(parity_due_);
      parity_due_.clear();
      payloads_.clear();
      for (const auto& d : parity_sent_) payloads_.emplace_back(d.data(), d.size());
      mode_ = Mode::kUdp;
      first_packet_number_ = options_.reserve_packet_numbers(payloads_.size());
      next_payload_ = 0;
      batch_reserved_ = false;
      for (const auto& d : parity_sent_) {
        ++stats_.parity_datagrams;
        stats_.parity_bytes += d.size();
      }
    }
  }
  if (trailing_parity_ && mode_ == Mode::kUdp && next_payload_ < payloads_.size() && index_ >= plan_->refinements.size()) {
    return NextBatch(now_us);
  }
  if (index_ >= plan_->refinements.size()) {
    phase_ = options_.repair ? Phase::kAwaitRepair : Phase::kLinger;
    ended_us_ = now_us;
    end_reason_ = max_level_ >= 0 ? "max_level" : "complete";
    a.kind = SenderAction::kEnd;
    a.reason = end_reason_;
    return a;
  }
  if (step_ == Step::kControl && pending_view_ &&
      (!view_applied_us_ || now_us >= *view_applied_us_ + kMinViewIntervalUs)) {
    const uint32_t first_changed = ApplyView(now_us);
    if (first_changed > 0) {
      a.kind = SenderAction::kLevels;
      a.first_changed_level = first_changed;
      return a;
    }
  }
  const PlannedRefinement& r = plan_->refinements[index_];
  const uint32_t stream = plan_->primitives[r.primitive].stream;
  const uint32_t count = static_cast<uint32_t>(r.datagrams.size());
  if (step_ == Step::kControl) {
    const bool unproven = transport_ == SessionTransport::kUdp && !proven_;
    if (unproven && HelloWaitOver(now_us)) {
      transport_ = SessionTransport::kGrpc;
      a.kind = SenderAction::kTransportChange;
      a.transport = transport_;
      a.reason = "no HELLO proved a UDP address within " + std::to_string(options_.hello_timeout_us / 1000) + " ms";
      return a;
    }
    const bool cut = transport_ == SessionTransport::kUdp && InReliableCut(r);
    if (unproven && !cut && options_.wait_for_hello) {
      // The HELLO hook wakes the driver when an address is proven.
      a.kind = SenderAction::kWait;
      a.due_us = hello_deadline_us_;
      return a;
    }
    const bool early = unproven && !cut;
    if (early) {
      // No address to send DATA to yet: the refinement goes on the stream,
      // paced as UDP would be, and the next one looks again.
      mode_ = Mode::kStreamPaced;
      ++stats_.early_refinements;
      for (const ByteRange& d : r.datagrams) stats_.early_bytes += d.length;
    } else if (cut) {
      // On the stream, but paced and charged to the server's share like the
      // UDP datagrams: moving data to the stream does not lift --max-rate.
      mode_ = Mode::kStreamPaced;
      ++stats_.reliable_refinements;
      stats_.reliable_datagrams += count;
      for (const ByteRange& d : r.datagrams) stats_.reliable_bytes += d.length;
    } else {
      mode_ = transport_ == SessionTransport::kUdp ? Mode::kUdp : Mode::kStream;
    }
    // Parity: over UDP a protected refinement joins its primitive's block,
    // and the parity of blocks closed before follows this refinement's END
    // (interleaved with the next block's data: one burst does not take both).
    // The primitive's last block closes with its last protected refinement
    // and its parity follows that refinement's END at once: the client
    // decodes it before it completes, not after.
    parity_sent_.clear();
    bool parity_follows = false;
    if (mode_ == Mode::kUdp && options_.erasure != nullptr) {
      // The client holds the refinement, when incomplete, for the parity
      // announced here (reconstructor.h, parity_hold_us): announced when
      // the loss its block would be sized for now is above 0.
      double burst = 0;
      parity_follows = JoinParityBlock(r) && ParityLossNow(&burst) > 0;
      if (last_protected_[r.primitive] == index_) CloseParityBlock(r.primitive);
      parity_sent_ = std::move(parity_due_);
      parity_due_.clear();
    }
    first_packet_number_ = mode_ == Mode::kUdp ? options_.reserve_packet_numbers(count + 1 + parity_sent_.size()) : 0;
    end_datagram_ = ServerEndDatagram(*plan_, artifact_, r, count);
    payloads_.clear();
    payloads_.reserve(count + 1 + parity_sent_.size());
    for (const ByteRange& d : r.datagrams) payloads_.emplace_back(artifact_.data() + d.offset, static_cast<size_t>(d.length));
    payloads_.emplace_back(end_datagram_.data(), end_datagram_.size());
    for (const auto& d : parity_sent_) {
      payloads_.emplace_back(d.data(), d.size());
      ++stats_.parity_datagrams;
      stats_.parity_bytes += d.size();
    }
    next_payload_ = 0;
    batch_reserved_ = false;
    step_ = Step::kDatagrams;
    a.kind = SenderAction::kControl;
    a.refinement = &r;
    a.stream = stream;
    a.count = count;
    a.first_packet_number = first_packet_number_;
    a.reliable = mode_ != Mode::kUdp;
    a.before_proof = early;
    a.parity_follows = parity_follows;
    return a;
  }
  if (step_ == Step::kDatagrams) {
    if (next_payload_ < payloads_.size()) return NextBatch(now_us);
    step_ = Step::kRefinementEnd;
  }
  stats_.datagrams_sent += count + 1;  // parity not included (parity_datagrams)
  if (mode_ == Mode::kUdp) {
    end_sent_us_[{stream, r.refinement}] = now_us;
    // Entries of refinements never reported stay bounded by the plan's size.
  }
  ++index_;
  step_ = Step::kControl;
  a.kind = SenderAction::kRefinementEnd;
  a.refinement = &r;
  a.stream = stream;
  a.count = count;
  a.parity = mode_ == Mode::kUdp ? static_cast<uint32_t>(parity_sent_.size()) : 0;
  return a;
}

SenderAction SessionSender::NextBatch(uint64_t now_us) {
  SenderAction a;
  const size_t left = payloads_.size() - next_payload_;
  size_t take = left;
  bool paced = true;
  switch (mode_) {
    case Mode::kStream:
      take = std::min(options_.burst_datagrams, left);
      paced = false;
      break;
    case Mode::kStreamPaced:
      take = 1;
      paced = left > 1;  // the END follows its data at once
      break;
    case Mode::kUdp:
      take = std::min(options_.burst_datagrams, left);
      break;
  }
  size_t bytes = 0;
  for (size_t i = 0; i < take; ++i) bytes += payloads_[next_payload_ + i].second + kPacketOverheadBytes;
  if (paced) {
    if (!batch_reserved_) {
      pacer_.SetRate(controller_.rate_bps());
      uint64_t due = pacer_.DueUs(now_us, bytes);
      if (options_.server_share != nullptr) due = std::max(due, options_.server_share->Reserve(now_us, bytes));
      batch_reserved_ = true;
      batch_due_us_ = due;
    }
    if (now_us < batch_due_us_) {
      a.due_us = batch_due_us_;
      return a;
    }
    batch_reserved_ = false;
    pacer_.OnSent(now_us, bytes);
  }
  a.kind = SenderAction::kDatagrams;
  a.on_stream = mode_ != Mode::kUdp;
  a.first_packet_number = first_packet_number_ + next_payload_;
  a.datagrams = PayloadSpan(payloads_.data() + next_payload_, take);
  if (mode_ == Mode::kUdp) {
    for (const auto& p : a.datagrams) stats_.bytes_sent += p.second;
  }
  next_payload_ += take;
  return a;
}

SenderAction SessionSender::AfterEnd(uint64_t now_us) {
  SenderAction a;
  if (phase_ == Phase::kAwaitRepair) {
    if (repair_received_) {
      if (!repair_status_.ok()) return Finish(repair_status_, end_reason_);
      repair_next_ = 0;
      phase_ = Phase::kRepairing;
    } else if (client_closed_) {
      return Finish(Status::Ok(), end_reason_);
    } else if (now_us < ended_us_ + kRepairWaitUs) {
      a.due_us = ended_us_ + kRepairWaitUs;
      return a;
    } else {
      // No request: the client gets the linger to close, as without repair.
      phase_ = Phase::kLinger;
      ended_us_ = now_us;
    }
  }
  if (phase_ == Phase::kRepairing) {
    if (repair_next_ < repair_payloads_.size()) {
      const size_t take = std::min(options_.burst_datagrams, repair_payloads_.size() - repair_next_);
      a.kind = SenderAction::kDatagrams;
      a.on_stream = true;
      a.datagrams = PayloadSpan(repair_payloads_.data() + repair_next_, take);
      for (const DatagramPayload& d : a.datagrams) {
        ++stats_.repaired;
        stats_.repaired_bytes += d.second;
      }
      repair_next_ += take;
      return a;
    }
    // After its repair request the client sends nothing more the server
    // reads: the session is over once RepairEnd is written.
    phase_ = Phase::kLinger;
    client_closed_ = true;
    a.kind = SenderAction::kRepairEnd;
    a.count = static_cast<uint32_t>(stats_.repaired);
    a.bytes = stats_.repaired_bytes;
    return a;
  }
  // kLinger: the client closes its side (or sends done) so that the call ends OK.
  if (client_closed_) return Finish(Status::Ok(), end_reason_);
  if (now_us >= ended_us_ + kLingerUs) {
    return Finish(Cancelled("the client did not close the session within " + std::to_string(kLingerUs / 1000000) +
                            " s of its end"),
                  end_reason_);
  }
  a.due_us = ended_us_ + kLingerUs;
  return a;
}

}  // namespace meshstream
