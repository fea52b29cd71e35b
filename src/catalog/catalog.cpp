// SPDX-License-Identifier: MIT
// The catalogue's storage: one SQLite database (through SQLiteCpp, Debian's C++ wrapper of the
// C API), one transaction per change.
#include "meshmark/catalog/catalog.h"

#include <ctime>
#include <limits>
#include <mutex>
#include <optional>

#include <SQLiteCpp/SQLiteCpp.h>
#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

constexpr const char* kFormat = "meshmark-catalog";
constexpr int kVersion = 2;

// Schema v2. A recipient row exists for each name given a code; (asset, code) is unique, so the
// database itself refuses two names with one code. Keys are stored as their key-file JSON without
// the recipients: the recipients table is the family's list, joined to the key when it is read
// (so `catalog export` writes exactly a key file), and a new name costs one row, not a rewrite of
// every name before it (version 1 stored them in the JSON too; opening one strips them).
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

std::string utc_now()
{
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

}  // namespace

struct Catalog::Impl
{
    class KeyStore;
    std::filesystem::path path;
    std::unique_ptr<SQLite::Database> db;
    mutable std::mutex mutex;  // one statement or transaction at a time on the connection

    // Runs \p work, turning SQLite's errors into one sentence naming the catalogue.
    template <class Work>
    auto guarded(const char* doing, Work&& work) const
    {
        try
        {
            return work();
        }
        catch (const SQLite::Exception& e)
        {
            const int code = e.getErrorCode();
            if (code == SQLITE_BUSY || code == SQLITE_LOCKED)
            {
                throw IoError(path.string() +
                              ": the catalogue stayed busy (another call is changing it) while " +
                              doing + "; try again or raise --lock-timeout.");
            }
            throw IoError(path.string() + ": cannot " + std::string(doing) + " the catalogue (" +
                          e.what() + ").");
        }
    }

    // The key stored as \p json for asset \p id, with its recipients from the table.
    Key key_of(const std::string& id, const std::string& json) const
    {
        Key key = parse_key(json, path.string() + " (asset " + id + ")");
        if (key.recipients)
        {
            std::vector<Recipient>& list = key.recipients->recipients;
            list.clear();
            SQLite::Statement row(
                *db, "SELECT name, code FROM recipients WHERE asset = ? ORDER BY code");
            row.bind(1, id);
            while (row.executeStep())
            {
                list.push_back({row.getColumn(0).getString(),
                                static_cast<std::uint32_t>(row.getColumn(1).getInt64())});
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
    void migrate_from_v1()
    {
        std::vector<std::pair<std::string, std::string>> keys;
        {
            SQLite::Statement row(*db, "SELECT id, key_json FROM assets");
            while (row.executeStep())
            {
                keys.emplace_back(row.getColumn(0).getString(), row.getColumn(1).getString());
            }
        }
        SQLite::Statement set(*db, "UPDATE assets SET key_json = ? WHERE id = ?");
        for (const auto& [id, json] : keys)
        {
            set.bind(1, stored_json(parse_key(json, path.string() + " (asset " + id + ")")));
            set.bind(2, id);
            set.exec();
            set.reset();
        }
        db->exec("UPDATE meta SET value = '2' WHERE name = 'version'");
    }

    CatalogAsset asset_of(SQLite::Statement& row) const
    {
        CatalogAsset a;
        a.id = row.getColumn("id").getString();
        a.original = row.getColumn("original").getString();
        a.original_sha256 = row.getColumn("original_sha256").getString();
        a.published = row.getColumn("published").getString();
        a.key = key_of(a.id, row.getColumn("key_json").getString());
        a.vertex_count = row.getColumn("vertex_count").getInt64();
        a.face_count = row.getColumn("face_count").getInt64();
        a.added = row.getColumn("added").getString();
        a.is_complete = row.getColumn("complete").getInt() != 0;
        return a;
    }
};

Catalog::Catalog(std::filesystem::path path, Open mode, std::chrono::milliseconds busy_timeout)
    : impl_(std::make_unique<Impl>())
{
    impl_->path = std::move(path);
    const std::string name = impl_->path.string();
    std::error_code error;
    const bool exists = std::filesystem::exists(impl_->path, error);
    if (!exists && mode == Open::Existing)
    {
        throw IoError(name + ": no such catalogue (create one with `meshmark catalog add`).");
    }
    if (!exists)
    {
        // Created empty, mode 0600, before SQLite opens it: the catalogue holds keys (its WAL
        // and shared-memory files take the database's mode).
        create_parent_directories(impl_->path);
        const int fd = ::open(impl_->path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
        if (fd >= 0)
        {
            ::close(fd);
        }
    }
    impl_->guarded(
        "open",
        [&]
        {
            impl_->db = std::make_unique<SQLite::Database>(
                name, SQLite::OPEN_READWRITE | SQLite::OPEN_FULLMUTEX,
                static_cast<int>(busy_timeout.count()));
            auto& db = *impl_->db;
            // A file that is not SQLite fails here, on the first read.
            db.exec("PRAGMA journal_mode=WAL");
            db.exec("PRAGMA synchronous=FULL");
            db.exec("PRAGMA foreign_keys=ON");
            SQLite::Transaction transaction(db, SQLite::TransactionBehavior::IMMEDIATE);
            const bool has_meta = db.tableExists("meta");
            if (!has_meta && db.tableExists("assets"))
            {
                throw IoError(name + ": this database is not a meshmark catalogue.");
            }
            if (!has_meta)
            {
                const bool is_empty =
                    db.execAndGet("SELECT count(*) FROM sqlite_master").getInt() == 0;
                if (!is_empty)
                {
                    throw IoError(name + ": this database is not a meshmark catalogue.");
                }
                db.exec(kSchema);
                SQLite::Statement insert(db, "INSERT INTO meta(name, value) VALUES (?, ?)");
                insert.bind(1, "format");
                insert.bind(2, kFormat);
                insert.exec();
                insert.reset();
                insert.bind(1, "version");
                insert.bind(2, std::to_string(kVersion));
                insert.exec();
            }
            else
            {
                const std::string format =
                    db.execAndGet("SELECT value FROM meta WHERE name = 'format'").getString();
                const int version = std::stoi(
                    db.execAndGet("SELECT value FROM meta WHERE name = 'version'").getString());
                if (format != kFormat)
                {
                    throw IoError(name + ": this database is not a meshmark catalogue.");
                }
                if (version > kVersion)
                {
                    throw IoError(name + ": the catalogue is format version " +
                                  std::to_string(version) + ", newer than this meshmark reads (" +
                                  std::to_string(kVersion) + ").");
                }
                if (version == 1)
                {
                    impl_->migrate_from_v1();
                }
            }
            transaction.commit();
        });
}

Catalog::~Catalog() = default;

const std::filesystem::path& Catalog::path() const noexcept
{
    return impl_->path;
}

std::optional<CatalogAsset> Catalog::asset(const std::string& id) const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded("read",
                          [&]() -> std::optional<CatalogAsset>
                          {
                              SQLite::Statement row(*impl_->db,
                                                    "SELECT * FROM assets WHERE id = ?");
                              row.bind(1, id);
                              if (!row.executeStep())
                              {
                                  return std::nullopt;
                              }
                              return impl_->asset_of(row);
                          });
}

std::vector<CatalogAsset> Catalog::assets() const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded("read",
                          [&]
                          {
                              std::vector<CatalogAsset> all;
                              SQLite::Statement row(*impl_->db, "SELECT * FROM assets ORDER BY id");
                              while (row.executeStep())
                              {
                                  all.push_back(impl_->asset_of(row));
                              }
                              return all;
                          });
}

std::vector<Catalog::Summary> Catalog::summaries(const std::optional<std::string>& id) const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]
        {
            std::vector<Summary> all;
            SQLite::Statement row(
                *impl_->db,
                std::string(
                    "SELECT a.id, a.original_sha256, a.vertex_count, a.face_count, a.added, "
                    "a.complete, (SELECT count(*) FROM recipients r WHERE r.asset = a.id) "
                    "FROM assets a") +
                    (id ? " WHERE a.id = ?" : " ORDER BY a.id"));
            if (id)
            {
                row.bind(1, *id);
            }
            while (row.executeStep())
            {
                all.push_back({row.getColumn(0).getString(), row.getColumn(1).getString(),
                               row.getColumn(2).getInt64(), row.getColumn(3).getInt64(),
                               row.getColumn(4).getString(), row.getColumn(5).getInt() != 0,
                               row.getColumn(6).getInt64()});
            }
            return all;
        });
}

std::vector<CatalogRecipient> Catalog::recipients(const std::string& id) const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]
        {
            std::vector<CatalogRecipient> all;
            SQLite::Statement row(*impl_->db,
                                  "SELECT name, code, path, delivered, issued FROM recipients "
                                  "WHERE asset = ? ORDER BY code");
            row.bind(1, id);
            while (row.executeStep())
            {
                all.push_back({row.getColumn(0).getString(),
                               static_cast<std::uint32_t>(row.getColumn(1).getInt64()),
                               row.getColumn(2).getString(), row.getColumn(3).getInt() != 0,
                               row.getColumn(4).getString()});
            }
            return all;
        });
}

std::size_t Catalog::complete_count() const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]
        {
            return static_cast<std::size_t>(
                impl_->db->execAndGet("SELECT count(*) FROM assets WHERE complete = 1").getInt64());
        });
}

std::vector<Catalog::IndexEntry> Catalog::shape_index() const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]
        {
            std::vector<IndexEntry> entries;
            SQLite::Statement row(
                *impl_->db, "SELECT id, shape, vertex_count, face_count FROM assets ORDER BY id");
            while (row.executeStep())
            {
                const SQLite::Column blob = row.getColumn(1);
                const auto* data = static_cast<const std::uint8_t*>(blob.getBlob());
                const auto size = static_cast<std::size_t>(blob.getBytes());
                // A signature of this build, of an older one (the positions' features alone), or
                // none.
                if (size != 0 && size != static_cast<std::size_t>(kShapeViews * kShapeFeatures) &&
                    size != static_cast<std::size_t>(kShapeViews * kShapePositionFeatures))
                {
                    throw IoError(path().string() + ": the shape signature of asset '" +
                                  row.getColumn(0).getString() + "' is damaged (" +
                                  std::to_string(size) + " bytes).");
                }
                entries.push_back({row.getColumn(0).getString(),
                                   std::vector<std::uint8_t>(data, data + size),
                                   row.getColumn(2).getInt64(), row.getColumn(3).getInt64()});
            }
            return entries;
        });
}

void Catalog::set_shape(const std::string& id, const ShapeSignature& signature)
{
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded(
        "change",
        [&]
        {
            SQLite::Transaction transaction(*impl_->db, SQLite::TransactionBehavior::IMMEDIATE);
            SQLite::Statement set(*impl_->db, "UPDATE assets SET shape = ? WHERE id = ?");
            const std::vector<std::uint8_t> shape = signature.to_bytes();
            set.bind(1, shape.data(), static_cast<int>(shape.size()));
            set.bind(2, id);
            if (set.exec() == 0)
            {
                throw InvalidOption(impl_->path.string() + ": no asset '" + id +
                                    "' in the catalogue.");
            }
            transaction.commit();
        });
}

void Catalog::remove(const std::string& id)
{
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded("change",
                   [&]
                   {
                       SQLite::Transaction transaction(*impl_->db,
                                                       SQLite::TransactionBehavior::IMMEDIATE);
                       SQLite::Statement drop(*impl_->db, "DELETE FROM assets WHERE id = ?");
                       drop.bind(1, id);
                       drop.exec();
                       transaction.commit();
                   });
}

// An asset's family key, kept in the catalogue (see Catalog::family_store).
class Catalog::Impl::KeyStore final : public FamilyKeyStore
{
public:
    KeyStore(Catalog::Impl& impl, std::string id, std::optional<CatalogAsset> prototype,
             std::optional<ShapeSignature> signature)
        : impl_(impl),
          id_(std::move(id)),
          prototype_(std::move(prototype)),
          signature_(std::move(signature))
    {
    }

    [[nodiscard]] std::string name() const override
    {
        return impl_.path.string() + " (asset " + id_ + ")";
    }
    [[nodiscard]] std::string single_owner_advice() const override
    {
        return "the catalogue's assets are marked with family keys.";
    }

    [[nodiscard]] std::optional<Key> peek() const override
    {
        const std::lock_guard lock(impl_.mutex);
        return impl_.guarded("read",
                             [&]() -> std::optional<Key>
                             {
                                 SQLite::Statement row(*impl_.db,
                                                       "SELECT key_json FROM assets WHERE id = ?");
                                 row.bind(1, id_);
                                 if (!row.executeStep())
                                 {
                                     return std::nullopt;
                                 }
                                 return parse_key(row.getColumn(0).getString(), name());
                             });
    }

    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        const std::lock_guard lock(impl_.mutex);
        const auto start = std::chrono::steady_clock::now();
        return impl_.guarded(
            "record the copies in",
            [&]
            {
                auto& db = *impl_.db;
                SQLite::Transaction transaction(db, SQLite::TransactionBehavior::IMMEDIATE);
                const double waited =
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                std::optional<Key> now;
                std::optional<bool> complete;
                {
                    SQLite::Statement row(db, "SELECT key_json, complete FROM assets WHERE id = ?");
                    row.bind(1, id_);
                    if (row.executeStep())
                    {
                        now = impl_.key_of(id_, row.getColumn(0).getString());
                        complete = row.getColumn(1).getInt() != 0;
                    }
                }
                if (!now && !prototype_)
                {
                    throw InvalidOption(impl_.path.string() + ": no asset '" + id_ +
                                        "' in the catalogue.");
                }
                const std::size_t before =
                    now && now->recipients ? now->recipients->recipients.size() : 0;
                const std::optional<Key> changed = update(now);
                if (!changed)
                {
                    return waited;
                }
                if (!now)
                {
                    CatalogAsset a = *prototype_;
                    SQLite::Statement insert(
                        db,
                        "INSERT INTO assets(id, original, original_sha256, published, key_json, "
                        "vertex_count, face_count, added, complete, shape) "
                        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, 0, ?)");
                    insert.bind(1, id_);
                    insert.bind(2, a.original.string());
                    insert.bind(3, a.original_sha256);
                    insert.bind(4, a.published.string());
                    insert.bind(5, Impl::stored_json(*changed));
                    insert.bind(6, static_cast<std::int64_t>(a.vertex_count));
                    insert.bind(7, static_cast<std::int64_t>(a.face_count));
                    insert.bind(8, utc_now());
                    const std::vector<std::uint8_t> shape =
                        signature_ ? signature_->to_bytes() : std::vector<std::uint8_t>{};
                    insert.bind(9, shape.data(), static_cast<int>(shape.size()));
                    insert.exec();
                }
                else
                {
                    SQLite::Statement set(db, "UPDATE assets SET key_json = ? WHERE id = ?");
                    set.bind(1, Impl::stored_json(*changed));
                    set.bind(2, id_);
                    set.exec();
                }
                // The names this change gave a code (the key's recipients past those it held).
                const std::string issued = utc_now();
                SQLite::Statement insert(db,
                                         "INSERT INTO recipients(asset, name, code, path, issued) "
                                         "VALUES (?, ?, ?, ?, ?)");
                const auto& all = changed->recipients->recipients;
                for (std::size_t r = before; r < all.size(); ++r)
                {
                    insert.bind(1, id_);
                    insert.bind(2, all[r].name);
                    insert.bind(3, static_cast<std::int64_t>(all[r].index));
                    insert.bind(4, std::string());  // its path once delivered
                    insert.bind(5, issued);
                    insert.exec();
                    insert.reset();
                }
                transaction.commit();
                return waited;
            });
    }

    void delivered(const std::vector<IssuedCopy>& copies) override
    {
        const std::lock_guard lock(impl_.mutex);
        impl_.guarded(
            "record the copies in",
            [&]
            {
                auto& db = *impl_.db;
                SQLite::Transaction transaction(db, SQLite::TransactionBehavior::IMMEDIATE);
                SQLite::Statement set(
                    db,
                    "UPDATE recipients SET delivered = 1, path = ? WHERE asset = ? AND name = ?");
                bool published = false;
                for (const IssuedCopy& copy : copies)
                {
                    set.bind(1, std::filesystem::absolute(copy.path).lexically_normal().string());
                    set.bind(2, id_);
                    set.bind(3, copy.name);
                    set.exec();
                    set.reset();
                    published = published || copy.name == kPublishedRecipient;
                }
                if (published)
                {
                    SQLite::Statement done(db, "UPDATE assets SET complete = 1 WHERE id = ?");
                    done.bind(1, id_);
                    done.exec();
                }
                transaction.commit();
            });
    }

private:
    Catalog::Impl& impl_;
    std::string id_;
    std::optional<CatalogAsset> prototype_;
    std::optional<ShapeSignature> signature_;
};

std::optional<std::uint32_t> Catalog::recipient_index(const std::string& id,
                                                      const std::string& name) const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded("read",
                          [&]() -> std::optional<std::uint32_t>
                          {
                              SQLite::Statement row(
                                  *impl_->db,
                                  "SELECT code FROM recipients WHERE asset = ? AND name = ?");
                              row.bind(1, id);
                              row.bind(2, name);
                              if (row.executeStep())
                              {
                                  return static_cast<std::uint32_t>(row.getColumn(0).getInt64());
                              }
                              return std::nullopt;
                          });
}

Catalog::RecordedName Catalog::record_recipient(const std::string& id, const std::string& name)
{
    check_recipient_name(name);
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "record the copy in",
        [&]
        {
            auto& db = *impl_->db;
            auto find = [&]() -> std::optional<std::uint32_t>
            {
                SQLite::Statement row(db,
                                      "SELECT code FROM recipients WHERE asset = ? AND name = ?");
                row.bind(1, id);
                row.bind(2, name);
                if (row.executeStep())
                {
                    return static_cast<std::uint32_t>(row.getColumn(0).getInt64());
                }
                return std::nullopt;
            };
            if (const std::optional<std::uint32_t> code = find())
            {
                return RecordedName{*code, false};  // known: nothing to write
            }
            SQLite::Transaction transaction(db, SQLite::TransactionBehavior::IMMEDIATE);
            {
                SQLite::Statement row(db, "SELECT complete FROM assets WHERE id = ?");
                row.bind(1, id);
                if (!row.executeStep())
                {
                    throw InvalidOption(impl_->path.string() + ": no asset '" + id +
                                        "' in the catalogue.");
                }
                if (row.getColumn(0).getInt() == 0)
                {
                    throw InvalidOption(
                        impl_->path.string() + ": asset '" + id +
                        "' was interrupted while being added; run `meshmark catalog add` again.");
                }
            }
            if (const std::optional<std::uint32_t> code =
                    find())  // recorded by another process meanwhile
            {
                return RecordedName{*code, false};
            }
            SQLite::Statement next(
                db, "SELECT COALESCE(MAX(code) + 1, 0) FROM recipients WHERE asset = ?");
            next.bind(1, id);
            next.executeStep();
            const std::int64_t code = next.getColumn(0).getInt64();
            if (code >= static_cast<std::int64_t>(std::numeric_limits<std::uint32_t>::max()))
            {
                throw InvalidOption(impl_->path.string() + ": asset '" + id +
                                    "' holds as many recipients as it can.");
            }
            SQLite::Statement insert(
                db,
                "INSERT INTO recipients(asset, name, code, path, issued) VALUES (?, ?, ?, '', ?)");
            insert.bind(1, id);
            insert.bind(2, name);
            insert.bind(3, code);
            insert.bind(4, utc_now());
            insert.exec();
            transaction.commit();
            return RecordedName{static_cast<std::uint32_t>(code), true};
        });
}

std::unique_ptr<FamilyKeyStore> Catalog::family_store(const std::string& id,
                                                      std::optional<CatalogAsset> prototype,
                                                      std::optional<ShapeSignature> signature)
{
    return std::make_unique<Impl::KeyStore>(*impl_, id, std::move(prototype), std::move(signature));
}

}  // namespace meshmark
