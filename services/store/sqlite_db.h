// The SQLite layer of the embedded store (services/store/sqlite_store.h):
// errors as Status, prepared statements with bound parameters, and
// transactions. Nothing here knows the schema (sqlite_schema.h) or the rows
// (sqlite_store.cc).
//
// Contract: all SQL is fixed text; caller values only ever become bound
// parameters. Thread safety: none; the store guards its one connection with
// a mutex, and a Stmt or Txn lives inside one locked call.
#ifndef MESHSTREAM_SERVICES_STORE_SQLITE_DB_H_
#define MESHSTREAM_SERVICES_STORE_SQLITE_DB_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"

struct sqlite3;
struct sqlite3_stmt;

namespace meshstream {

// The Status of SQLite result code `rc`: BUSY and LOCKED are Unavailable,
// CORRUPT and NOTADB DataLoss, FULL ResourceExhausted, I/O and permission
// errors IoError, the rest Internal. The message is "sqlite: <what>: <why>".
Status SqlError(sqlite3* db, int rc, const std::string& what);

// Runs `sql` (one or more statements without parameters).
Status ExecSql(sqlite3* db, const char* sql);

// A prepared statement with parameters bound in order. Errors of prepare and
// bind are kept and returned by the first Step.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  template <typename... Args>
  Stmt& Bind(const Args&... args) {
    (BindOne(args), ...);
    return *this;
  }

  // true: a row is ready; false: the statement is done.
  StatusOr<bool> Step();
  // Runs a statement that returns no rows.
  Status Run();
  // Rows changed by the last statement of the connection.
  int Changes() const;

  int64_t Int(int col) const;
  double Real(int col) const;
  std::string Text(int col) const;

 private:
  void Check(int rc);
  void BindOne(int64_t v);
  void BindOne(uint64_t v) { BindOne(static_cast<int64_t>(v)); }  // the int64 with the same bits
  void BindOne(int32_t v) { BindOne(static_cast<int64_t>(v)); }
  void BindOne(bool v) { BindOne(static_cast<int64_t>(v ? 1 : 0)); }
  void BindOne(double v);
  void BindOne(const char*) = delete;  // would bind as a bool; pass a std::string
  void BindOne(const std::string& v);

  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int index_ = 0;
  Status error_;
};

// BEGIN IMMEDIATE ... COMMIT; rolled back when destroyed uncommitted.
class Txn {
 public:
  explicit Txn(sqlite3* db) : db_(db) {}
  ~Txn();
  Txn(const Txn&) = delete;
  Txn& operator=(const Txn&) = delete;
  Status Begin();
  Status Commit();

 private:
  sqlite3* db_;
  bool open_ = false;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_SQLITE_DB_H_
