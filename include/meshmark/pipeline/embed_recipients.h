// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/file_lock.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// The text that names the recipient in an output pattern: `out/{recipient}.glb`.
inline constexpr const char* kRecipientPlaceholder = "{recipient}";

/// Options of embed_recipients: the in-memory embed's (for a new family key) plus the recipients.
struct EmbedRecipientsOptions : EmbedMeshOptions
{
    EmbedRecipientsOptions()
    {
        embed.repetitions = kFamilyRepetitions;
    }  // the owner's mark of a family key

    /// Names to issue a copy to, in order; a name the key already holds gets its copy again,
    /// byte for byte. Each passes check_recipient_name; a name given twice is issued once.
    std::vector<std::string> recipients;
    /// Longest wait for the key while another call issues on it (file_lock.h); then IoError.
    std::chrono::milliseconds lock_timeout = kDefaultLockTimeout;
    int recipient_modes = RecipientCodes{}.modes;            ///< M of a new family key.
    double recipient_share = RecipientCodes{}.energy_share;  ///< Energy share of a new family key.
    /// Where a copy written at a path will be read from, when not there (a cluster worker
    /// stages copies: WriteOptions::link_folder); empty: where it is written.
    std::function<std::filesystem::path(const std::filesystem::path&)> link_folder;
    /// \throws InvalidOption on bad or missing names, a negative lock timeout and the in-memory
    /// embed's errors.
    void validate() const;
};

/// One copy embed_recipients wrote.
struct IssuedCopy
{
    std::string name;
    std::uint32_t index = 0;
    std::filesystem::path path;
    bool is_new = false;  ///< A recipient the key did not hold before this call.
    EmbedStats stats;     ///< The copy's displacement (owner's mark and its code together).
};

/// What embed_recipients did.
struct EmbedRecipientsReport
{
    Key key;                   ///< The family key as written (every recipient so far).
    bool key_created = false;  ///< The key file did not exist before.
    std::vector<IssuedCopy> copies;
    MeshFormat input_format = MeshFormat::Ply;
    std::int64_t vertex_count = 0;
    std::int64_t face_count = 0;
    /// Phases "read", "basis" (the watermark, the owner's field and the code modes, and
    /// recording the names in the key) and "copies"; then "codes" and "write", the parts of
    /// "copies" spent on the codes' fields and on writing, and "lock", the part of "basis"
    /// spent waiting for the key's lock.
    PhaseTimings seconds;
};

/// \brief Where a family key is kept, and how it changes: its own key file (embed_recipients
/// with a key path) or a catalogue's record (catalog/catalog.h).
/// \details change() is the one step in which names get their codes: every other call issuing
/// on the same key waits for it (a file lock, a database transaction), and the key it stores is
/// durable before change() returns, so copies written afterwards are traced. peek() may return
/// a key that is already out of date: only its parameters are used (a family key's never change).
class FamilyKeyStore
{
public:
    FamilyKeyStore() = default;
    FamilyKeyStore(const FamilyKeyStore&) = delete;
    FamilyKeyStore& operator=(const FamilyKeyStore&) = delete;
    FamilyKeyStore(FamilyKeyStore&&) = delete;
    FamilyKeyStore& operator=(FamilyKeyStore&&) = delete;
    virtual ~FamilyKeyStore() = default;
    /// Names the key in messages (its path).
    [[nodiscard]] virtual std::string name() const = 0;
    /// The end of the message refusing a single owner's key: what to do instead.
    [[nodiscard]] virtual std::string single_owner_advice() const = 0;
    /// The key as stored now, without waiting; none when there is none yet.
    [[nodiscard]] virtual std::optional<Key> peek() const = 0;
    /// \brief Exclusively: \p update receives the key as stored now (none yet: std::nullopt)
    /// and returns the key to store, or std::nullopt to leave it. Returns the seconds spent
    /// waiting for other calls. \throws IoError (the wait expired, the store failed).
    virtual double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) = 0;
    /// Called once every copy of \p copies is written.
    virtual void delivered(const std::vector<IssuedCopy>& copies) { (void)copies; }
};

/// \brief The output path of \p name: \p pattern with every kRecipientPlaceholder replaced.
/// \throws InvalidOption unless \p pattern contains the placeholder.
[[nodiscard]] std::filesystem::path recipient_output(const std::string& pattern,
                                                     const std::string& name);

/// \brief The copies of \p names (each given once), each with its code's index: the family
/// key's for a name it holds, the next free one for a new name (added to \p key, is_new set);
/// paths from \p output_of. What embed_recipients records; catalog_plan_issue's too.
/// \throws InvalidOption when the key holds as many recipients as it can.
[[nodiscard]] std::vector<IssuedCopy> assign_recipient_indices(
    Key& key, const std::vector<std::string>& names,
    const std::function<std::filesystem::path(const std::string&)>& output_of);

/// \brief Names from a recipients file (`--recipients`, the Python package's recipients_file):
/// one per line; blank lines and lines starting with '#' skipped, spaces around a name dropped.
/// \throws IoError when it cannot be opened or read.
[[nodiscard]] std::vector<std::string> read_recipients_file(const std::filesystem::path& path);

/// \brief Issue one marked copy of \p input per recipient (docs/fingerprinting.md).
/// \details With no file at \p key_path a new family key is made (seed, payload and embedding
/// options as for embed_file, plus the recipients' modes and energy share); with a family key
/// there, its parameters decide everything and \p input must be its original (fingerprint).
/// New names get the next free indices. The watermark's basis and the owner's field are built
/// once; each copy then costs its code's field (M modes) and its write, in the format of its
/// extension (everything but positions preserved when that is the input's), missing folders
/// created.
///
/// Any number of calls, in processes or threads, may issue on one key at once: the key is read,
/// given the new names' indices and written durably in one step under its lock (FileLock;
/// a call waits up to lock_timeout for it), before any copy is made. So every name gets its own
/// code, a name issued by several calls gets one index and the same bytes, and a copy is never
/// visible before the key records its recipient. On a failure after that the copies this call
/// created are removed; the names stay recorded (a recorded name without a copy accuses
/// nobody), and a later call issues them again, byte for byte.
/// \throws InvalidOption (bad names or options, pattern without the placeholder, an output
/// naming the input or the key, the Laplacian basis or paper rule), IoError (unreadable input,
/// a key that is not a family key or belongs to another original, unwritable outputs, the
/// lock's wait expired),
/// InvalidMesh, NumericalError.
EmbedRecipientsReport embed_recipients(const std::filesystem::path& input,
                                       const std::string& output_pattern,
                                       const std::filesystem::path& key_path,
                                       const EmbedRecipientsOptions& options);

/// \brief embed_recipients with the key kept in \p store and copy paths given by \p output_of
/// (a catalogue's issuing). \p given, when not null, is \p input already read (what
/// read_mesh_file returned); \p input then only names it in messages. Same steps and errors.
EmbedRecipientsReport embed_recipients(
    const std::filesystem::path& input, const MeshFile* given,
    const std::function<std::filesystem::path(const std::string&)>& output_of,
    FamilyKeyStore& store, const EmbedRecipientsOptions& options);

}  // namespace meshmark
