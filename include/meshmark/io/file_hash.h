// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace meshmark {

/// \brief The SHA-256 of a file's bytes, as 64 lowercase hex digits (what `sha256sum` prints).
/// \details Read in 1 MiB chunks through OpenSSL's libcrypto (EVP); the file is never written.
/// \throws IoError naming the file when it cannot be opened or read.
[[nodiscard]] std::string sha256_of_file(const std::filesystem::path& path);

}  // namespace meshmark
