// SPDX-License-Identifier: MIT
#include "requests.h"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>

#include "meshmark/core/error.h"
#include "service.h"

namespace meshmark::service
{

namespace fs = std::filesystem;
using Json = nlohmann::json;

// An asset id as a request may name one: a catalogue id is the relative path it was added
// under, so no control characters, no absolute path, no `..` segment, at most kMaxAssetId bytes.
// Only ever a key in the database; checked anyway so a hostile name fails early and clearly.
std::string asset_problem(const std::string& id)
{
    if (id.empty() || id.size() > kMaxAssetId)
    {
        return "an asset id has 1 to " + std::to_string(kMaxAssetId) + " bytes";
    }
    if (id.front() == '/')
    {
        return "an asset id is a relative path";
    }
    std::size_t start = 0;
    for (std::size_t i = 0; i <= id.size(); ++i)
    {
        if (i == id.size() || id[i] == '/')
        {
            if (id.compare(start, i - start, "..") == 0 && i - start == 2)
            {
                return "an asset id has no '..' segment";
            }
            start = i + 1;
            continue;
        }
        const auto u = static_cast<unsigned char>(id[i]);
        if (u < 0x20U || u == 0x7FU)
        {
            return "an asset id has no control characters";
        }
    }
    return {};
}

// The key's payload is key material: a scan's answer says how many of its bits were read
// (bit_count, bits_false_positive_probability), never which.
void strip_payload(Json& json)
{
    if (json.is_object())
    {
        json.erase("bits_expected");
        json.erase("bits_found");
    }
    if (json.is_object() || json.is_array())
    {
        for (Json& child : json)
        {
            strip_payload(child);
        }
    }
}

std::optional<MeshFormat> format_named(std::string name)
{
    for (char& c : name)
    {
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    static const std::map<std::string, MeshFormat> kFormats{
        {"ply", MeshFormat::Ply},    {"obj", MeshFormat::Obj},   {"off", MeshFormat::Off},
        {"stl", MeshFormat::Stl},    {"gltf", MeshFormat::Gltf}, {"glb", MeshFormat::Glb},
        {"3mf", MeshFormat::ThreeMf}};
    const auto it = kFormats.find(name);
    return it == kFormats.end() ? std::nullopt : std::optional(it->second);
}

const char* extension_of(MeshFormat format)
{
    switch (format)
    {
        case MeshFormat::Ply:
            return "ply";
        case MeshFormat::Obj:
            return "obj";
        case MeshFormat::Off:
            return "off";
        case MeshFormat::Stl:
            return "stl";
        case MeshFormat::Gltf:
            return "gltf";
        case MeshFormat::Glb:
            return "glb";
        case MeshFormat::ThreeMf:
            return "3mf";
    }
    return "bin";
}

const char* content_type_of(MeshFormat format)
{
    switch (format)
    {
        case MeshFormat::Glb:
            return "model/gltf-binary";
        case MeshFormat::Gltf:
            return "model/gltf+json";
        case MeshFormat::Obj:
            return "model/obj";
        case MeshFormat::Stl:
            return "model/stl";
        case MeshFormat::ThreeMf:
            return "model/3mf";
        case MeshFormat::Ply:
        case MeshFormat::Off:
            return "application/octet-stream";
    }
    return "application/octet-stream";
}

// A file name for Content-Disposition: the original's stem, the recipient, the extension;
// anything but [A-Za-z0-9._-] becomes '_' (the header's quoted string stays plain ASCII).
std::string download_name(const std::string& original, const std::string& recipient,
                          MeshFormat format)
{
    std::string name = fs::path(original).stem().string() + "-" + recipient;
    for (char& c : name)
    {
        const auto u = static_cast<unsigned char>(c);
        if (!(std::isalnum(u) != 0 || c == '.' || c == '_' || c == '-'))
        {
            c = '_';
        }
    }
    return name + "." + extension_of(format);
}

std::size_t parse_bytes(const std::string& text, const std::string& what)
{
    std::size_t used = 0;
    double value = 0.0;
    try
    {
        value = std::stod(text, &used);
    }
    catch (const std::exception&)
    {
        used = 0;
    }
    std::string unit = text.substr(used);
    for (char& c : unit)
    {
        c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    }
    static const std::map<std::string, double> kUnits{
        {"", 1.0},           {"B", 1.0},           {"K", 1024.0},        {"KB", 1024.0},
        {"KIB", 1024.0},     {"M", 1048576.0},     {"MB", 1048576.0},    {"MIB", 1048576.0},
        {"G", 1073741824.0}, {"GB", 1073741824.0}, {"GIB", 1073741824.0}};
    const auto it = kUnits.find(unit);
    if (used == 0 || it == kUnits.end() || !std::isfinite(value) || value < 0.0 ||
        value * it->second > 1e18)
    {
        throw InvalidOption(what + " must be a size such as 512M or 2G, got '" + text + "'.");
    }
    return static_cast<std::size_t>(value * it->second);
}

}  // namespace meshmark::service
