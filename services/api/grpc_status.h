// The one place where a meshstream Status becomes a grpc::Status (and, for
// clients, back). Every service method returns ToGrpcStatus(...) of what the
// library said; nothing else builds a grpc::Status from a Status.
//
//   kInvalidArgument, kInvalidInput, kUnsupported -> INVALID_ARGUMENT
//   kNotFound -> NOT_FOUND                kFailedPrecondition -> FAILED_PRECONDITION
//   kDataLoss -> DATA_LOSS                kResourceExhausted -> RESOURCE_EXHAUSTED
//   kUnauthenticated -> UNAUTHENTICATED   kPermissionDenied -> PERMISSION_DENIED
//   kUnavailable -> UNAVAILABLE           kAborted -> ABORTED
//   kAlreadyExists -> ALREADY_EXISTS      kIoError, kInternal -> INTERNAL
// (docs/api.md, "Errors").
#ifndef MESHSTREAM_SERVICES_API_GRPC_STATUS_H_
#define MESHSTREAM_SERVICES_API_GRPC_STATUS_H_

#include <grpcpp/support/status.h>

#include "codec/core/status.h"

namespace meshstream {

grpc::Status ToGrpcStatus(const Status& status);
// The client side: what a call's grpc::Status means as a Status (the message
// is kept; transport failures are kUnavailable, a deadline kUnavailable too).
Status FromGrpcStatus(const grpc::Status& status);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_GRPC_STATUS_H_
