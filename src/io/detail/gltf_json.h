// SPDX-License-Identifier: MIT
// The glTF JSON as the reader and the preserving writer see it: nlohmann::ordered_json (which
// keeps every member, unknown ones included, in its order), the extension names meshmark
// decodes, and the few lookups both sides make.
#pragma once

#include <array>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "numbers.h"
#include "support.h"

namespace meshmark::detail
{

using GltfJson = nlohmann::ordered_json;

inline constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";
inline constexpr std::array<const char*, 2> kMeshoptExtensions = {"EXT_meshopt_compression",
                                                                  "KHR_meshopt_compression"};

/// \brief Parse the JSON text of an asset.
/// \details GLB JSON chunks are padded with spaces (some writers use NULs), which are left
/// out. \throws GltfJson::exception when the text is not JSON.
[[nodiscard]] inline GltfJson parse_unpadded_json(const std::string& json)
{
    const auto end = json.find_last_not_of(std::string(" \t\r\n\0", 5));
    return GltfJson::parse(json.substr(0, end == std::string::npos ? 0 : end + 1));
}

/// parse_unpadded_json for the reader: a text that is not JSON is an IoError naming \p path.
[[nodiscard]] inline GltfJson parse_asset_json(const std::filesystem::path& path,
                                               const std::string& json)
{
    try
    {
        return parse_unpadded_json(json);
    }
    catch (const GltfJson::exception& e)
    {
        fail_io(path, std::string("not a valid glTF 2.0 asset: ") + e.what());
    }
}

/// The meshopt extension object of a bufferView or buffer (EXT_ first, then KHR_), or null;
/// its name in \p name when asked.
[[nodiscard]] inline const GltfJson* meshopt_extension(const GltfJson& object,
                                                       std::string* name = nullptr)
{
    if (!object.is_object() || !object.contains("extensions") || !object["extensions"].is_object())
    {
        return nullptr;
    }
    for (const char* ext : kMeshoptExtensions)
    {
        if (object["extensions"].contains(ext) && object["extensions"][ext].is_object())
        {
            if (name != nullptr)
            {
                *name = ext;
            }
            return &object["extensions"][ext];
        }
    }
    return nullptr;
}

/// A float32 bound as the JSON number with the float's shortest digits ("0.1", not
/// "0.10000000149011612"), so readers converting it to float get the exact value back.
[[nodiscard]] inline GltfJson float_number(double value)
{
    std::string text;
    append_shortest(text, static_cast<float>(value));
    double parsed = 0.0;
    static_cast<void>(parse_double(text, parsed));
    return GltfJson(parsed);
}

}  // namespace meshmark::detail
