// SPDX-License-Identifier: MIT
// The catalogue's changes of family keys and recipients: each one transaction, begun for its
// asset (catalog_store.h), so that a name gets one code and a code one name however many
// threads and processes record at once.
#include <limits>

#include "catalog/catalog_impl.h"

namespace meshmark
{

using catalog_detail::utc_now;

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
        return impl_.path().string() + " (asset " + id_ + ")";
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
                                 const auto rows =
                                     impl_.query("SELECT key_json FROM assets WHERE id = ?", {id_});
                                 if (rows.empty())
                                 {
                                     return std::nullopt;
                                 }
                                 return parse_key(rows[0][0].as_text(), name());
                             });
    }

    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        const std::lock_guard lock(impl_.mutex);
        const auto start = std::chrono::steady_clock::now();
        return impl_.guarded("record the copies in",
                             [&] {
                                 return in_transaction(*impl_.store, id_,
                                                       [&] { return change_in(start, update); });
                             });
    }

    void delivered(const std::vector<IssuedCopy>& copies) override
    {
        const std::lock_guard lock(impl_.mutex);
        impl_.guarded(
            "record the copies in",
            [&]
            {
                in_transaction(
                    *impl_.store, id_,
                    [&]
                    {
                        bool published = false;
                        for (const IssuedCopy& copy : copies)
                        {
                            impl_.execute(
                                "UPDATE recipients SET delivered = 1, path = ? "
                                "WHERE asset = ? AND name = ?",
                                {std::filesystem::absolute(copy.path).lexically_normal().string(),
                                 id_, copy.name});
                            published = published || copy.name == kPublishedRecipient;
                        }
                        if (published)
                        {
                            impl_.execute("UPDATE assets SET complete = 1 WHERE id = ?", {id_});
                        }
                    });
            });
    }

private:
    // change()'s work, in its transaction: what it waited for that transaction, in seconds.
    double change_in(std::chrono::steady_clock::time_point start,
                     const std::function<std::optional<Key>(std::optional<Key>)>& update)
    {
        const double waited =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::optional<Key> now;
        const auto rows = impl_.query("SELECT key_json FROM assets WHERE id = ?", {id_});
        if (!rows.empty())
        {
            now = impl_.key_of(id_, rows[0][0].as_text());
        }
        if (!now && !prototype_)
        {
            throw InvalidOption(impl_.path().string() + ": no asset '" + id_ +
                                "' in the catalogue.");
        }
        const std::size_t before = now && now->recipients ? now->recipients->recipients.size() : 0;
        const std::optional<Key> changed = update(now);
        if (!changed)
        {
            return waited;
        }
        if (!now)
        {
            const CatalogAsset& a = *prototype_;
            impl_.execute(
                "INSERT INTO assets(id, original, original_sha256, published, key_json, "
                "vertex_count, face_count, added, complete, shape) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, 0, ?)",
                {id_, a.original.string(), a.original_sha256, a.published.string(),
                 Impl::stored_json(*changed), a.vertex_count, a.face_count, utc_now(),
                 Value::blob(signature_ ? signature_->to_bytes() : std::vector<std::uint8_t>{})});
        }
        else
        {
            impl_.execute("UPDATE assets SET key_json = ? WHERE id = ?",
                          {Impl::stored_json(*changed), id_});
        }
        // The names this change gave a code (the key's recipients past those it held); each its
        // path once delivered.
        const std::string issued = utc_now();
        const auto& all = changed->recipients->recipients;
        for (std::size_t r = before; r < all.size(); ++r)
        {
            impl_.execute(
                "INSERT INTO recipients(asset, name, code, path, issued) "
                "VALUES (?, ?, ?, '', ?)",
                {id_, all[r].name, static_cast<std::int64_t>(all[r].index), issued});
        }
        return waited;
    }

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
                              const auto rows = impl_->query(
                                  "SELECT code FROM recipients WHERE asset = ? AND name = ?",
                                  {id, name});
                              if (rows.empty())
                              {
                                  return std::nullopt;
                              }
                              return static_cast<std::uint32_t>(rows[0][0].as_int());
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
            auto find = [&]() -> std::optional<std::uint32_t>
            {
                const auto rows = impl_->query(
                    "SELECT code FROM recipients WHERE asset = ? AND name = ?", {id, name});
                if (rows.empty())
                {
                    return std::nullopt;
                }
                return static_cast<std::uint32_t>(rows[0][0].as_int());
            };
            if (const std::optional<std::uint32_t> code = find())
            {
                return RecordedName{*code, false};  // known: nothing to write
            }
            return in_transaction(
                *impl_->store, id,
                [&]
                {
                    const auto asset =
                        impl_->query("SELECT complete FROM assets WHERE id = ?", {id});
                    if (asset.empty())
                    {
                        throw InvalidOption(path().string() + ": no asset '" + id +
                                            "' in the catalogue.");
                    }
                    if (asset[0][0].as_int() == 0)
                    {
                        throw InvalidOption(path().string() + ": asset '" + id +
                                            "' was interrupted while being added; run `meshmark "
                                            "catalog add` again.");
                    }
                    // recorded by another process meanwhile
                    if (const std::optional<std::uint32_t> code = find())
                    {
                        return RecordedName{*code, false};
                    }
                    const std::int64_t code =
                        impl_
                            ->query(
                                "SELECT COALESCE(MAX(code) + 1, 0) FROM recipients "
                                "WHERE asset = ?",
                                {id})[0][0]
                            .as_int();
                    if (code >=
                        static_cast<std::int64_t>(std::numeric_limits<std::uint32_t>::max()))
                    {
                        throw InvalidOption(path().string() + ": asset '" + id +
                                            "' holds as many recipients as it can.");
                    }
                    impl_->execute(
                        "INSERT INTO recipients(asset, name, code, path, issued) "
                        "VALUES (?, ?, ?, '', ?)",
                        {id, name, code, utc_now()});
                    return RecordedName{static_cast<std::uint32_t>(code), true};
                });
        });
}

std::unique_ptr<FamilyKeyStore> Catalog::family_store(const std::string& id,
                                                      std::optional<CatalogAsset> prototype,
                                                      std::optional<ShapeSignature> signature)
{
    return std::make_unique<Impl::KeyStore>(*impl_, id, std::move(prototype), std::move(signature));
}

}  // namespace meshmark
