// SPDX-License-Identifier: MIT
// The service's bearer token, kept in a private file (docs/service.md).
#pragma once

#include <filesystem>
#include <string>

namespace meshmark::service
{

/// \brief The token in \p path: created (256 random bits in hex, mode 0600) when missing, and
/// then *created is true; refused (IoError) when anyone but its owner may read the file, or when
/// it is shorter than 16 characters.
[[nodiscard]] std::string load_token(const std::filesystem::path& path, bool* created);

}  // namespace meshmark::service
