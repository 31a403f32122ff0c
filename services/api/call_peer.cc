#include "services/api/call_peer.h"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <cstdint>

#include "net/udp_socket.h"

namespace meshstream {

namespace {

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX escapes of a URI decoded; false on a malformed one.
bool PercentDecode(const std::string& in, std::string* out) {
  out->clear();
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] != '%') {
      out->push_back(in[i]);
      continue;
    }
    if (i + 2 >= in.size() || HexDigit(in[i + 1]) < 0 || HexDigit(in[i + 2]) < 0) return false;
    out->push_back(static_cast<char>(HexDigit(in[i + 1]) * 16 + HexDigit(in[i + 2])));
    i += 2;
  }
  return true;
}

}  // namespace

std::string PeerHost(const std::string& grpc_peer) {
  if (grpc_peer.rfind("ipv4:", 0) != 0 && grpc_peer.rfind("ipv6:", 0) != 0) return "";
  std::string decoded, host;
  uint16_t port = 0;
  if (!PercentDecode(grpc_peer.substr(5), &decoded) || !SplitHostPort(decoded, &host, &port).ok()) return "";
  // Numeric only (a peer is never a name), in inet_ntop's canonical form.
  unsigned char raw[sizeof(in6_addr)];
  char text[INET6_ADDRSTRLEN] = {0};
  const int family = host.find(':') == std::string::npos ? AF_INET : AF_INET6;
  if (inet_pton(family, host.c_str(), raw) != 1 || inet_ntop(family, raw, text, sizeof text) == nullptr) return "";
  return text;
}

}  // namespace meshstream
