#include "codec/loss/reconstructor.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <utility>

#include "codec/core/fnv.h"

namespace meshstream {
namespace {

// What one buffered datagram costs besides its bytes (vector, index entry),
// charged to max_buffered_bytes so that tiny datagrams cannot exhaust memory.
constexpr size_t kEntryOverhead = 64;

uint64_t HashBytes(const uint8_t* data, size_t size) {
  Fnv1a h;
  h.Add(data, size);
  return h.value;
}

}  // namespace

StatusOr<StreamReconstructor> StreamReconstructor::Create(const uint8_t* header, size_t size, uint32_t stream_id,
                                                          const ReconstructorOptions& options) {
  if (options.lod < -1) return InvalidArgument("reconstructor: lod " + std::to_string(options.lod) + " is below -1");
  StreamReconstructor r;
  MS_ASSIGN_OR_RETURN(r.reader_, StreamReader::Create(header, size, stream_id));
  r.reader_.SetTaskRunner(options.runner);
  r.options_ = options;
  r.stream_id_ = stream_id;
  return r;
}

Status StreamReconstructor::SetBase(QuantizedMesh decoded_base) {
  if (controls_ > 0) return InvalidArgument("reconstructor: the base must be set before the first control block");
  MS_RETURN_IF_ERROR(reader_.SetBase(std::move(decoded_base)));
  has_base_ = true;
  return Status::Ok();
}

size_t StreamReconstructor::limit() const {
  const size_t count = reader_.refinement_count();
  return options_.lod < 0 ? count : std::min(count, static_cast<size_t>(options_.lod));
}

bool StreamReconstructor::done() const { return applied() >= limit(); }

StreamReconstructor::Pending& StreamReconstructor::At(size_t k) {
  if (pending_.size() <= k) pending_.resize(k + 1);
  return pending_[k];
}

void StreamReconstructor::OfferOne(Pending& p, const ParsedDatagram& d) {
  const uint64_t accepted = reader_.stats().accepted;
  if (!reader_.OfferDatagram(d)) {
    ++stats_.rejected;
  } else if (reader_.stats().accepted != accepted) {
    ++stats_.accepted;
    ++p.usable;
  } else {
    ++stats_.duplicates;  // every unit it carries arrived in another datagram
  }
}

void StreamReconstructor::Offer(Pending& p) {
  for (const Buffered& b : p.seen) {
    OfferOne(p, b.parsed.Over(b.bytes.data()));
    buffered_bytes_ -= b.bytes.size() + kEntryOverhead;
  }
  p.seen = {};
  p.by_hash = {};
}

Status StreamReconstructor::BeginFront() {
  Pending& p = pending_.front();
  const Status begun = reader_.BeginRefinement(p.control.data(), p.control.size());
  if (!begun.ok()) return failed_ = begun.WithContext("reconstructor");
  begun_ = true;
  Offer(p);
  return Status::Ok();
}

bool StreamReconstructor::Complete(const Pending& p) const {
  return p.has_control && p.has_end && p.usable >= p.announced;
}

Status StreamReconstructor::OnControl(const uint8_t* control, size_t size, uint64_t now_us) {
  MS_RETURN_IF_ERROR(failed_);
  if (!has_base_) return InvalidArgument("reconstructor: a control block arrived before the base mesh was set");
  if (controls_ >= reader_.refinement_count()) {
    return InvalidInput("reconstructor: control block " + std::to_string(controls_) + " but the stream has " +
                        std::to_string(reader_.refinement_count()) + " refinements");
  }
  const size_t index = controls_++;
  if (index >= limit()) return Status::Ok();  // beyond the level of detail asked for
  // Controls arrive in order and refinements are decoded only after theirs, so index >= applied().
  Pending& p = At(index - applied());
  p.control.assign(control, control + size);
  p.has_control = true;
  p.control_time_us = now_us;
  if (index == applied() && !begun_) return BeginFront();
  return Status::Ok();
}

void StreamReconstructor::OnDatagram(const uint8_t* data, size_t size, uint64_t now_us) {
  if (!failed_.ok()) return;
  auto parsed = ParsedDatagram::Parse(data, size);
  if (!parsed.ok()) {
    ++stats_.datagrams;
    ++stats_.rejected;
    return;
  }
  OnDatagram(parsed.value(), now_us);
}

void StreamReconstructor::OnDatagram(const ParsedDatagram& d, uint64_t now_us) {
  (void)now_us;  // readiness is decided by control arrival times and Poll's clock
  if (!failed_.ok()) return;
  const DatagramHeader& h = d.header();
  const uint8_t* data = d.data();
  const size_t size = d.size();
  const bool end = h.kind == DatagramKind::kEnd;
  ++(end ? stats_.ends : stats_.datagrams);
  const StreamHeader& header = reader_.header();
  // An END may announce at most two datagrams per split (structure and
  // geometry travel in at most two); data datagrams must fit the stream.
  const bool fits = h.refinement < header.split_counts.size() &&
                    (end ? h.count <= 2 * uint64_t(header.split_counts[h.refinement]) : DatagramFits(h, header));
  if (h.stream != stream_id_ || !fits) {
    ++stats_.rejected;
    return;
  }
  if (h.refinement < applied() || h.refinement >= limit()) {
    if (!end) ++stats_.late;
    return;
  }
  const size_t k = h.refinement - applied();
  if (end) {
    // ENDs cost no buffer, so they are kept whatever the window.
    Pending& p = At(k);
    if (!p.has_end) {
      p.has_end = true;
      p.announced = h.count;
    }
    return;
  }
  if (k > options_.window) {
    ++stats_.overflow;
    return;
  }
  Pending& p = At(k);
  if (k == 0 && begun_) {
    OfferOne(p, d);  // the refinement being decoded: straight to the reader
    return;
  }
  const uint64_t hash = HashBytes(data, size);
  const auto range = p.by_hash.equal_range(hash);
  for (auto it = range.first; it != range.second; ++it) {
    const std::vector<uint8_t>& other = p.seen[it->second].bytes;
    if (other.size() == size && (size == 0 || std::memcmp(other.data(), data, size) == 0)) {
      ++stats_.duplicates;
      return;
    }
  }
  const size_t cost = size + kEntryOverhead;
  if (buffered_bytes_ > options_.max_buffered_bytes || cost > options_.max_buffered_bytes - buffered_bytes_) {
    ++stats_.overflow;
    return;
  }
  p.by_hash.emplace(hash, static_cast<uint32_t>(p.seen.size()));
  p.seen.push_back(Buffered{std::vector<uint8_t>(data, data + size), d});
  buffered_bytes_ += cost;
}

StatusOr<bool> StreamReconstructor::DecodeNext(uint64_t now_us, bool flushing) {
  MS_RETURN_IF_ERROR(failed_);
  if (done() || pending_.empty() || !pending_.front().has_control) return false;
  if (!begun_) MS_RETURN_IF_ERROR(BeginFront());
  const Pending& p = pending_.front();
  const bool complete = Complete(p);
  const bool timed_out = now_us >= p.control_time_us && now_us - p.control_time_us >= options_.straggler_timeout_us;
  if (!complete && !timed_out && !p.declared && !flushing) return false;
  const Status finished = reader_.FinishRefinement(options_.recovery);
  if (!finished.ok()) return failed_ = finished.WithContext("reconstructor");
  ++(complete ? stats_.finished_complete : p.declared && !timed_out ? stats_.finished_declared : stats_.finished_timeout);
  begun_ = false;
  pending_.pop_front();
  if (!done() && !pending_.empty() && pending_.front().has_control) MS_RETURN_IF_ERROR(BeginFront());
  return true;
}

void StreamReconstructor::Declare(uint32_t refinement) {
  if (!failed_.ok() || refinement < applied() || refinement >= limit()) return;
  At(refinement - applied()).declared = true;
}

StatusOr<size_t> StreamReconstructor::Poll(uint64_t now_us) {
  size_t decoded = 0;
  for (;;) {
    MS_ASSIGN_OR_RETURN(bool did, DecodeNext(now_us, false));
    if (!did) return decoded;
    ++decoded;
  }
}

Status StreamReconstructor::Flush() {
  for (;;) {
    MS_ASSIGN_OR_RETURN(bool did, DecodeNext(0, true));
    if (!did) return Status::Ok();
  }
}

}  // namespace meshstream
