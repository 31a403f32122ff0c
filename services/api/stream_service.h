// meshstream.v1.StreamService: the reliable half of a streaming session
// (docs/streaming-protocol.md), a thin translation of the session plan
// (services/streaming/session_plan.h) into protobuf messages.
//
// Today every session uses TRANSPORT_GRPC: the datagrams travel on this
// stream as StreamDatagram messages (the fallback of the protocol); the UDP
// transport comes with the rest of the streaming issue, and a client that
// asks for it is told TRANSPORT_GRPC in SessionStart.
//
// Thread safety: gRPC calls Open from its threads at once; the class holds
// only pointers to thread-safe parts.
#ifndef MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
#define MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_

#include <atomic>
#include <cstdint>

#include "meshstream/v1/stream.grpc.pb.h"
#include "services/api/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/store/store.h"

namespace meshstream {

struct StreamServiceOptions {
  int max_sessions = 256;                         // concurrent sessions; then RESOURCE_EXHAUSTED
  uint64_t max_artifact_bytes = uint64_t{4} << 30;
};

class StreamServiceImpl final : public v1::StreamService::Service {
 public:
  StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                    const std::atomic<bool>* draining);

  grpc::Status Open(grpc::ServerContext* context,
                    grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream) override;

 private:
  Store* store_;
  const Authenticator* auth_;
  StreamServiceOptions options_;
  const std::atomic<bool>* draining_;
  CallLimit sessions_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
