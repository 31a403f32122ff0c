// CatchExceptions: the one place where an exception becomes a Status.
#include "importers/exception_boundary.h"

#include <new>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

TEST(ExceptionBoundary, PassesResultsThrough) {
  EXPECT_TRUE(CatchExceptions("w", [] { return Status::Ok(); }).ok());
  const StatusOr<int> v = CatchExceptions("w", []() -> StatusOr<int> { return 7; });
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(v.value(), 7);
  const Status e = CatchExceptions("w", [] { return InvalidInput("bad"); });
  EXPECT_EQ(e.code(), StatusCode::kInvalidInput);
  EXPECT_EQ(e.message(), "bad");
}

TEST(ExceptionBoundary, EveryExceptionBecomesAStatusNamingWhere) {
  const StatusOr<int> oom = CatchExceptions("model.obj", []() -> StatusOr<int> { throw std::bad_alloc(); });
  EXPECT_EQ(oom.status().code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(oom.status().message(), "model.obj: out of memory");
  const Status length = CatchExceptions("out.glb", []() -> Status {
    std::vector<int> v;
    v.reserve(v.max_size() + 1);  // std::length_error
    return Status::Ok();
  });
  EXPECT_EQ(length.code(), StatusCode::kInternal);
  EXPECT_EQ(length.message().rfind("out.glb: ", 0), 0u) << length.message();
  const Status runtime = CatchExceptions("x", []() -> Status { throw std::runtime_error("boom"); });
  EXPECT_EQ(runtime.message(), "x: boom");
  const Status other = CatchExceptions("x", []() -> Status { throw 42; });
  EXPECT_EQ(other.code(), StatusCode::kInternal);
  EXPECT_EQ(other.message(), "x: unknown exception");
}

}  // namespace
}  // namespace meshstream
