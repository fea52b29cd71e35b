// SPDX-License-Identifier: MIT
// The catalogue: opening it, reading it, migrating it, each change one transaction, on the
// storage of its location (catalog_store.h: an SQLite file, or a PostgreSQL database for a
// `postgresql://` location). The changes of keys and recipients: catalog_recipients.cpp.
#include "meshmark/catalog/catalog.h"

#include <optional>

#include "catalog/catalog_impl.h"

namespace meshmark
{

using catalog_detail::kAssetColumns;
using catalog_detail::kRecipientColumns;

namespace
{

constexpr const char* kFormat = "meshmark-catalog";
constexpr int kVersion = 3;
/// meta row naming how the stored signatures read their originals' polygons: missing in a
/// catalogue an older build wrote (its OBJ, OFF and PLY readers fanned every polygon from its
/// first corner), "filled" since polygons that are not convex are triangulated inside.
constexpr const char* kPolygonsMeta = "signature_polygons";
constexpr const char* kPolygonsCurrent = "filled";

}  // namespace

std::int64_t catalog_store::Value::as_int() const
{
    return type == Type::Integer ? integer : std::stoll(bytes);
}

void Catalog::Impl::open(Open mode) const
{
    const std::string name = path().string();
    const bool has_meta = store->has_table("meta");
    if (!has_meta && store->has_table("assets"))
    {
        throw IoError(name + ": this database is not a meshmark catalogue.");
    }
    if (!has_meta)
    {
        if (!store->is_empty())
        {
            throw IoError(name + ": this database is not a meshmark catalogue.");
        }
        if (mode == Open::Existing && store->empty_is_missing())
        {
            throw IoError(name +
                          ": no catalogue in this database (create one with `meshmark "
                          "catalog add` or `meshmark catalog migrate`).");
        }
        store->create_schema();
        execute("INSERT INTO meta(name, value) VALUES (?, ?)", {"format", kFormat});
        execute("INSERT INTO meta(name, value) VALUES (?, ?)",
                {"version", std::to_string(kVersion)});
        execute("INSERT INTO meta(name, value) VALUES (?, ?)", {kPolygonsMeta, kPolygonsCurrent});
        return;
    }
    const auto value = [&](const char* key) -> std::string
    {
        const auto rows = query("SELECT value FROM meta WHERE name = ?", {key});
        return rows.empty() ? std::string() : rows[0][0].as_text();
    };
    const std::string version = value("version");
    if (value("format") != kFormat || version.empty())
    {
        throw IoError(name + ": this database is not a meshmark catalogue.");
    }
    if (std::stoi(version) > kVersion)
    {
        throw IoError(name + ": the catalogue is format version " + version +
                      ", newer than this meshmark reads (" + std::to_string(kVersion) + ").");
    }
    if (std::stoi(version) == 1)
    {
        migrate_from_v1();
    }
    if (std::stoi(version) <= 2)
    {
        // Version 3 adds the points' section to new signatures: older builds must not read
        // them as damaged. Signatures without it stay valid (`catalog reindex` adds it).
        execute("UPDATE meta SET value = ? WHERE name = 'version'", {std::to_string(kVersion)});
    }
}

Catalog::Catalog(std::filesystem::path path, Open mode, std::chrono::milliseconds busy_timeout)
    : impl_(std::make_unique<Impl>())
{
    const std::string location = path.string();
    const bool postgres = catalog_store::is_postgres_location(location);
    const std::string shown = catalog_store::without_password(location);
    try
    {
        impl_->store = postgres ? catalog_store::open_postgres(location, busy_timeout)
                                : catalog_store::open_sqlite(path, mode == Open::CreateIfMissing,
                                                             busy_timeout);
    }
    catch (const catalog_store::StoreError& e)
    {
        throw IoError(shown + ": cannot open the catalogue (" + e.what() + ").");
    }
    impl_->guarded("open", [&] { in_transaction(*impl_->store, "", [&] { impl_->open(mode); }); });
}

Catalog::~Catalog() = default;

const std::filesystem::path& Catalog::path() const noexcept
{
    return impl_->path();
}

std::optional<CatalogAsset> Catalog::asset(const std::string& id) const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]() -> std::optional<CatalogAsset>
        {
            const auto rows = impl_->query(
                std::string("SELECT ") + kAssetColumns + " FROM assets WHERE id = ?", {id});
            if (rows.empty())
            {
                return std::nullopt;
            }
            return impl_->asset_of(rows[0]);
        });
}

std::vector<CatalogAsset> Catalog::assets() const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded(
        "read",
        [&]
        {
            std::vector<CatalogAsset> all;
            for (const Row& row :
                 impl_->query(std::string("SELECT ") + kAssetColumns + " FROM assets ORDER BY id"))
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
            const std::string sql =
                std::string(
                    "SELECT a.id, a.original_sha256, a.vertex_count, a.face_count, "
                    "a.added, a.complete, "
                    "(SELECT count(*) FROM recipients r WHERE r.asset = a.id) "
                    "FROM assets a") +
                (id ? " WHERE a.id = ?" : " ORDER BY a.id");
            for (const Row& row :
                 impl_->query(sql, id ? std::vector<Value>{*id} : std::vector<Value>{}))
            {
                all.push_back({row[0].as_text(), row[1].as_text(), row[2].as_int(), row[3].as_int(),
                               row[4].as_text(), row[5].as_int() != 0, row[6].as_int()});
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
            for (const Row& row : impl_->query("SELECT name, code, path, delivered, issued FROM "
                                               "recipients WHERE asset = ? ORDER BY code",
                                               {id}))
            {
                all.push_back({row[0].as_text(), static_cast<std::uint32_t>(row[1].as_int()),
                               row[2].as_text(), row[3].as_int() != 0, row[4].as_text()});
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
                impl_->query("SELECT count(*) FROM assets WHERE complete = 1")[0][0].as_int());
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
            for (const Row& row :
                 impl_->query("SELECT id, shape, vertex_count, face_count FROM assets ORDER BY id"))
            {
                const std::size_t size = row[1].bytes.size();
                constexpr auto kViews = static_cast<std::size_t>(kShapeViews * kShapeFeatures);
                // A signature of this build (views and points), of older ones (the views alone;
                // the positions' features alone), or none.
                if (size != 0 && size != kViews && size != kViews + kShapePointBytes &&
                    size != static_cast<std::size_t>(kShapeViews * kShapePositionFeatures))
                {
                    throw IoError(path().string() + ": the shape signature of asset '" +
                                  row[0].as_text() + "' is damaged (" + std::to_string(size) +
                                  " bytes).");
                }
                entries.push_back(index_entry(row[0].as_text(), row[1].as_blob(), row[2].as_int(),
                                              row[3].as_int()));
            }
            return entries;
        });
}

Catalog::IndexEntry index_entry(std::string id, std::vector<std::uint8_t> stored,
                                std::int64_t vertex_count, std::int64_t face_count)
{
    constexpr auto kViews = static_cast<std::size_t>(kShapeViews * kShapeFeatures);
    Catalog::IndexEntry entry{std::move(id), std::move(stored), vertex_count, face_count, {}};
    if (entry.views.size() == kViews + kShapePointBytes)
    {
        entry.points.assign(entry.views.begin() + static_cast<std::ptrdiff_t>(kViews),
                            entry.views.end());
        entry.views.resize(kViews);
    }
    return entry;
}

void Catalog::set_shape(const std::string& id, const ShapeSignature& signature)
{
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded("change",
                   [&]
                   {
                       in_transaction(
                           *impl_->store, id,
                           [&]
                           {
                               if (impl_->execute("UPDATE assets SET shape = ? WHERE id = ?",
                                                  {Value::blob(signature.to_bytes()), id}) == 0)
                               {
                                   throw InvalidOption(path().string() + ": no asset '" + id +
                                                       "' in the catalogue.");
                               }
                           });
                   });
}

void Catalog::remove(const std::string& id)
{
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded("change",
                   [&]
                   {
                       in_transaction(*impl_->store, id,
                                      [&]
                                      {
                                          // (the recipients too: ON DELETE CASCADE)
                                          impl_->execute("DELETE FROM assets WHERE id = ?", {id});
                                      });
                   });
}

bool Catalog::has_stale_signatures() const
{
    const std::lock_guard lock(impl_->mutex);
    return impl_->guarded("read",
                          [&]
                          {
                              const auto rows = impl_->query(
                                  "SELECT value FROM meta WHERE name = ?", {kPolygonsMeta});
                              return rows.empty() || rows[0][0].as_text() != kPolygonsCurrent;
                          });
}

void Catalog::set_signatures_stale(bool stale)
{
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded("record the signatures' state in",
                   [&]
                   {
                       impl_->execute("DELETE FROM meta WHERE name = ?", {kPolygonsMeta});
                       if (!stale)
                       {
                           impl_->execute("INSERT INTO meta(name, value) VALUES (?, ?)",
                                          {kPolygonsMeta, kPolygonsCurrent});
                       }
                   });
}

std::size_t Catalog::copy_from(const Catalog& source)
{
    // Read first (source and destination may not be locked in either order by two calls).
    std::vector<Row> assets;
    std::vector<Row> recipients;
    std::vector<Row> polygons;  // the signatures' state goes with them
    {
        const std::lock_guard lock(source.impl_->mutex);
        source.impl_->guarded(
            "read",
            [&]
            {
                // One snapshot of both tables (a change meanwhile waits).
                in_transaction(
                    *source.impl_->store, "",
                    [&]
                    {
                        assets = source.impl_->query(std::string("SELECT ") + kAssetColumns +
                                                     " FROM assets ORDER BY id");
                        recipients =
                            source.impl_->query(std::string("SELECT ") + kRecipientColumns +
                                                " FROM recipients ORDER BY asset, code");
                        polygons = source.impl_->query("SELECT value FROM meta WHERE name = ?",
                                                       {kPolygonsMeta});
                    });
            });
    }
    const std::lock_guard lock(impl_->mutex);
    impl_->guarded(
        "copy the assets into",
        [&]
        {
            in_transaction(
                *impl_->store, "",
                [&]
                {
                    if (impl_->query("SELECT count(*) FROM assets")[0][0].as_int() != 0)
                    {
                        throw InvalidOption(path().string() +
                                            ": the catalogue already holds assets; migrate into "
                                            "a new one.");
                    }
                    for (const Row& row : assets)
                    {
                        impl_->execute(std::string("INSERT INTO assets(") + kAssetColumns +
                                           ") VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                                       row);
                    }
                    for (const Row& row : recipients)
                    {
                        impl_->execute(std::string("INSERT INTO recipients(") + kRecipientColumns +
                                           ") VALUES (?, ?, ?, ?, ?, ?)",
                                       row);
                    }
                    impl_->execute("DELETE FROM meta WHERE name = ?", {kPolygonsMeta});
                    if (!polygons.empty())
                    {
                        impl_->execute("INSERT INTO meta(name, value) VALUES (?, ?)",
                                       {kPolygonsMeta, polygons[0][0].as_text()});
                    }
                });
        });
    return assets.size();
}

}  // namespace meshmark
