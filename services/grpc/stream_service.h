// meshstream.v1.StreamService: the reliable half of a streaming session
// (docs/spec/streaming-protocol.md, "Sessions") on gRPC's callback API. A thin
// transport on the session host (services/streaming/session_host.h), which
// admits, prepares, registers and drives every session: each Open is a
// grpc::ServerBidiReactor (StreamServiceImpl::Call, a QueuedSessionStream)
// that authenticates the call from its metadata, reads the client's
// messages and writes the host's ServerMessages one at a time. The server
// logs "session ASSET@VERSION opened (udp|grpc)" and one line at its end.
//
// Thread safety: gRPC calls Open from its threads at once; the host is
// thread-safe.
#ifndef MESHSTREAM_SERVICES_GRPC_STREAM_SERVICE_H_
#define MESHSTREAM_SERVICES_GRPC_STREAM_SERVICE_H_

#include "meshstream/v1/stream.grpc.pb.h"
#include "services/streaming/session_host.h"

namespace meshstream {

class StreamServiceImpl final : public v1::StreamService::CallbackService {
 public:
  // `host` outlives the service and every call it took.
  explicit StreamServiceImpl(SessionHost* host) : host_(host) {}

  grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>* Open(grpc::CallbackServerContext* context) override;

 private:
  class Call;
  SessionHost* host_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_GRPC_STREAM_SERVICE_H_
