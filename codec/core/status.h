// Typed errors for every module boundary of meshstream.
//
// Contract: codec/ and importers/ never throw; every fallible function returns
// Status or StatusOr<T>. A Status carries a code and a one-line message that
// names what is wrong and where ("accessors[3]: count 900 exceeds bufferView 2").
// Exactly one place per transport maps a Status to the outside world: the CLI
// maps codes to exit codes (cli/exit_codes.h), the gRPC services map them to
// grpc::Status and back (proto/rpc_status.h).
// Thread safety: plain values, safe to copy and move between threads.
#ifndef MESHSTREAM_CODEC_CORE_STATUS_H_
#define MESHSTREAM_CODEC_CORE_STATUS_H_

#include <cassert>
#include <optional>
#include <string>
#include <utility>

namespace meshstream {

enum class StatusCode {
  kOk = 0,
  kInvalidInput,       // the data is malformed, inconsistent or hostile
  kUnsupported,        // well-formed, but uses a feature meshstream refuses
  kNotFound,           // a file or an object that was named does not exist
  kIoError,            // reading or writing failed
  kResourceExhausted,  // a size cap was hit (input too large, count too big)
  kInvalidArgument,    // the caller passed a bad parameter (usage error)
  kInternal,           // a bug or a library failure we could not classify
  kDataLoss,           // stored bytes do not match their digest or recorded size
  kFailedPrecondition, // the object is not in the state the operation needs
  kUnauthenticated,    // no credentials, or credentials that are not valid
  kPermissionDenied,   // valid credentials that may not do this
  kUnavailable,        // a service or database cannot be reached now; retry later
  kAborted,            // lost a race (a job lease taken over); the caller stops
  kAlreadyExists,      // an object with this name exists and may not be replaced
  kCancelled,          // the caller (or the server, draining) stopped the operation
  kDeadlineExceeded,   // a deadline ran out before the operation finished
};

const char* StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message)
      : code_(code), message_(std::move(message)) {}

  static Status Ok() { return Status(); }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }

  // Returns a copy whose message is "<context>: <message>".
  Status WithContext(const std::string& context) const {
    if (ok()) return *this;
    return Status(code_, context + ": " + message_);
  }

  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidInput(std::string m) { return Status(StatusCode::kInvalidInput, std::move(m)); }
inline Status Unsupported(std::string m) { return Status(StatusCode::kUnsupported, std::move(m)); }
inline Status NotFound(std::string m) { return Status(StatusCode::kNotFound, std::move(m)); }
inline Status IoError(std::string m) { return Status(StatusCode::kIoError, std::move(m)); }
inline Status ResourceExhausted(std::string m) { return Status(StatusCode::kResourceExhausted, std::move(m)); }
inline Status InvalidArgument(std::string m) { return Status(StatusCode::kInvalidArgument, std::move(m)); }
inline Status Internal(std::string m) { return Status(StatusCode::kInternal, std::move(m)); }
inline Status DataLoss(std::string m) { return Status(StatusCode::kDataLoss, std::move(m)); }
inline Status FailedPrecondition(std::string m) { return Status(StatusCode::kFailedPrecondition, std::move(m)); }
inline Status Unauthenticated(std::string m) { return Status(StatusCode::kUnauthenticated, std::move(m)); }
inline Status PermissionDenied(std::string m) { return Status(StatusCode::kPermissionDenied, std::move(m)); }
inline Status Unavailable(std::string m) { return Status(StatusCode::kUnavailable, std::move(m)); }
inline Status Aborted(std::string m) { return Status(StatusCode::kAborted, std::move(m)); }
inline Status AlreadyExists(std::string m) { return Status(StatusCode::kAlreadyExists, std::move(m)); }
inline Status Cancelled(std::string m) { return Status(StatusCode::kCancelled, std::move(m)); }
inline Status DeadlineExceeded(std::string m) { return Status(StatusCode::kDeadlineExceeded, std::move(m)); }

// Either a value or a non-OK Status.
template <typename T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(const Status& status) : status_(status) {  // NOLINT: implicit by design
    assert(!status.ok() && "StatusOr built from an OK Status has no value");
    if (status_.ok()) status_ = Internal("StatusOr constructed from OK status without a value");
  }
  StatusOr(T value) : value_(std::move(value)) {}  // NOLINT: implicit by design

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }

  const T& value() const& { assert(ok()); return *value_; }
  T& value() & { assert(ok()); return *value_; }
  T&& value() && { assert(ok()); return std::move(*value_); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  Status status_;
  std::optional<T> value_;
};

}  // namespace meshstream

#define MS_STATUS_CONCAT_INNER_(a, b) a##b
#define MS_STATUS_CONCAT_(a, b) MS_STATUS_CONCAT_INNER_(a, b)

// Returns from the current function if `expr` (a Status) is not OK.
#define MS_RETURN_IF_ERROR(expr)                      \
  do {                                                \
    ::meshstream::Status ms_status_ = (expr);         \
    if (!ms_status_.ok()) return ms_status_;          \
  } while (false)

// `lhs = value of expr` (a StatusOr), or returns its error.
#define MS_ASSIGN_OR_RETURN(lhs, expr) \
  MS_ASSIGN_OR_RETURN_IMPL_(MS_STATUS_CONCAT_(ms_statusor_, __LINE__), lhs, expr)
#define MS_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                              \
  if (!tmp.ok()) return tmp.status();             \
  lhs = std::move(tmp).value()

#endif  // MESHSTREAM_CODEC_CORE_STATUS_H_
