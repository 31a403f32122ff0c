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
  if (options.erasure != nullptr) r.parity_.emplace(options.erasure, stream_id, options.max_buffered_bytes);
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
  std::vector<std::vector<uint8_t>> rebuilt;
  if (h.kind == DatagramKind::kParity) {
    ++stats_.parity;
    if (!parity_ || h.stream != stream_id_ || h.version != reader_.header().version) return;
    parity_->OnParity(d, &rebuilt);
    ArriveRebuilt(rebuilt);
    return;
  }
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
  // A copy for parity blocks, whatever happens to the datagram below (one
  // of a refinement already decoded still helps rebuild its block's others).
  if (parity_ && !end && h.refinement < limit()) parity_->OnData(d, &rebuilt);
  Arrive(d);
  ArriveRebuilt(rebuilt);
}

void StreamReconstructor::Arrive(const ParsedDatagram& d) {
  const DatagramHeader& h = d.header();
  const uint8_t* data = d.data();
  const size_t size = d.size();
  const bool end = h.kind == DatagramKind::kEnd;
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

void StreamReconstructor::ArriveRebuilt(std::vector<std::vector<uint8_t>>& rebuilt) {
  if (rebuilt.empty()) return;
  uint32_t first_decoded = UINT32_MAX;
  for (const std::vector<uint8_t>& bytes : rebuilt) {
    auto d = ParsedDatagram::Parse(bytes.data(), bytes.size());
    if (!d.ok()) continue;  // ParityRecovery returns only datagrams that parse
    ++stats_.recovered;
    const uint32_t r = d->header().refinement;
    if (r < applied()) {
      first_decoded = std::min(first_decoded, r);
    } else {
      Arrive(d.value());
    }
  }
  if (first_decoded == UINT32_MAX) return;
  const Status s = DecodeAgainFrom(first_decoded);
  if (!s.ok()) failed_ = s.WithContext("reconstructor: decoding again");
}

Status StreamReconstructor::DecodeAgainFrom(uint32_t r) {
  auto at = history_.find(r);
  if (at == history_.end() || !at->second.before_finish) {
    ++stats_.recovered_late;  // released, or decoded before parity was kept
    return Status::Ok();
  }
  const size_t target = applied();
  // The reader as it was before refinement r finished, with what arrived
  // for r then; what arrived since (the rebuilt datagrams among it) is
  // offered on top, then r and every later refinement finish again.
  StreamReader reader = std::move(*at->second.before_finish);
  std::swap(reader_, reader);
  for (uint32_t i = r; i < target; ++i) {
    Decoded& decoded = history_[i];
    if (i > r) MS_RETURN_IF_ERROR(reader_.BeginRefinement(decoded.control.data(), decoded.control.size()));
    for (const std::vector<uint8_t>* bytes : parity_->Kept(i)) reader_.OfferDatagram(bytes->data(), bytes->size());
    decoded.before_finish.reset();
    if (!reader_.HasEveryUnit()) decoded.before_finish.emplace(reader_);
    MS_RETURN_IF_ERROR(reader_.FinishRefinement(options_.recovery));
    ++stats_.redecoded;
  }
  ++decodes_again_;
  // The refinement being decoded was begun in the old reader: begin it in
  // this one with every datagram that arrived for it.
  if (begun_ && !pending_.empty()) {
    Pending& p = pending_.front();
    MS_RETURN_IF_ERROR(reader_.BeginRefinement(p.control.data(), p.control.size()));
    p.usable = 0;
    for (const std::vector<uint8_t>* bytes : parity_->Kept(static_cast<uint32_t>(target))) {
      auto d = ParsedDatagram::Parse(bytes->data(), bytes->size());
      if (d.ok()) OfferOne(p, d.value());
    }
  }
  return Status::Ok();
}

void StreamReconstructor::ReleaseHistory() {
  if (!parity_ || applied() <= options_.parity_horizon) return;
  const uint32_t first = static_cast<uint32_t>(applied() - options_.parity_horizon);
  history_.erase(history_.begin(), history_.lower_bound(first));
  parity_->Release(first);
}

StatusOr<bool> StreamReconstructor::DecodeNext(uint64_t now_us, bool flushing) {
  MS_RETURN_IF_ERROR(failed_);
  if (done() || pending_.empty() || !pending_.front().has_control) return false;
  if (!begun_) MS_RETURN_IF_ERROR(BeginFront());
  Pending& p = pending_.front();
  const bool complete = Complete(p);
  const bool timed_out = now_us >= p.control_time_us && now_us - p.control_time_us >= options_.straggler_timeout_us;
  if (!complete && !timed_out && !p.declared && !flushing) return false;
  if (!complete && !flushing && Held(p, now_us)) return false;
  if (parity_) {
    // Kept so that parity arriving later can have it decoded again.
    Decoded& decoded = history_[static_cast<uint32_t>(applied())];
    decoded.control = p.control;
    if (!reader_.HasEveryUnit()) decoded.before_finish.emplace(reader_);
  }
  const Status finished = reader_.FinishRefinement(options_.recovery);
  if (!finished.ok()) return failed_ = finished.WithContext("reconstructor");
  ++(complete ? stats_.finished_complete : p.declared && !timed_out ? stats_.finished_declared : stats_.finished_timeout);
  begun_ = false;
  pending_.pop_front();
  ReleaseHistory();
  if (!done() && !pending_.empty() && pending_.front().has_control) MS_RETURN_IF_ERROR(BeginFront());
  return true;
}

bool StreamReconstructor::Held(Pending& p, uint64_t now_us) {
  if (!parity_ || options_.parity_hold_us == 0 || !p.parity_follows || holds_over_) return false;
  if (!parity_->MayStillCover(static_cast<uint32_t>(applied()))) return false;
  if (pending_.size() > options_.window) return false;  // never drop data for a hold
  if (now_us >= p.control_time_us && now_us - p.control_time_us >= options_.parity_hold_us) return false;
  if (!p.held) {
    p.held = true;
    ++stats_.held_for_parity;
  }
  return true;
}

StreamReconstructor::Pending* StreamReconstructor::Ahead(uint32_t refinement) {
  if (!failed_.ok() || refinement < applied() || refinement >= limit()) return nullptr;
  return &At(refinement - applied());
}

void StreamReconstructor::ExpectParity(uint32_t refinement) {
  if (Pending* p = Ahead(refinement)) p->parity_follows = true;
}

void StreamReconstructor::Declare(uint32_t refinement) {
  if (Pending* p = Ahead(refinement)) p->declared = true;
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
