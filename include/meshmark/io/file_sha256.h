// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace meshmark
{

/// \brief The SHA-256 of \p path's bytes, in lower-case hex (OpenSSL's libcrypto), read in
/// blocks of 1 MiB (what `sha256sum` prints): how a catalogue knows an original is unchanged,
/// how an embed record commits to its files and how an evidence report names them.
/// \throws IoError when the file cannot be opened or read.
[[nodiscard]] std::string file_sha256(const std::filesystem::path& path);

/// \brief The SHA-256 of \p bytes, in lower-case hex: a file's before it is written (the key of
/// a catalogue's asset as `catalog export` writes it).
[[nodiscard]] std::string bytes_sha256(std::string_view bytes);

}  // namespace meshmark
