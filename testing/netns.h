// A network namespace joined to the host by a veth pair, for tests and
// benchmarks that need the kernel to lose, shape or delay real packets
// (docs/spec/streaming-protocol.md, "Testing"): the host side is 10.77.X.1/24,
// the namespace side 10.77.X.2/24 (X from the pid), and commands run inside
// with `ip netns exec`. Loss is an nftables rule in the namespace
// (`numgen random mod 100 < P drop` on its input, UDP only or every
// protocol), a rate limit is tc tbf on the namespace's veth (its egress,
// the client's uploads) and on the host's veth (the downloads).
//
// Create returns Unavailable with the system's words when the kernel or the
// tools refuse (not root, no CAP_NET_ADMIN, no netns, no nft): callers skip
// with exactly that message. Everything is removed by the destructor; Create
// first removes what a crashed run left (names mstest-*, mst<N>h/n).
// Thread safety: one owner.
#ifndef MESHSTREAM_TESTING_NETNS_H_
#define MESHSTREAM_TESTING_NETNS_H_

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include "codec/core/status.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

class NetNs {
 public:
  static StatusOr<std::unique_ptr<NetNs>> Create() {
    RemoveStale();
    std::unique_ptr<NetNs> n(new NetNs());
    const int id = static_cast<int>(getpid() % 200) + 20;
    n->name_ = "mstest-" + std::to_string(getpid());
    n->host_if_ = "mst" + std::to_string(getpid() % 100000) + "h";
    n->ns_if_ = "mst" + std::to_string(getpid() % 100000) + "n";
    n->host_ip_ = "10.77." + std::to_string(id) + ".1";
    n->ns_ip_ = "10.77." + std::to_string(id) + ".2";
    const std::string steps[] = {
        "ip netns add " + n->name_,
        "ip link add " + n->host_if_ + " type veth peer name " + n->ns_if_,
        "ip link set " + n->ns_if_ + " netns " + n->name_,
        "ip addr add " + n->host_ip_ + "/24 dev " + n->host_if_,
        "ip link set " + n->host_if_ + " up",
        "ip netns exec " + n->name_ + " ip addr add " + n->ns_ip_ + "/24 dev " + n->ns_if_,
        "ip netns exec " + n->name_ + " ip link set " + n->ns_if_ + " up",
        "ip netns exec " + n->name_ + " ip link set lo up",
        "ip netns exec " + n->name_ + " nft add table inet mstest",
        "ip netns exec " + n->name_ + " nft add chain inet mstest input '{ type filter hook input priority 0; }'",
    };
    for (const std::string& step : steps) {
      const CommandResult r = RunCommand(step + " 2>&1");
      if (r.exit_code != 0) {
        return Unavailable("network namespaces are not available here (" + step + ": " + Trim(r.out + r.err) + ")");
      }
    }
    n->made_ = true;
    return n;
  }

  ~NetNs() {
    if (!made_) return;
    RunCommand("ip link del " + host_if_ + " 2>/dev/null");
    RunCommand("ip netns del " + name_ + " 2>/dev/null");
  }

  const std::string& name() const { return name_; }
  const std::string& host_ip() const { return host_ip_; }  // the server side
  const std::string& ns_ip() const { return ns_ip_; }      // the client side
  // `command` prefixed to run inside the namespace.
  std::string Inside(const std::string& command) const { return "ip netns exec " + name_ + " " + command; }

  // Drops `percent` % of the packets the namespace receives (udp_only: of
  // UDP only); 0 removes the rule.
  Status SetLoss(int percent, bool udp_only) {
    Status s = Run(Inside("nft flush chain inet mstest input"));
    if (!s.ok() || percent <= 0) return s;
    const std::string match = udp_only ? "meta l4proto udp " : "";
    if (percent >= 100) return Run(Inside("nft add rule inet mstest input " + match + "drop"));
    return Run(Inside("nft add rule inet mstest input " + match + "numgen random mod 100 '<' " +
                      std::to_string(percent) + " drop"));
  }
  // tbf on both veth ends (each shapes what leaves it); 0 removes it.
  Status SetRate(double mbit) {
    // Removing a qdisc that is not there fails: ignored.
    (void)Run("tc qdisc del dev " + host_if_ + " root");
    (void)Run(Inside("tc qdisc del dev " + ns_if_ + " root"));
    if (mbit <= 0) return Status::Ok();
    char rate[64];
    std::snprintf(rate, sizeof rate, "%.3fmbit", mbit);
    const std::string qdisc = std::string(" root tbf rate ") + rate + " burst 32kbit latency 100ms";
    Status s = Run("tc qdisc add dev " + host_if_ + qdisc);
    if (!s.ok()) return s;
    return Run(Inside("tc qdisc add dev " + ns_if_ + qdisc));
  }

 private:
  NetNs() = default;
  static std::string Trim(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return s;
  }
  static Status Run(const std::string& command) {
    const CommandResult r = RunCommand(command + " 2>&1");
    if (r.exit_code != 0) return Internal(command + ": " + Trim(r.out + r.err));
    return Status::Ok();
  }
  // What crashed runs left: namespaces mstest-* whose pid is gone, and their veths.
  static void RemoveStale() {
    const CommandResult list = RunCommand("ip netns list 2>/dev/null");
    size_t start = 0;
    while (start < list.out.size()) {
      size_t end = list.out.find('\n', start);
      if (end == std::string::npos) end = list.out.size();
      const std::string line = list.out.substr(start, end - start);
      start = end + 1;
      if (line.rfind("mstest-", 0) != 0) continue;
      const std::string name = line.substr(0, line.find(' '));
      const std::string pid = name.substr(7);
      if (pid.find_first_not_of("0123456789") != std::string::npos || pid.empty()) continue;
      if (access(("/proc/" + pid).c_str(), F_OK) == 0) continue;  // its test still runs
      RunCommand("ip link del mst" + std::to_string(std::stoul(pid) % 100000) + "h 2>/dev/null");
      RunCommand("ip netns del " + name + " 2>/dev/null");
    }
  }

  std::string name_, host_if_, ns_if_, host_ip_, ns_ip_;
  bool made_ = false;
};

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_NETNS_H_
