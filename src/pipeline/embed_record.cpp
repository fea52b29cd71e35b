// SPDX-License-Identifier: MIT
// The embed record: a commitment to the original, the marked copy and the key, for a
// third party's timestamp (docs/evidence.md).
#include "meshmark/pipeline/embed_record.h"

#include <chrono>
#include <cstdio>
#include <ctime>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/file_sha256.h"

#ifndef MESHMARK_VERSION
#error "MESHMARK_VERSION is set by src/pipeline/CMakeLists.txt"
#endif

namespace meshmark
{

RecordedFile recorded_file(const std::filesystem::path& path)
{
    std::error_code error;
    const auto size = std::filesystem::file_size(path, error);
    if (error)
    {
        throw IoError(path.string() + ": cannot read the file's size for the embed record (" +
                      error.message() + ").");
    }
    return {path.string(), static_cast<std::uint64_t>(size), file_sha256(path)};
}

namespace
{

std::string utc_now()
{
    const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

std::string hex64(std::uint64_t value)
{
    char text[24];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
    return text;
}

nlohmann::json file_json(const RecordedFile& file)
{
    return {{"file", file.file}, {"bytes", file.bytes}, {"sha256", file.sha256}};
}

}  // namespace

EmbedRecord make_embed_record(const std::filesystem::path& input,
                              const std::filesystem::path& output,
                              const std::filesystem::path& key_path, const Key& key,
                              const RecordedFile* original)
{
    EmbedRecord record;
    record.created_utc = utc_now();
    record.tool_version = std::string("meshmark ") + MESHMARK_VERSION;
    record.original = original != nullptr ? *original : recorded_file(input);
    record.marked = recorded_file(output);
    record.key = recorded_file(key_path);
    record.original_fingerprint = key.original;
    return record;
}

nlohmann::json to_json(const EmbedRecord& record)
{
    return {{"format", "meshmark-embed-record"},
            {"version", 1},
            {"created_utc", record.created_utc},
            {"tool", record.tool_version},
            {"original", file_json(record.original)},
            {"marked", file_json(record.marked)},
            {"key", file_json(record.key)},
            {"original_fingerprint",
             {{"vertex_count", record.original_fingerprint.vertex_count},
              {"face_count", record.original_fingerprint.face_count},
              {"position_hash", hex64(record.original_fingerprint.position_hash)}}}};
}

void write_embed_record(const std::filesystem::path& path, const EmbedRecord& record)
{
    create_parent_directories(path);
    write_file_atomically(path, [&](std::ostream& out) { out << to_json(record).dump(2) << '\n'; });
}

}  // namespace meshmark
