#include "proto/rpc_status.h"

namespace meshstream {

grpc::Status ToGrpcStatus(const Status& status) {
  grpc::StatusCode code = grpc::StatusCode::INTERNAL;
  switch (status.code()) {
    case StatusCode::kOk: return grpc::Status::OK;
    case StatusCode::kInvalidArgument:
    case StatusCode::kInvalidInput:
    case StatusCode::kUnsupported: code = grpc::StatusCode::INVALID_ARGUMENT; break;
    case StatusCode::kNotFound: code = grpc::StatusCode::NOT_FOUND; break;
    case StatusCode::kFailedPrecondition: code = grpc::StatusCode::FAILED_PRECONDITION; break;
    case StatusCode::kDataLoss: code = grpc::StatusCode::DATA_LOSS; break;
    case StatusCode::kResourceExhausted: code = grpc::StatusCode::RESOURCE_EXHAUSTED; break;
    case StatusCode::kUnauthenticated: code = grpc::StatusCode::UNAUTHENTICATED; break;
    case StatusCode::kPermissionDenied: code = grpc::StatusCode::PERMISSION_DENIED; break;
    case StatusCode::kUnavailable: code = grpc::StatusCode::UNAVAILABLE; break;
    case StatusCode::kAborted: code = grpc::StatusCode::ABORTED; break;
    case StatusCode::kAlreadyExists: code = grpc::StatusCode::ALREADY_EXISTS; break;
    case StatusCode::kCancelled: code = grpc::StatusCode::CANCELLED; break;
    case StatusCode::kDeadlineExceeded: code = grpc::StatusCode::DEADLINE_EXCEEDED; break;
    case StatusCode::kIoError:
    case StatusCode::kInternal: code = grpc::StatusCode::INTERNAL; break;
  }
  return grpc::Status(code, status.message());
}

Status FromGrpcStatus(const grpc::Status& status) {
  const std::string& m = status.error_message();
  const auto or_else = [&m](const char* what) { return m.empty() ? std::string(what) : m; };
  switch (status.error_code()) {
    case grpc::StatusCode::OK: return Status::Ok();
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE: return InvalidArgument(or_else("invalid argument"));
    case grpc::StatusCode::NOT_FOUND: return NotFound(or_else("not found"));
    case grpc::StatusCode::FAILED_PRECONDITION: return FailedPrecondition(or_else("failed precondition"));
    case grpc::StatusCode::DATA_LOSS: return DataLoss(or_else("data loss"));
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return ResourceExhausted(or_else("resource exhausted"));
    case grpc::StatusCode::UNAUTHENTICATED: return Unauthenticated(or_else("unauthenticated"));
    case grpc::StatusCode::PERMISSION_DENIED: return PermissionDenied(or_else("permission denied"));
    case grpc::StatusCode::UNAVAILABLE: return Unavailable(or_else("the server cannot be reached"));
    case grpc::StatusCode::ABORTED: return Aborted(or_else("aborted"));
    case grpc::StatusCode::ALREADY_EXISTS: return AlreadyExists(or_else("already exists"));
    case grpc::StatusCode::CANCELLED: return Cancelled(or_else("cancelled"));
    case grpc::StatusCode::DEADLINE_EXCEEDED: return DeadlineExceeded(or_else("deadline exceeded"));
    default: return Internal(or_else("internal error"));
  }
}

}  // namespace meshstream
