// A server full of sessions still answers (issue 22): `--max-sessions`
// sessions held open and stalled (clients that read nothing, on a server of
// far fewer gRPC threads than sessions) and GetVersion, the health check and
// the refusal of one more session (RESOURCE_EXHAUSTED) each answer within
// 1 s. With a thread per session (the synchronous Open of before) the
// sessions beyond --max-threads were refused and GetVersion found no thread.
//
// The same tests measure what the server holds (threads, resident memory,
// file descriptors), printed as "saturation: ..." lines. docs/design/deploy.md
// records a larger run:
//   MESHSTREAM_SATURATION_SESSIONS=4096 build/bin/integration_tests --gtest_filter='StreamSaturation.*'
#include <dirent.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "meshstream/v1/stream.grpc.pb.h"
#include "testing/asset_calls.h"
#include "testing/grpc_probe.h"
#include "testing/proc_status.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ServeProcess;
using Clock = std::chrono::steady_clock;

int Sessions(int fallback) {
  const char* text = std::getenv("MESHSTREAM_SATURATION_SESSIONS");
  return text != nullptr && std::atoi(text) > 0 ? std::atoi(text) : fallback;
}

// What /proc says about a process: threads, resident KiB, open descriptors.
struct Held {
  int64_t threads = -1, rss_kib = -1, fds = -1;
};

Held Measure(pid_t pid) {
  Held h;
  const test_util::ProcStatus status = test_util::ReadProcStatus(pid);
  h.threads = status.threads;
  h.rss_kib = status.rss_kib;
  h.fds = 0;
  if (DIR* d = opendir(("/proc/" + std::to_string(pid) + "/fd").c_str())) {
    while (readdir(d) != nullptr) ++h.fds;
    closedir(d);
    h.fds -= 2;  // . and ..
  }
  return h;
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Channels of their own (no shared subchannel), so that the sessions spread
// over several connections as many clients' would.
// `small_window`: the client's flow-control window stays small (no BDP
// probing), so a session it does not read stalls after a few messages
// instead of being buffered whole.
std::vector<std::shared_ptr<grpc::Channel>> Channels(const std::string& address, int n, bool small_window = false) {
  std::vector<std::shared_ptr<grpc::Channel>> out;
  for (int i = 0; i < n; ++i) {
    grpc::ChannelArguments args;
    if (small_window) {
      args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
      args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 16 * 1024);
    }
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    args.SetInt("meshstream.test.channel", i);
    args.SetMaxReceiveMessageSize(256 << 20);
    out.push_back(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
  }
  return out;
}

// The loss-tolerant profile's streams, also over gRPC: the reliable one's
// (what a gRPC session gets by default) is small enough to fit the socket
// buffers whole, and a session that is meant to stall would finish.
v1::ClientMessage OpenMessage(const std::string& asset, v1::Transport transport) {
  v1::ClientMessage m;
  m.mutable_open()->set_asset(asset);
  m.mutable_open()->set_max_level(-1);
  m.mutable_open()->set_transport(transport);
  m.mutable_open()->set_profile(v1::PROFILE_LOSS_TOLERANT);
  return m;
}

// A client that opens a session and then reads nothing.
struct StalledSession {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>> stream;
};

// A client that reads every message of its session, then opens the next,
// until told to stop: sessions streaming without a client thread each.
class ReadingClient final : public grpc::ClientBidiReactor<v1::ClientMessage, v1::ServerMessage> {
 public:
  ReadingClient(v1::StreamService::Stub* stub, std::atomic<bool>* stop, std::atomic<int64_t>* completed,
                std::atomic<int64_t>* bytes)
      : stub_(stub), stop_(stop), completed_(completed), bytes_(bytes) {
    Begin();
  }
  void Wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_cv_.wait(lock, [this] { return finished_; });
  }
  void OnWriteDone(bool) override {}
  void OnReadDone(bool ok) override {
    if (ok) {
      *bytes_ += static_cast<int64_t>(in_.ByteSizeLong());
      if (in_.kind_case() == v1::ServerMessage::kEnd) {
        ended_ = true;
        StartWritesDone();
      }
      StartRead(&in_);
    }
  }
  int64_t mine() const { return mine_.load(); }
  static inline std::atomic<int64_t> refused{0};
  static inline std::atomic<int64_t> ended{0};
  static inline std::atomic<int64_t> by_code[17] = {};
  void OnDone(const grpc::Status& status) override {
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) ++refused;
    if (ended_) ++ended;  // SessionEnd arrived (a slow client may then miss the linger)
    ++by_code[std::min<int>(status.error_code(), 16)];
    if (ended_ && status.ok()) {
      ++*completed_;
      ++mine_;
    }
    if (!stop_->load()) {
      Begin();
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = true;
    done_cv_.notify_all();
  }

 private:
  void Begin() {
    context_ = std::make_unique<grpc::ClientContext>();
    ended_ = false;
    open_ = OpenMessage("asset", v1::TRANSPORT_GRPC);
    stub_->async()->Open(context_.get(), this);
    StartWrite(&open_);
    StartRead(&in_);
    StartCall();
  }
  v1::StreamService::Stub* stub_;
  std::atomic<bool>* stop_;
  std::atomic<int64_t>* completed_;
  std::atomic<int64_t>* bytes_;
  std::unique_ptr<grpc::ClientContext> context_;
  v1::ClientMessage open_;
  v1::ServerMessage in_;
  bool ended_ = false;
  std::atomic<int64_t> mine_{0};
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool finished_ = false;
};

// How long a UDP session waits for its client's HELLO before it falls back
// to the stream (--hello-timeout, here its default).
constexpr int kHelloTimeoutMs = 1000;
// What the calls of a full server must not take: a bound that only catches a
// server that no longer answers (every thread held by a session), never a
// slow machine; the times themselves are printed below.
constexpr double kHangS = 10.0;

std::unique_ptr<ServeProcess> StartServer(test_util::TempDir& dir, int sessions, const std::string& model) {
  // Far fewer gRPC threads than sessions: a session must not hold one.
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1", "--max-sessions",
                                     std::to_string(sessions), "--max-threads", "32", "--session-idle-timeout", "600",
                                     "--hello-timeout", std::to_string(kHelloTimeoutMs)});
  EXPECT_TRUE(server.ok()) << server.status().ToString();
  if (!server.ok()) return nullptr;
  const Status ingested = test_util::IngestSharedModel((*server)->address(), "asset", model);
  EXPECT_TRUE(ingested.ok()) << ingested.ToString();
  return std::move(server).value();
}

TEST(StreamSaturation, AFullServerOfStalledSessionsStillAnswers) {
  const int kSessions = Sessions(256);
  test_util::TempDir dir;
  // The largest model: far more than a stream's window, so the sessions stall.
  auto server = StartServer(dir, kSessions, "horse.ply");
  ASSERT_NE(server, nullptr);
  const Held idle = Measure(server->pid());
  const auto channels = Channels(server->address(), 8, true);

  // Half over UDP (they never send a HELLO: they wait, then fall back to the
  // stream), half over gRPC; none reads a byte.
  std::vector<std::unique_ptr<StalledSession>> stalled;
  for (int i = 0; i < kSessions; ++i) {
    auto s = std::make_unique<StalledSession>();
    auto stub = v1::StreamService::NewStub(channels[static_cast<size_t>(i) % channels.size()]);
    s->stream = stub->Open(&s->context);
    ASSERT_TRUE(s->stream->Write(OpenMessage("asset", i % 2 == 0 ? v1::TRANSPORT_UDP : v1::TRANSPORT_GRPC)));
    stalled.push_back(std::move(s));
  }
  // The server's own word that every session is open.
  const auto deadline = Clock::now() + std::chrono::seconds(120);
  size_t opened = 0;
  while (Clock::now() < deadline && (opened = Count(server->log(), " opened (")) < static_cast<size_t>(kSessions)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(opened, static_cast<size_t>(kSessions)) << server->log().substr(0, 4000);
  // Past the HELLO wait (twice --hello-timeout): every session has written
  // what its stream takes and stalls.
  std::this_thread::sleep_for(std::chrono::milliseconds(2 * kHelloTimeoutMs));
  const Held full = Measure(server->pid());

  auto client = test_util::NewAssetClient(server->address());
  auto begin = Clock::now();
  v1::Version version;
  const Status got = test_util::GetVersion(*client, "asset", 0, &version);
  const double get_s = std::chrono::duration<double>(Clock::now() - begin).count();
  EXPECT_TRUE(got.ok()) << got.ToString();
  EXPECT_LT(get_s, kHangS) << "GetVersion";

  begin = Clock::now();
  const test_util::HealthAnswer health = test_util::CheckHealth(client->channel());
  const double health_s = std::chrono::duration<double>(Clock::now() - begin).count();
  EXPECT_TRUE(health.status.ok()) << health.status.error_message();
  EXPECT_EQ(health.serving_status, 1);
  EXPECT_LT(health_s, kHangS) << "health";

  begin = Clock::now();
  {
    auto stub = v1::StreamService::NewStub(client->channel());
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    auto stream = stub->Open(&context);
    stream->Write(OpenMessage("asset", v1::TRANSPORT_GRPC));
    v1::ServerMessage m;
    EXPECT_FALSE(stream->Read(&m)) << "one more session was served";
    const grpc::Status refused = stream->Finish();
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  }
  const double refuse_s = std::chrono::duration<double>(Clock::now() - begin).count();
  EXPECT_LT(refuse_s, kHangS) << "the refusal";
  EXPECT_EQ(Count(server->log(), " ended ("), 0u) << server->log().substr(server->log().size() > 3000 ? server->log().size() - 3000 : 0);

  std::printf("saturation: %d stalled sessions: server threads %lld (idle %lld), RSS %lld KiB (idle %lld, %.1f KiB "
              "per session), fds %lld (idle %lld); GetVersion %.3f s, health %.3f s, refusal %.3f s\n",
              kSessions, static_cast<long long>(full.threads), static_cast<long long>(idle.threads),
              static_cast<long long>(full.rss_kib), static_cast<long long>(idle.rss_kib),
              static_cast<double>(full.rss_kib - idle.rss_kib) / kSessions, static_cast<long long>(full.fds),
              static_cast<long long>(idle.fds), get_s, health_s, refuse_s);
  // No thread per session: the server's threads do not grow with them.
  EXPECT_LT(full.threads, idle.threads + 16) << "threads grew with the sessions";
  for (auto& s : stalled) s->context.TryCancel();
  stalled.clear();
  EXPECT_EQ(server->Terminate(), 0);
}

// Every client streams sessions back to back (over gRPC: unpaced, what
// costs the server most) until each has completed one; the server's threads
// stay flat and the rate of completed sessions is printed.
TEST(StreamSaturation, SessionsStreamingAtOnceWithoutAThreadEach) {
  const int kSessions = Sessions(64);
  test_util::TempDir dir;
  // Room for twice the clients: a client opens its next session as soon as
  // its last one ended, maybe before the server has released that slot.
  auto server = StartServer(dir, 2 * kSessions, "stanford-bunny.obj");
  ASSERT_NE(server, nullptr);
  const Held idle = Measure(server->pid());
  const auto channels = Channels(server->address(), 8);
  std::vector<std::unique_ptr<v1::StreamService::Stub>> stubs;
  for (const auto& c : channels) stubs.push_back(v1::StreamService::NewStub(c));
  std::atomic<bool> stop{false};
  std::atomic<int64_t> completed{0}, bytes{0};
  std::vector<std::unique_ptr<ReadingClient>> clients;
  const auto begin = Clock::now();
  for (int i = 0; i < kSessions; ++i) {
    clients.push_back(
        std::make_unique<ReadingClient>(stubs[static_cast<size_t>(i) % stubs.size()].get(), &stop, &completed, &bytes));
  }
  Held peak;
  // Every session progresses at its share of the server's throughput, so
  // with thousands at once none may complete for a while: the bound is generous.
  const auto until = begin + std::chrono::seconds(kSessions > 1024 ? 60 : 300);
  bool all = false;
  while (!all && Clock::now() < until) {
    const Held h = Measure(server->pid());
    peak.threads = std::max(peak.threads, h.threads);
    peak.rss_kib = std::max(peak.rss_kib, h.rss_kib);
    peak.fds = std::max(peak.fds, h.fds);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    all = true;
    for (const auto& c : clients) all = all && c->mine() > 0;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - begin).count();
  stop = true;
  for (auto& c : clients) c->Wait();
  std::printf("saturation: %d sessions streaming at once: %lld sessions ended (%lld of them OK) in %.1f s (%.0f per "
              "second, %.1f MB/s of messages); server peak threads %lld (idle %lld), RSS %lld KiB (idle %lld), fds %lld (idle %lld)\n",
              kSessions, static_cast<long long>(ReadingClient::ended.load()), static_cast<long long>(completed.load()),
              seconds, ReadingClient::ended.load() / seconds,
              static_cast<double>(bytes.load()) / seconds / 1e6,
              static_cast<long long>(peak.threads), static_cast<long long>(idle.threads),
              static_cast<long long>(peak.rss_kib), static_cast<long long>(idle.rss_kib),
              static_cast<long long>(peak.fds), static_cast<long long>(idle.fds));
  EXPECT_EQ(ReadingClient::refused.load(), 0) << "sessions refused";
  for (int code = 1; code <= 16; ++code) {
    if (ReadingClient::by_code[code] > 0) {
      std::printf("saturation: %lld sessions ended with gRPC code %d\n",
                  static_cast<long long>(ReadingClient::by_code[code].load()), code);
    }
  }
  if (kSessions <= 1024) {
    EXPECT_TRUE(all) << "every client completed a session";
  }
  EXPECT_LT(peak.threads, idle.threads + 16) << "threads grew with the sessions";
  EXPECT_EQ(server->Terminate(), 0);
}

}  // namespace
}  // namespace meshstream
