// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

// Zip containers (3MF packages) in memory through libzip (Debian libzip-dev).
struct zip;

namespace meshmark::detail
{

/// A zip archive opened read-only on bytes in memory; errors name \p path.
class ZipArchive
{
public:
    /// \p bytes must outlive the archive (libzip reads them in place).
    /// \throws IoError when the bytes are not a zip archive.
    ZipArchive(const std::filesystem::path& path, const std::string& bytes);
    ZipArchive(const ZipArchive&) = delete;
    ZipArchive& operator=(const ZipArchive&) = delete;
    ~ZipArchive();

    /// The entry named \p name, compared exactly first and then ignoring ASCII case (OPC part
    /// names are case-insensitive); nullopt when there is none.
    [[nodiscard]] std::optional<std::uint64_t> find(const std::string& name) const;

    /// \brief The uncompressed content of entry \p index.
    /// \throws IoError when its declared size exceeds \p max_bytes (checked before anything is
    /// decompressed), when it cannot be decompressed, or when its data do not match the
    /// declared size and CRC.
    [[nodiscard]] std::string read(std::uint64_t index, std::uint64_t max_bytes) const;

    /// The name of entry \p index as stored.
    [[nodiscard]] std::string name(std::uint64_t index) const;

    /// Declared uncompressed size of entry \p index.
    [[nodiscard]] std::uint64_t size(std::uint64_t index) const;

private:
    const std::filesystem::path& path_;
    struct zip* archive_ = nullptr;
};

/// \brief \p bytes (a zip archive) with the content of each named entry replaced.
/// \details The replaced entries keep their name, position, compression method (deflate when
/// libzip cannot write the original method) and modification time; every other entry is copied
/// by libzip with its compressed bytes as they are.
[[nodiscard]] std::string replace_zip_entries(
    const std::filesystem::path& path, const std::string& bytes,
    const std::vector<std::pair<std::string, std::string>>& contents);

/// A new zip archive holding \p entries (name, content) in this order, deflated.
[[nodiscard]] std::string new_zip(const std::filesystem::path& path,
                                  const std::vector<std::pair<std::string, std::string>>& entries);

}  // namespace meshmark::detail
