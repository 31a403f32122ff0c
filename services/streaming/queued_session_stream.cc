#include "services/streaming/queued_session_stream.h"

#include <utility>

#include "services/streaming/session_messages.h"

namespace meshstream {

void QueuedSessionStream::Start(SessionTransport transport, const UdpEndpoint::Session* udp) {
  host_->CompleteStart(session_.start, transport, udp);
  Send(std::move(session_.start));
  session_.start.Clear();
  Started();
}

void QueuedSessionStream::TransportChanged(SessionTransport transport, const std::string& reason) {
  Send(TransportChangeMessage(transport, reason));
}

void QueuedSessionStream::Control(const SenderAction& control) {
  Send(ControlMessage(session_.hot->bytes, control));
}

void QueuedSessionStream::Datagram(const uint8_t* data, size_t size) {
  Send(DatagramMessage(data, size));
}

void QueuedSessionStream::RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                                        uint32_t parity_datagrams) {
  Send(RefinementEndMessage(stream, refinement, datagrams_sent, parity_datagrams));
}

void QueuedSessionStream::End(const std::string& reason) {
  Send(EndMessage(reason));
}

void QueuedSessionStream::RepairEnd(uint32_t datagrams, uint64_t bytes) {
  Send(RepairEndMessage(datagrams, bytes));
}

void QueuedSessionStream::Levels(const SessionPlan& plan, uint32_t first_changed_level) {
  Send(LevelPlanMessage(plan, first_changed_level));
}

void QueuedSessionStream::Finish(const Status& status, const std::string& reason, const SessionSenderStats& stats) {
  host_->LogEnd(session_, reason, EndNote(), stats, EndTail());
  Close(status);
}

QueuedSessionStream::AfterClientMessage QueuedSessionStream::Deliver(const v1::ClientMessage& message) {
  switch (message.kind_case()) {
    case v1::ClientMessage::kReport:
      registration_.OnReport(FromProto(message.report()));
      return AfterClientMessage::kReadMore;
    case v1::ClientMessage::kRepair:
      registration_.OnRepair(FromProto(message.repair()));
      return AfterClientMessage::kRepairAsked;
    case v1::ClientMessage::kView:
      registration_.OnView(FromProto(message.view()));
      return AfterClientMessage::kReadMore;
    case v1::ClientMessage::kDone:
      registration_.OnClientClosed(true);
      return AfterClientMessage::kDone;
    default:
      registration_.OnClientMessage();
      return AfterClientMessage::kReadMore;
  }
}

}  // namespace meshstream
