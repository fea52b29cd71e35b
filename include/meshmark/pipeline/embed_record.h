// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "meshmark/watermark/key.h"

namespace meshmark
{

/// One file of an embed record: its name as given, its size and its SHA-256.
struct RecordedFile
{
    std::string file;  ///< The path as given on the command line.
    std::uint64_t bytes = 0;
    std::string sha256;  ///< 64 lowercase hex digits, as `sha256sum` prints them.
};

/// \brief What an embed did, in a form a third party can check later without the key
/// (docs/evidence.md, "The embed record"): when, with which tool, and the SHA-256 of the
/// original, of the marked copy and of the key file as written.
/// \details The key file's hash is a commitment: it reveals nothing of the key (seed, payload,
/// parameters), yet once the owner shows the key file, anyone can check it is the one
/// recorded. The original's fingerprint the key holds (vertex and face counts, a hash of the
/// positions, no secret) ties the key to the original's geometry. Timestamped by a third
/// party (an RFC 3161 authority), the record shows the mark and its key existed at that time.
struct EmbedRecord
{
    std::string created_utc;   ///< ISO 8601, seconds, "Z" (when the record was made).
    std::string tool_version;  ///< "meshmark 0.1.0".
    RecordedFile original;
    RecordedFile marked;
    RecordedFile key;
    MeshFingerprint original_fingerprint;  ///< As recorded in the key (Key::original).
};

/// \brief \p path's size and SHA-256 as it is on disk now (RecordedFile::file: \p path as given).
/// \throws IoError naming the file when it cannot be read.
[[nodiscard]] RecordedFile recorded_file(const std::filesystem::path& path);

/// \brief The record of an embed whose files exist now: hashes of \p input, \p output and
/// \p key_path as they are on disk, the UTC time now, and \p key's original fingerprint (its
/// only part used).
/// \param original  If not null, the original as recorded_file() hashed it before the embed:
///                  an embed in place has replaced \p input with the marked copy by now.
/// \throws IoError naming a file that cannot be read.
[[nodiscard]] EmbedRecord make_embed_record(const std::filesystem::path& input,
                                            const std::filesystem::path& output,
                                            const std::filesystem::path& key_path, const Key& key,
                                            const RecordedFile* original = nullptr);

/// \brief The record as JSON: `format` ("meshmark-embed-record"), `version` (1), `created_utc`,
/// `tool`, `original` / `marked` / `key` (each `file`, `bytes`, `sha256`),
/// `original_fingerprint` (`vertex_count`, `face_count`, `position_hash`). Never the key's seed,
/// payload or parameters.
[[nodiscard]] nlohmann::json to_json(const EmbedRecord& record);

/// \brief Write \p record as indented JSON to \p path, atomically (missing folders created).
/// \throws IoError when it cannot be written.
void write_embed_record(const std::filesystem::path& path, const EmbedRecord& record);

}  // namespace meshmark
