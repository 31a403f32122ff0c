// The HTTP server core (services/http/http_server.h) in this process, on
// real sockets, with small limits: connections at once, the head's and the
// idle timeouts, HEAD and keep-alive, pipelining, drain and stop, a handler
// that throws, the upgrade extension point (upgrade.h) and TLS.
#include "services/http/http_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include <boost/asio/write.hpp>

#include "services/http/upgrade.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

int PortOf(const std::string& address) { return std::stoi(address.substr(address.rfind(':') + 1)); }

int Connect(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

void Send(int fd, const std::string& bytes) {
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return;
    sent += static_cast<size_t>(n);
  }
}

// What arrives until the peer closes or `timeout` passes; `closed` says which.
std::string Receive(int fd, milliseconds timeout, bool* closed = nullptr, size_t stop_after = SIZE_MAX) {
  std::string out;
  const auto deadline = Clock::now() + timeout;
  if (closed) *closed = false;
  while (out.size() < stop_after) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left)) <= 0) break;
    char buf[65536];
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) {
      if (closed) *closed = true;
      break;
    }
    out.append(buf, static_cast<size_t>(n));
  }
  return out;
}

// One response: the head and Content-Length bytes of body.
std::string ReadResponse(int fd, milliseconds timeout = milliseconds(5000)) {
  std::string got;
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const size_t end = got.find("\r\n\r\n");
    if (end != std::string::npos) {
      const size_t cl = got.find("Content-Length: ");
      size_t length = 0;
      if (cl != std::string::npos && cl < end) length = std::stoul(got.substr(cl + 16));
      if (got.size() >= end + 4 + length) return got;
    }
    const std::string more =
        Receive(fd, std::chrono::duration_cast<milliseconds>(deadline - Clock::now()), nullptr, 1);
    if (more.empty()) break;
    got += more;
  }
  return got;
}

HttpResponse Text(const std::string& text) {
  HttpResponse r;
  r.SetHeader("Content-Type", "text/plain");
  r.SetBody(text);
  return r;
}

struct TestServer {
  std::unique_ptr<HttpServer> server;
  int port = 0;
};

TestServer Start(HttpServerOptions options, HttpHandler handler) {
  if (options.listen.empty()) options.listen = "127.0.0.1:0";
  auto started = HttpServer::Start(std::move(options), std::move(handler));
  EXPECT_TRUE(started.ok()) << started.status().ToString();
  TestServer t;
  if (!started.ok()) return t;
  t.server = std::move(started).value();
  t.port = PortOf(t.server->address());
  return t;
}

HttpHandler Echo() {
  return [](const HttpRequest& r) { return Text(r.method + " " + r.path + " ?" + r.query); };
}

TEST(HttpServer, AnswersKeepsAliveAndHead) {
  TestServer t = Start({}, Echo());
  ASSERT_TRUE(t.server);
  EXPECT_EQ(t.server->address().rfind("127.0.0.1:", 0), 0u);
  const int fd = Connect(t.port);
  ASSERT_GE(fd, 0);
  Send(fd, "GET /a?x=1 HTTP/1.1\r\nHost: h\r\n\r\n");
  std::string r = ReadResponse(fd);
  EXPECT_EQ(r.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << r;
  EXPECT_NE(r.find("Content-Length: 11\r\n"), std::string::npos) << r;
  EXPECT_NE(r.find("Date: "), std::string::npos) << r;
  EXPECT_NE(r.find("\r\n\r\nGET /a ?x=1"), std::string::npos) << r;
  // The same connection: HEAD gets the length and no body.
  Send(fd, "HEAD /bb HTTP/1.1\r\nHost: h\r\n\r\n");
  r = Receive(fd, milliseconds(500));
  EXPECT_EQ(r.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << r;
  EXPECT_NE(r.find("Content-Length: 10\r\n"), std::string::npos) << r;
  EXPECT_EQ(r.substr(r.find("\r\n\r\n") + 4), "") << r;
  close(fd);
}

TEST(HttpServer, PipelinedRequestsInOrder) {
  TestServer t = Start({}, Echo());
  const int fd = Connect(t.port);
  Send(fd, "GET /1 HTTP/1.1\r\nHost: h\r\n\r\nGET /2 HTTP/1.1\r\nHost: h\r\n\r\nGET /3 HTTP/1.1\r\nHost: h\r\n"
           "Connection: close\r\n\r\n");
  bool closed = false;
  const std::string r = Receive(fd, milliseconds(3000), &closed);
  EXPECT_TRUE(closed);
  const size_t a = r.find("GET /1"), b = r.find("GET /2"), c = r.find("GET /3");
  ASSERT_NE(c, std::string::npos) << r;
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);
  EXPECT_NE(r.find("Connection: close"), std::string::npos);
  close(fd);
}

TEST(HttpServer, RefusesWhatItDoesNotServe) {
  TestServer t = Start({}, Echo());
  const auto ask = [&](const std::string& request) {
    const int fd = Connect(t.port);
    Send(fd, request);
    const std::string r = Receive(fd, milliseconds(3000));
    close(fd);
    return r;
  };
  EXPECT_EQ(ask("POST /a HTTP/1.1\r\nHost: h\r\nContent-Length: 0\r\nConnection: close\r\n\r\n").substr(0, 12),
            "HTTP/1.1 405");
  EXPECT_NE(ask("DELETE /a HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n").find("Allow: GET, HEAD, OPTIONS"),
            std::string::npos);
  EXPECT_EQ(ask("GET a HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n").substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(ask("OPTIONS * HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n").substr(0, 12), "HTTP/1.1 200");
  EXPECT_EQ(ask("GET / HTTP/1.1\r\nX: " + std::string(17000, 'a') + "\r\n\r\n").substr(0, 12), "HTTP/1.1 431");
  EXPECT_EQ(ask("GET / HTTP/1.1\r\nContent-Length: 5000\r\n\r\n" + std::string(5000, 'a')).substr(0, 12),
            "HTTP/1.1 413");
  EXPECT_EQ(ask("GET / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n2000\r\n" + std::string(8192, 'a') + "\r\n0\r\n\r\n")
                .substr(0, 12),
            "HTTP/1.1 413");
  EXPECT_EQ(ask("\x01\x02\x03 / HTTP/1.1\r\n\r\n").substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(ask("GET / HTTP/1.1\r\nBad Header\r\n\r\n").substr(0, 12), "HTTP/1.1 400");
  // A small body is read and ignored.
  EXPECT_EQ(ask("GET /x HTTP/1.1\r\nContent-Length: 3\r\nConnection: close\r\n\r\nabc").substr(0, 12),
            "HTTP/1.1 200");
  // HTTP/1.0 closes after the answer unless asked to keep the connection.
  bool closed = false;
  const int fd = Connect(t.port);
  Send(fd, "GET /x HTTP/1.0\r\n\r\n");
  EXPECT_EQ(Receive(fd, milliseconds(3000), &closed).substr(0, 12), "HTTP/1.0 200");
  EXPECT_TRUE(closed);
  close(fd);
}

TEST(HttpServer, AHandlerThatThrowsIs500) {
  TestServer t = Start({}, [](const HttpRequest&) -> HttpResponse { throw std::runtime_error("boom"); });
  const int fd = Connect(t.port);
  Send(fd, "GET / HTTP/1.1\r\nConnection: close\r\n\r\n");
  const std::string r = Receive(fd, milliseconds(3000));
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 500") << r;
  EXPECT_NE(r.find("\"error\""), std::string::npos) << r;
  close(fd);
}

TEST(HttpServer, ConnectionsAtOnceAreBounded) {
  HttpServerOptions o;
  o.max_connections = 2;
  TestServer t = Start(o, Echo());
  const int a = Connect(t.port), b = Connect(t.port);
  Send(a, "GET /a HTTP/1.1\r\n\r\n");
  Send(b, "GET /b HTTP/1.1\r\n\r\n");
  EXPECT_EQ(ReadResponse(a).substr(0, 12), "HTTP/1.1 200");
  EXPECT_EQ(ReadResponse(b).substr(0, 12), "HTTP/1.1 200");
  // The third is closed at once, without an answer.
  const int c = Connect(t.port);
  Send(c, "GET /c HTTP/1.1\r\n\r\n");
  bool closed = false;
  EXPECT_EQ(Receive(c, milliseconds(2000), &closed), "");
  EXPECT_TRUE(closed);
  close(c);
  // A place freed is a place taken again.
  close(a);
  std::string answer;
  for (int i = 0; i < 50 && answer.empty(); ++i) {
    std::this_thread::sleep_for(milliseconds(20));
    const int d = Connect(t.port);
    Send(d, "GET /d HTTP/1.1\r\nConnection: close\r\n\r\n");
    answer = Receive(d, milliseconds(1000));
    close(d);
  }
  EXPECT_EQ(answer.substr(0, 12), "HTTP/1.1 200");
  close(b);
  EXPECT_GE(t.server->stats().refused, 1u);
}

TEST(HttpServer, TimeoutsCloseSlowAndIdleConnections) {
  HttpServerOptions o;
  o.header_timeout = milliseconds(300);
  o.idle_timeout = milliseconds(300);
  TestServer t = Start(o, Echo());
  // Nothing sent.
  int fd = Connect(t.port);
  bool closed = false;
  auto start = Clock::now();
  Receive(fd, milliseconds(3000), &closed);
  EXPECT_TRUE(closed);
  EXPECT_LT(Clock::now() - start, milliseconds(2000));
  close(fd);
  // A head sent a byte at a time, too slowly.
  fd = Connect(t.port);
  start = Clock::now();
  for (char ch : std::string("GET / HTTP/1.1\r\nHost: h\r\n")) {
    Send(fd, std::string(1, ch));
    std::this_thread::sleep_for(milliseconds(30));
    if (Clock::now() - start > milliseconds(1000)) break;
  }
  Receive(fd, milliseconds(2000), &closed);
  EXPECT_TRUE(closed);
  close(fd);
  // Idle after a response.
  fd = Connect(t.port);
  Send(fd, "GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(ReadResponse(fd).substr(0, 12), "HTTP/1.1 200");
  Receive(fd, milliseconds(3000), &closed);
  EXPECT_TRUE(closed);
  close(fd);
}

TEST(HttpServer, DrainClosesIdleAndFinishesRunning) {
  std::atomic<bool> release{false};
  std::atomic<bool> entered{false};
  TestServer t = Start({}, [&release, &entered](const HttpRequest& r) {
    if (r.path == "/slow") {
      entered = true;
      while (!release.load()) std::this_thread::sleep_for(milliseconds(5));
    }
    return Text("done " + r.path);
  });
  const int idle = Connect(t.port);
  const int busy = Connect(t.port);
  Send(busy, "GET /slow HTTP/1.1\r\n\r\n");
  // The drain begins once /slow runs (not after a guess of how long that takes).
  const auto entered_by = Clock::now() + milliseconds(30000);
  while (!entered.load() && Clock::now() < entered_by) std::this_thread::sleep_for(milliseconds(2));
  ASSERT_TRUE(entered.load()) << "the slow request never reached its handler";
  t.server->BeginDrain();
  bool closed = false;
  EXPECT_EQ(Receive(idle, milliseconds(2000), &closed), "");
  EXPECT_TRUE(closed) << "an idle connection is closed by the drain";
  // No new connection is served.
  const int late = Connect(t.port);
  if (late >= 0) {
    Send(late, "GET / HTTP/1.1\r\n\r\n");
    EXPECT_EQ(Receive(late, milliseconds(1000), &closed), "");
    close(late);
  }
  std::thread stopper([&] { t.server->Stop(Clock::now() + milliseconds(5000)); });
  std::this_thread::sleep_for(milliseconds(100));
  release = true;
  const std::string r = Receive(busy, milliseconds(10000), &closed);
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 200") << r;
  EXPECT_NE(r.find("Connection: close"), std::string::npos) << r;
  EXPECT_NE(r.find("done /slow"), std::string::npos) << r;
  EXPECT_TRUE(closed);
  stopper.join();
  close(idle);
  close(busy);
}

TEST(HttpServer, StopAfterTheDeadlineClosesTheRest) {
  HttpServerOptions o;
  TestServer t = Start(o, Echo());
  // A head that never ends: the connection is not idle, the deadline ends it.
  const int fd = Connect(t.port);
  Send(fd, "GET / HTTP/1.1\r\nHost: h\r\n");
  std::this_thread::sleep_for(milliseconds(100));
  const auto start = Clock::now();
  t.server->Stop(Clock::now() + milliseconds(300));
  EXPECT_LT(Clock::now() - start, milliseconds(3000));
  bool closed = false;
  Receive(fd, milliseconds(2000), &closed);
  EXPECT_TRUE(closed);
  close(fd);
}

// An upgrade handler as a WebSocket route would be: it takes the stream and
// the slot, and answers on its own.
class TakeOver final : public HttpUpgradeHandler {
 public:
  void Upgrade(HttpPlainStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) override {
    calls++;
    auto s = std::make_shared<HttpPlainStream>(std::move(stream));
    auto message = std::make_shared<std::string>("TAKEN OVER " + std::string(request.target()) + "\n");
    auto held = std::make_shared<HttpConnectionSlot>(std::move(slot));
    boost::asio::async_write(*s, boost::asio::buffer(*message),
                             [s, message, held](const boost::system::error_code&, size_t) {
                               boost::system::error_code ignored;
                               s->socket().shutdown(boost::asio::ip::tcp::socket::shutdown_both, ignored);
                             });
  }
  void Upgrade(HttpTlsStream, HttpUpgradeRequest, HttpConnectionSlot) override { calls++; }
  std::atomic<int> calls{0};
};

TEST(HttpServer, UpgradeHandlersTakeTheConnectionOver) {
  auto handler = std::make_shared<TakeOver>();
  HttpServerOptions o;
  o.upgrades["/ws"] = handler;
  TestServer t = Start(o, Echo());
  const std::string upgrade =
      "GET /ws HTTP/1.1\r\nHost: h\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  int fd = Connect(t.port);
  Send(fd, upgrade);
  EXPECT_EQ(Receive(fd, milliseconds(3000)), "TAKEN OVER /ws\n");
  EXPECT_EQ(handler->calls.load(), 1);
  close(fd);
  // The same path without an upgrade: 426.
  fd = Connect(t.port);
  Send(fd, "GET /ws HTTP/1.1\r\nHost: h\r\nConnection: close\r\n\r\n");
  const std::string r = Receive(fd, milliseconds(3000));
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 426") << r;
  EXPECT_NE(r.find("Upgrade: websocket"), std::string::npos) << r;
  close(fd);
  // Bytes after the upgrade request before the answer: refused.
  fd = Connect(t.port);
  Send(fd, upgrade + "early");
  EXPECT_EQ(Receive(fd, milliseconds(3000)).substr(0, 12), "HTTP/1.1 400");
  close(fd);
  // Other paths are the handler's as before.
  fd = Connect(t.port);
  Send(fd, "GET /other HTTP/1.1\r\nConnection: close\r\n\r\n");
  EXPECT_NE(Receive(fd, milliseconds(3000)).find("GET /other"), std::string::npos);
  close(fd);
  EXPECT_EQ(handler->calls.load(), 1);
  EXPECT_EQ(t.server->stats().upgraded, 1u);
}

TEST(HttpServer, Tls) {
  test_util::TempDir dir;
  const std::string cert = dir.File("cert.pem"), key = dir.File("key.pem");
  const auto made = test_util::RunCommand(
      "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2 "
      "-subj /CN=localhost -addext subjectAltName=DNS:localhost,IP:127.0.0.1 -keyout " +
      test_util::Quote(key) + " -out " + test_util::Quote(cert));
  ASSERT_EQ(made.exit_code, 0) << made.err;
  HttpServerOptions o;
  o.tls_cert = cert;
  o.tls_key = key;
  TestServer t = Start(o, Echo());
  ASSERT_TRUE(t.server);
  EXPECT_TRUE(t.server->tls());
  const std::string script =
      "const fs = require('fs'); require('https').get({host: '127.0.0.1', port: " + std::to_string(t.port) +
      ", path: '/secure?q', servername: 'localhost', ca: fs.readFileSync(process.argv[1])}, (r) => {"
      " let b = ''; r.on('data', (c) => b += c); r.on('end', () => { console.log(r.statusCode + ' ' + b); }); })"
      ".on('error', (e) => { console.log('error ' + e.message); process.exit(1); });";
  const auto fetched = test_util::RunCommand("node -e " + test_util::Quote(script) + " " + test_util::Quote(cert));
  EXPECT_EQ(fetched.exit_code, 0) << fetched.out << fetched.err;
  EXPECT_EQ(fetched.out, "200 GET /secure ?q\n");
  // Plain HTTP to the TLS port gets no answer.
  const int fd = Connect(t.port);
  Send(fd, "GET / HTTP/1.1\r\n\r\n");
  bool closed = false;
  const std::string r = Receive(fd, milliseconds(3000), &closed);
  EXPECT_EQ(r.find("HTTP/1.1 200"), std::string::npos) << r;
  close(fd);
  // Files that are not a certificate and a key.
  test_util::WriteText(dir.File("junk.pem"), "not a certificate");
  HttpServerOptions bad;
  bad.listen = "127.0.0.1:0";
  bad.tls_cert = dir.File("junk.pem");
  bad.tls_key = key;
  EXPECT_EQ(HttpServer::Start(bad, Echo()).status().code(), StatusCode::kInvalidArgument);
  bad.tls_cert = cert;
  bad.tls_key = "";
  EXPECT_EQ(HttpServer::Start(bad, Echo()).status().code(), StatusCode::kInvalidArgument);
}

TEST(HttpServer, Addresses) {
  HttpServerOptions o;
  o.listen = "unix:/tmp/x";
  EXPECT_EQ(HttpServer::Start(o, Echo()).status().code(), StatusCode::kInvalidArgument);
  o.listen = "127.0.0.1";
  EXPECT_EQ(HttpServer::Start(o, Echo()).status().code(), StatusCode::kInvalidArgument);
  o.listen = "localhost:0";
  auto local = HttpServer::Start(o, Echo());
  ASSERT_TRUE(local.ok()) << local.status().ToString();
  // The same port twice: the second cannot listen.
  o.listen = (*local)->address();
  EXPECT_EQ(HttpServer::Start(o, Echo()).status().code(), StatusCode::kUnavailable);
  o.listen = "[::1]:0";
  auto v6 = HttpServer::Start(o, Echo());
  if (v6.ok()) {
    EXPECT_EQ((*v6)->address().rfind("[::1]:", 0), 0u) << (*v6)->address();
  }
}

}  // namespace
}  // namespace meshstream
