#include "services/grpc/stream_service.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/alarm.h>

#include "net/steady_clock.h"
#include "proto/rpc_status.h"
#include "services/grpc/call_auth.h"
#include "services/streaming/queued_session_stream.h"

namespace meshstream {

namespace {

// The session log line's last field: the server's own time from the Open's
// arrival to the SessionStart (the base meshes) handed to gRPC, when it was.
std::string OpenToBase(uint64_t open_us, uint64_t base_us) {
  if (base_us == 0 || base_us < open_us) return "";
  char text[64];
  std::snprintf(text, sizeof text, ", open to base %.3f ms", static_cast<double>(base_us - open_us) / 1000.0);
  return text;
}

}  // namespace

// One Open call: the reactor gRPC drives, and the SessionStream the send
// loop writes to. Its messages are written one at a time from a queue
// (gRPC allows one write in flight); the send loop stops feeding the
// session while the queue is full.
class StreamServiceImpl::Call final : public grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>,
                                      public QueuedSessionStream {
 public:
  using Reactor = grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>;

  Call(SessionHost* host, grpc::CallbackServerContext* context) : QueuedSessionStream(host), context_(context) {
    cancel_->context = context;
    host_->openers().Post([this] { Admit(); });
  }

  // The reactor.
  void OnReadDone(bool ok) override {
    if (!opened_) {
      opened_ = true;
      open_received_us_ = SteadyNowUs();
      if (!ok || in_.kind_case() != v1::ClientMessage::kOpen) {
        return FinishNow(InvalidArgument("the first message must be open"));
      }
      host_->openers().Post([this] { OpenSession(); });
      return;
    }
    if (!ok) return registration_.OnClientClosed(false);  // a half-close, or the call ended
    // After a repair request (once per session) or done the server reads
    // nothing more from the client.
    if (Deliver(in_) != AfterClientMessage::kReadMore) return;
    StartRead(&in_);
  }

  void OnWriteDone(bool ok) override {
    const v1::ServerMessage* next = nullptr;
    bool more = false;
    bool finish = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.pop_front();
      if (!ok) {
        broken_ = true;
        queue_.clear();
      }
      if (!queue_.empty()) {
        next = &queue_.front();
        more = queue_.size() > 1;
      } else {
        writing_ = false;
        finish = finish_wanted_ && !finished_;
        finished_ = finished_ || finish;
      }
    }
    // A message with others queued behind it is written with gRPC's buffer
    // hint: its write completes at once and the transport sends it with the
    // next ones, in one TCP write when the last of them (never hinted) goes,
    // instead of one system call and one wake-up per message.
    if (next != nullptr) StartWrite(next, more ? grpc::WriteOptions().set_buffer_hint() : grpc::WriteOptions());
    if (finish) Reactor::Finish(finish_status_);
    if (ok) {
      registration_.OnWritten();
    } else {
      registration_.Cancel(Cancelled("the client went away"), "client went away");
    }
  }

  void OnCancel() override {
    cancelled_ = true;
    if (registered_) Stop();
  }

  // gRPC calls it once Finish was called and every reaction has returned.
  // No opener task runs then: each ends with its last touch of the call
  // (FinishNow, StartRead, or Begin, before which nothing can Finish).
  void OnDone() override {
    registration_ = SendLoop::Registration();  // after any step of the send loop under way
    {
      std::lock_guard<std::mutex> lock(cancel_->mutex);
      cancel_->context = nullptr;  // the grace alarm may still fire: it finds nothing to cancel
    }
    delete this;
  }

  size_t queued() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

 private:
  // The wire (QueuedSessionStream), from the send loop's thread.
  void Send(v1::ServerMessage message) override { Queue(std::move(message)); }
  void Started() override { base_handed_us_ = SteadyNowUs(); }
  std::string EndTail() const override { return OpenToBase(open_received_us_, base_handed_us_); }

  void Close(const Status& status) override {
    bool now = false, cut = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finish_wanted_ = true;
      finish_status_ = ToGrpcStatus(status);
      if (!writing_) {
        now = !finished_;
        finished_ = true;
      } else if (!status.ok()) {
        // What is queued is dropped; the write in flight ends the call when
        // it completes (OnWriteDone finishes with the status). A stalled
        // client (the idle cut-off) never completes it: cancelled now. Any
        // other error (a client that asks for what its session has not,
        // say) keeps its status for a client that reads, and is cancelled
        // after a grace period if the write is still stuck then, so that a
        // client that stopped reading cannot hold its slot.
        while (queue_.size() > 1) queue_.pop_back();
        if (status.code() == StatusCode::kDeadlineExceeded) {
          cut = true;
        } else {
          std::shared_ptr<CancelHandle> handle = cancel_;
          grace_.Set(std::chrono::system_clock::now() + kFinishGrace, [handle](bool fired) {
            if (!fired) return;
            std::lock_guard<std::mutex> lock(handle->mutex);
            if (handle->context != nullptr) handle->context->TryCancel();
          });
        }
      }
    }
    if (now) Reactor::Finish(finish_status_);
    if (cut) context_->TryCancel();
  }

  // On the opener pool: who, a slot, then the first message.
  void Admit() {
    auto admission = host_->Admit(AuthenticateCall(host_->authenticator(), *context_));
    if (!admission.ok()) return FinishNow(admission.status());
    admission_ = std::move(admission).value();
    StartRead(&in_);
  }

  // On the opener pool: the OpenRequest checked and planned, then the
  // session joins the send loop.
  void OpenSession() {
    auto prepared = host_->Prepare(admission_.tenant, in_.open(), /*allow_udp=*/true);
    if (!prepared.ok()) return FinishNow(prepared.status());
    session_ = std::move(prepared).value();
    // Until Begin the send loop does not step the session (send_loop.h): the
    // client's messages and a cancel are only recorded, nothing can Finish
    // the call, and so gRPC cannot end it (OnDone) while this runs.
    registration_ = host_->Register(session_, this, session_.udp ? "udp" : "grpc");
    StartRead(&in_);
    registered_ = true;
    if (cancelled_) Stop();
    registration_.Begin();  // the last touch of `this`: the session may finish at once
  }

  // The call was cancelled: by the client, or by the server draining.
  void Stop() {
    if (host_->draining()) {
      registration_.Drain();
    } else {
      registration_.Cancel(Cancelled("the client went away"), "client went away");
    }
  }

  // Before the session joined the send loop: nothing is queued.
  void FinishNow(const Status& status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finished_ = true;
    }
    Reactor::Finish(ToGrpcStatus(status));
  }

  void Queue(v1::ServerMessage message) {
    const v1::ServerMessage* first = nullptr;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (broken_ || finish_wanted_) return;
      queue_.push_back(std::move(message));  // keeps references to the others valid
      if (writing_) return;
      writing_ = true;
      first = &queue_.front();
    }
    StartWrite(first);
  }

  // What the grace alarm of Finish cancels, shared with its callback, which
  // may run after the call is gone (context null then).
  struct CancelHandle {
    std::mutex mutex;
    grpc::CallbackServerContext* context = nullptr;
  };
  static constexpr std::chrono::seconds kFinishGrace{2};

  grpc::CallbackServerContext* context_;
  std::shared_ptr<CancelHandle> cancel_ = std::make_shared<CancelHandle>();
  grpc::Alarm grace_;
  v1::ClientMessage in_;
  bool opened_ = false;  // the first read's callback, then the reads' (one at a time)
  uint64_t open_received_us_ = 0;  // when the OpenRequest arrived (SteadyNowUs)
  uint64_t base_handed_us_ = 0;    // when Start handed the SessionStart to gRPC (the send loop's thread)

  SessionAdmission admission_;  // set by the opener before the first read
  std::atomic<bool> registered_{false};
  std::atomic<bool> cancelled_{false};

  mutable std::mutex mutex_;  // below: the write queue
  std::deque<v1::ServerMessage> queue_;  // its front is being written while writing_
  bool writing_ = false;
  bool broken_ = false;  // a write failed: the client is gone
  bool finish_wanted_ = false;
  bool finished_ = false;  // Finish was called
  grpc::Status finish_status_;
};

grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>* StreamServiceImpl::Open(
    grpc::CallbackServerContext* context) {
  return new Call(host_, context);
}

}  // namespace meshstream
