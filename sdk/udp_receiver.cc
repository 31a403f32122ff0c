#include "sdk/udp_receiver.h"

#include <chrono>

#include "net/hello.h"
#include "net/steady_clock.h"
#include "net/packet_header.h"
#include "net/replay_window.h"

namespace meshstream::sdk {

class UdpReceiver::Window : public ReplayWindow {};

StatusOr<std::unique_ptr<UdpReceiver>> UdpReceiver::Start(const SocketAddress& server, uint64_t session_id,
                                                           const SessionKeys& keys,
                                                           std::function<void(UdpPacket&&)> deliver) {
  const std::string any = server.family() == AF_INET6 ? "[::]:0" : "0.0.0.0:0";
  auto local = SocketAddress::Parse(any, server.family());
  if (!local.ok()) return local.status();
  auto socket = UdpSocket::Bind(local.value());
  if (!socket.ok()) return socket.status().WithContext("udp");
  std::unique_ptr<UdpReceiver> r(new UdpReceiver());
  r->socket_ = std::move(socket).value();
  r->server_ = server;
  r->session_id_ = session_id;
  r->keys_ = keys;
  r->deliver_ = std::move(deliver);
  r->window_ = std::make_unique<Window>();
  UdpReceiver* raw = r.get();
  r->thread_ = std::thread([raw] { raw->Run(); });
  return r;
}

UdpReceiver::~UdpReceiver() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

DropCounters UdpReceiver::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

void UdpReceiver::SendHello() {
  const Challenge zero{};
  const std::vector<uint8_t> payload = HelloPayload(have_challenge_ ? echo_ : zero);
  auto sealed = SealPacket(PacketType::kHello, session_id_, next_packet_number_++, keys_.client_to_server,
                           payload.data(), payload.size());
  if (!sealed.ok()) return;
  const uint64_t now = SteadyNowUs();
  if (first_hello_us_ == 0) first_hello_us_ = now;
  last_hello_us_ = now;
  if (socket_.SendTo(server_, sealed->data(), sealed->size()).ok()) ++hellos_sent_;
}

void UdpReceiver::Run() {
  std::vector<IncomingDatagram> batch(32);
  SendHello();
  int wait_ms = 0;
  while (!stop_) {
    if (!have_data_ && hellos_sent_ < static_cast<uint64_t>(kMaxHellos) &&
        SteadyNowUs() >= last_hello_us_ + static_cast<uint64_t>(kHelloIntervalMs) * 1000) {
      SendHello();
    }
    // A read that leaves the socket empty (fewer than a batch) has read
    // everything that was in it when the read began: the horizon moves there.
    // It waits only after a read without waiting found nothing, so an idle
    // horizon is at most one wait behind.
    const uint64_t before = SteadyNowUs();
    auto n = socket_.ReceiveBatch(&batch, kMaxDatagramBytes + 1, wait_ms);
    if (!n.ok()) continue;
    for (size_t i = 0; i < n.value(); ++i) Handle(batch[i]);
    if (n.value() < batch.size()) caught_up_us_.store(before);
    wait_ms = n.value() == 0 && wait_ms == 0 ? kIdleWaitMs : 0;
  }
}

void UdpReceiver::Handle(const IncomingDatagram& d) {
  auto count = [this](DropReason reason) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.Count(reason);
  };
  if (d.truncated) return count(DropReason::kTooLong);
  PacketHeader header;
  DropReason reason = ParseHeader(d.data.data(), d.data.size(), &header);
  if (reason != DropReason::kNone) return count(reason);
  if (header.session_id != session_id_) return count(DropReason::kUnknownSession);
  OpenedPacket packet;
  reason = OpenPacket(d.data.data(), d.data.size(), Direction::kServerToClient, keys_.server_to_client, &packet);
  if (reason != DropReason::kNone) return count(reason);
  reason = window_->Accept(packet.header.packet_number);
  if (reason != DropReason::kNone) return count(reason);
  if (packet.header.type == PacketType::kHelloAck) {
    auto challenge = ParseHelloAckPayload(packet.payload);
    if (!challenge.ok()) return count(DropReason::kBadPayload);
    count(DropReason::kNone);
    if (hello_rtt_us_ == 0) hello_rtt_us_ = SteadyNowUs() - last_hello_us_;
    echo_ = challenge.value();
    have_challenge_ = true;
    if (!have_data_) SendHello();
    return;
  }
  count(DropReason::kNone);
  have_data_ = true;
  UdpPacket p;
  p.packet_number = packet.header.packet_number;
  p.payload = std::move(packet.payload);
  p.time_us = SteadyNowUs();
  deliver_(std::move(p));
}

}  // namespace meshstream::sdk
