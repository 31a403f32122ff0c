// The server's sending thread (services/streaming/send_loop.h) with a
// recording stream in place of the gRPC call: a session is not stepped
// before Registration::Begin, whatever its call reports meanwhile (a
// cancel, a repair request), so the loop can neither call the stream nor
// Finish (and so let gRPC delete the call) while the opener still sets the
// call up; Begin's first step takes up what was reported. Over UDP (a real
// endpoint on loopback), a HELLO wakes the session only until an address is
// proven.
#include "services/streaming/send_loop.h"

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "net/hello.h"
#include "net/packet_crypto.h"
#include "net/steady_clock.h"

namespace meshstream {
namespace {

// One primitive of one refinement of two datagrams.
struct Fixture {
  std::vector<uint8_t> artifact;
  SessionPlan plan;
  Fixture() {
    artifact.assign(64, 0);
    artifact[0] = kStreamVersion;
    PlannedPrimitive p;
    p.stream = 3;
    p.header = {0, 8};
    p.base = {8, 8};
    p.refinements = 1;
    plan.primitives.push_back(p);
    PlannedRefinement r;
    r.control = {16, 8};
    r.datagrams = {{24, 16}, {40, 16}};
    plan.refinements.push_back(r);
    plan.levels = 1;
  }
};

// Records what the loop calls, never holds a message back.
class RecordingStream : public SessionStream {
 public:
  void Start(SessionTransport, const UdpEndpoint::Session*) override { Record("start"); }
  void TransportChanged(SessionTransport, const std::string&) override { Record("transport_change"); }
  void Control(const SenderAction&) override { Record("control"); }
  void Datagram(const uint8_t*, size_t) override { Record("datagram"); }
  void RefinementEnd(uint32_t, uint32_t, uint32_t, uint32_t) override { Record("refinement_end"); }
  void End(const std::string&) override { Record("end"); }
  void RepairEnd(uint32_t, uint64_t) override { Record("repair_end"); }
  void Levels(const SessionPlan&, uint32_t) override { Record("levels"); }
  void Finish(const Status& status, const std::string&, const SessionSenderStats&) override {
    std::lock_guard<std::mutex> lock(mutex_);
    calls_.push_back("finish");
    status_ = status;
    finished_ = true;
    changed_.notify_all();
  }
  // The loop asks before every action: the count of its steps' actions.
  // While `hold` is set the stream reports itself full (a client that reads
  // slowly): the loop steps nothing until a write completes.
  size_t queued() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    ++asked_;
    return hold_ ? size_t{1} << 20 : 0;
  }
  void Hold(bool hold) {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_ = hold;
  }
  size_t asked() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return asked_;
  }

  std::vector<std::string> calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return calls_;
  }
  // The Finish status, once the loop called it within `timeout`.
  bool WaitFinished(std::chrono::milliseconds timeout, Status* status) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!changed_.wait_for(lock, timeout, [this] { return finished_; })) return false;
    *status = status_;
    return true;
  }

 private:
  void Record(const std::string& call) {
    std::lock_guard<std::mutex> lock(mutex_);
    calls_.push_back(call);
  }
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> calls_;
  bool finished_ = false;
  Status status_;
  mutable size_t asked_ = 0;
  bool hold_ = false;
};

std::unique_ptr<SessionSender> Sender(const Fixture& f, bool repair = false) {
  SessionSenderOptions options;
  options.transport = SessionTransport::kGrpc;
  options.repair = repair;
  return std::make_unique<SessionSender>(f.plan, f.artifact, -1, options, SteadyNowUs());
}

// Longer than the loop's 100 ms period (its draining check and idle sweep).
constexpr std::chrono::milliseconds kQuiet{350};
constexpr std::chrono::milliseconds kDeadline{5000};

TEST(SendLoop, ACancelBeforeBeginStepsNothingUntilBegin) {
  Fixture f;
  SendLoop loop;
  RecordingStream stream;
  SendLoop::Registration reg = loop.Add(Sender(f), &stream, nullptr);
  reg.Cancel(Cancelled("the client went away"), "client went away");
  std::this_thread::sleep_for(kQuiet);
  EXPECT_TRUE(stream.calls().empty()) << "stepped before Begin";
  EXPECT_EQ(loop.sessions(), 1u);

  reg.Begin();
  Status status;
  ASSERT_TRUE(stream.WaitFinished(kDeadline, &status)) << "Begin does not take up the cancel";
  EXPECT_EQ(status.code(), StatusCode::kCancelled);
  EXPECT_EQ(stream.calls(), std::vector<std::string>{"finish"}) << "a cancelled session sends nothing";
}

TEST(SendLoop, ARepairBeforeBeginStepsNothingUntilBegin) {
  Fixture f;
  SendLoop loop;
  RecordingStream stream;
  SendLoop::Registration reg = loop.Add(Sender(f, /*repair=*/true), &stream, nullptr);
  reg.OnRepair({RepairItem{3, 0, {1}}});
  reg.OnClientClosed(false);
  reg.OnWritten();
  std::this_thread::sleep_for(kQuiet);
  EXPECT_TRUE(stream.calls().empty()) << "stepped before Begin";

  reg.Begin();
  Status status;
  ASSERT_TRUE(stream.WaitFinished(kDeadline, &status)) << "Begin does not step the session";
  EXPECT_TRUE(status.ok()) << status.ToString();
  const std::vector<std::string> calls = stream.calls();
  ASSERT_FALSE(calls.empty());
  EXPECT_EQ(calls.front(), "start");
  EXPECT_EQ(calls.back(), "finish");
  EXPECT_EQ(calls, (std::vector<std::string>{"start", "control", "datagram", "datagram", "datagram", "refinement_end",
                                             "end", "datagram", "repair_end", "finish"}))
      << "the repair asked before Begin is sent after the end";
}

// Without repair, after its end a session waits up to kLingerUs for the
// client to close; a cancel or a repair request after Begin steps it at once.
void RunToTheEnd(const RecordingStream& stream) {
  const auto until = std::chrono::steady_clock::now() + kDeadline;
  while (std::chrono::steady_clock::now() < until) {
    const std::vector<std::string> calls = stream.calls();
    if (!calls.empty() && calls.back() == "end") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(stream.calls(), (std::vector<std::string>{"start", "control", "datagram", "datagram", "datagram",
                                                      "refinement_end", "end"}));
}

constexpr std::chrono::milliseconds kSoonerThanTheLinger{SessionSender::kLingerUs / 2000};

// Streams a session without repair to its end, pokes it, and says whether
// it finished sooner than the linger, and with what.
bool FinishesAtOnceAfter(const std::function<void(SendLoop::Registration&)>& poke, Status* status) {
  Fixture f;
  SendLoop loop;
  RecordingStream stream;
  SendLoop::Registration reg = loop.Add(Sender(f), &stream, nullptr);
  reg.Begin();
  RunToTheEnd(stream);
  poke(reg);
  return stream.WaitFinished(kSoonerThanTheLinger, status);
}

TEST(SendLoop, AfterBeginACancelStepsTheSessionAtOnce) {
  Status status;
  ASSERT_TRUE(FinishesAtOnceAfter(
      [](SendLoop::Registration& reg) { reg.Cancel(Cancelled("the client went away"), "client went away"); },
      &status))
      << "the cancel did not wake the session";
  EXPECT_EQ(status.code(), StatusCode::kCancelled);
}

TEST(SendLoop, AfterBeginARepairStepsTheSessionAtOnce) {
  Status status;
  ASSERT_TRUE(FinishesAtOnceAfter(
      [](SendLoop::Registration& reg) { reg.OnRepair({RepairItem{3, 0, {1}}}); },  // opened without repair
      &status))
      << "the repair did not wake the session";
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
}

// A client on loopback: HELLOs sealed with the session's keys.
struct HelloClient {
  UdpSocket socket = std::move(UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"))).value();
  uint64_t next_pn = 0;
  void Hello(const UdpEndpoint& endpoint, const UdpEndpoint::Session& s, const Challenge& echo) {
    const std::vector<uint8_t> payload = HelloPayload(echo);
    const std::vector<uint8_t> sealed =
        SealPacket(PacketType::kHello, s.id(), next_pn++, s.keys().client_to_server, payload.data(), payload.size())
            .value();
    ASSERT_TRUE(socket.SendTo(endpoint.local(), sealed.data(), sealed.size()).ok());
  }
  // The challenge of the first HELLO_ACK within `ms`.
  bool Ack(const UdpEndpoint::Session& s, int ms, Challenge* challenge) {
    std::vector<IncomingDatagram> in(16);
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    while (std::chrono::steady_clock::now() < until) {
      auto n = socket.ReceiveBatch(&in, 2000, 10);
      if (!n.ok()) return false;
      for (size_t i = 0; i < n.value(); ++i) {
        OpenedPacket p;
        if (OpenPacket(in[i].data.data(), in[i].data.size(), Direction::kServerToClient, s.keys().server_to_client,
                       &p) != DropReason::kNone ||
            p.header.type != PacketType::kHelloAck) {
          continue;
        }
        auto c = ParseHelloAckPayload(p.payload);
        if (!c.ok()) continue;
        *challenge = c.value();
        return true;
      }
    }
    return false;
  }
};

// Waits until the endpoint has looked at `count` datagrams.
void WaitCounted(const UdpEndpoint& e, uint64_t count) {
  const auto until = std::chrono::steady_clock::now() + kDeadline;
  while (std::chrono::steady_clock::now() < until) {
    const UdpEndpointStats s = e.stats();
    if (s.received.accepted() + s.received.dropped() >= count) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ADD_FAILURE() << "the endpoint did not see " << count << " datagrams";
}

TEST(SendLoop, OnceAnAddressIsProvenHellosNoLongerWakeTheSession) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok()) << endpoint.status().ToString();
  auto registered = (*endpoint)->RegisterSession();
  ASSERT_TRUE(registered.ok());
  std::shared_ptr<UdpEndpoint::Session> udp = std::move(registered).value();
  const UdpEndpoint::Session& s = *udp;

  Fixture f;
  SessionSenderOptions options;
  options.transport = SessionTransport::kUdp;
  options.hello_timeout_us = 10000000;
  UdpEndpoint::Session* raw = udp.get();
  options.reserve_packet_numbers = [raw](uint64_t count) { return raw->ReservePacketNumbers(count); };
  SendLoop loop;
  RecordingStream stream;
  // The stream is full until the address is proven, so the refinement is
  // not begun on the stream before (sessions do not wait for the proof).
  stream.Hold(true);
  SendLoop::Registration reg =
      loop.Add(std::make_unique<SessionSender>(f.plan, f.artifact, -1, options, SteadyNowUs()), &stream, udp);
  reg.Begin();

  // The round trip proves the client's address; once the stream has room,
  // the refinement goes as UDP.
  HelloClient client;
  client.Hello(**endpoint, s, Challenge{});
  Challenge challenge{};
  ASSERT_TRUE(client.Ack(s, 2000, &challenge));
  client.Hello(**endpoint, s, challenge);
  WaitCounted(**endpoint, 2);
  ASSERT_TRUE(s.proven());
  stream.Hold(false);
  reg.OnWritten();
  const auto until = std::chrono::steady_clock::now() + kDeadline;
  // The END is recorded inside the step, the datagrams counted when the
  // outbox is flushed after it: wait for both.
  while (std::chrono::steady_clock::now() < until) {
    const std::vector<std::string> calls = stream.calls();
    if (!calls.empty() && calls.back() == "end" && (*endpoint)->stats().data_sent >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_EQ(stream.calls(), (std::vector<std::string>{"start", "control", "refinement_end", "end"}));
  EXPECT_EQ((*endpoint)->stats().data_sent, 3u) << "two data datagrams and the END, as UDP";

  // In the linger now (2 s): HELLOs, copies or retries, wake nothing.
  const size_t asked = stream.asked();
  for (int i = 0; i < 5; ++i) client.Hello(**endpoint, s, Challenge{});
  WaitCounted(**endpoint, 7);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(stream.asked(), asked) << "a HELLO after the proof stepped the session";

  reg.Cancel(Cancelled("the client went away"), "client went away");
  Status status;
  ASSERT_TRUE(stream.WaitFinished(kDeadline, &status));
  EXPECT_EQ(status.code(), StatusCode::kCancelled);
}

}  // namespace
}  // namespace meshstream
