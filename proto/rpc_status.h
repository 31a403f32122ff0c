// The one mapping between a meshstream Status and a grpc::Status, each way.
// Servers (services/api) return ToGrpcStatus(...) of what the library said;
// clients (sdk/, and through it cli/) read a finished call with
// FromGrpcStatus. Nothing else converts between the two.
//
//   Status                               grpc::StatusCode
//   kOk                                  OK
//   kInvalidArgument, kInvalidInput,     INVALID_ARGUMENT (OUT_OF_RANGE reads back
//     kUnsupported                         as kInvalidArgument)
//   kNotFound                            NOT_FOUND
//   kFailedPrecondition                  FAILED_PRECONDITION
//   kDataLoss                            DATA_LOSS
//   kResourceExhausted                   RESOURCE_EXHAUSTED
//   kUnauthenticated                     UNAUTHENTICATED
//   kPermissionDenied                    PERMISSION_DENIED
//   kUnavailable                         UNAVAILABLE
//   kAborted                             ABORTED
//   kAlreadyExists                       ALREADY_EXISTS
//   kCancelled                           CANCELLED
//   kDeadlineExceeded                    DEADLINE_EXCEEDED
//   kIoError, kInternal                  INTERNAL (UNKNOWN, UNIMPLEMENTED read back
//                                          as kInternal)
//
// So a round trip keeps every code but the three the wire has no word for
// (kInvalidInput and kUnsupported come back as kInvalidArgument, kIoError as
// kInternal), and the three gRPC codes meshstream never sends (OUT_OF_RANGE,
// UNKNOWN, UNIMPLEMENTED). Messages are kept as they are both ways; a
// client-side status with no message (a transport failure, a deadline) gets
// one that names what happened ("deadline exceeded").
// (docs/spec/api.md, "Errors"; tests/services/rpc_status_test.cc pins the table.)
//
// Thread safety: pure functions.
#ifndef MESHSTREAM_PROTO_RPC_STATUS_H_
#define MESHSTREAM_PROTO_RPC_STATUS_H_

#include <grpcpp/support/status.h>

#include "codec/core/status.h"

namespace meshstream {

grpc::Status ToGrpcStatus(const Status& status);
Status FromGrpcStatus(const grpc::Status& status);

}  // namespace meshstream

#endif  // MESHSTREAM_PROTO_RPC_STATUS_H_
