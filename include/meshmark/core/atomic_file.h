// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>

namespace meshmark {

/// Options of write_file_atomically.
struct AtomicWriteOptions
{
    unsigned permissions = 0644;  ///< Mode of the new file (0600 for key files).
    bool allow_overwrite = true;  ///< When false, an existing file at the target is an error.
};

/// \brief Write a file so that it either appears complete or not at all.
/// \details Calls \p write with a stream on a temporary file created next to \p path (same
/// directory, so the final rename is atomic), flushes and fsyncs it, then renames it over
/// \p path. If \p write throws, or any step fails, the temporary file is removed and nothing
/// at \p path changes. A file is never opened for writing at \p path itself.
/// \throws IoError naming \p path when the directory is not writable or a write fails;
/// exceptions from \p write are passed on after the cleanup.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write,
                           const AtomicWriteOptions& options = {});

/// \brief True when \p a and \p b name the same existing file (after resolving links).
[[nodiscard]] bool is_same_file(const std::filesystem::path& a, const std::filesystem::path& b);

}  // namespace meshmark
