// The floors of the service benchmark: a trivial gRPC server in the same
// process as the meshstream server, on its own port, with a
// grpc::CallbackGenericService that
//   - /meshstream.bench.Echo/Echo: answers a unary call with its request
//     bytes (the floor of a unary call: the gRPC library over loopback TCP,
//     no protobuf, no store);
//   - /meshstream.bench.Echo/Sink: reads a client stream to its end and
//     answers with the number of bytes received as 8 little-endian bytes
//     (the floor of an Ingest: the same messages through the same transport,
//     nothing stored).
// Any other method is UNIMPLEMENTED.
//
// Thread safety: EchoServer is started and destroyed by one thread; its
// handlers run on gRPC's threads. SinkStream may be called from any thread.
#ifndef MESHSTREAM_BENCH_SERVICE_ECHO_H_
#define MESHSTREAM_BENCH_SERVICE_ECHO_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/byte_buffer.h>

#include "codec/core/status.h"

namespace meshstream::bench {

inline constexpr char kEchoMethod[] = "/meshstream.bench.Echo/Echo";
inline constexpr char kSinkMethod[] = "/meshstream.bench.Echo/Sink";

class EchoServer {
 public:
  // Listens on 127.0.0.1 at a free port.
  static StatusOr<std::unique_ptr<EchoServer>> Start();
  ~EchoServer();
  const std::string& address() const { return address_; }

 private:
  EchoServer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string address_;
};

// `bytes` as a one-slice ByteBuffer, and back.
grpc::ByteBuffer ToByteBuffer(const std::string& bytes);
std::string FromByteBuffer(const grpc::ByteBuffer& buffer);

// Streams `messages` to the Sink method of the echo server on `channel`,
// each Write waiting for the previous one (as a synchronous client writer
// does), then half-closes and reads the answer. *received: the byte count
// the server answered.
grpc::Status SinkStream(const std::shared_ptr<grpc::Channel>& channel, const std::vector<grpc::ByteBuffer>& messages,
                        uint64_t* received);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SERVICE_ECHO_H_
