#include "services/streaming/session_runner.h"

#include <algorithm>
#include <thread>

#include "codec/bitstream/format.h"
#include "codec/loss/reliable_cut.h"
#include "net/steady_clock.h"

namespace meshstream {

namespace {

using Clock = std::chrono::steady_clock;


// Sleeps until `due_us`, waking every few milliseconds to see whether the
// session was cancelled; false when it was.
bool SleepUntil(uint64_t due_us, const std::function<bool()>& cancelled) {
  for (;;) {
    const uint64_t now = SteadyNowUs();
    if (now >= due_us) return true;
    if (cancelled()) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(std::min<uint64_t>(due_us - now, 5000)));
  }
}

}  // namespace

SessionRunner::SessionRunner(const SessionPlan& plan, const std::vector<uint8_t>& artifact, int32_t max_level,
                             SessionRunnerOptions options)
    : plan_(plan), artifact_(artifact), max_level_(max_level), options_(options),
      pacer_(options.rate.initial_bps, std::max<size_t>(1, options.burst_datagrams) * kMaxDatagramBytes),
      controller_(options.rate) {}

void SessionRunner::OnReport(const ClientReportInfo& report) {
  const uint64_t now = SteadyNowUs();
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.reports;
  stats_.reported_received += report.received;
  stats_.reported_missing += report.missing;
  for (uint64_t sample : report.rtt_samples_us) {
    if (sample > 0 && sample < 60000000) controller_.OnRttSample(sample);
  }
  uint64_t rtt = 0;
  auto it = end_sent_us_.find({report.stream, report.refinement});
  if (it != end_sent_us_.end()) {
    if (report.end_received && now > it->second + report.hold_us) rtt = now - it->second - report.hold_us;
    end_sent_us_.erase(it);
  } else {
    return;  // not a refinement this session sent over UDP (or reported twice)
  }
  udp_reported_received_ += report.received;
  udp_reported_missing_ += report.missing;
  controller_.OnReport(now, report.received, report.missing, rtt);
}

SessionRunnerStats SessionRunner::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  SessionRunnerStats s = stats_;
  s.final_rate_bps = controller_.rate_bps();
  s.rate_decreases = controller_.decreases();
  s.min_rtt_us = controller_.min_rtt_us();
  s.srtt_us = controller_.srtt_us();
  return s;
}

// The END datagram carries its stream's version: the first byte of the
// stream header (docs/progressive-format.md, sections 3 and 6).
std::vector<uint8_t> SessionRunner::EndDatagram(const PlannedRefinement& r, uint32_t stream, uint32_t count) const {
  const ByteRange& header = plan_.primitives[r.primitive].header;
  const uint8_t version = header.length > 0 ? artifact_[header.offset] : kStreamVersion;
  return MakeEndDatagram(stream, r.refinement, count, version);
}

bool SessionRunner::InReliableCut(const PlannedRefinement& r) {
  if (!options_.reliable_cut) return false;
  constexpr uint64_t kMinReported = 32;
  double loss = options_.expected_loss >= 0 ? options_.expected_loss : kReferenceLoss;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const uint64_t reported = udp_reported_received_ + udp_reported_missing_;
    if (reported >= kMinReported) loss = static_cast<double>(udp_reported_missing_) / static_cast<double>(reported);
    stats_.cut_loss = loss;
  }
  const std::vector<uint32_t> cut = ReliableCutFor(plan_.primitives[r.primitive], loss);
  return std::binary_search(cut.begin(), cut.end(), r.refinement);
}

bool SessionRunner::WaitToSend(size_t bytes, const std::function<bool()>& cancelled) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pacer_.SetRate(controller_.rate_bps());
  }
  uint64_t due = pacer_.DueUs(SteadyNowUs(), bytes);
  if (options_.server_share != nullptr) due = std::max(due, options_.server_share->Reserve(SteadyNowUs(), bytes));
  return SleepUntil(due, cancelled);
}

bool SessionRunner::SendRefinementGrpc(const PlannedRefinement& r, uint32_t stream, SessionSink& sink,
                                       const std::function<bool()>* paced) {
  const uint32_t count = static_cast<uint32_t>(r.datagrams.size());
  if (!sink.Control(r, stream, count, 0, true)) return false;
  for (const ByteRange& d : r.datagrams) {
    const size_t bytes = static_cast<size_t>(d.length) + kPacketOverheadBytes;
    if (paced != nullptr && !WaitToSend(bytes, *paced)) return false;
    if (!sink.Datagram(artifact_.data() + d.offset, d.length)) return false;
    if (paced != nullptr) pacer_.OnSent(SteadyNowUs(), bytes);
  }
  const std::vector<uint8_t> end = EndDatagram(r, stream, count);
  if (!sink.Datagram(end.data(), end.size())) return false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.datagrams_sent += count + 1;
  }
  return sink.RefinementEnd(stream, r.refinement, count);
}

bool SessionRunner::SendRefinementUdp(const PlannedRefinement& r, uint32_t stream, SessionSink& sink,
                                      const std::function<bool()>& cancelled) {
  const uint32_t count = static_cast<uint32_t>(r.datagrams.size());
  const uint64_t first = udp_->ReservePacketNumbers(count + 1);
  if (!sink.Control(r, stream, count, first, false)) return false;
  const std::vector<uint8_t> end = EndDatagram(r, stream, count);
  std::vector<std::pair<const uint8_t*, size_t>> all;
  all.reserve(count + 1);
  for (const ByteRange& d : r.datagrams) all.emplace_back(artifact_.data() + d.offset, static_cast<size_t>(d.length));
  all.emplace_back(end.data(), end.size());

  Pacer& pacer = pacer_;
  size_t next = 0;
  uint64_t bytes = 0;
  while (next < all.size()) {
    // The next batch: as many datagrams as are due together (at most a burst).
    const size_t take = std::min(options_.burst_datagrams, all.size() - next);
    size_t batch_bytes = 0;
    for (size_t i = 0; i < take; ++i) batch_bytes += all[next + i].second + kPacketOverheadBytes;
    if (!WaitToSend(batch_bytes, cancelled)) return false;
    std::vector<std::pair<const uint8_t*, size_t>> batch(all.begin() + static_cast<long>(next),
                                                         all.begin() + static_cast<long>(next + take));
    const Status s = udp_->SendData(batch, first + next);
    if (!s.ok()) return false;
    pacer.OnSent(SteadyNowUs(), batch_bytes);
    for (const auto& p : batch) bytes += p.second;
    next += take;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.datagrams_sent += all.size();
    stats_.bytes_sent += bytes;
    end_sent_us_[{stream, r.refinement}] = SteadyNowUs();
    // Entries of refinements never reported stay bounded by the plan's size.
  }
  return sink.RefinementEnd(stream, r.refinement, count);
}

StatusOr<std::string> SessionRunner::Run(SessionSink& sink, const std::function<bool()>& cancelled) {
  SessionTransport transport = SessionTransport::kGrpc;
  if (options_.want_udp && options_.udp != nullptr) {
    auto session = options_.udp->RegisterSession();
    if (session.ok()) {
      udp_ = std::move(session).value();
      transport = SessionTransport::kUdp;
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.transport = transport;
  }
  if (!sink.Start(transport, udp_.get())) return Aborted("the client went away");
  if (transport == SessionTransport::kUdp) {
    // From when the start has been handed to the transport (a large start
    // on a slow link takes a while to write), not from before it.
    // An authenticated HELLO that has not proven the address yet means the
    // round trip is under way (a lost HELLO_ACK, a slow path): the wait is
    // extended from it, up to three timeouts in all.
    const uint64_t registered_us = udp_->last_hello_us();
    const auto first_deadline = Clock::now() + options_.hello_timeout;
    const auto last_deadline = first_deadline + 2 * options_.hello_timeout;
    auto deadline = first_deadline;
    bool proven = false;
    while (!proven && Clock::now() < deadline && !cancelled()) {
      proven = udp_->WaitProven(std::min<std::chrono::milliseconds>(
          std::chrono::milliseconds(20),
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()) + std::chrono::milliseconds(1)));
      const uint64_t heard = udp_->last_hello_us();
      if (!proven && heard > registered_us) {
        const auto from_hello = Clock::now() - std::chrono::microseconds(SteadyNowUs() - heard) + options_.hello_timeout;
        deadline = std::min(last_deadline, std::max(deadline, std::chrono::time_point_cast<Clock::duration>(from_hello)));
      }
    }
    if (cancelled()) return Aborted("cancelled");
    if (!proven) {
      transport = SessionTransport::kGrpc;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.transport = transport;
      }
      const std::string reason = "no HELLO proved a UDP address within " +
                                 std::to_string(options_.hello_timeout.count()) + " ms";
      if (!sink.TransportChanged(transport, reason)) return Aborted("the client went away");
      udp_.reset();
    }
  }
  for (const PlannedRefinement& r : plan_.refinements) {
    if (cancelled()) return Aborted("cancelled");
    const uint32_t stream = plan_.primitives[r.primitive].stream;
    bool ok = false;
    if (transport == SessionTransport::kUdp && InReliableCut(r)) {
      // On the stream, but paced and charged to the server's share like the
      // UDP datagrams: moving data to the stream does not lift --max-rate.
      ok = SendRefinementGrpc(r, stream, sink, &cancelled);
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.reliable_refinements;
      stats_.reliable_datagrams += r.datagrams.size();
      for (const ByteRange& d : r.datagrams) stats_.reliable_bytes += d.length;
    } else {
      ok = transport == SessionTransport::kUdp ? SendRefinementUdp(r, stream, sink, cancelled)
                                               : SendRefinementGrpc(r, stream, sink);
    }
    if (!ok) return cancelled() ? Aborted("cancelled") : Aborted("the client went away");
  }
  const std::string reason = max_level_ >= 0 ? "max_level" : "complete";
  if (!sink.End(reason)) return Aborted("the client went away");
  return reason;
}

}  // namespace meshstream
