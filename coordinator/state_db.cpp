#include "coordinator/state_db.h"

#include "common/core/error.h"

#include <sqlite3.h>

namespace alphorn::coordinator {

namespace {

struct Statement {
    sqlite3_stmt* handle = nullptr;
    ~Statement() { sqlite3_finalize(handle); }
};

}  // namespace

StateDatabase::StateDatabase(const std::string& path) : m_path(path) {
    if (sqlite3_open_v2(path.c_str(), &m_db,
                        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                        nullptr) != SQLITE_OK) {
        std::string message = m_db ? sqlite3_errmsg(m_db) : "out of memory";
        sqlite3_close(m_db);
        fail("%s: cannot open the state database: %s", path, message);
    }
    sqlite3_busy_timeout(m_db, 5000);
    // WAL + synchronous=FULL: a committed transaction survives a crash of the process or the
    // machine.
    execute("PRAGMA journal_mode=WAL");
    execute("PRAGMA synchronous=FULL");
}

std::string StateDatabase::sqlError(const char* what, const std::string& sql) const {
    std::string statement = sql.substr(0, sql.find('\n'));
    if (statement.size() > 60) statement = statement.substr(0, 60);
    if (statement.size() < sql.size()) statement += "...";
    return absl::StrFormat("%s: %s in \"%s\": %s", m_path, what, statement, sqlite3_errmsg(m_db));
}

StateDatabase::~StateDatabase() {
    sqlite3_close(m_db);
}

std::vector<StateDatabase::Row> StateDatabase::query(const std::string& sql,
                                                     const std::vector<Value>& parameters) {
    std::lock_guard lock(m_mutex);
    return queryLocked(sql, parameters);
}

void StateDatabase::transaction(const std::vector<Write>& writes) {
    // Under the one lock: the connection is shared between threads, and a statement of another
    // thread must not land inside this transaction.
    std::lock_guard lock(m_mutex);
    queryLocked("BEGIN IMMEDIATE", {});
    try {
        for (const Write& write : writes) queryLocked(write.sql, write.parameters);
        queryLocked("COMMIT", {});
    } catch (const StorageError&) {
        // Also after a failed COMMIT, which may leave the transaction open.
        sqlite3_exec(m_db, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

std::vector<StateDatabase::Row> StateDatabase::queryLocked(const std::string& sql,
                                                           const std::vector<Value>& parameters) {
    Statement statement;
    if (sqlite3_prepare_v2(m_db, sql.c_str(), -1, &statement.handle, nullptr) != SQLITE_OK)
        throw StorageError(sqlError("SQL error", sql));
    for (size_t i = 0; i < parameters.size(); ++i) {
        const int index = static_cast<int>(i) + 1;
        const Value& value = parameters[i];
        int rc = SQLITE_OK;
        if (std::holds_alternative<std::nullptr_t>(value))
            rc = sqlite3_bind_null(statement.handle, index);
        else if (auto* integer = std::get_if<int64_t>(&value))
            rc = sqlite3_bind_int64(statement.handle, index, *integer);
        else if (auto* real = std::get_if<double>(&value))
            rc = sqlite3_bind_double(statement.handle, index, *real);
        else {
            const std::string& bytes = std::get<std::string>(value);
            rc = sqlite3_bind_blob(statement.handle, index, bytes.data(),
                                   static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
        }
        if (rc != SQLITE_OK) throw StorageError(sqlError("SQL bind error", sql));
    }
    std::vector<Row> rows;
    for (;;) {
        int rc = sqlite3_step(statement.handle);
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) throw StorageError(sqlError("SQL error", sql));
        Row row;
        for (int c = 0; c < sqlite3_column_count(statement.handle); ++c) {
            switch (sqlite3_column_type(statement.handle, c)) {
                case SQLITE_NULL:
                    row.emplace_back(nullptr);
                    break;
                case SQLITE_INTEGER:
                    row.emplace_back(int64_t(sqlite3_column_int64(statement.handle, c)));
                    break;
                case SQLITE_FLOAT:
                    row.emplace_back(sqlite3_column_double(statement.handle, c));
                    break;
                default: {
                    const char* data =
                        static_cast<const char*>(sqlite3_column_blob(statement.handle, c));
                    row.emplace_back(
                        std::string(data ? data : "", sqlite3_column_bytes(statement.handle, c)));
                }
            }
        }
        rows.push_back(std::move(row));
    }
    return rows;
}

void StateDatabase::execute(const std::string& sql, const std::vector<Value>& parameters) {
    query(sql, parameters);
}

int64_t StateDatabase::lastInsertId() {
    std::lock_guard lock(m_mutex);
    return sqlite3_last_insert_rowid(m_db);
}

int64_t StateDatabase::integer(const Value& value) {
    if (auto* integer = std::get_if<int64_t>(&value)) return *integer;
    if (auto* real = std::get_if<double>(&value)) return static_cast<int64_t>(*real);
    return 0;
}

std::string StateDatabase::text(const Value& value) {
    if (auto* bytes = std::get_if<std::string>(&value)) return *bytes;
    if (auto* integer = std::get_if<int64_t>(&value)) return std::to_string(*integer);
    return "";
}

}  // namespace alphorn::coordinator
