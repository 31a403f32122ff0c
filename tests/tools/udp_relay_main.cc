// meshstream_udp_relay: the tests' seeded UDP relay (testing/udp_relay.h)
// as a program, for `make demo` and for trying a lossy link by hand:
//
//   meshstream_udp_relay --upstream HOST:PORT [--loss P] [--burst N]
//                        [--delay-ms D] [--jitter-ms J] [--duplicate P] [--seed S]
//
// prints "relay on HOST:PORT" (give it to `meshstream fetch --udp-via`) and
// forwards until SIGTERM or SIGINT, then prints its counters. The
// impairments apply both ways; --burst N makes the loss come in bursts of N
// datagrams on average (Gilbert-Elliott) instead of independently.
#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "testing/udp_relay.h"

namespace {

volatile sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

int Usage(const char* why) {
  std::fprintf(stderr,
               "meshstream_udp_relay: %s\n"
               "usage: meshstream_udp_relay --upstream HOST:PORT [--loss P] [--burst N] [--delay-ms D]\n"
               "                            [--jitter-ms J] [--duplicate P] [--seed S]\n",
               why);
  return 2;
}

bool Number(const char* text, double lo, double hi, double* out) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= lo && v <= hi)) return false;
  *out = v;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using meshstream::LinkModel;
  std::string upstream;
  double loss = 0, burst = 0, delay_ms = 0, jitter_ms = 0, duplicate = 0, seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) return Usage((flag + ": needs a value").c_str());
    const char* value = argv[++i];
    bool ok = true;
    if (flag == "--upstream") {
      upstream = value;
    } else if (flag == "--loss") {
      ok = Number(value, 0, 1, &loss);
    } else if (flag == "--burst") {
      ok = Number(value, 1, 1000, &burst);
    } else if (flag == "--delay-ms") {
      ok = Number(value, 0, 10000, &delay_ms);
    } else if (flag == "--jitter-ms") {
      ok = Number(value, 0, 10000, &jitter_ms);
    } else if (flag == "--duplicate") {
      ok = Number(value, 0, 1, &duplicate);
    } else if (flag == "--seed") {
      ok = Number(value, 0, 1e15, &seed);
    } else {
      return Usage(("unknown option " + flag).c_str());
    }
    if (!ok) return Usage((flag + ": not a number in range: " + value).c_str());
  }
  if (upstream.empty()) return Usage("--upstream is required");
  auto address = meshstream::SocketAddress::Parse(upstream);
  if (!address.ok()) return Usage(address.status().message().c_str());
  LinkModel imp = burst > 1 && loss > 0 ? LinkModel::Bursts(loss, burst, static_cast<uint64_t>(seed))
                                         : LinkModel::Loss(loss, static_cast<uint64_t>(seed));
  imp.delay_us = static_cast<uint64_t>(delay_ms * 1000);
  imp.jitter_us = static_cast<uint64_t>(jitter_ms * 1000);
  imp.duplicate = duplicate;
  meshstream::test_util::RelayOptions options;
  options.upstream = address.value();
  options.to_client = imp;
  options.to_server = imp;
  options.to_server.seed = imp.seed + 1000;
  auto relay = meshstream::test_util::UdpRelay::Start(options);
  if (!relay.ok()) {
    std::fprintf(stderr, "meshstream_udp_relay: %s\n", relay.status().ToString().c_str());
    return 1;
  }
  signal(SIGTERM, OnSignal);
  signal(SIGINT, OnSignal);
  std::printf("relay on %s\n", (*relay)->front().ToString().c_str());
  std::fflush(stdout);
  while (!g_stop) pause();
  (*relay)->Stop();
  const auto down = (*relay)->to_client(), up = (*relay)->to_server();
  std::fprintf(stderr, "meshstream_udp_relay: to clients %llu in, %llu dropped; to the server %llu in, %llu dropped\n",
               static_cast<unsigned long long>(down.in), static_cast<unsigned long long>(down.dropped),
               static_cast<unsigned long long>(up.in), static_cast<unsigned long long>(up.dropped));
  return 0;
}
