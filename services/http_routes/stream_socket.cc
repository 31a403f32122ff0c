#include "services/http_routes/stream_socket.h"

#include <algorithm>
#include <cctype>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include "proto/rpc_status.h"
#include "services/streaming/queued_session_stream.h"

namespace meshstream {

namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace websocket = boost::beast::websocket;
namespace net = boost::asio;

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t')) --b;
  return s.substr(a, b - a);
}

// The close a Status ends a session with: 1000 for OK, else 4000 + its gRPC
// code, the message as the reason (a WebSocket reason holds 123 bytes).
websocket::close_reason CloseFor(const Status& status) {
  if (status.ok()) return websocket::close_reason(websocket::close_code::normal);
  const grpc::Status g = ToGrpcStatus(status);
  std::string reason = g.error_message();
  if (reason.size() > 123) reason.resize(123);
  websocket::close_reason close;
  close.code = static_cast<uint16_t>(4000 + static_cast<int>(g.error_code()));
  close.reason = reason;
  return close;
}

std::vector<uint8_t> Frame(StreamFrame type, const v1::ServerMessage& message) {
  std::vector<uint8_t> out(1 + message.ByteSizeLong());
  out[0] = static_cast<uint8_t>(type);
  message.SerializeWithCachedSizesToArray(out.data() + 1);
  return out;
}

// One connection taken over: the WebSocket, and the session's reliable
// channel for the send loop (SessionStream). Every WebSocket operation runs
// on the connection's strand; the send loop's calls queue frames under
// `mutex_` and post the writes there.
template <class Stream>
class SocketSession final : public QueuedSessionStream, public std::enable_shared_from_this<SocketSession<Stream>> {
 public:
  SocketSession(Stream stream, HttpConnectionSlot slot, SessionHost* host, const StreamSocketOptions* options,
                std::string remote)
      : QueuedSessionStream(host), ws_(std::move(stream)), slot_(std::move(slot)), options_(options),
        remote_(std::move(remote)) {}

  ~SocketSession() override {
    registration_ = SendLoop::Registration();  // first: after any step of the send loop under way
  }

  void Accept(HttpUpgradeRequest request, std::optional<std::string> authorization, bool subprotocol) {
    authorization_ = std::move(authorization);
    beast::get_lowest_layer(ws_).expires_never();
    websocket::stream_base::timeout timeout;
    timeout.handshake_timeout = options_->handshake_timeout;
    timeout.idle_timeout = websocket::stream_base::none();
    timeout.keep_alive_pings = false;
    ws_.set_option(timeout);
    ws_.set_option(websocket::stream_base::decorator([subprotocol](websocket::response_type& response) {
      response.set(http::field::server, "meshstream");
      if (subprotocol) response.set(http::field::sec_websocket_protocol, kStreamSubprotocol);
    }));
    ws_.read_message_max(options_->max_message_bytes);
    ws_.binary(true);
    request_ = std::move(request);
    ws_.async_accept(request_, [self = this->shared_from_this()](beast::error_code ec) {
      if (ec) return;  // the client went away during the handshake
      self->host_->openers().Post([self] { self->Admit(); });
    });
  }

  // The wire (QueuedSessionStream), from the send loop's thread: a
  // ServerMessage frame, or the datagram frame for a datagram.
  void Send(v1::ServerMessage message) override { Queue(Frame(StreamFrame::kServerMessage, message)); }
  void Datagram(const uint8_t* data, size_t size) override {
    std::vector<uint8_t> out(1 + size);
    out[0] = static_cast<uint8_t>(StreamFrame::kDatagram);
    std::copy(data, data + size, out.begin() + 1);
    Queue(std::move(out));
  }
  std::string EndNote() const override { return ", websocket " + remote_; }
  void Close(const Status& status) override {
    std::shared_ptr<SocketSession> self;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      self = std::move(keep_alive_);
      close_ = CloseFor(status);
      close_wanted_ = true;
      if (!status.ok()) {
        while (queue_.size() > (writing_ ? 1u : 0u)) queue_.pop_back();  // what is queued is dropped
      }
    }
    if (!self) self = this->shared_from_this();
    // `self` moves into the handler: this thread (the send loop's, in the
    // middle of this session's step) must never hold the last reference.
    // If it did, the handler having run already, the destructor would run
    // here and wait for the step it is in (the registration's removal):
    // the send loop would stop for good.
    net::post(ws_.get_executor(), [self = std::move(self), ok = status.ok()] {
      if (!ok) {
        // A write the client does not take would hold the connection: the
        // close gets the handshake timeout, then the socket goes.
        beast::get_lowest_layer(self->ws_).expires_after(self->options_->handshake_timeout);
      }
      self->MaybeClose();
    });
  }
  size_t queued() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

 private:
  // On the opener pool: who, a slot, then the first message.
  void Admit() {
    auto admission = host_->Admit(host_->authenticator().Authenticate(authorization_));
    if (!admission.ok()) return CloseNow(admission.status());
    admission_ = std::move(admission).value();
    net::post(ws_.get_executor(), [self = this->shared_from_this()] { self->Read(); });
  }

  // On the strand: the next client message.
  void Read() {
    ws_.async_read(in_, [self = this->shared_from_this()](beast::error_code ec, size_t) { self->OnRead(ec); });
  }

  void OnRead(beast::error_code ec) {
    if (ec) {
      // A closing handshake is the client closing its side; anything else
      // (a reset, a message over the limit) is a client gone.
      if (registered_) {
        if (ec == websocket::error::closed) {
          registration_.OnClientClosed(false);
        } else {
          registration_.Cancel(Cancelled("the client went away"), "client went away");
        }
      }
      return;
    }
    const auto bytes = in_.cdata();
    const auto* data = static_cast<const uint8_t*>(bytes.data());
    const size_t size = bytes.size();
    v1::ClientMessage message;
    Status bad;
    if (!ws_.got_binary() || size == 0 || data[0] != static_cast<uint8_t>(StreamFrame::kClientMessage)) {
      bad = InvalidArgument("a message of the session's framing starts with 1 (a ClientMessage) and is binary");
    } else if (!message.ParseFromArray(data + 1, static_cast<int>(size - 1))) {
      bad = InvalidArgument("a ClientMessage that does not parse");
    }
    in_.consume(in_.size());
    if (!opened_) {
      opened_ = true;
      if (bad.ok() && message.kind_case() != v1::ClientMessage::kOpen) bad = InvalidArgument("the first message must be open");
      if (!bad.ok()) return CloseNow(bad);
      host_->openers().Post([self = this->shared_from_this(), open = message.open()] { self->OpenSession(open); });
      return;
    }
    if (!bad.ok()) return registration_.Cancel(bad, "bad client message");
    // Once per session, as over gRPC: nothing is read after a repair
    // request. After done the socket is read on, for its close.
    if (Deliver(message) == AfterClientMessage::kRepairAsked) return;
    Read();
  }

  // On the opener pool: the session prepared, then in the send loop.
  void OpenSession(const v1::OpenRequest& open) {
    auto prepared = host_->Prepare(admission_.tenant, open, /*allow_udp=*/false);
    if (!prepared.ok()) return CloseNow(prepared.status());
    session_ = std::move(prepared).value();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      keep_alive_ = this->shared_from_this();  // until Finish: the send loop holds `this` by pointer
    }
    net::post(ws_.get_executor(), [self = this->shared_from_this()] {
      self->registration_ = self->host_->Register(self->session_, self.get(), "websocket " + self->remote_);
      self->registered_ = true;
      self->Read();
      self->registration_.Begin();
    });
  }

  // Before the session joined the send loop: close with `status`.
  void CloseNow(const Status& status) {
    if (options_->log && status.code() != StatusCode::kOk) {
      options_->log("websocket " + remote_ + " refused: " + status.ToString());
    }
    net::post(ws_.get_executor(), [self = this->shared_from_this(), reason = CloseFor(status)] {
      self->closed_ = true;
      self->ws_.async_close(reason, [self](beast::error_code) {});
    });
  }

  void Queue(std::vector<uint8_t> frame) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (broken_ || close_wanted_) return;
      queue_.push_back(std::move(frame));
      if (writing_) return;
      writing_ = true;
    }
    net::post(ws_.get_executor(), [self = this->shared_from_this()] { self->WriteFront(); });
  }

  // On the strand, while writing_: writes the queue's front.
  void WriteFront() {
    const std::vector<uint8_t>* front;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      front = &queue_.front();  // deque: stays valid while others are pushed behind it
    }
    ws_.async_write(net::buffer(*front), [self = this->shared_from_this()](beast::error_code ec, size_t) {
      self->OnWritten(ec);
    });
  }

  void OnWritten(beast::error_code ec) {
    bool more = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.pop_front();
      if (ec) {
        broken_ = true;
        queue_.clear();
      }
      more = !queue_.empty();
      writing_ = more;
    }
    if (ec) {
      if (registered_) registration_.Cancel(Cancelled("the client went away"), "client went away");
      return;
    }
    if (registered_) registration_.OnWritten();
    if (more) return WriteFront();
    MaybeClose();
  }

  // On the strand: once Finish asked for it and the queue is written.
  void MaybeClose() {
    websocket::close_reason reason;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!close_wanted_ || writing_ || closed_ || broken_) return;
      closed_ = true;
      reason = close_;
    }
    ws_.async_close(reason, [self = this->shared_from_this()](beast::error_code) {});
  }

  websocket::stream<Stream> ws_;
  HttpConnectionSlot slot_;  // our place among the HTTP connections, for the connection's life
  const StreamSocketOptions* options_;
  std::string remote_;
  HttpUpgradeRequest request_;
  std::optional<std::string> authorization_;
  beast::flat_buffer in_;

  SessionAdmission admission_;  // the opener pool's, before the first read
  // The strand's.
  bool opened_ = false;
  bool registered_ = false;

  mutable std::mutex mutex_;  // below
  std::deque<std::vector<uint8_t>> queue_;  // its front is being written while writing_
  bool writing_ = false;
  bool broken_ = false;
  bool close_wanted_ = false;
  bool closed_ = false;
  websocket::close_reason close_;
  std::shared_ptr<SocketSession> keep_alive_;  // from the session's registration to its Finish
};

template <class Stream>
void Refuse(Stream stream, const HttpUpgradeRequest& request, int status, const std::string& message) {
  auto response = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(status), request.version());
  response->set(http::field::server, "meshstream");
  response->set(http::field::content_type, "application/json");
  response->set(http::field::cache_control, "no-store");
  std::string escaped;
  for (char c : message) {
    if (c == '"' || c == '\\') escaped += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) escaped += c;
  }
  response->body() = "{\"error\": \"" + escaped + "\"}";
  response->keep_alive(false);
  response->prepare_payload();
  auto holder = std::make_shared<Stream>(std::move(stream));
  http::async_write(*holder, *response, [holder, response](beast::error_code, size_t) {
    beast::error_code ignored;
    beast::get_lowest_layer(*holder).socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
  });
}

}  // namespace

StreamSocketRoute::StreamSocketRoute(SessionHost* host, StreamSocketOptions options)
    : host_(host), options_(std::move(options)) {}

StatusOr<std::string> StreamSocketRoute::CheckRequest(const HttpUpgradeRequest& request, const CorsPolicy& cors,
                                                     bool tls, int* http_status, bool* offered_subprotocol) {
  *offered_subprotocol = false;
  const auto origin_field = request.find(http::field::origin);
  if (origin_field != request.end()) {
    const std::string origin = Lower(std::string(origin_field->value()));
    const auto host_field = request.find(http::field::host);
    const std::string own =
        host_field == request.end() ? "" : Lower((tls ? "https://" : "http://") + std::string(host_field->value()));
    const bool same_origin = !own.empty() && origin == own;
    if (!same_origin && !cors.AllowedOrigin(std::string(origin_field->value()))) {
      *http_status = 403;
      return PermissionDenied("origin " + std::string(origin_field->value()) +
                              " may not open sessions (only this server's own origin and --http-cors-origin)");
    }
  }
  std::string token;
  const auto auth = request.find(http::field::authorization);
  bool offered = false, ours = false;
  for (auto it = request.find(http::field::sec_websocket_protocol); it != request.end() &&
                                                                     it->name() == http::field::sec_websocket_protocol;
       ++it) {
    std::string list(it->value());
    size_t start = 0;
    while (start <= list.size()) {
      size_t comma = list.find(',', start);
      if (comma == std::string::npos) comma = list.size();
      const std::string item = Trim(list.substr(start, comma - start));
      if (!item.empty()) {
        offered = true;
        if (item == kStreamSubprotocol) ours = true;
        if (item.rfind("bearer.", 0) == 0) token = item.substr(7);
      }
      start = comma + 1;
    }
  }
  if (offered && !ours) {
    *http_status = 400;
    return InvalidArgument(std::string("Sec-WebSocket-Protocol: offer ") + kStreamSubprotocol);
  }
  *offered_subprotocol = offered;
  if (auth != request.end()) return std::string(auth->value());
  return token.empty() ? std::string() : "Bearer " + token;
}

template <class Stream>
void StreamSocketRoute::Take(Stream stream, HttpUpgradeRequest request, HttpConnectionSlot slot, bool tls) {
  int http_status = 400;
  bool subprotocol = false;
  auto authorization = CheckRequest(request, options_.cors, tls, &http_status, &subprotocol);
  if (!authorization.ok()) return Refuse(std::move(stream), request, http_status, authorization.status().message());
  beast::error_code ec;
  const auto peer = beast::get_lowest_layer(stream).socket().remote_endpoint(ec);
  const std::string remote = ec ? "?" : peer.address().to_string() + ":" + std::to_string(peer.port());
  auto session = std::make_shared<SocketSession<Stream>>(std::move(stream), std::move(slot), host_, &options_, remote);
  std::optional<std::string> header;
  if (!authorization->empty()) header = std::move(authorization).value();
  session->Accept(std::move(request), std::move(header), subprotocol);
}

void StreamSocketRoute::Upgrade(HttpPlainStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) {
  Take(std::move(stream), std::move(request), std::move(slot), false);
}

void StreamSocketRoute::Upgrade(HttpTlsStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) {
  Take(std::move(stream), std::move(request), std::move(slot), true);
}

}  // namespace meshstream
