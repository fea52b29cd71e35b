// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>

namespace meshmark {

/// \brief The SHA-256 of \p path's bytes, in lower-case hex (OpenSSL's libcrypto), read in
/// blocks of 1 MiB (what `sha256sum` prints): how a catalogue knows an original is unchanged,
/// how an embed record commits to its files and how an evidence report names them.
/// \throws IoError when the file cannot be opened or read.
[[nodiscard]] std::string file_sha256(const std::filesystem::path& path);

}  // namespace meshmark
