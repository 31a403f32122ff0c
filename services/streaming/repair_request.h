// A client's RepairRequest on the server (docs/spec/streaming-protocol.md,
// "Sessions", step 5): the datagrams it names, checked against the session's
// plan. The protobuf message is translated to RepairItems by
// services/grpc/proto_convert.h; this is where its content is judged.
//
// Contract: safe on untrusted input (tests/fuzz/fuzz_service_repair.cc).
// A request names at most as many items as the plan has refinements (one
// per refinement is what a client needs); more is InvalidArgument naming
// the count and the limit, before any item is looked at, so that a request
// of a million empty items (within gRPC's message limit) costs nothing.
// Every item must be a primitive (its wire stream id) and refinement of this
// session and every ordinal one of that refinement's data datagrams;
// otherwise InvalidArgument naming the first item that does not fit.
// Repeats are sent once. The answer is bounded by the plan: at most every
// data datagram of the session once, whatever the request repeats.
// Thread safety: pure.
#ifndef MESHSTREAM_SERVICES_STREAMING_REPAIR_REQUEST_H_
#define MESHSTREAM_SERVICES_STREAMING_REPAIR_REQUEST_H_

#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "services/streaming/session_plan.h"

namespace meshstream {

struct RepairItem {
  uint32_t stream = 0;  // RepairItem.primitive: the wire stream id
  uint32_t refinement = 0;
  std::vector<uint32_t> datagrams;  // ordinals k of the refinement's data datagrams
};

// The byte ranges (in the artifact) of the datagrams `items` name, in the
// order they are first named.
StatusOr<std::vector<ByteRange>> RepairDatagrams(const SessionPlan& plan, const std::vector<RepairItem>& items);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_REPAIR_REQUEST_H_
