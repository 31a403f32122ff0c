// proto/rpc_status.h: the one mapping between Status and grpc::Status, each
// way, pinned code by code. Every StatusCode goes to the wire and back, and
// every grpc::StatusCode comes in and goes back out; the only codes that do
// not come back as themselves are the ones the header names as folded.
#include <iterator>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "proto/rpc_status.h"

namespace meshstream {
namespace {

constexpr StatusCode kAllStatusCodes[] = {
    StatusCode::kOk,          StatusCode::kInvalidInput,      StatusCode::kUnsupported,
    StatusCode::kNotFound,    StatusCode::kIoError,           StatusCode::kResourceExhausted,
    StatusCode::kInvalidArgument, StatusCode::kInternal,      StatusCode::kDataLoss,
    StatusCode::kFailedPrecondition, StatusCode::kUnauthenticated, StatusCode::kPermissionDenied,
    StatusCode::kUnavailable, StatusCode::kAborted,           StatusCode::kAlreadyExists,
    StatusCode::kCancelled,   StatusCode::kDeadlineExceeded,
};

TEST(RpcStatus, EveryStatusCodeHasOneWireCodeAndComesBack) {
  // The enum's last value: a code added to status.h must be added here.
  static_assert(static_cast<int>(StatusCode::kDeadlineExceeded) + 1 == std::size(kAllStatusCodes));
  const std::map<StatusCode, grpc::StatusCode> wire = {
      {StatusCode::kOk, grpc::StatusCode::OK},
      {StatusCode::kInvalidInput, grpc::StatusCode::INVALID_ARGUMENT},
      {StatusCode::kUnsupported, grpc::StatusCode::INVALID_ARGUMENT},
      {StatusCode::kInvalidArgument, grpc::StatusCode::INVALID_ARGUMENT},
      {StatusCode::kNotFound, grpc::StatusCode::NOT_FOUND},
      {StatusCode::kIoError, grpc::StatusCode::INTERNAL},
      {StatusCode::kInternal, grpc::StatusCode::INTERNAL},
      {StatusCode::kResourceExhausted, grpc::StatusCode::RESOURCE_EXHAUSTED},
      {StatusCode::kDataLoss, grpc::StatusCode::DATA_LOSS},
      {StatusCode::kFailedPrecondition, grpc::StatusCode::FAILED_PRECONDITION},
      {StatusCode::kUnauthenticated, grpc::StatusCode::UNAUTHENTICATED},
      {StatusCode::kPermissionDenied, grpc::StatusCode::PERMISSION_DENIED},
      {StatusCode::kUnavailable, grpc::StatusCode::UNAVAILABLE},
      {StatusCode::kAborted, grpc::StatusCode::ABORTED},
      {StatusCode::kAlreadyExists, grpc::StatusCode::ALREADY_EXISTS},
      {StatusCode::kCancelled, grpc::StatusCode::CANCELLED},
      {StatusCode::kDeadlineExceeded, grpc::StatusCode::DEADLINE_EXCEEDED},
  };
  // The three the wire has no word for.
  const std::map<StatusCode, StatusCode> folded = {
      {StatusCode::kInvalidInput, StatusCode::kInvalidArgument},
      {StatusCode::kUnsupported, StatusCode::kInvalidArgument},
      {StatusCode::kIoError, StatusCode::kInternal},
  };
  for (const StatusCode code : kAllStatusCodes) {
    SCOPED_TRACE(StatusCodeName(code));
    const Status status(code, code == StatusCode::kOk ? "" : "what went wrong");
    const grpc::Status out = ToGrpcStatus(status);
    EXPECT_EQ(out.error_code(), wire.at(code));
    EXPECT_EQ(out.error_message(), status.message());
    const Status back = FromGrpcStatus(out);
    const auto f = folded.find(code);
    EXPECT_EQ(back.code(), f == folded.end() ? code : f->second);
    EXPECT_EQ(back.message(), status.message());
  }
}

TEST(RpcStatus, EveryGrpcCodeReadsAsOneStatusCodeAndGoesBackOut) {
  // The three gRPC codes meshstream never sends read as their nearest code.
  const std::map<grpc::StatusCode, grpc::StatusCode> folded = {
      {grpc::StatusCode::OUT_OF_RANGE, grpc::StatusCode::INVALID_ARGUMENT},
      {grpc::StatusCode::UNKNOWN, grpc::StatusCode::INTERNAL},
      {grpc::StatusCode::UNIMPLEMENTED, grpc::StatusCode::INTERNAL},
  };
  for (int c = grpc::StatusCode::OK; c <= grpc::StatusCode::UNAUTHENTICATED; ++c) {
    const auto code = static_cast<grpc::StatusCode>(c);
    SCOPED_TRACE(c);
    const grpc::Status in(code, code == grpc::StatusCode::OK ? "" : "the server's words");
    const Status read = FromGrpcStatus(in);
    EXPECT_EQ(read.ok(), code == grpc::StatusCode::OK);
    const grpc::Status out = ToGrpcStatus(read);
    const auto f = folded.find(code);
    EXPECT_EQ(out.error_code(), f == folded.end() ? code : f->second);
    EXPECT_EQ(out.error_message(), in.error_message());
  }
  EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc::StatusCode::CANCELLED, "x")).code(), StatusCode::kCancelled);
  EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "x")).code(),
            StatusCode::kDeadlineExceeded);
}

TEST(RpcStatus, AClientSideFailureWithoutAMessageGetsOne) {
  EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "")).message(), "deadline exceeded");
  EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc::StatusCode::UNAVAILABLE, "")).message(), "the server cannot be reached");
  EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc::StatusCode::CANCELLED, "")).message(), "cancelled");
}

}  // namespace
}  // namespace meshstream
