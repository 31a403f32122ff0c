#include "services/store/pg_pool.h"

#include <sodium.h>

#include <chrono>
#include <new>
#include <thread>

#include <pqxx/pqxx>

namespace meshstream {

std::string OneLine(const char* what) {
  std::string s;
  for (const char* p = what; *p != '\0'; ++p) {
    const char c = (*p == '\n' || *p == '\t' || *p == '\r') ? ' ' : *p;
    if (c == ' ' && (s.empty() || s.back() == ' ')) continue;
    s += c;
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

bool PgPool::Lease::open() const { return connection_ != nullptr && connection_->is_open(); }

StatusOr<PgPool::Lease> PgPool::Acquire(bool fresh) {
  std::unique_ptr<pqxx::connection> stale;  // closed after the lock is released
  std::unique_lock<std::mutex> lock(mu_);
  const bool ready = cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms_),
                                  [&] { return !idle_.empty() || open_ < max_; });
  if (!ready) {
    return Unavailable("all " + std::to_string(max_) + " PostgreSQL connections stayed busy for " +
                       std::to_string(timeout_ms_) + " ms");
  }
  if (!idle_.empty()) {
    std::unique_ptr<pqxx::connection> connection = std::move(idle_.back());
    idle_.pop_back();
    if (!fresh) return Lease(this, std::move(connection));
    stale = std::move(connection);
    --open_;  // its slot is ours
  }
  ++open_;
  lock.unlock();
  StatusOr<std::unique_ptr<pqxx::connection>> connection = Connect();
  if (!connection.ok()) {
    lock.lock();
    --open_;
    cv_.notify_one();
    return connection.status();
  }
  return Lease(this, std::move(connection).value());
}

StatusOr<std::unique_ptr<pqxx::connection>> PgPool::Connect() {
  try {
    auto connection = std::make_unique<pqxx::connection>(conninfo_);
    // The pool replaces a broken connection itself; libpqxx 6 would
    // otherwise reconnect behind our back on the next statement.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
    connection->inhibit_reactivation(true);
#pragma GCC diagnostic pop
    return connection;
  } catch (const pqxx::broken_connection& e) {
    // libpq's message names the host and the reason, never the password.
    return Unavailable("cannot connect to PostgreSQL: " + OneLine(e.what()));
  } catch (const std::exception& e) {
    return Unavailable("cannot connect to PostgreSQL: " + OneLine(e.what()));
  }
}

void PgPool::Release(std::unique_ptr<pqxx::connection> connection) {
  std::lock_guard<std::mutex> lock(mu_);
  if (connection != nullptr && connection->is_open()) {
    idle_.push_back(std::move(connection));
  } else {
    --open_;  // a broken or discarded connection frees its slot
  }
  cv_.notify_one();
}

PgFailure ClassifyPgException(std::exception_ptr exception, const std::string& what, int conflict_attempts) {
  PgFailure f;
  try {
    std::rethrow_exception(exception);
  } catch (const pqxx::in_doubt_error& e) {
    f.outcome_known = false;
    f.error = Unavailable(what + ": the connection to PostgreSQL broke while committing; the outcome is unknown: " +
                          OneLine(e.what()));
  } catch (const pqxx::statement_completion_unknown& e) {
    f.outcome_known = false;
    f.error = Unavailable(what + ": PostgreSQL did not say whether the statement completed: " + OneLine(e.what()));
  } catch (const pqxx::broken_connection& e) {
    f.lost_connection = true;
    f.error = Unavailable(what + ": lost the connection to PostgreSQL: " + OneLine(e.what()));
  } catch (const pqxx::transaction_rollback& e) {  // serialization failure, deadlock
    f.conflict = true;
    f.error = Aborted(what + ": gave up after " + std::to_string(conflict_attempts) +
                      " attempts that conflicted with other transactions: " + OneLine(e.what()));
  } catch (const pqxx::unique_violation& e) {
    f.error = AlreadyExists(what + ": " + OneLine(e.what()));
  } catch (const pqxx::foreign_key_violation& e) {
    f.error = FailedPrecondition(what + ": " + OneLine(e.what()));
  } catch (const pqxx::integrity_constraint_violation& e) {
    f.error = InvalidArgument(what + ": " + OneLine(e.what()));
  } catch (const pqxx::data_exception& e) {
    f.error = InvalidArgument(what + ": " + OneLine(e.what()));
  } catch (const pqxx::insufficient_resources& e) {
    f.error = Unavailable(what + ": PostgreSQL is out of resources: " + OneLine(e.what()));
  } catch (const pqxx::sql_error& e) {
    const std::string state = e.sqlstate();
    const std::string cls = state.substr(0, 2);
    if (cls == "08" || state.rfind("57P", 0) == 0) {  // connection exception; shutdown, terminated session
      f.lost_connection = true;
      f.error = Unavailable(what + ": PostgreSQL closed the session: " + OneLine(e.what()));
    } else if (state == "57014" || state == "55P03") {  // statement_timeout, lock_timeout: not retried here
      f.error = Unavailable(what + ": PostgreSQL cancelled the statement: " + OneLine(e.what()));
    } else if (cls == "40") {
      f.conflict = true;
      f.error = Aborted(what + ": gave up after " + std::to_string(conflict_attempts) +
                        " conflicting attempts: " + OneLine(e.what()));
    } else if (cls == "53") {
      f.error = Unavailable(what + ": PostgreSQL is out of resources: " + OneLine(e.what()));
    } else {
      f.error = Internal(what + ": " + OneLine(e.what()) + " (SQLSTATE " + state + ")");
    }
  } catch (const std::bad_alloc&) {
    f.error = ResourceExhausted(what + ": out of memory");
  } catch (const std::exception& e) {
    f.error = Internal(what + ": " + OneLine(e.what()));
  } catch (...) {
    f.error = Internal(what + ": an unknown exception");
  }
  return f;
}

void PauseAfterConflict(int conflicts) {
  std::this_thread::sleep_for(std::chrono::milliseconds(5 * conflicts + static_cast<int>(randombytes_uniform(10))));
}

}  // namespace meshstream
