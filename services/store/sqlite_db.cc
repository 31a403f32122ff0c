#include "services/store/sqlite_db.h"

#include <sqlite3.h>

#include <climits>

namespace meshstream {

namespace {

// The start of a statement's text, for messages.
std::string Head(const char* sql) {
  std::string s = sql != nullptr ? sql : "";
  return s.size() > 48 ? s.substr(0, 48) + "..." : s;
}

}  // namespace

Status SqlError(sqlite3* db, int rc, const std::string& what) {
  const std::string message = "sqlite: " + what + ": " + (db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  switch (rc & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Unavailable(message);
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return DataLoss(message);
    case SQLITE_FULL:
      return ResourceExhausted(message);
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_READONLY:
    case SQLITE_PERM:
      return IoError(message);
    default:
      return Internal(message);
  }
}

Status ExecSql(sqlite3* db, const char* sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &error);
  if (rc == SQLITE_OK) return Status::Ok();
  std::string message = error != nullptr ? error : sqlite3_errstr(rc);
  sqlite3_free(error);
  return SqlError(nullptr, rc, message);
}

Stmt::Stmt(sqlite3* db, const char* sql) : db_(db) {
  const int rc = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
  if (rc != SQLITE_OK) error_ = SqlError(db, rc, std::string("prepare '") + Head(sql) + "'");
}

Stmt::~Stmt() { sqlite3_finalize(stmt_); }

StatusOr<bool> Stmt::Step() {
  if (!error_.ok()) return error_;
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return SqlError(db_, rc, Head(sqlite3_sql(stmt_)));
}

Status Stmt::Run() {
  MS_ASSIGN_OR_RETURN(const bool row, Step());
  if (row) return Internal("sqlite: a statement returned a row unexpectedly");
  return Status::Ok();
}

int Stmt::Changes() const { return sqlite3_changes(db_); }

int64_t Stmt::Int(int col) const { return sqlite3_column_int64(stmt_, col); }

double Stmt::Real(int col) const { return sqlite3_column_double(stmt_, col); }

std::string Stmt::Text(int col) const {
  const unsigned char* text = sqlite3_column_text(stmt_, col);
  const int n = sqlite3_column_bytes(stmt_, col);
  return text == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(text), n);
}

void Stmt::Check(int rc) {
  if (rc != SQLITE_OK && error_.ok()) error_ = SqlError(db_, rc, "bind");
}

void Stmt::BindOne(int64_t v) { Check(sqlite3_bind_int64(stmt_, ++index_, v)); }

void Stmt::BindOne(double v) { Check(sqlite3_bind_double(stmt_, ++index_, v)); }

void Stmt::BindOne(const std::string& v) {
  if (v.size() > static_cast<size_t>(INT_MAX)) {
    if (error_.ok()) error_ = ResourceExhausted("sqlite: a text of " + std::to_string(v.size()) + " bytes");
    ++index_;
    return;
  }
  Check(sqlite3_bind_text(stmt_, ++index_, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
}

Txn::~Txn() {
  if (open_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

Status Txn::Begin() {
  MS_RETURN_IF_ERROR(ExecSql(db_, "BEGIN IMMEDIATE"));
  open_ = true;
  return Status::Ok();
}

Status Txn::Commit() {
  MS_RETURN_IF_ERROR(ExecSql(db_, "COMMIT"));
  open_ = false;
  return Status::Ok();
}

}  // namespace meshstream
