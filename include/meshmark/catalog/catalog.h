// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/file_lock.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/watermark/key.h"

namespace meshmark
{

/// The recipient name of an asset's published copy (the one `catalog add` writes).
inline constexpr const char* kPublishedRecipient = "published";

/// One asset of a catalogue.
struct CatalogAsset
{
    std::string id;                   ///< Its name: the path under the folder it was added from.
    std::filesystem::path original;   ///< The original file (absolute).
    std::string original_sha256;      ///< The original's bytes' SHA-256, in hex.
    std::filesystem::path published;  ///< The published marked copy (absolute).
    Key key;                          ///< Its family key, every recipient so far.
    std::int64_t vertex_count = 0;
    std::int64_t face_count = 0;
    std::string added;         ///< When it was recorded (UTC, ISO 8601).
    bool is_complete = false;  ///< The published copy is written (false: an interrupted add).
};

/// One recipient's copy of an asset, as recorded.
struct CatalogRecipient
{
    std::string name;
    std::uint32_t index = 0;     ///< Its code's index in the family key.
    std::filesystem::path path;  ///< Where its copy was written.
    bool is_delivered = false;   ///< The copy was written (false: recorded, then interrupted).
    std::string issued;          ///< When it was recorded (UTC, ISO 8601).
};

/// \brief A catalogue of marked assets: an SQLite database holding each asset's original
/// (location and SHA-256), its key, its recipients and its shape (docs/catalog.md); or a
/// PostgreSQL database, for a location `postgresql://...` (docs/catalog.md, "On PostgreSQL").
/// \details The file is created mode 0600 (it holds keys). Every change is one transaction,
/// committed durably (WAL, synchronous=FULL) before anything it records is written elsewhere;
/// other processes wait up to the busy timeout for a transaction in progress. One Catalog may
/// be used from several threads (its connection is serialized).
class Catalog
{
public:
    enum class Open
    {
        CreateIfMissing,  ///< `catalog add`
        Existing,         ///< every other command: a missing file is an error
    };

    /// \param path a file, or a PostgreSQL connection URI (`postgresql://user@host:port/db`):
    /// its database must exist; CreateIfMissing makes the catalogue's tables in an empty one.
    /// \throws IoError (cannot create or open it, not a meshmark catalogue, a newer format).
    explicit Catalog(std::filesystem::path path, Open mode = Open::Existing,
                     std::chrono::milliseconds busy_timeout = kDefaultLockTimeout);
    ~Catalog();
    Catalog(const Catalog&) = delete;
    Catalog& operator=(const Catalog&) = delete;
    Catalog(Catalog&&) = delete;
    Catalog& operator=(Catalog&&) = delete;

    /// Its location as shown in messages and JSON (a PostgreSQL URL without its password).
    [[nodiscard]] const std::filesystem::path& path() const noexcept;

    /// The asset \p id, if recorded (complete or not).
    [[nodiscard]] std::optional<CatalogAsset> asset(const std::string& id) const;
    /// Every asset, complete or not, by id.
    [[nodiscard]] std::vector<CatalogAsset> assets() const;
    /// What a listing shows of an asset, without its key (read in one query for all).
    struct Summary
    {
        std::string id;
        std::string original_sha256;
        std::int64_t vertex_count = 0;
        std::int64_t face_count = 0;
        std::string added;
        bool is_complete = false;
        std::int64_t recipients = 0;  ///< Names recorded, the published copy's included.
    };
    /// Every asset's summary, by id; or the one of \p id (empty when there is none).
    [[nodiscard]] std::vector<Summary> summaries(
        const std::optional<std::string>& id = std::nullopt) const;
    /// The recipients of \p id, by code index.
    [[nodiscard]] std::vector<CatalogRecipient> recipients(const std::string& id) const;
    /// Number of complete assets.
    [[nodiscard]] std::size_t complete_count() const;

    /// \brief An entry of the shape index: an asset and its signature as stored
    /// (ShapeSignature::to_bytes: kShapeFeatures bytes a view, each feature times 255;
    /// kShapePositionFeatures in a catalogue of an older build), kept in that form so that
    /// 100,000 assets take 771 MB, not four times as much.
    struct IndexEntry
    {
        std::string id;
        std::vector<std::uint8_t> views;
        std::int64_t vertex_count = 0;  ///< the original's (a copy in its numbering has as many)
        std::int64_t face_count = 0;
        /// The signature's points' section (ShapeSignature::points_from_bytes); empty when the
        /// signature was stored before points were kept (`catalog reindex` adds them).
        std::vector<std::uint8_t> points;
    };
    /// The shape index of every recorded asset, an interrupted add's included: its key is
    /// recorded before its copy is written, so a copy the interruption left on disk is traced.
    [[nodiscard]] std::vector<IndexEntry> shape_index() const;
    /// \brief Whether the stored signatures may have been computed by a build whose readers
    /// fanned polygons that are not convex (a catalogue written before they were triangulated
    /// inside): `catalog reindex` recomputes them all, then clears it.
    [[nodiscard]] bool has_stale_signatures() const;
    /// Record whether the stored signatures are stale (catalog_reindex, copy_from's callers).
    void set_signatures_stale(bool stale);
    /// \brief Store \p signature as asset \p id's shape (catalog_reindex), in one transaction.
    /// \throws InvalidOption when there is no such asset.
    void set_shape(const std::string& id, const ShapeSignature& signature);

    /// \brief The family key of asset \p id as a FamilyKeyStore (embed_recipients): change()
    /// is one immediate transaction. A store for a new asset (\p prototype given) records the
    /// asset, with \p signature, in the transaction that creates its key; a store of an existing
    /// asset refuses one that is not complete. delivered() records the copies as written, and
    /// the asset as complete once its published copy is.
    [[nodiscard]] std::unique_ptr<FamilyKeyStore> family_store(
        const std::string& id, std::optional<CatalogAsset> prototype = std::nullopt,
        std::optional<ShapeSignature> signature = std::nullopt);

    /// A recipient's code index, and whether this call recorded it.
    struct RecordedName
    {
        std::uint32_t index = 0;
        bool is_new = false;
    };
    /// \brief The code index of recipient \p name of asset \p id: the one recorded, or the next
    /// free one, recorded durably (one committed transaction) before this returns. Any number of
    /// threads and processes may record at once: a name gets one index, an index one name.
    /// \throws InvalidOption (a bad name, no such asset, an incomplete one, the key full),
    /// IoError (the catalogue stayed busy or cannot be written).
    [[nodiscard]] RecordedName record_recipient(const std::string& id, const std::string& name);
    /// The code index of recipient \p name of asset \p id when recorded (a read: no waiting on
    /// the disk).
    [[nodiscard]] std::optional<std::uint32_t> recipient_index(const std::string& id,
                                                               const std::string& name) const;

    /// Remove asset \p id and its recipients (`catalog add --force` re-marking a changed original).
    void remove(const std::string& id);

    /// \brief Copy every asset of \p source (its key, recipients and shape, as stored) into this
    /// catalogue, in one transaction (`catalog migrate`); the number of assets copied.
    /// \throws InvalidOption when this catalogue already holds assets; IoError.
    std::size_t copy_from(const Catalog& source);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// \brief An index entry of a signature as stored (ShapeSignature::to_bytes): the views, and the
/// points' section apart when it is there.
[[nodiscard]] Catalog::IndexEntry index_entry(std::string id, std::vector<std::uint8_t> stored,
                                              std::int64_t vertex_count = 0,
                                              std::int64_t face_count = 0);

}  // namespace meshmark
