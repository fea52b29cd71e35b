// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/core/file_lock.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark {

/// The text that names the recipient in an output pattern: `out/{recipient}.glb`.
inline constexpr const char* kRecipientPlaceholder = "{recipient}";

/// Options of embed_recipients: the in-memory embed's (for a new family key) plus the recipients.
struct EmbedRecipientsOptions : EmbedMeshOptions
{
    EmbedRecipientsOptions() { embed.repetitions = kFamilyRepetitions; }  // the owner's mark of a family key

    /// Names to issue a copy to, in order; a name the key already holds gets its copy again,
    /// byte for byte. Each passes check_recipient_name; a name given twice is issued once.
    std::vector<std::string> recipients;
    /// Longest wait for the key while another call issues on it (file_lock.h); then IoError.
    std::chrono::milliseconds lock_timeout = kDefaultLockTimeout;
    int recipient_modes = RecipientCodes{}.modes;            ///< M of a new family key.
    double recipient_share = RecipientCodes{}.energy_share;  ///< Energy share of a new family key.
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
    Key key;                      ///< The family key as written (every recipient so far).
    bool key_created = false;     ///< The key file did not exist before.
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

/// \brief The output path of \p name: \p pattern with every kRecipientPlaceholder replaced.
/// \throws InvalidOption unless \p pattern contains the placeholder.
[[nodiscard]] std::filesystem::path recipient_output(const std::string& pattern, const std::string& name);

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
EmbedRecipientsReport embed_recipients(const std::filesystem::path& input, const std::string& output_pattern,
                                       const std::filesystem::path& key_path, const EmbedRecipientsOptions& options);

}  // namespace meshmark
