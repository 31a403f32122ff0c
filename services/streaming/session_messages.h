// The messages of a session's reliable channel: the ServerMessages built
// from the plan, the artifact and the sender's actions (session_sender.h),
// and the library's records of the client's messages. Every transport
// (queued_session_stream.h: the gRPC call, the WebSocket) and the in-process
// tests of the two session cores (tests/sessions/) use them, so all see the
// same translation.
// Thread safety: pure.
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_MESSAGES_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_MESSAGES_H_

#include <cstdint>
#include <string>
#include <vector>

#include "meshstream/v1/stream.pb.h"
#include "services/streaming/repair_request.h"
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

// A client's report: `missing` counts the ordinals (at most 2^20), and at
// most 16 RTT samples are kept (the rest of an untrusted report is ignored).
ClientReportInfo FromProto(const v1::ClientReport& report);

// A client's view, checked (CheckView): InvalidArgument naming the field
// ("view.camera_position: 3 numbers", "view.viewport_width ...").
StatusOr<View> FromProto(const v1::View& view);

// The LevelPlan of a plan whose refinements were ordered again
// (SessionSender::OnView): every primitive's level list.
v1::ServerMessage LevelPlanMessage(const SessionPlan& plan, uint32_t first_changed_level);
std::vector<RepairItem> FromProto(const v1::RepairRequest& request);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_MESSAGES_H_
