// SPDX-License-Identifier: MIT
// What a request to the service may name, and the words of its answers: asset ids, formats,
// file names, the payload kept out of scan answers (docs/service.md).
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "meshmark/io/mesh_io.h"

namespace meshmark::service
{

/// Longest asset id a request may name (a bound on what a client can make the service hold;
/// chosen by hand; no study on record).
inline constexpr std::size_t kMaxAssetId = 1024;

/// Empty when \p id may name an asset; else why not (no absolute path, `..` segment or control
/// character; 1 to kMaxAssetId bytes).
[[nodiscard]] std::string asset_problem(const std::string& id);

/// Removes the key's payload bits (`bits_expected`, `bits_found`) from a report, at any depth.
void strip_payload(nlohmann::json& json);

/// The format a request names ("glb", "PLY", ...), or none.
[[nodiscard]] std::optional<MeshFormat> format_named(std::string name);
/// The file extension of \p format, without the dot.
[[nodiscard]] const char* extension_of(MeshFormat format);
/// The Content-Type of a copy in \p format.
[[nodiscard]] const char* content_type_of(MeshFormat format);
/// The Content-Disposition file name of \p recipient's copy of \p original in \p format.
[[nodiscard]] std::string download_name(const std::string& original, const std::string& recipient,
                                        MeshFormat format);

}  // namespace meshmark::service
