#include "services/streaming/send_loop.h"

#include <algorithm>
#include <chrono>

#include "net/steady_clock.h"

namespace meshstream {

namespace {

// How often the thread looks at `draining` when nothing is due sooner.
constexpr uint64_t kPeriodUs = 100000;
// Actions one session may take in a row before the others get their turn.
constexpr int kActionsPerTurn = 64;
// Sealed datagrams the kernel did not take (its buffer full) are tried again
// this often, for at most this many periods, then counted as send errors: the
// thread never sleeps on a full buffer while other sessions are due.
constexpr uint64_t kRetryUs = 200;
constexpr int kMaxRetries = 20;

// How a draining server stops a session (the loop's sweep, Registration::Drain).
void CancelForDraining(SessionSender& sender) {
  sender.Cancel(Unavailable("the server is shutting down; open the session again"), "draining");
}

}  // namespace

struct SendLoop::Entry {
  std::mutex mutex;  // below; held while the loop steps the session
  std::unique_ptr<SessionSender> sender;
  SessionStream* stream = nullptr;  // null once removed
  std::shared_ptr<UdpEndpoint::Session> udp;  // the only reference to it
  bool hello_hooked = false;  // udp's HELLO hook wakes the entry (until the sender's HELLO wait is over)
  bool start_unwritten = false;  // the SessionStart is queued: wait until it is written
  // Waiting for its stream to write (no timer: the idle sweep looks at it).
  std::atomic<bool> blocked{false};
  std::atomic<uint64_t> idle_deadline_us{0};  // the sender's, when it blocked
  // Guarded by SendLoop::mutex_: Registration::Begin was called (before,
  // nothing schedules the session), and when it is due.
  bool begun = false;
  uint64_t scheduled_us = SenderAction::kNever;

  // Over gRPC from here: ~Session, run here, clears the HELLO hook (no HELLO
  // wakes the entry after) and leaves the endpoint's table.
  void DropUdp() {
    udp.reset();
    hello_hooked = false;
  }
};

SendLoop::SendLoop(SendLoopOptions options) : options_(options) {
  options_.max_queued = std::max<size_t>(1, options_.max_queued);
  thread_ = std::thread([this] { Run(); });
}

SendLoop::~SendLoop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

size_t SendLoop::sessions() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

SendLoop::Registration SendLoop::Add(std::unique_ptr<SessionSender> sender, SessionStream* stream,
                                     std::shared_ptr<UdpEndpoint::Session> udp) {
  auto entry = std::make_shared<Entry>();
  entry->sender = std::move(sender);
  entry->stream = stream;
  entry->udp = std::move(udp);
  if (entry->udp) {
    // A HELLO that proves an address (or extends the wait) wakes the session.
    std::weak_ptr<Entry> weak = entry;
    entry->udp->SetOnHello([this, weak] {
      if (auto e = weak.lock()) Schedule(e, 0);
    });
    entry->hello_hooked = true;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    entries_[entry.get()] = entry;
  }
  return Registration(this, entry);
}

void SendLoop::Schedule(const std::shared_ptr<Entry>& entry, uint64_t due_us) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Before Begin a step is only wanted: Begin's own, at once, takes it up.
    if (!entry->begun || due_us >= entry->scheduled_us) return;
    entry->scheduled_us = due_us;
    timers_.push(Timer{due_us, seq_++, entry});
  }
  wake_.notify_one();
}

void SendLoop::Remove(Entry* entry) {
  {
    std::lock_guard<std::mutex> session_lock(entry->mutex);  // after any step under way
    entry->stream = nullptr;
    entry->sender.reset();
    entry->DropUdp();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.erase(entry);
}

void SendLoop::Run() {
  std::unique_lock<std::mutex> lock(mutex_);
  bool drained = false;
  uint64_t next_sweep_us = 0;
  std::vector<std::shared_ptr<Entry>> ready;
  while (!stop_) {
    const uint64_t now = SteadyNowUs();
    if (!drained && options_.draining != nullptr && options_.draining->load()) {
      drained = true;
      for (auto& [raw, entry] : entries_) {
        if (!entry->begun) continue;  // its first step (Begin) sees `draining`
        entry->scheduled_us = 0;
        timers_.push(Timer{0, seq_++, entry});
      }
    }
    ready.clear();
    while (!timers_.empty() && timers_.top().due_us <= now) {
      Timer t = timers_.top();
      timers_.pop();
      if (t.entry->scheduled_us != t.due_us) continue;  // rescheduled sooner since
      t.entry->scheduled_us = SenderAction::kNever;
      ready.push_back(std::move(t.entry));
    }
    if (now >= next_sweep_us) {
      // The sessions waiting for their streams have no timer (a stalled
      // client would leave one per wait in the heap): their idle deadlines
      // are looked at here, once per period.
      next_sweep_us = now + kPeriodUs;
      for (auto& [raw, entry] : entries_) {
        if (entry->blocked.load() && now >= entry->idle_deadline_us.load()) ready.push_back(entry);
      }
    }
    // Datagrams the kernel refused wait for their retry like a timer.
    const bool retry_due = outbox_.pending() > 0 && now >= retry_at_us_;
    if (ready.empty() && !retry_due) {
      uint64_t due = timers_.empty() ? now + kPeriodUs : std::min(timers_.top().due_us, now + kPeriodUs);
      if (outbox_.pending() > 0) due = std::min(due, retry_at_us_);
      wake_.wait_for(lock, std::chrono::microseconds(due - now));
      continue;
    }
    lock.unlock();
    for (const std::shared_ptr<Entry>& entry : ready) Step(entry);
    ready.clear();
    FlushOutbox();
    lock.lock();
  }
}

void SendLoop::FlushOutbox() {
  if (outbox_.pending() == 0) return;
  const uint64_t now = SteadyNowUs();
  if (outbox_.Flush() == 0) {
    stuck_since_us_ = 0;
    return;
  }
  if (stuck_since_us_ == 0) stuck_since_us_ = now;
  if (now - stuck_since_us_ >= kRetryUs * kMaxRetries) {
    outbox_.Drop();  // what the kernel still refuses is lost (the receiver predicts it)
    stuck_since_us_ = 0;
    return;
  }
  retry_at_us_ = now + kRetryUs;
}

void SendLoop::Step(const std::shared_ptr<Entry>& entry) {
  std::unique_lock<std::mutex> lock(entry->mutex);
  if (entry->stream == nullptr || entry->sender == nullptr || entry->sender->finished()) return;
  SessionSender& sender = *entry->sender;
  SessionStream& stream = *entry->stream;
  if (options_.draining != nullptr && options_.draining->load()) CancelForDraining(sender);
  for (int n = 0; n < kActionsPerTurn; ++n) {
    const uint64_t now = SteadyNowUs();
    if (entry->hello_hooked && entry->udp) {
      if (sender.awaiting_hello()) {
        sender.OnHello(entry->udp->last_hello_us(), entry->udp->proven());
      } else {
        // The wait is over: a HELLO (a client's retry, a copy) no longer
        // wakes the session, and no step asks the endpoint's lock.
        entry->udp->SetOnHello(nullptr);
        entry->hello_hooked = false;
      }
    }
    const size_t queued = stream.queued();
    const bool full = queued >= options_.max_queued || (entry->start_unwritten && queued > 0);
    if (full && !sender.stopping(now)) {
      // Woken by the stream's next write, or by the idle sweep.
      entry->idle_deadline_us = sender.idle_deadline_us();
      entry->blocked = true;
      return;
    }
    entry->blocked = false;
    entry->start_unwritten = false;
    SenderAction a = sender.Next(now);
    switch (a.kind) {
      case SenderAction::kWait: {
        lock.unlock();
        if (a.due_us != SenderAction::kNever) Schedule(entry, a.due_us);
        return;
      }
      case SenderAction::kStart:
        stream.Start(a.transport, entry->udp.get());
        entry->start_unwritten = true;
        break;
      case SenderAction::kTransportChange:
        stream.TransportChanged(a.transport, a.reason);
        entry->DropUdp();
        break;
      case SenderAction::kControl:
        stream.Control(a);
        break;
      case SenderAction::kDatagrams:
        if (a.on_stream) {
          for (const auto& [data, size] : a.datagrams) stream.Datagram(data, size);
        } else if (!entry->udp || !entry->udp->SealData(a.datagrams, a.first_packet_number, &outbox_).ok()) {
          sender.Cancel(Cancelled("the client went away"), "client went away");
        }
        break;
      case SenderAction::kRefinementEnd:
        stream.RefinementEnd(a.stream, a.refinement->refinement, a.count, a.parity);
        break;
      case SenderAction::kEnd:
        stream.End(a.reason);
        break;
      case SenderAction::kRepairEnd:
        stream.RepairEnd(a.count, a.bytes);
        break;
      case SenderAction::kLevels:
        stream.Levels(sender.plan(), a.first_changed_level);
        break;
      case SenderAction::kFinish:
        entry->DropUdp();
        stream.Finish(a.status, sender.end_reason(), sender.stats());
        return;
    }
  }
  lock.unlock();
  Schedule(entry, 0);  // more to do: after the other sessions due now
}

SendLoop::Registration& SendLoop::Registration::operator=(Registration&& other) noexcept {
  if (this != &other) {
    Reset();
    loop_ = other.loop_;
    entry_ = std::move(other.entry_);
    other.loop_ = nullptr;
  }
  return *this;
}

SendLoop::Registration::~Registration() { Reset(); }

void SendLoop::Registration::Reset() {
  if (entry_ != nullptr) loop_->Remove(entry_.get());
  entry_.reset();
  loop_ = nullptr;
}

void SendLoop::Registration::OnClientMessage() {
  std::lock_guard<std::mutex> lock(entry_->mutex);
  if (entry_->sender) entry_->sender->OnClientMessage(SteadyNowUs());
}

void SendLoop::Registration::OnReport(const ClientReportInfo& report) {
  // Reports steer the rate and the cut of what is still to be planned: no wake-up needed.
  std::lock_guard<std::mutex> lock(entry_->mutex);
  if (entry_->sender) entry_->sender->OnReport(SteadyNowUs(), report);
}

void SendLoop::Registration::OnView(const StatusOr<View>& view) {
  {
    std::lock_guard<std::mutex> lock(entry_->mutex);
    if (!entry_->sender) return;
    if (view.ok()) {
      entry_->sender->OnView(SteadyNowUs(), view.value());
    } else {
      entry_->sender->Cancel(view.status(), "bad view");
    }
  }
  loop_->Schedule(entry_, 0);
}

void SendLoop::Registration::OnRepair(const std::vector<RepairItem>& items) {
  {
    std::lock_guard<std::mutex> lock(entry_->mutex);
    if (entry_->sender) entry_->sender->OnRepair(SteadyNowUs(), items);
  }
  loop_->Schedule(entry_, 0);
}

void SendLoop::Registration::OnClientClosed(bool done) {
  {
    std::lock_guard<std::mutex> lock(entry_->mutex);
    if (entry_->sender) entry_->sender->OnClientClosed(SteadyNowUs(), done);
  }
  loop_->Schedule(entry_, 0);
}

void SendLoop::Begin(std::shared_ptr<Entry> entry) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    entry->begun = true;
  }
  Schedule(entry, 0);
}

void SendLoop::Registration::Begin() {
  // Copies: once scheduled the session may finish and its owner destroy
  // this registration while Begin still runs.
  SendLoop* loop = loop_;
  loop->Begin(entry_);
}

void SendLoop::Registration::OnWritten() { loop_->Schedule(entry_, 0); }

void SendLoop::Registration::Drain() {
  {
    std::lock_guard<std::mutex> lock(entry_->mutex);
    if (entry_->sender) CancelForDraining(*entry_->sender);
  }
  loop_->Schedule(entry_, 0);
}

void SendLoop::Registration::Cancel(Status status, std::string reason) {
  {
    std::lock_guard<std::mutex> lock(entry_->mutex);
    if (entry_->sender) entry_->sender->Cancel(std::move(status), std::move(reason));
  }
  loop_->Schedule(entry_, 0);
}

}  // namespace meshstream
