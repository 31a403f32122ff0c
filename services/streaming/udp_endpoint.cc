#include "services/streaming/udp_endpoint.h"

#include <algorithm>
#include <chrono>
#include <cstring>

#include "codec/core/byte_io.h"
#include "net/steady_clock.h"
#include "proto/sha256.h"

namespace meshstream {

namespace {

uint64_t RandomSessionId() {
  const std::string hex = RandomHex(8);
  uint64_t id = 0;
  for (char c : hex) id = id << 4 | static_cast<uint64_t>(c <= '9' ? c - '0' : c - 'a' + 10);
  return id;
}

}  // namespace

struct UdpEndpoint::SessionState {
  uint64_t id = 0;
  SessionKeys keys;
  std::atomic<uint64_t> next_packet_number{0};
  std::atomic<uint64_t> last_hello_us{0};

  std::mutex mutex;  // everything below
  std::function<void()> on_hello;
  ReplayWindow window;
  struct Address {
    SocketAddress address;
    AmplificationLimit limit;
    Challenge challenge{};
    bool challenged = false;
  };
  std::vector<Address> addresses;
  SocketAddress proven;
};

StatusOr<std::unique_ptr<UdpEndpoint>> UdpEndpoint::Start(const SocketAddress& listen) {
  auto socket = UdpSocket::Bind(listen);
  if (!socket.ok()) return socket.status().WithContext("--udp-listen");
  std::unique_ptr<UdpEndpoint> endpoint(new UdpEndpoint(std::move(socket).value()));
  UdpEndpoint* raw = endpoint.get();
  endpoint->thread_ = std::thread([raw] { raw->Run(); });
  return endpoint;
}

UdpEndpoint::~UdpEndpoint() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

StatusOr<std::shared_ptr<UdpEndpoint::Session>> UdpEndpoint::RegisterSession() {
  auto keys = NewSessionKeys();
  if (!keys.ok()) return keys.status();
  auto state = std::make_shared<SessionState>();
  state->keys = keys.value();
  state->last_hello_us = SteadyNowUs();
  std::unique_lock<std::shared_mutex> lock(table_mutex_);
  do {
    state->id = RandomSessionId();
  } while (table_.count(state->id) != 0);
  table_[state->id] = state;
  return std::shared_ptr<Session>(new Session(this, state));
}

void UdpEndpoint::Unregister(uint64_t id) {
  std::unique_lock<std::shared_mutex> lock(table_mutex_);
  table_.erase(id);
}

size_t UdpEndpoint::session_count() const {
  std::shared_lock<std::shared_mutex> lock(table_mutex_);
  return table_.size();
}

UdpEndpointStats UdpEndpoint::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void UdpEndpoint::Run() {
  std::vector<IncomingDatagram> batch(32);
  while (!stop_) {
    // One byte more than the largest datagram, so that a longer one shows as truncated.
    auto n = socket_.ReceiveBatch(&batch, kMaxDatagramBytes + 1, 50);
    if (!n.ok()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    for (size_t i = 0; i < n.value(); ++i) Handle(batch[i]);
  }
}

void UdpEndpoint::Handle(const IncomingDatagram& d) {
  auto drop = [this](DropReason reason) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.received.Count(reason);
  };
  if (d.truncated) return drop(DropReason::kTooLong);
  PacketHeader header;
  DropReason reason = ParseHeader(d.data.data(), d.data.size(), &header);
  if (reason != DropReason::kNone) return drop(reason);
  std::shared_ptr<SessionState> state;
  {
    std::shared_lock<std::shared_mutex> lock(table_mutex_);
    auto it = table_.find(header.session_id);
    if (it != table_.end()) state = it->second;
  }
  if (!state) return drop(DropReason::kUnknownSession);
  OpenedPacket packet;
  reason = OpenPacket(d.data.data(), d.data.size(), Direction::kClientToServer, state->keys.client_to_server, &packet);
  if (reason != DropReason::kNone) return drop(reason);
  // The only client -> server type is HELLO (OpenPacket refused the others).
  std::unique_lock<std::mutex> lock(state->mutex);
  reason = state->window.Accept(packet.header.packet_number);
  if (reason != DropReason::kNone) {
    lock.unlock();
    return drop(reason);
  }
  auto echo = ParseHelloPayload(packet.payload);
  if (!echo.ok()) {
    lock.unlock();
    return drop(DropReason::kBadPayload);
  }
  state->last_hello_us = SteadyNowUs();
  if (state->on_hello) state->on_hello();
  SessionState::Address* entry = nullptr;
  for (SessionState::Address& a : state->addresses) {
    if (a.address == d.from) entry = &a;
  }
  if (entry == nullptr) {
    if (state->addresses.size() >= kMaxAddressesPerSession) {
      lock.unlock();
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.received.Count(DropReason::kNone);
      ++stats_.addresses_refused;
      return;
    }
    state->addresses.push_back(SessionState::Address{d.from, {}, {}, false});
    entry = &state->addresses.back();
  }
  entry->limit.OnReceived(d.data.size());
  if (entry->limit.proven()) {  // a repeated echo: nothing to answer
    lock.unlock();
    return drop(DropReason::kNone);
  }
  if (entry->challenged && SameChallenge(echo.value(), entry->challenge)) {
    entry->limit.MarkProven();
    state->proven = d.from;
    if (state->on_hello) state->on_hello();
    lock.unlock();
    return drop(DropReason::kNone);
  }
  // Not proven: a fresh challenge, within the address's budget.
  auto challenge = NewChallenge();
  if (!challenge.ok() || !entry->limit.MaySend(PacketType::kHelloAck, kHelloAckDatagramBytes)) {
    lock.unlock();
    return drop(DropReason::kNone);
  }
  entry->challenge = challenge.value();
  entry->challenged = true;
  const std::vector<uint8_t> payload = HelloAckPayload(entry->challenge);
  const uint64_t pn = state->next_packet_number.fetch_add(1);
  auto sealed = SealPacket(PacketType::kHelloAck, state->id, pn, state->keys.server_to_client, payload.data(), payload.size());
  if (!sealed.ok()) {
    lock.unlock();
    return drop(DropReason::kNone);
  }
  entry->limit.OnSent(sealed->size());
  const SocketAddress to = d.from;
  lock.unlock();
  const Status sent = socket_.SendTo(to, sealed->data(), sealed->size());
  std::lock_guard<std::mutex> stats_lock(stats_mutex_);
  stats_.received.Count(DropReason::kNone);
  if (sent.ok()) {
    ++stats_.hello_acks_sent;
  } else {
    ++stats_.send_errors;
  }
}

UdpEndpoint::Session::~Session() {
  SetOnHello(nullptr);
  endpoint_->Unregister(state_->id);
}

void UdpEndpoint::Session::SetOnHello(std::function<void()> on_hello) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->on_hello = std::move(on_hello);
}

uint64_t UdpEndpoint::Session::id() const { return state_->id; }

const SessionKeys& UdpEndpoint::Session::keys() const { return state_->keys; }

bool UdpEndpoint::Session::proven() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return !state_->proven.empty();
}

SocketAddress UdpEndpoint::Session::address() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->proven;
}

uint64_t UdpEndpoint::Session::ReservePacketNumbers(uint64_t count) {
  return state_->next_packet_number.fetch_add(count);
}

uint64_t UdpEndpoint::Session::last_hello_us() const { return state_->last_hello_us.load(); }

Status UdpEndpoint::Session::SealData(PayloadSpan payloads, uint64_t first_packet_number, DatagramOutbox* out) {
  SocketAddress to;
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    to = state_->proven;
    bool allowed = false;
    for (const SessionState::Address& a : state_->addresses) {
      if (a.address == to && a.limit.MaySend(PacketType::kData, kMaxDatagramBytes)) allowed = true;
    }
    if (to.empty() || !allowed) return FailedPrecondition("udp: no proven client address");
  }
  if (out->endpoint_ != endpoint_ && out->pending() > 0) out->Flush();
  if (out->endpoint_ != endpoint_) out->Drop();  // what another endpoint's socket did not take
  out->endpoint_ = endpoint_;
  for (size_t i = 0; i < payloads.size(); ++i) {
    if (out->pending() >= DatagramOutbox::kMaxPending) out->Flush();
    if (out->end_ == out->slots_.size()) {
      if (out->first_ > 0) {
        // Move what is left to the front (it is at most kMaxPending slots).
        std::rotate(out->slots_.begin(), out->slots_.begin() + static_cast<long>(out->first_),
                    out->slots_.begin() + static_cast<long>(out->end_));
        out->end_ -= out->first_;
        out->first_ = 0;
      }
      if (out->end_ == out->slots_.size()) out->slots_.emplace_back();
    }
    DatagramOutbox::Slot& slot = out->slots_[out->end_];
    auto size = SealPacketInto(PacketType::kData, state_->id, first_packet_number + i, state_->keys.server_to_client,
                               payloads[i].first, payloads[i].second, slot.bytes.data(), slot.bytes.size());
    if (!size.ok()) return size.status();
    slot.size = size.value();
    slot.to = to;
    ++out->end_;
  }
  return Status::Ok();
}

Status UdpEndpoint::Session::SendData(PayloadSpan payloads, uint64_t first_packet_number) {
  DatagramOutbox out;
  MS_RETURN_IF_ERROR(SealData(payloads, first_packet_number, &out));
  out.Flush();
  out.Drop();
  return Status::Ok();
}

size_t DatagramOutbox::Flush() {
  if (pending() == 0 || endpoint_ == nullptr) return pending();
  batch_.clear();
  uint64_t bytes = 0;
  for (size_t i = first_; i < end_; ++i) batch_.push_back({&slots_[i].to, slots_[i].bytes.data(), slots_[i].size});
  auto sent = endpoint_->socket_.SendBatch(batch_.data(), batch_.size());
  // An error the kernel gives for the batch itself (not a full buffer): the
  // datagrams are lost, as a full buffer's would be after the retries.
  const size_t done = sent.ok() ? sent.value() : batch_.size();
  for (size_t i = 0; i < done; ++i) bytes += batch_[i].size;
  first_ += done;
  if (first_ == end_) first_ = end_ = 0;
  std::lock_guard<std::mutex> lock(endpoint_->stats_mutex_);
  ++endpoint_->stats_.send_calls;
  if (sent.ok()) {
    endpoint_->stats_.data_sent += done;
    endpoint_->stats_.data_bytes_sent += bytes;
  } else {
    endpoint_->stats_.send_errors += done;
  }
  if (pending() > 0) ++endpoint_->stats_.send_retries;
  return pending();
}

void DatagramOutbox::Drop() {
  if (pending() > 0 && endpoint_ != nullptr) {
    std::lock_guard<std::mutex> lock(endpoint_->stats_mutex_);
    endpoint_->stats_.send_errors += pending();
  }
  first_ = end_ = 0;
}

}  // namespace meshstream
