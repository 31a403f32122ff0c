#include "services/http/http_server.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <ctime>
#include <exception>
#include <iterator>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket/rfc6455.hpp>

#include "net/udp_socket.h"
#include "parallel/executor.h"
#include "services/http/upgrade.h"

namespace meshstream {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace ssl = boost::asio::ssl;
using tcp = boost::asio::ip::tcp;

// How many connections hold a slot, and waiting until none does.
class HttpConnectionTable {
 public:
  explicit HttpConnectionTable(int max) : max_(max < 1 ? 1 : max) {}

  bool TryTake() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count_ >= max_) return false;
    ++count_;
    return true;
  }
  void Give() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      --count_;
    }
    none_.notify_all();
  }
  // True when no slot is taken by `deadline`.
  bool WaitEmpty(std::chrono::steady_clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    return none_.wait_until(lock, deadline, [this] { return count_ == 0; });
  }

 private:
  const int max_;
  std::mutex mutex_;
  std::condition_variable none_;
  int count_ = 0;
};

void HttpConnectionSlot::Release() {
  if (!table_) return;
  table_->Give();
  table_.reset();
}

namespace {

// A response body: a slice of shared immutable bytes, written without a copy.
struct SharedBytesBody {
  struct value_type {
    std::shared_ptr<const std::vector<uint8_t>> data;
    size_t offset = 0;
    size_t size = 0;
  };

  class writer {
   public:
    using const_buffers_type = net::const_buffer;

    template <bool isRequest, class Fields>
    writer(const http::header<isRequest, Fields>&, const value_type& body) : body_(body) {}

    void init(beast::error_code& ec) { ec = {}; }

    boost::optional<std::pair<const_buffers_type, bool>> get(beast::error_code& ec) {
      ec = {};
      if (sent_ || !body_.data || body_.size == 0) return boost::none;
      sent_ = true;
      return {{net::const_buffer(body_.data->data() + body_.offset, body_.size), false}};
    }

   private:
    const value_type& body_;
    bool sent_ = false;
  };
};

using Response = http::response<SharedBytesBody>;

class ConnectionBase;

// What the server and its connections share; connections keep it alive.
struct Core {
  HttpServerOptions options;
  HttpHandler handler;
  std::shared_ptr<HttpConnectionTable> table;
  std::optional<ssl::context> tls;
  Executor pool;  // the routes: what is queued at Stop is dropped (a draining server answers nothing more)
  std::atomic<bool> draining{false};
  std::atomic<uint64_t> accepted{0}, refused{0}, requests{0}, upgraded{0};

  std::mutex mutex;  // live, next_id
  std::unordered_map<uint64_t, std::weak_ptr<ConnectionBase>> live;
  uint64_t next_id = 0;

  Core(HttpServerOptions o, HttpHandler h)
      : options(std::move(o)),
        handler(std::move(h)),
        table(std::make_shared<HttpConnectionTable>(options.max_connections)),
        pool(options.pool_threads, Executor::StopPolicy::kDropQueued) {}

  void Log(const std::string& line) const {
    if (options.log) options.log(line);
  }

  std::vector<std::shared_ptr<ConnectionBase>> Live() {
    std::vector<std::shared_ptr<ConnectionBase>> out;
    std::lock_guard<std::mutex> lock(mutex);
    for (auto& [id, weak] : live) {
      if (auto c = weak.lock()) out.push_back(std::move(c));
    }
    return out;
  }
};

class ConnectionBase : public std::enable_shared_from_this<ConnectionBase> {
 public:
  virtual ~ConnectionBase() = default;
  // Both post to the connection's strand (callable from any thread).
  virtual void PostCloseIfIdle() = 0;
  virtual void PostClose() = 0;
};

std::string EndpointText(const tcp::endpoint& e) {
  const std::string host = e.address().to_string();
  return (e.address().is_v6() ? "[" + host + "]" : host) + ":" + std::to_string(e.port());
}

bool IsHttpError(const beast::error_code& ec) {
  return ec.category() == http::make_error_code(http::error::end_of_stream).category();
}

// A header value as it may be sent: no CR, LF or NUL.
std::string CleanValue(std::string value) {
  for (char& c : value) {
    if (c == '\r' || c == '\n' || c == '\0') c = ' ';
  }
  return value;
}

template <class Stream>
Stream MakeStream(tcp::socket&& socket, ssl::context* tls);

template <>
HttpPlainStream MakeStream<HttpPlainStream>(tcp::socket&& socket, ssl::context*) {
  return HttpPlainStream(std::move(socket));
}

template <>
HttpTlsStream MakeStream<HttpTlsStream>(tcp::socket&& socket, ssl::context* tls) {
  return HttpTlsStream(std::move(socket), *tls);
}

template <class Stream>
class Connection final : public ConnectionBase {
 public:
  static constexpr bool kTls = std::is_same_v<Stream, HttpTlsStream>;

  Connection(std::shared_ptr<Core> core, tcp::socket&& socket, HttpConnectionSlot slot, std::string remote)
      : core_(std::move(core)),
        stream_(MakeStream<Stream>(std::move(socket), core_->tls ? &*core_->tls : nullptr)),
        executor_(stream_.get_executor()),
        slot_(std::move(slot)),
        remote_(std::move(remote)),
        buffer_(static_cast<size_t>(core_->options.max_header_bytes + core_->options.max_body_bytes + 8192)) {}

  ~Connection() override { Unregister(); }

  void Start() {
    {
      std::lock_guard<std::mutex> lock(core_->mutex);
      id_ = ++core_->next_id;
      core_->live.emplace(id_, weak_from_this());
    }
    net::dispatch(executor_, [self = Self()] { self->Begin(); });
  }

  void PostCloseIfIdle() override {
    net::post(executor_, [self = Self()] { self->CloseIfIdle(); });
  }
  void PostClose() override {
    net::post(executor_, [self = Self()] { self->Close(); });
  }

 private:
  enum class State { kNew, kHandshake, kReading, kWorking, kWriting, kClosing, kClosed, kUpgraded };

  std::shared_ptr<Connection> Self() { return std::static_pointer_cast<Connection>(shared_from_this()); }
  beast::tcp_stream& Lowest() { return beast::get_lowest_layer(stream_); }
  const HttpServerOptions& Options() const { return core_->options; }

  void Unregister() {
    if (id_ == 0) return;
    std::lock_guard<std::mutex> lock(core_->mutex);
    core_->live.erase(id_);
    id_ = 0;
  }

  void Begin() {
    if constexpr (kTls) {
      state_ = State::kHandshake;
      Lowest().expires_after(Options().header_timeout);
      stream_.async_handshake(ssl::stream_base::server, [self = Self()](const beast::error_code& ec) {
        if (ec) return self->Close();
        self->ReadRequest();
      });
    } else {
      ReadRequest();
    }
  }

  void ReadRequest() {
    if (state_ == State::kClosed) return;
    if (core_->draining.load() && buffer_.size() == 0) return Close();
    state_ = State::kReading;
    parser_.emplace();
    parser_->header_limit(Options().max_header_bytes);
    parser_->body_limit(Options().max_body_bytes);
    Lowest().expires_after(first_ ? Options().header_timeout : Options().idle_timeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = Self()](const beast::error_code& ec, size_t) { self->OnRead(ec); });
  }

  void OnRead(const beast::error_code& ec) {
    if (state_ != State::kReading) return;  // closed meanwhile
    if (!ec) return HandleRequest();
    if (ec == http::error::header_limit) {
      return Fail(431, "the request's head (request line and header fields) is larger than " +
                           std::to_string(Options().max_header_bytes) + " bytes");
    }
    if (ec == http::error::body_limit) {
      return Fail(413, "a request body larger than " + std::to_string(Options().max_body_bytes) +
                           " bytes (GET, HEAD and OPTIONS take none)");
    }
    if (IsHttpError(ec) && ec != http::error::end_of_stream && ec != http::error::partial_message) {
      return Fail(400, "not a valid HTTP/1.1 request: " + ec.message());
    }
    Close();  // end of stream, timeout, a network or TLS error
  }

  // An error the server answers itself, closing the connection after it.
  void Fail(int status, const std::string& message) {
    keep_alive_ = false;
    head_ = false;
    Respond(JsonError(status, message), true);
  }

  void HandleRequest() {
    HttpUpgradeRequest request = parser_->release();
    version_ = request.version();
    keep_alive_ = request.keep_alive();
    const http::verb method = request.method();
    head_ = method == http::verb::head;
    if (method != http::verb::get && method != http::verb::head && method != http::verb::options) {
      HttpResponse r = JsonError(405, "method " + std::string(request.method_string()) +
                                          " is not allowed (GET, HEAD and OPTIONS are)",
                                 "METHOD_NOT_ALLOWED");
      r.SetHeader("Allow", "GET, HEAD, OPTIONS");
      return Respond(std::move(r), false);
    }
    const std::string target(request.target());
    if (target.empty() || (target[0] != '/' && !(method == http::verb::options && target == "*"))) {
      return Respond(JsonError(400, "the request target must be an absolute path ('/...')", "INVALID_ARGUMENT"),
                     false);
    }
    const size_t question = target.find('?');
    std::string path = target.substr(0, question);

    const auto upgrade = Options().upgrades.find(path);
    if (upgrade != Options().upgrades.end() && upgrade->second) {
      if (method == http::verb::get && beast::websocket::is_upgrade(request)) {
        if (buffer_.size() != 0) {
          return Fail(400, "bytes followed the upgrade request before the server answered it");
        }
        return Upgrade(*upgrade->second, std::move(request));
      }
      HttpResponse r = JsonError(426, path + ": a WebSocket route (send GET with 'Upgrade: websocket')",
                                 "UPGRADE_REQUIRED");
      r.SetHeader("Upgrade", "websocket");
      r.SetHeader("Connection", "Upgrade");
      return Respond(std::move(r), false);
    }

    HttpRequest plain;
    plain.method = std::string(request.method_string());
    plain.target = target;
    plain.path = std::move(path);
    if (question != std::string::npos) plain.query = target.substr(question + 1);
    plain.headers.reserve(static_cast<size_t>(std::distance(request.begin(), request.end())));
    for (const auto& field : request) {
      std::string name(field.name_string());
      for (char& c : name) {
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
      }
      plain.headers.emplace_back(std::move(name), std::string(field.value()));
    }
    plain.remote = remote_;

    state_ = State::kWorking;
    std::shared_ptr<Connection> self = Self();
    const bool posted = core_->pool.Post([self, core = core_, plain = std::move(plain)]() {
      HttpResponse r;
      try {
        r = core->handler(plain);
      } catch (const std::exception& e) {
        r = JsonError(500, std::string("internal error: ") + e.what(), "INTERNAL");
      } catch (...) {
        r = JsonError(500, "internal error", "INTERNAL");
      }
      net::post(self->executor_, [self, r = std::move(r)]() mutable { self->Respond(std::move(r), false); });
    });
    if (!posted) Respond(StatusResponse(Unavailable("the server is shutting down")), true);
  }

  void Upgrade(HttpUpgradeHandler& handler, HttpUpgradeRequest request) {
    state_ = State::kUpgraded;
    Unregister();
    core_->upgraded.fetch_add(1);
    try {
      handler.Upgrade(std::move(stream_), std::move(request), std::move(slot_));
    } catch (const std::exception& e) {
      core_->Log(std::string("http: an upgrade handler threw: ") + e.what());
    } catch (...) {
      core_->Log("http: an upgrade handler threw");
    }
  }

  void Respond(HttpResponse r, bool close) {
    if (state_ == State::kClosed || state_ == State::kClosing || state_ == State::kUpgraded) return;
    state_ = State::kWriting;
    core_->requests.fetch_add(1);
    Response& res = response_.emplace();
    res.version(version_);
    res.result(static_cast<unsigned>(r.status));
    for (auto& [name, value] : r.headers) res.insert(name, CleanValue(std::move(value)));
    res.set(http::field::date, HttpDate(static_cast<int64_t>(std::time(nullptr))));
    res.set(http::field::server, "meshstream");
    res.keep_alive(keep_alive_ && !close && !core_->draining.load());
    const bool bodiless = r.status == 204 || r.status == 304 || r.status < 200;
    if (!bodiless) res.content_length(r.size);
    if (!bodiless && !head_) res.body() = SharedBytesBody::value_type{std::move(r.data), r.offset, r.size};
    serializer_.emplace(res);
    WriteSome();
  }

  void WriteSome() {
    Lowest().expires_after(Options().send_timeout);
    http::async_write_some(stream_, *serializer_, [self = Self()](const beast::error_code& ec, size_t) {
      self->OnWrite(ec);
    });
  }

  void OnWrite(const beast::error_code& ec) {
    if (state_ != State::kWriting) return;
    if (ec) return Close();
    if (!serializer_->is_done()) return WriteSome();
    const bool keep = response_->keep_alive();
    serializer_.reset();
    response_.reset();
    first_ = false;
    if (keep) return ReadRequest();
    Shutdown();
  }

  // Ends the connection after a response, letting the client read it: TLS
  // close_notify, or the send side shut and what the client still sends
  // read and dropped for a moment (closing with unread bytes would reset
  // the connection, and the client could lose the response).
  void Shutdown() {
    state_ = State::kClosing;
    Lowest().expires_after(std::chrono::seconds(1));
    if constexpr (kTls) {
      stream_.async_shutdown([self = Self()](const beast::error_code&) { self->Close(); });
    } else {
      beast::error_code ignored;
      Lowest().socket().shutdown(tcp::socket::shutdown_send, ignored);
      Linger();
    }
  }

  void Linger() {
    Lowest().async_read_some(net::buffer(discard_), [self = Self()](const beast::error_code& ec, size_t) {
      if (ec || self->state_ != State::kClosing) return self->Close();
      self->Linger();
    });
  }

  void CloseIfIdle() {
    const bool idle = state_ == State::kNew || state_ == State::kHandshake ||
                      (state_ == State::kReading && parser_ && !parser_->got_some() && buffer_.size() == 0);
    if (idle) Close();
  }

  void Close() {
    if (state_ == State::kClosed || state_ == State::kUpgraded) return;
    state_ = State::kClosed;
    Lowest().close();
    Unregister();
    slot_.Release();
  }

  std::shared_ptr<Core> core_;
  Stream stream_;
  const net::any_io_executor executor_;  // the connection's strand
  HttpConnectionSlot slot_;
  const std::string remote_;
  uint64_t id_ = 0;
  State state_ = State::kNew;
  bool first_ = true;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  unsigned version_ = 11;
  bool keep_alive_ = false;
  bool head_ = false;
  std::optional<Response> response_;
  std::optional<http::response_serializer<SharedBytesBody>> serializer_;
  char discard_[4096];
};

}  // namespace

struct HttpServer::Impl {
  std::shared_ptr<Core> core;
  net::io_context ioc;
  // The io threads run until Stop even when no operation is pending: a
  // request on the pool posts its response back later.
  net::executor_work_guard<net::io_context::executor_type> work;
  tcp::acceptor acceptor;
  net::steady_timer accept_retry;
  std::vector<std::thread> threads;
  std::string address;
  std::mutex stop_mutex;
  bool stopped = false;

  Impl(std::shared_ptr<Core> c, int io_threads)
      : core(std::move(c)),
        ioc(io_threads),
        work(net::make_work_guard(ioc)),
        acceptor(net::make_strand(ioc)),
        accept_retry(acceptor.get_executor()) {}

  void Accept() {
    acceptor.async_accept(net::make_strand(ioc), [this](const beast::error_code& ec, tcp::socket socket) {
      OnAccept(ec, std::move(socket));
    });
  }

  void OnAccept(const beast::error_code& ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted || !acceptor.is_open()) return;
    if (ec) {
      // Out of descriptors, or the like: try again in a moment instead of spinning.
      core->Log("http: accept failed: " + ec.message());
      accept_retry.expires_after(std::chrono::milliseconds(100));
      accept_retry.async_wait([this](const beast::error_code& wait) {
        if (!wait && acceptor.is_open()) Accept();
      });
      return;
    }
    if (core->draining.load()) {
      beast::error_code ignored;
      socket.close(ignored);
      return;
    }
    if (!core->table->TryTake()) {
      const uint64_t refused = core->refused.fetch_add(1) + 1;
      if (refused == 1 || refused % 1000 == 0) {
        core->Log("http: " + std::to_string(refused) + " connections refused so far: " +
                  std::to_string(core->options.max_connections) + " are open");
      }
      beast::error_code ignored;
      socket.close(ignored);
      return Accept();
    }
    core->accepted.fetch_add(1);
    HttpConnectionSlot slot(core->table);
    beast::error_code remote_error;
    const tcp::endpoint remote = socket.remote_endpoint(remote_error);
    const std::string remote_text = remote_error ? std::string("?") : EndpointText(remote);
    try {
      if (core->tls) {
        std::make_shared<Connection<HttpTlsStream>>(core, std::move(socket), std::move(slot), remote_text)->Start();
      } else {
        std::make_shared<Connection<HttpPlainStream>>(core, std::move(socket), std::move(slot), remote_text)->Start();
      }
    } catch (const std::exception& e) {
      core->Log(std::string("http: a connection could not start: ") + e.what());
    }
    Accept();
  }
};

HttpServer::HttpServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpServer::~HttpServer() {
  if (impl_) Stop(std::chrono::steady_clock::now());
}

StatusOr<std::unique_ptr<HttpServer>> HttpServer::Start(HttpServerOptions options, HttpHandler handler) {
  if (options.listen.rfind("unix:", 0) == 0) {
    return InvalidArgument("--http-listen " + options.listen + ": HTTP listens on HOST:PORT, not a unix socket");
  }
  std::string host;
  uint16_t port = 0;
  Status split = SplitHostPort(options.listen, &host, &port);
  if (!split.ok()) return split.WithContext("--http-listen");
  if (options.tls_cert.empty() != options.tls_key.empty()) {
    return InvalidArgument("--tls-cert and --tls-key: give both or neither");
  }
  options.io_threads = std::max(1, options.io_threads);
  options.pool_threads = std::max(1, options.pool_threads);
  const int io_threads = options.io_threads;
  const std::string listen = options.listen;
  try {
    auto core = std::make_shared<Core>(std::move(options), std::move(handler));
    const HttpServerOptions& o = core->options;
    if (!o.tls_cert.empty()) {
      core->tls.emplace(ssl::context::tls_server);
      core->tls->set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                             ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1 | ssl::context::single_dh_use);
      beast::error_code ec;
      core->tls->use_certificate_chain_file(o.tls_cert, ec);
      if (ec) return InvalidArgument("--tls-cert " + o.tls_cert + ": " + ec.message());
      core->tls->use_private_key_file(o.tls_key, ssl::context::pem, ec);
      if (ec) return InvalidArgument("--tls-key " + o.tls_key + ": " + ec.message());
    }
    auto impl = std::make_unique<Impl>(core, io_threads);

    beast::error_code ec;
    tcp::endpoint endpoint;
    const net::ip::address literal = net::ip::make_address(host, ec);
    if (!ec) {
      endpoint = tcp::endpoint(literal, port);
    } else {
      tcp::resolver resolver(impl->ioc);
      const auto found = resolver.resolve(host, std::to_string(port), ec);
      if (ec || found.empty()) {
        return InvalidArgument("--http-listen " + listen + ": cannot resolve " + host +
                               (ec ? ": " + ec.message() : std::string()));
      }
      endpoint = found.begin()->endpoint();
    }
    const auto cannot = [&listen](const beast::error_code& e) {
      return Unavailable("--http-listen " + listen + ": cannot listen there: " + e.message());
    };
    impl->acceptor.open(endpoint.protocol(), ec);
    if (ec) return cannot(ec);
    impl->acceptor.set_option(net::socket_base::reuse_address(true), ec);
    if (ec) return cannot(ec);
    impl->acceptor.bind(endpoint, ec);
    if (ec) return cannot(ec);
    impl->acceptor.listen(net::socket_base::max_listen_connections, ec);
    if (ec) return cannot(ec);
    const tcp::endpoint bound = impl->acceptor.local_endpoint(ec);
    if (ec) return cannot(ec);
    impl->address = EndpointText(bound);

    impl->Accept();
    Impl* raw = impl.get();
    for (int i = 0; i < io_threads; ++i) {
      impl->threads.emplace_back([raw] {
        for (;;) {
          try {
            raw->ioc.run();
            return;
          } catch (const std::exception& e) {
            raw->core->Log(std::string("http: an io handler threw: ") + e.what());
          } catch (...) {
            raw->core->Log("http: an io handler threw");
          }
        }
      });
    }
    return std::unique_ptr<HttpServer>(new HttpServer(std::move(impl)));
  } catch (const std::exception& e) {
    return Internal("--http-listen " + listen + ": " + e.what());
  }
}

const std::string& HttpServer::address() const { return impl_->address; }

bool HttpServer::tls() const { return impl_->core->tls.has_value(); }

void HttpServer::BeginDrain() {
  Impl& s = *impl_;
  if (s.core->draining.exchange(true)) return;
  net::post(s.acceptor.get_executor(), [&s] {
    beast::error_code ignored;
    s.acceptor.close(ignored);
    s.accept_retry.cancel();
  });
  for (const auto& connection : s.core->Live()) connection->PostCloseIfIdle();
}

void HttpServer::Stop(std::chrono::steady_clock::time_point deadline) {
  Impl& s = *impl_;
  std::lock_guard<std::mutex> lock(s.stop_mutex);
  if (s.stopped) return;
  s.stopped = true;
  BeginDrain();
  if (!s.core->table->WaitEmpty(deadline)) {
    // The grace period is over: close what is left (a response still being
    // written, a connection an upgrade handler holds ends with the threads).
    for (const auto& connection : s.core->Live()) connection->PostClose();
    s.core->table->WaitEmpty(std::chrono::steady_clock::now() + std::chrono::milliseconds(200));
  }
  s.work.reset();
  s.ioc.stop();
  for (std::thread& t : s.threads) {
    if (t.joinable()) t.join();
  }
  // After the io threads: running requests finish (their responses go to a
  // stopped io_context, destroyed with it); queued ones are dropped.
  s.core->pool.Stop();
  beast::error_code ignored;
  s.acceptor.close(ignored);
}

HttpServerStats HttpServer::stats() const {
  const Core& c = *impl_->core;
  HttpServerStats out;
  out.accepted = c.accepted.load();
  out.refused = c.refused.load();
  out.requests = c.requests.load();
  out.upgraded = c.upgraded.load();
  return out;
}

}  // namespace meshstream
