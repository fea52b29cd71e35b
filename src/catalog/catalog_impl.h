// SPDX-License-Identifier: MIT
// Catalog's implementation (internal), shared by catalog.cpp (opening, reading, migrating) and
// catalog_recipients.cpp (the family keys' changes, the recipients' codes).
#pragma once

#include <ctime>
#include <mutex>

#include "catalog/catalog_store.h"
#include "meshmark/catalog/catalog.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace catalog_detail
{

// Schema v2 (store_sqlite.cpp, store_postgres.cpp). A recipient row exists for each name given a
// code; (asset, code) is unique, so the database itself refuses two names with one code. Keys
// are stored as their key-file JSON without the recipients: the recipients table is the
// family's list, joined to the key when it is read (so `catalog export` writes exactly a key
// file), and a new name costs one row, not a rewrite of every name before it (version 1 stored
// them in the JSON too; opening one strips them).
constexpr const char* kAssetColumns =
    "id, original, original_sha256, published, key_json, vertex_count, face_count, added, "
    "complete, shape";
constexpr const char* kRecipientColumns = "asset, name, code, path, delivered, issued";

inline std::string utc_now()
{
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

}  // namespace catalog_detail

using catalog_store::in_transaction;
using catalog_store::Row;
using catalog_store::Value;

struct Catalog::Impl
{
    class KeyStore;
    std::unique_ptr<catalog_store::Store> store;
    mutable std::mutex mutex;  // one statement or transaction at a time on the connection

    [[nodiscard]] const std::filesystem::path& path() const { return store->location(); }

    std::vector<Row> query(const std::string& sql, const std::vector<Value>& params = {}) const
    {
        return store->query(sql, params);
    }
    std::int64_t execute(const std::string& sql, const std::vector<Value>& params = {}) const
    {
        return store->execute(sql, params);
    }

    // Runs \p work, turning the store's errors into one sentence naming the catalogue.
    template <class Work>
    auto guarded(const char* doing, Work&& work) const
    {
        try
        {
            return work();
        }
        catch (const catalog_store::StoreError& e)
        {
            if (e.busy())
            {
                throw IoError(path().string() +
                              ": the catalogue stayed busy (another call is changing it) while " +
                              doing + "; try again or raise --lock-timeout.");
            }
            throw IoError(path().string() + ": cannot " + std::string(doing) + " the catalogue (" +
                          e.what() + ").");
        }
    }

    // The key stored as \p json for asset \p id, with its recipients from the table.
    Key key_of(const std::string& id, const std::string& json) const
    {
        Key key = parse_key(json, path().string() + " (asset " + id + ")");
        if (key.recipients)
        {
            std::vector<Recipient>& list = key.recipients->recipients;
            list.clear();
            for (const Row& row :
                 query("SELECT name, code FROM recipients WHERE asset = ? ORDER BY code", {id}))
            {
                list.push_back({row[0].as_text(), static_cast<std::uint32_t>(row[1].as_int())});
            }
        }
        return key;
    }

    // \p key as stored: its JSON without the recipients (they are the table's rows).
    static std::string stored_json(Key key)
    {
        if (key.recipients)
        {
            key.recipients->recipients.clear();
        }
        return to_json(key);
    }

    // Version 1 kept every recipient in the key's JSON as well: strip them (the table holds the
    // same names and codes), in the transaction that opened the file.
    void migrate_from_v1() const
    {
        for (const Row& row : query("SELECT id, key_json FROM assets"))
        {
            const std::string& id = row[0].as_text();
            execute(
                "UPDATE assets SET key_json = ? WHERE id = ?",
                {stored_json(parse_key(row[1].as_text(), path().string() + " (asset " + id + ")")),
                 id});
        }
        execute("UPDATE meta SET value = '2' WHERE name = 'version'");
    }

    // An asset of a row of kAssetColumns.
    CatalogAsset asset_of(const Row& row) const
    {
        CatalogAsset a;
        a.id = row[0].as_text();
        a.original = row[1].as_text();
        a.original_sha256 = row[2].as_text();
        a.published = row[3].as_text();
        a.key = key_of(a.id, row[4].as_text());
        a.vertex_count = row[5].as_int();
        a.face_count = row[6].as_int();
        a.added = row[7].as_text();
        a.is_complete = row[8].as_int() != 0;
        return a;
    }

    // Makes the tables in a new catalogue, checks (and upgrades) those of an existing one.
    void open(Open mode) const;
};

}  // namespace meshmark
