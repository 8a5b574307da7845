#pragma once
/// A small RAII layer over the sqlite3 C API for the landmark store: one connection, prepared
/// statements that reset themselves, errors as Status naming the database path. Internal to
/// src/store (the public headers do not include it).

#include <sqlite3.h>

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace twocam::store {

/// An open sqlite3 connection; closed on destruction. Not copyable.
class SqliteConnection {
 public:
  SqliteConnection() = default;
  ~SqliteConnection();
  SqliteConnection(const SqliteConnection&) = delete;
  SqliteConnection& operator=(const SqliteConnection&) = delete;

  /// Opens `path` with sqlite3_open_v2 flags (SQLITE_OPEN_READONLY, or READWRITE [| CREATE]).
  /// Extended result codes are enabled. The error names the path.
  [[nodiscard]] Status open(const std::string& path, int flags);
  void close();

  /// Runs one or more statements without results. The error names the path and the SQL.
  [[nodiscard]] Status exec(const std::string& sql);
  /// Runs a statement whose first row's first column is an integer (a PRAGMA, a COUNT).
  [[nodiscard]] Status queryInt(const std::string& sql, int64_t* value);
  /// The first column of every row as text (PRAGMA integrity_check).
  [[nodiscard]] Status queryTextColumn(const std::string& sql, std::vector<std::string>* rows);

  /// "PATH: MESSAGE (sqlite: ERRMSG)".
  [[nodiscard]] Status error(const std::string& what) const;

  [[nodiscard]] sqlite3* db() const { return db_; }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

/// A prepared statement; finalized on destruction. bind*() take 1-based parameter indices.
/// step() returns kRow, kDone or kError; reset() readies it for the next binding.
class SqliteStatement {
 public:
  enum class StepResult { kRow, kDone, kError };

  SqliteStatement() = default;
  ~SqliteStatement();
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;

  [[nodiscard]] Status prepare(SqliteConnection& connection, const std::string& sql);
  [[nodiscard]] bool prepared() const { return stmt_ != nullptr; }

  void bindInt(int index, int64_t value);
  void bindDouble(int index, double value);
  void bindText(int index, const std::string& value);
  void bindBlob(int index, const void* data, size_t bytes);
  void bindNull(int index);

  StepResult step();
  /// Steps a statement that returns no rows; the error names the path and the SQL.
  [[nodiscard]] Status run();
  void reset();

  [[nodiscard]] int64_t columnInt(int index) const;
  [[nodiscard]] double columnDouble(int index) const;
  [[nodiscard]] std::string columnText(int index) const;
  [[nodiscard]] bool columnIsNull(int index) const;
  /// The BLOB column's bytes (empty for NULL or a zero-length blob).
  [[nodiscard]] std::vector<uint8_t> columnBlob(int index) const;

  /// "PATH: MESSAGE in 'SQL' (sqlite: ERRMSG)".
  [[nodiscard]] Status error(const std::string& what) const;

 private:
  sqlite3_stmt* stmt_ = nullptr;
  SqliteConnection* connection_ = nullptr;
  std::string sql_;
};

}  // namespace twocam::store
