// TCP sockets on 127.0.0.1 for tests of what a client does when the server is
// not there or never answers: a port nothing listens on, and a listener whose
// connections the kernel completes but nobody accepts or answers.
#ifndef MESHSTREAM_TESTING_LOOPBACK_SOCKET_H_
#define MESHSTREAM_TESTING_LOOPBACK_SOCKET_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace meshstream::test_util {

// A socket bound to a free loopback port; with `listen`, listening (a backlog
// of 16) so that connections complete and then hear nothing. Closed on
// destruction. ok() is false when any step failed.
class LoopbackSocket {
 public:
  explicit LoopbackSocket(bool listen) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd_ < 0) return;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof a;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &length) != 0 || (listen && ::listen(fd_, 16) != 0)) {
      Close();
      return;
    }
    port_ = ntohs(a.sin_port);
  }
  ~LoopbackSocket() { Close(); }
  LoopbackSocket(const LoopbackSocket&) = delete;
  LoopbackSocket& operator=(const LoopbackSocket&) = delete;

  bool ok() const { return port_ != 0; }
  int port() const { return port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
  int port_ = 0;
};

// "127.0.0.1:PORT" of a port that was free a moment ago and that nothing
// listens on (bound, then closed); empty when no port could be had.
inline std::string UnusedLoopbackAddress() {
  LoopbackSocket s(false);
  return s.ok() ? s.address() : std::string();
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_LOOPBACK_SOCKET_H_
