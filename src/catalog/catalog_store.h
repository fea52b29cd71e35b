// SPDX-License-Identifier: MIT
// The catalogue's storage behind Catalog (internal): a connection that runs SQL with `?`
// parameters and one kind of write transaction. Two implementations: an SQLite file
// (store_sqlite.cpp, the default) and a PostgreSQL database (store_postgres.cpp, a
// `postgresql://` location). Catalog (catalog.cpp) writes the same statements to both.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace meshmark::catalog_store
{

/// A value bound to a statement or read from a row.
struct Value
{
    enum class Type
    {
        Null,
        Integer,
        Text,
        Blob,
    };
    Type type = Type::Null;
    std::int64_t integer = 0;
    std::string bytes;  ///< text, or a blob's bytes

    Value() = default;
    Value(std::int64_t i) : type(Type::Integer), integer(i) {}       // NOLINT: implicit on purpose
    Value(std::string s) : type(Type::Text), bytes(std::move(s)) {}  // NOLINT
    Value(const char* s) : type(Type::Text), bytes(s) {}             // NOLINT
    static Value blob(const std::vector<std::uint8_t>& data)
    {
        Value v;
        v.type = Type::Blob;
        v.bytes.assign(data.begin(), data.end());
        return v;
    }

    [[nodiscard]] std::int64_t as_int() const;  ///< an integer (a text holding one too)
    [[nodiscard]] const std::string& as_text() const { return bytes; }
    [[nodiscard]] std::vector<std::uint8_t> as_blob() const { return {bytes.begin(), bytes.end()}; }
};
using Row = std::vector<Value>;

/// What a store throws on a failing statement; Catalog turns it into an IoError naming it.
class StoreError : public std::runtime_error
{
public:
    StoreError(const std::string& what, bool busy) : std::runtime_error(what), busy_(busy) {}
    /// The statement waited for a lock longer than the busy timeout.
    [[nodiscard]] bool busy() const noexcept { return busy_; }

private:
    bool busy_;
};

class Store
{
public:
    virtual ~Store() = default;

    /// The location as shown in messages and JSON: a path, or a URL without its password.
    [[nodiscard]] virtual const std::filesystem::path& location() const = 0;
    /// Rows of \p sql, its `?` bound in turn to \p params.
    virtual std::vector<Row> query(const std::string& sql, const std::vector<Value>& params) = 0;
    /// Runs \p sql; the number of rows it changed.
    virtual std::int64_t execute(const std::string& sql, const std::vector<Value>& params) = 0;

    /// \brief Begins the write transaction of a change of asset \p asset ("" for one of the
    /// whole catalogue: opening it, a migration), waiting up to the busy timeout for any
    /// other that could conflict. SQLite: BEGIN IMMEDIATE (one writer at a time). PostgreSQL:
    /// an advisory lock on the asset (shared on the catalogue) or on the catalogue.
    virtual void begin(const std::string& asset) = 0;
    virtual void commit() = 0;
    virtual void rollback() noexcept = 0;

    [[nodiscard]] virtual bool has_table(const std::string& name) = 0;
    /// The database holds no table at all (a new catalogue can be made in it).
    [[nodiscard]] virtual bool is_empty() = 0;
    /// Creates the tables (schema v2), in the transaction begun.
    virtual void create_schema() = 0;
    /// A database without the catalogue's tables is refused when opened as existing (a
    /// PostgreSQL database exists before its catalogue; an empty SQLite file is made one).
    [[nodiscard]] virtual bool empty_is_missing() const = 0;
};

/// A PostgreSQL location: `postgresql://...` or `postgres://...` (libpq's connection URIs).
bool is_postgres_location(const std::string& location);
/// \p location with any password removed (its userinfo's and a `password=` parameter).
std::string without_password(const std::string& location);

/// \param create make the file (mode 0600) when missing; otherwise a missing one is an error.
std::unique_ptr<Store> open_sqlite(const std::filesystem::path& path, bool create,
                                   std::chrono::milliseconds busy_timeout);
std::unique_ptr<Store> open_postgres(const std::string& url,
                                     std::chrono::milliseconds busy_timeout);

/// Runs \p work in a transaction of \p store begun for \p asset; rolled back when it throws.
template <class Work>
auto in_transaction(Store& store, const std::string& asset, Work&& work)
{
    store.begin(asset);
    try
    {
        if constexpr (std::is_void_v<decltype(work())>)
        {
            work();
            store.commit();
        }
        else
        {
            auto result = work();
            store.commit();
            return result;
        }
    }
    catch (...)
    {
        store.rollback();
        throw;
    }
}

}  // namespace meshmark::catalog_store
