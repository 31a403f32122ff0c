// The SessionStream of a transport whose reliable channel carries the
// protocol's messages (docs/spec/streaming-protocol.md): what the send loop asks
// for (start, control blocks, datagrams on the stream, refinement ends, the
// end, the repair's end) translated once into ServerMessages
// (session_messages.h), and the client's messages handed to the session's
// registration. A transport (the gRPC call of services/grpc/stream_service.cc,
// the WebSocket of services/http_routes/stream_socket.cc; a WebTransport one later)
// derives from it and implements only its wire: Send (queue one message;
// the send loop waits while queued() is at its bound, which is the
// back-pressure), Close (end the channel with a status once what is queued
// is written, at once when the status is not OK) and queued().
//
// Thread safety: the SessionStream methods come from the send loop's thread
// (session_host.h); Deliver from the transport's reading side, one message
// at a time.
#ifndef MESHSTREAM_SERVICES_STREAMING_QUEUED_SESSION_STREAM_H_
#define MESHSTREAM_SERVICES_STREAMING_QUEUED_SESSION_STREAM_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "meshstream/v1/stream.pb.h"
#include "services/streaming/send_loop.h"
#include "services/streaming/session_host.h"

namespace meshstream {

class QueuedSessionStream : public SessionStream {
 public:
  explicit QueuedSessionStream(SessionHost* host) : host_(host) {}

  void Start(SessionTransport transport, const UdpEndpoint::Session* udp) final;
  void TransportChanged(SessionTransport transport, const std::string& reason) final;
  void Control(const SenderAction& control) final;
  // A StreamDatagram message; a transport with a frame of its own for
  // datagrams overrides it.
  void Datagram(const uint8_t* data, size_t size) override;
  void RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                     uint32_t parity_datagrams) final;
  void End(const std::string& reason) final;
  void RepairEnd(uint32_t datagrams, uint64_t bytes) final;
  void Levels(const SessionPlan& plan, uint32_t first_changed_level) final;
  // Logs the session's end line (SessionHost::LogEnd), then Close(status).
  void Finish(const Status& status, const std::string& reason, const SessionSenderStats& stats) final;

 protected:
  // What the reading side does after a client message.
  enum class AfterClientMessage {
    kReadMore,
    kDone,         // the client said it is done
    kRepairAsked,  // once per session: nothing more is read after it
  };
  // A client message after the open, handed to the registration.
  AfterClientMessage Deliver(const v1::ClientMessage& message);

  // The wire.
  virtual void Send(v1::ServerMessage message) = 0;
  virtual void Close(const Status& status) = 0;
  // After the SessionStart was handed to Send.
  virtual void Started() {}
  // For the end line: inside its parentheses after the reason, and after it.
  virtual std::string EndNote() const { return ""; }
  virtual std::string EndTail() const { return ""; }

  SessionHost* const host_;
  // Set on the opener pool before the session joins the loop, read-only
  // after (but the SessionStart, which Start moves out).
  PreparedSession session_;
  SendLoop::Registration registration_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_QUEUED_SESSION_STREAM_H_
