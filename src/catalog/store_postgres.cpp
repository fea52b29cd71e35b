// SPDX-License-Identifier: MIT
// The catalogue in a PostgreSQL database (through libpq, its C client library): the schema of
// the SQLite file, READ COMMITTED transactions serialized as SQLite's BEGIN IMMEDIATE would be
// where it matters, by advisory locks held to the end of the transaction: a change of an asset
// takes the asset's lock (and the catalogue's, shared), a change of the whole catalogue
// (creating the tables, a migration) the catalogue's lock alone. Waiting for one is bounded by
// lock_timeout, the busy timeout. The UNIQUE constraints stay, as a second guard.
#include <algorithm>
#include <cstring>

#include <libpq-fe.h>

#include "catalog/catalog_store.h"
#include "meshmark/core/error.h"

namespace meshmark::catalog_store
{
namespace
{

// BIGINT where SQLite's INTEGER is 64 bits (counts, codes), BYTEA for its BLOB.
constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS assets (
    id TEXT PRIMARY KEY,
    original TEXT NOT NULL,
    original_sha256 TEXT NOT NULL,
    published TEXT NOT NULL,
    key_json TEXT NOT NULL,
    vertex_count BIGINT NOT NULL,
    face_count BIGINT NOT NULL,
    added TEXT NOT NULL,
    complete INTEGER NOT NULL DEFAULT 0,
    shape BYTEA NOT NULL
);
CREATE TABLE IF NOT EXISTS recipients (
    asset TEXT NOT NULL REFERENCES assets(id) ON DELETE CASCADE,
    name TEXT NOT NULL,
    code BIGINT NOT NULL,
    path TEXT NOT NULL,
    delivered INTEGER NOT NULL DEFAULT 0,
    issued TEXT NOT NULL,
    PRIMARY KEY (asset, name),
    UNIQUE (asset, code)
);
)sql";

// The advisory locks' first key: 'mm' (meshmark); the second is 0 for the catalogue, a hash of
// the asset's id for an asset (two ids of one hash merely wait for each other).
constexpr std::int32_t kLockClass = 0x6d6d;

std::int32_t lock_of(const std::string& asset)
{
    std::uint32_t hash = 2166136261U;  // FNV-1a, the same in every process and build
    for (const char c : asset)
    {
        hash = (hash ^ static_cast<unsigned char>(c)) * 16777619U;
    }
    hash = hash == 0 ? 1 : hash;
    std::int32_t key = 0;
    std::memcpy(&key, &hash, sizeof key);
    return key;
}

// Type OIDs of the columns read (pg_type.h).
constexpr Oid kBool = 16;
constexpr Oid kBytea = 17;
constexpr Oid kInt8 = 20;
constexpr Oid kInt2 = 21;
constexpr Oid kInt4 = 23;

std::int64_t big_endian(const char* data, int size)
{
    std::uint64_t v = 0;
    for (int i = 0; i < size; ++i)
    {
        v = (v << 8U) | static_cast<unsigned char>(data[i]);
    }
    if (size < 8 && size > 0 && (v >> (8U * static_cast<unsigned>(size) - 1U)) != 0)
    {
        v |= ~std::uint64_t{0} << (8U * static_cast<unsigned>(size));  // sign-extend
    }
    std::int64_t out = 0;
    std::memcpy(&out, &v, sizeof out);
    return out;
}

class PostgresStore final : public Store
{
public:
    PostgresStore(const std::string& url, std::chrono::milliseconds busy_timeout)
        : location_(without_password(url)), busy_timeout_(busy_timeout)
    {
        conn_ = PQconnectdb(url.c_str());
        if (conn_ == nullptr || PQstatus(conn_) != CONNECTION_OK)
        {
            const std::string why = conn_ ? trimmed(PQerrorMessage(conn_)) : "out of memory";
            PQfinish(conn_);
            conn_ = nullptr;
            throw IoError(location_.string() + ": cannot open the catalogue (" + why + ").");
        }
        // No NOTICE on stderr ("relation ... already exists, skipping").
        PQsetNoticeProcessor(
            conn_, [](void*, const char*) {}, nullptr);
        configure();
    }
    ~PostgresStore() override { PQfinish(conn_); }
    PostgresStore(const PostgresStore&) = delete;
    PostgresStore& operator=(const PostgresStore&) = delete;

    [[nodiscard]] const std::filesystem::path& location() const override { return location_; }

    std::vector<Row> query(const std::string& sql, const std::vector<Value>& params) override
    {
        const Result result = run(sql, params);
        std::vector<Row> rows;
        const int columns = PQnfields(result.get());
        for (int r = 0; r < PQntuples(result.get()); ++r)
        {
            Row row;
            for (int c = 0; c < columns; ++c)
            {
                row.push_back(value_of(result.get(), r, c));
            }
            rows.push_back(std::move(row));
        }
        return rows;
    }

    std::int64_t execute(const std::string& sql, const std::vector<Value>& params) override
    {
        const Result result = run(sql, params);
        const char* changed = PQcmdTuples(result.get());
        return *changed != 0 ? std::stoll(changed) : 0;
    }

    void begin(const std::string& asset) override
    {
        run("BEGIN", {});
        in_transaction_ = true;
        try
        {
            if (asset.empty())
            {
                run("SELECT pg_advisory_xact_lock(" + std::to_string(kLockClass) + ", 0)", {});
            }
            else
            {
                run("SELECT pg_advisory_xact_lock_shared(" + std::to_string(kLockClass) +
                        ", 0), pg_advisory_xact_lock(" + std::to_string(kLockClass) + ", " +
                        std::to_string(lock_of(asset)) + ")",
                    {});
            }
        }
        catch (...)
        {
            rollback();
            throw;
        }
    }
    void commit() override
    {
        in_transaction_ = false;  // (a failed COMMIT ends the transaction too)
        run("COMMIT", {});
    }
    void rollback() noexcept override
    {
        in_transaction_ = false;
        PQclear(PQexec(conn_, "ROLLBACK"));
    }

    [[nodiscard]] bool has_table(const std::string& name) override
    {
        return query(
                   "SELECT count(*) FROM information_schema.tables "
                   "WHERE table_schema = current_schema() AND table_name = ?",
                   {name})[0][0]
                   .as_int() != 0;
    }
    [[nodiscard]] bool is_empty() override
    {
        return query(
                   "SELECT count(*) FROM information_schema.tables "
                   "WHERE table_schema = current_schema()",
                   {})[0][0]
                   .as_int() == 0;
    }
    void create_schema() override
    {
        const Result result(PQexec(conn_, kSchema));
        check(result.get());
    }
    [[nodiscard]] bool empty_is_missing() const override { return true; }

private:
    struct Clear
    {
        void operator()(PGresult* r) const { PQclear(r); }
    };
    using Result = std::unique_ptr<PGresult, Clear>;

    // libpq's message on one line ("ERROR:  ...\nDETAIL:  ...\n" as "ERROR: ... DETAIL: ...").
    static std::string trimmed(const std::string& text)
    {
        std::string line;
        for (const char c : text)
        {
            if (c == '\n' || c == ' ')
            {
                if (!line.empty() && line.back() != ' ')
                {
                    line += ' ';
                }
            }
            else
            {
                line += c;
            }
        }
        while (!line.empty() && line.back() == ' ')
        {
            line.pop_back();
        }
        return line;
    }

    void check(PGresult* result) const
    {
        const ExecStatusType status = PQresultStatus(result);
        if (status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK)
        {
            return;
        }
        const char* state = result ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
        const std::string code = state ? state : "";
        // 55P03: lock_timeout passed; 40001, 40P01: a serialization failure, a deadlock.
        const bool busy = code == "55P03" || code == "40001" || code == "40P01";
        throw StoreError(trimmed(result ? PQresultErrorMessage(result) : PQerrorMessage(conn_)),
                         busy);
    }

    // The session's settings, on a new connection or after a reset.
    void configure()
    {
        run_once("SET client_min_messages = warning", {});
        // (0 would wait for ever: SQLite's busy timeout of 0 fails at once)
        run_once("SET lock_timeout = " +
                     std::to_string(std::max<std::int64_t>(1, busy_timeout_.count())),
                 {});
    }

    // The connection made again when it was lost (the server restarted, a network cut): true
    // when it is back.
    bool reconnect()
    {
        PQreset(conn_);
        if (PQstatus(conn_) != CONNECTION_OK)
        {
            return false;
        }
        configure();
        return true;
    }

    // run_once, and once more after a lost connection is made again, outside a transaction
    // only (a statement in one would run without its transaction's earlier statements): a
    // long-running `serve` outlives a restart of the database server.
    Result run(const std::string& sql, const std::vector<Value>& params)
    {
        if (!in_transaction_ && PQstatus(conn_) != CONNECTION_OK)
        {
            (void)reconnect();
        }
        try
        {
            return run_once(sql, params);
        }
        catch (const StoreError&)
        {
            if (in_transaction_ || PQstatus(conn_) == CONNECTION_OK || !reconnect())
            {
                throw;
            }
        }
        return run_once(sql, params);
    }

    // Runs \p sql, its `?` turned into $1, $2, ...; text results but for integers and bytea,
    // read in binary.
    Result run_once(const std::string& sql, const std::vector<Value>& params)
    {
        std::string text;
        int n = 0;
        for (const char c : sql)
        {
            if (c == '?')
            {
                text += '$';
                text += std::to_string(++n);
            }
            else
            {
                text += c;
            }
        }
        std::vector<std::string> numbers(params.size());
        std::vector<const char*> values(params.size());
        std::vector<int> lengths(params.size());
        std::vector<int> formats(params.size());
        std::vector<Oid> types(params.size());
        for (std::size_t p = 0; p < params.size(); ++p)
        {
            const Value& v = params[p];
            switch (v.type)
            {
                case Value::Type::Null:
                    values[p] = nullptr;
                    break;
                case Value::Type::Integer:
                    numbers[p] = std::to_string(v.integer);
                    values[p] = numbers[p].c_str();
                    types[p] = kInt8;
                    break;
                case Value::Type::Text:
                    values[p] = v.bytes.c_str();
                    break;
                case Value::Type::Blob:
                    values[p] = v.bytes.data();
                    lengths[p] = static_cast<int>(v.bytes.size());
                    formats[p] = 1;
                    types[p] = kBytea;
                    break;
            }
        }
        Result result(PQexecParams(conn_, text.c_str(), static_cast<int>(params.size()),
                                   types.data(), values.data(), lengths.data(), formats.data(), 1));
        check(result.get());
        return result;
    }

    static Value value_of(const PGresult* result, int r, int c)
    {
        if (PQgetisnull(result, r, c) != 0)
        {
            return {};
        }
        const char* data = PQgetvalue(result, r, c);
        const int size = PQgetlength(result, r, c);
        switch (PQftype(result, c))
        {
            case kInt2:
            case kInt4:
            case kInt8:
            case kBool:
                return Value(big_endian(data, size));
            case kBytea:
            {
                Value v;
                v.type = Value::Type::Blob;
                v.bytes.assign(data, data + size);
                return v;
            }
            default:  // text (its binary form is its bytes)
                return Value(std::string(data, data + size));
        }
    }

    std::filesystem::path location_;
    PGconn* conn_ = nullptr;
    std::chrono::milliseconds busy_timeout_;
    bool in_transaction_ = false;  // between begin() and commit() or rollback()
};

}  // namespace

bool is_postgres_location(const std::string& location)
{
    return location.starts_with("postgresql://") || location.starts_with("postgres://");
}

std::string without_password(const std::string& location)
{
    const std::size_t scheme = location.find("://");
    if (scheme == std::string::npos)
    {
        return location;
    }
    std::string out = location;
    const std::size_t start = scheme + 3;
    const std::size_t end = std::min(out.find_first_of("/?", start), out.size());
    const std::size_t at = out.rfind('@', end == 0 ? 0 : end - 1);
    if (at != std::string::npos && at >= start)
    {
        const std::size_t colon = out.find(':', start);
        if (colon != std::string::npos && colon < at)
        {
            out.erase(colon, at - colon);
        }
    }
    // password=... among the parameters
    const std::size_t question = out.find('?');
    if (question != std::string::npos)
    {
        std::string kept;
        std::size_t from = question + 1;
        while (from <= out.size())
        {
            const std::size_t amp = std::min(out.find('&', from), out.size());
            const std::string param = out.substr(from, amp - from);
            if (!param.starts_with("password=") && !param.empty())
            {
                kept += (kept.empty() ? "" : "&") + param;
            }
            from = amp + 1;
        }
        out = out.substr(0, question) + (kept.empty() ? "" : "?" + kept);
    }
    return out;
}

std::unique_ptr<Store> open_postgres(const std::string& url, std::chrono::milliseconds busy_timeout)
{
    return std::make_unique<PostgresStore>(url, busy_timeout);
}

}  // namespace meshmark::catalog_store
