#include "store/sqlite_handle.h"

#include <cstring>

namespace twocam::store {

SqliteConnection::~SqliteConnection() { close(); }

Status SqliteConnection::open(const std::string& path, int flags) {
  close();
  path_ = path;
  const int rc = sqlite3_open_v2(path.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    Status st = error("cannot open");
    close();
    return st;
  }
  sqlite3_extended_result_codes(db_, 1);
  return Status::ok();
}

void SqliteConnection::close() {
  if (db_ != nullptr) {
    // Statements are finalized by their owners first (LandmarkStore declares them after the
    // connection); sqlite3_close_v2 defers the close if one is still alive.
    sqlite3_close_v2(db_);
    db_ = nullptr;
  }
}

Status SqliteConnection::exec(const std::string& sql) {
  char* message = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    const std::string text = message != nullptr ? message : sqlite3_errstr(rc);
    sqlite3_free(message);
    return Status::error(path_ + ": '" + sql + "' failed (sqlite: " + text + ")");
  }
  return Status::ok();
}

Status SqliteConnection::queryInt(const std::string& sql, int64_t* value) {
  SqliteStatement stmt;
  if (Status st = stmt.prepare(*this, sql); !st) return st;
  if (stmt.step() != SqliteStatement::StepResult::kRow) return stmt.error("no result");
  *value = stmt.columnInt(0);
  return Status::ok();
}

Status SqliteConnection::queryTextColumn(const std::string& sql, std::vector<std::string>* rows) {
  rows->clear();
  SqliteStatement stmt;
  if (Status st = stmt.prepare(*this, sql); !st) return st;
  for (;;) {
    const SqliteStatement::StepResult r = stmt.step();
    if (r == SqliteStatement::StepResult::kDone) return Status::ok();
    if (r == SqliteStatement::StepResult::kError) return stmt.error("failed");
    rows->push_back(stmt.columnText(0));
  }
}

Status SqliteConnection::error(const std::string& what) const {
  const char* message = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
  return Status::error(path_ + ": " + what + " (sqlite: " + message + ")");
}

SqliteStatement::~SqliteStatement() { sqlite3_finalize(stmt_); }

Status SqliteStatement::prepare(SqliteConnection& connection, const std::string& sql) {
  sqlite3_finalize(stmt_);
  stmt_ = nullptr;
  connection_ = &connection;
  sql_ = sql;
  if (sqlite3_prepare_v3(connection.db(),
                         sql.c_str(),
                         static_cast<int>(sql.size()),
                         SQLITE_PREPARE_PERSISTENT,
                         &stmt_,
                         nullptr) != SQLITE_OK) {
    return error("cannot prepare");
  }
  return Status::ok();
}

void SqliteStatement::bindInt(int index, int64_t value) { sqlite3_bind_int64(stmt_, index, value); }
void SqliteStatement::bindDouble(int index, double value) {
  sqlite3_bind_double(stmt_, index, value);
}
void SqliteStatement::bindText(int index, const std::string& value) {
  sqlite3_bind_text(stmt_, index, value.c_str(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
}
void SqliteStatement::bindBlob(int index, const void* data, size_t bytes) {
  // A zero-length blob stays a blob (not NULL): sqlite3_bind_zeroblob.
  if (bytes == 0) {
    sqlite3_bind_zeroblob(stmt_, index, 0);
  } else {
    sqlite3_bind_blob(stmt_, index, data, static_cast<int>(bytes), SQLITE_TRANSIENT);
  }
}
void SqliteStatement::bindNull(int index) { sqlite3_bind_null(stmt_, index); }

SqliteStatement::StepResult SqliteStatement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return StepResult::kRow;
  if (rc == SQLITE_DONE) return StepResult::kDone;
  return StepResult::kError;
}

Status SqliteStatement::run() {
  const StepResult r = step();
  Status st = r == StepResult::kError ? error("failed") : Status::ok();
  reset();
  return st;
}

void SqliteStatement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int64_t SqliteStatement::columnInt(int index) const { return sqlite3_column_int64(stmt_, index); }
double SqliteStatement::columnDouble(int index) const {
  return sqlite3_column_double(stmt_, index);
}
std::string SqliteStatement::columnText(int index) const {
  const unsigned char* text = sqlite3_column_text(stmt_, index);
  if (text == nullptr) return {};
  return {reinterpret_cast<const char*>(text),
          static_cast<size_t>(sqlite3_column_bytes(stmt_, index))};
}
bool SqliteStatement::columnIsNull(int index) const {
  return sqlite3_column_type(stmt_, index) == SQLITE_NULL;
}
std::vector<uint8_t> SqliteStatement::columnBlob(int index) const {
  const void* data = sqlite3_column_blob(stmt_, index);
  const int bytes = sqlite3_column_bytes(stmt_, index);
  std::vector<uint8_t> out(static_cast<size_t>(bytes));
  if (bytes > 0) std::memcpy(out.data(), data, out.size());
  return out;
}

Status SqliteStatement::error(const std::string& what) const {
  const char* message = connection_ != nullptr && connection_->db() != nullptr
                            ? sqlite3_errmsg(connection_->db())
                            : "no connection";
  const std::string path = connection_ != nullptr ? connection_->path() : std::string("?");
  return Status::error(path + ": " + what + " in '" + sql_ + "' (sqlite: " + message + ")");
}

}  // namespace twocam::store
