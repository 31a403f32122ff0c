// The ServerMessages of a session's reliable channel, built from the plan,
// the artifact and the sender's actions (services/streaming/session_sender.h).
// StreamService (stream_service.cc) queues them on the gRPC call; the
// in-process tests of the two session cores (tests/sessions/) feed them to
// the client's core, so both see the same translation.
// Thread safety: pure.
#ifndef MESHSTREAM_SERVICES_API_SERVER_MESSAGES_H_
#define MESHSTREAM_SERVICES_API_SERVER_MESSAGES_H_

#include <cstdint>
#include <string>
#include <vector>

#include "meshstream/v1/stream.pb.h"
#include "services/streaming/session_plan.h"
#include "services/streaming/session_sender.h"

namespace meshstream {

v1::Transport ToProto(SessionTransport t);

// The SessionStart's transport, datagram size and per primitive its header,
// base mesh and refinements; the caller adds the session id, the asset, the
// scene and the UDP endpoint and keys.
v1::ServerMessage SessionStartMessage(const SessionPlan& plan, const std::vector<uint8_t>& artifact,
                                      SessionTransport transport);
v1::ServerMessage TransportChangeMessage(SessionTransport transport, const std::string& reason);
// The ControlBlock of a kControl action.
v1::ServerMessage ControlMessage(const std::vector<uint8_t>& artifact, const SenderAction& control);
v1::ServerMessage DatagramMessage(const uint8_t* data, size_t size);
v1::ServerMessage RefinementEndMessage(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                                       uint32_t parity_datagrams = 0);
v1::ServerMessage EndMessage(const std::string& reason);
v1::ServerMessage RepairEndMessage(uint32_t datagrams, uint64_t bytes);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_SERVER_MESSAGES_H_
