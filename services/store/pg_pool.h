// The connection layer of the shared store (services/store/pg_store.h): a
// pool of libpqxx connections and RunPg, which runs one transaction on a
// pooled connection, maps every exception to a Status and retries what is
// safe to retry.
//
// Retries: a lost connection is replaced once and the transaction run again
// (a transaction that did not commit is rolled back by the server, so this is
// safe); failing again is Unavailable, as is a commit whose outcome is
// unknown (never retried). Serialization failures and deadlocks are retried
// up to `conflict_attempts` times with a short random pause, then Aborted.
// A lock or statement timeout is Unavailable at once. Messages never contain
// the conninfo (libpq's messages name the host, never the password).
//
// Thread safety: PgPool and RunPg may be used from any thread at once; a
// leased connection is used by one thread.
#ifndef MESHSTREAM_SERVICES_STORE_PG_POOL_H_
#define MESHSTREAM_SERVICES_STORE_PG_POOL_H_

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <pqxx/connection>

#include "codec/core/status.h"

namespace meshstream {

class PgPool {
 public:
  PgPool(std::string conninfo, int max_connections, int64_t acquire_timeout_ms)
      : conninfo_(std::move(conninfo)), max_(max_connections), timeout_ms_(acquire_timeout_ms) {}

  // One pooled connection, given back to the pool when destroyed.
  class Lease {
   public:
    Lease(PgPool* pool, std::unique_ptr<pqxx::connection> connection)
        : pool_(pool), connection_(std::move(connection)) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), connection_(std::move(other.connection_)) {
      other.pool_ = nullptr;
    }
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (pool_ != nullptr) pool_->Release(std::move(connection_));
    }
    pqxx::connection& connection() { return *connection_; }
    bool open() const;
    // Closes the connection; the pool opens a fresh one when it needs it.
    void Discard() { connection_.reset(); }

   private:
    PgPool* pool_;
    std::unique_ptr<pqxx::connection> connection_;
  };

  // An idle connection when there is one, else a new one when the pool is
  // not full, else waits (Unavailable after acquire_timeout_ms). `fresh`:
  // always a new connection (closing an idle one to make room), for the
  // retry after a connection broke, since the other idle ones are likely
  // broken too (the server restarted).
  StatusOr<Lease> Acquire(bool fresh = false);

 private:
  StatusOr<std::unique_ptr<pqxx::connection>> Connect();
  void Release(std::unique_ptr<pqxx::connection> connection);

  const std::string conninfo_;
  const int max_;
  const int64_t timeout_ms_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::unique_ptr<pqxx::connection>> idle_;
  int open_ = 0;  // connections leased or idle
};

// What went wrong in one attempt of a transaction, and whether to retry.
struct PgFailure {
  Status error;
  bool lost_connection = false;  // retry once on a fresh connection
  bool conflict = false;         // serialization failure or deadlock: retry a few times
  bool outcome_known = true;     // false: the transaction may have committed
};
// Maps the exception being handled (std::current_exception()) of an attempt
// named `what`.
PgFailure ClassifyPgException(std::exception_ptr exception, const std::string& what, int conflict_attempts);
// libpq's messages span lines; a Status message is one line.
std::string OneLine(const char* what);
// The pause before retry `conflicts` of a conflicting transaction.
void PauseAfterConflict(int conflicts);

// Runs `fn(connection)` (which opens and commits its own transaction and
// returns a Status or StatusOr) on a pooled connection, as described above.
template <typename F>
auto RunPg(PgPool& pool, int conflict_attempts, const std::string& what, F&& fn)
    -> decltype(fn(std::declval<pqxx::connection&>())) {
  using Result = decltype(fn(std::declval<pqxx::connection&>()));
  bool reconnected = false;
  int conflicts = 0;
  for (;;) {
    StatusOr<PgPool::Lease> leased = pool.Acquire(/*fresh=*/reconnected);
    if (!leased.ok()) return Result(leased.status().WithContext(what));
    PgPool::Lease lease = std::move(leased).value();
    PgFailure failure;
    try {
      return fn(lease.connection());
    } catch (...) {
      failure = ClassifyPgException(std::current_exception(), what, conflict_attempts);
    }
    if (!lease.open()) {
      lease.Discard();
      // A statement failed because the session ended: the server rolled the
      // transaction back, so running it again on a new connection is safe.
      if (failure.outcome_known) failure.lost_connection = true;
    }
    if (failure.lost_connection && failure.outcome_known && !reconnected) {
      reconnected = true;
      continue;
    }
    if (failure.conflict && ++conflicts < conflict_attempts) {
      PauseAfterConflict(conflicts);
      continue;
    }
    return Result(failure.error);
  }
}

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_POOL_H_
