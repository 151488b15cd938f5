// A thread-safe SQLite connection with bound parameters: the storage under the job store
// (job_store.h), which owns the schema and turns rows into types.
#pragma once

#include "common/core/error.h"

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <variant>
#include <vector>

struct sqlite3;

namespace alphorn::coordinator {

// A statement that could not run (a full or read-only disk, a damaged file). The services turn it
// into UNAVAILABLE: the request was fine, the coordinator's storage was not.
class StorageError : public Error {
  public:
    using Error::Error;
};

class StateDatabase {
  public:
    using Value = std::variant<std::nullptr_t, int64_t, double, std::string>;
    using Row = std::vector<Value>;

    // Opens (creating if needed) the database in WAL mode with synchronous=FULL.
    explicit StateDatabase(const std::string& path);
    ~StateDatabase();
    StateDatabase(const StateDatabase&) = delete;
    StateDatabase& operator=(const StateDatabase&) = delete;

    // Runs one statement with bound parameters; throws StorageError with SQLite's message.
    void execute(const std::string& sql, const std::vector<Value>& parameters = {});
    // Runs a query and returns all rows.
    std::vector<Row> query(const std::string& sql, const std::vector<Value>& parameters = {});
    // One statement of a transaction().
    struct Write {
        std::string sql;
        std::vector<Value> parameters;
    };
    // Runs the statements in one transaction: a crash, a full disk or any failing statement
    // leaves none of them done. Throws StorageError, having rolled back.
    void transaction(const std::vector<Write>& writes);
    int64_t lastInsertId();

    static int64_t integer(const Value& value);
    static std::string text(const Value& value);

  private:
    // "PATH: SQL error in "STATEMENT...": SQLite's message", the statement shortened to its
    // first line.
    std::string sqlError(const char* what, const std::string& sql) const;
    // query() with m_mutex held.
    std::vector<Row> queryLocked(const std::string& sql, const std::vector<Value>& parameters);

    std::string m_path;
    sqlite3* m_db = nullptr;
    std::mutex m_mutex;  // SQLite connections are not shared between threads without it
};

}  // namespace alphorn::coordinator
