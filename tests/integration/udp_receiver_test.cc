// The SDK's UDP receiver (sdk/udp_receiver.h) on real loopback sockets: its
// arrival horizon (caught_up_us) never passes a datagram that sits unread in
// the socket. The session times stragglers out by that horizon, so a receiver
// thread kept off the CPU cannot turn datagrams that did arrive into losses.
#include "sdk/udp_receiver.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "net/packet_crypto.h"
#include "net/steady_clock.h"
#include "net/udp_socket.h"

namespace meshstream {
namespace {

TEST(UdpReceiver, TheHorizonStaysBeforeADatagramNotYetDelivered) {
  auto server = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  auto keys = NewSessionKeys();
  ASSERT_TRUE(keys.ok());
  constexpr uint64_t kSession = 77;

  std::mutex mutex;
  std::condition_variable changed;
  bool in_first = false, release = false;
  std::vector<uint64_t> delivered;
  auto receiver = sdk::UdpReceiver::Start(server->local(), kSession, keys.value(), [&](sdk::UdpPacket&& p) {
    std::unique_lock<std::mutex> lock(mutex);
    if (delivered.empty()) {
      // The first delivery stalls the thread, as a host busy elsewhere would.
      in_first = true;
      changed.notify_all();
      changed.wait(lock, [&] { return release; });
    }
    delivered.push_back(p.packet_number);
    changed.notify_all();
  });
  ASSERT_TRUE(receiver.ok()) << receiver.status().ToString();
  sdk::UdpReceiver& r = *receiver.value();
  auto to = SocketAddress::Parse("127.0.0.1:" + std::to_string(r.local().port()));
  ASSERT_TRUE(to.ok());

  auto send = [&](uint64_t packet_number) {
    const uint8_t payload[4] = {1, 2, 3, 4};
    auto sealed = SealPacket(PacketType::kData, kSession, packet_number, keys->server_to_client, payload, sizeof payload);
    ASSERT_TRUE(sealed.ok());
    ASSERT_TRUE(server->SendTo(to.value(), sealed->data(), sealed->size()).ok());
  };
  send(10);
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(5), [&] { return in_first; })) << "the first DATA arrives";
  }
  const uint64_t second_sent = SteadyNowUs();
  send(11);
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  // The second datagram has been in the socket for 120 ms, unread.
  EXPECT_LT(r.caught_up_us(), second_sent) << "the horizon passed a datagram the thread has not read";
  {
    std::lock_guard<std::mutex> lock(mutex);
    release = true;
    changed.notify_all();
  }
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(5), [&] { return delivered.size() == 2; }));
    EXPECT_EQ(delivered, (std::vector<uint64_t>{10, 11}));
  }
  // Once the socket is drained the horizon moves past it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (r.caught_up_us() <= second_sent && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_GT(r.caught_up_us(), second_sent);
}

}  // namespace
}  // namespace meshstream
