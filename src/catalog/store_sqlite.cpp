// SPDX-License-Identifier: MIT
// The catalogue in an SQLite file (through SQLiteCpp, Debian's C++ wrapper of the C API):
// WAL, synchronous=FULL, one writer at a time (BEGIN IMMEDIATE), others waiting up to the busy
// timeout.
#include <SQLiteCpp/SQLiteCpp.h>
#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include "catalog/catalog_store.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark::catalog_store
{
namespace
{

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS assets (
    id TEXT PRIMARY KEY,
    original TEXT NOT NULL,
    original_sha256 TEXT NOT NULL,
    published TEXT NOT NULL,
    key_json TEXT NOT NULL,
    vertex_count INTEGER NOT NULL,
    face_count INTEGER NOT NULL,
    added TEXT NOT NULL,
    complete INTEGER NOT NULL DEFAULT 0,
    shape BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS recipients (
    asset TEXT NOT NULL REFERENCES assets(id) ON DELETE CASCADE,
    name TEXT NOT NULL,
    code INTEGER NOT NULL,
    path TEXT NOT NULL,
    delivered INTEGER NOT NULL DEFAULT 0,
    issued TEXT NOT NULL,
    PRIMARY KEY (asset, name),
    UNIQUE (asset, code)
);
)sql";

// Runs \p work, SQLite's exceptions turned into StoreError.
template <class Work>
auto guarded(Work&& work)
{
    try
    {
        return work();
    }
    catch (const SQLite::Exception& e)
    {
        const int code = e.getErrorCode();
        throw StoreError(e.what(), code == SQLITE_BUSY || code == SQLITE_LOCKED);
    }
}

class SqliteStore final : public Store
{
public:
    SqliteStore(std::filesystem::path path, std::chrono::milliseconds busy_timeout)
        : path_(std::move(path))
    {
        guarded(
            [&]
            {
                db_ = std::make_unique<SQLite::Database>(
                    path_.string(), SQLite::OPEN_READWRITE | SQLite::OPEN_FULLMUTEX,
                    static_cast<int>(busy_timeout.count()));
                // A file that is not SQLite fails here, on the first read.
                db_->exec("PRAGMA journal_mode=WAL");
                db_->exec("PRAGMA synchronous=FULL");
                db_->exec("PRAGMA foreign_keys=ON");
            });
    }

    [[nodiscard]] const std::filesystem::path& location() const override { return path_; }

    std::vector<Row> query(const std::string& sql, const std::vector<Value>& params) override
    {
        return guarded(
            [&]
            {
                SQLite::Statement statement(*db_, sql);
                bind(statement, params);
                std::vector<Row> rows;
                while (statement.executeStep())
                {
                    Row row;
                    for (int c = 0; c < statement.getColumnCount(); ++c)
                    {
                        row.push_back(value_of(statement.getColumn(c)));
                    }
                    rows.push_back(std::move(row));
                }
                return rows;
            });
    }

    std::int64_t execute(const std::string& sql, const std::vector<Value>& params) override
    {
        return guarded(
            [&]
            {
                SQLite::Statement statement(*db_, sql);
                bind(statement, params);
                return static_cast<std::int64_t>(statement.exec());
            });
    }

    void begin(const std::string& /*asset*/) override
    {
        guarded([&] { db_->exec("BEGIN IMMEDIATE"); });
    }
    void commit() override
    {
        guarded([&] { db_->exec("COMMIT"); });
    }
    void rollback() noexcept override
    {
        try
        {
            db_->exec("ROLLBACK");
        }
        catch (const SQLite::Exception&)  // none in progress (it failed to begin)
        {
        }
    }

    [[nodiscard]] bool has_table(const std::string& name) override
    {
        return guarded([&] { return db_->tableExists(name); });
    }
    [[nodiscard]] bool is_empty() override
    {
        return guarded(
                   [&]
                   { return db_->execAndGet("SELECT count(*) FROM sqlite_master").getInt(); }) == 0;
    }
    void create_schema() override
    {
        guarded([&] { db_->exec(kSchema); });
    }
    [[nodiscard]] bool empty_is_missing() const override { return false; }

private:
    static void bind(SQLite::Statement& statement, const std::vector<Value>& params)
    {
        static const char kNoBytes = 0;
        for (std::size_t p = 0; p < params.size(); ++p)
        {
            const Value& v = params[p];
            const int at = static_cast<int>(p) + 1;
            switch (v.type)
            {
                case Value::Type::Null:
                    statement.bind(at);
                    break;
                case Value::Type::Integer:
                    statement.bind(at, static_cast<int64_t>(v.integer));
                    break;
                case Value::Type::Text:
                    statement.bind(at, v.bytes);
                    break;
                case Value::Type::Blob:  // an empty blob, not NULL
                    statement.bind(at, v.bytes.empty() ? &kNoBytes : v.bytes.data(),
                                   static_cast<int>(v.bytes.size()));
                    break;
            }
        }
    }

    static Value value_of(const SQLite::Column& column)
    {
        Value v;
        if (column.isInteger())
        {
            v = Value(static_cast<std::int64_t>(column.getInt64()));
        }
        else if (column.isBlob())
        {
            v.type = Value::Type::Blob;
            const auto* data = static_cast<const char*>(column.getBlob());
            v.bytes.assign(data, data + column.getBytes());
        }
        else if (!column.isNull())
        {
            v = Value(column.getString());
        }
        return v;
    }

    std::filesystem::path path_;
    std::unique_ptr<SQLite::Database> db_;
};

}  // namespace

std::unique_ptr<Store> open_sqlite(const std::filesystem::path& path, bool create,
                                   std::chrono::milliseconds busy_timeout)
{
    std::error_code error;
    const bool exists = std::filesystem::exists(path, error);
    if (!exists && !create)
    {
        throw IoError(path.string() +
                      ": no such catalogue (create one with `meshmark catalog add`).");
    }
    if (!exists)
    {
        // Created empty, mode 0600, before SQLite opens it: the catalogue holds keys (its WAL
        // and shared-memory files take the database's mode).
        create_parent_directories(path);
        const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
        if (fd >= 0)
        {
            ::close(fd);
        }
    }
    return std::make_unique<SqliteStore>(path, busy_timeout);
}

}  // namespace meshmark::catalog_store
