// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <ostream>

namespace meshmark
{

/// Options of write_file_atomically.
struct AtomicWriteOptions
{
    unsigned permissions = 0644;  ///< Mode of the new file (0600 for key files).
    bool allow_overwrite = true;  ///< When false, an existing file at the target is an error.
};

/// \brief Create the missing folders of \p path's parent (like `mkdir -p`), each made durable
/// (its parent fsync'ed). Nothing to do for a path in the current folder or an existing one.
/// \throws IoError naming \p path and the folder that cannot be created (a file in the way, no
/// permission).
void create_parent_directories(const std::filesystem::path& path);

/// \brief Write a file so that it either appears complete or not at all.
/// \details Creates missing folders of \p path (create_parent_directories), then calls \p write
/// with a stream on a temporary file created next to \p path (same directory, so the final rename
/// is atomic), flushes and fsyncs it, then renames it over \p path and fsyncs the folder: once this
/// returns, the file survives a crash. If \p write throws, or any step fails, the temporary file is
/// removed and nothing at \p path changes. A file is never opened for writing at \p path itself.
/// \throws IoError naming \p path when the directory is not writable or a write fails;
/// exceptions from \p write are passed on after the cleanup.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write,
                           const AtomicWriteOptions& options = {});

/// Which file a path names (device and inode): tells whether a file was replaced since.
struct FileIdentity
{
    std::uint64_t device = 0;
    std::uint64_t inode = 0;
    friend bool operator==(const FileIdentity&, const FileIdentity&) = default;
};

/// The identity of the file at \p path, or {0, 0} when there is none.
[[nodiscard]] FileIdentity file_identity(const std::filesystem::path& path);

/// \brief True when \p a and \p b name the same existing file (after resolving links).
[[nodiscard]] bool is_same_file(const std::filesystem::path& a, const std::filesystem::path& b);

}  // namespace meshmark
