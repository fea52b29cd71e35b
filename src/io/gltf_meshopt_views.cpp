// SPDX-License-Identifier: MIT
// The bufferViews of a glTF asset compressed with EXT_meshopt_compression or
// KHR_meshopt_compression: their extension objects checked as the JSON declares them, and
// their streams decoded (meshopt.cpp) into the view's range of its (fallback) buffer, where
// the rest of the reader finds them like uncompressed data.
#include <algorithm>
#include <climits>

#include "io/detail/gltf_json.h"
#include "io/detail/gltf_reader.h"
#include "io/detail/support.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace fs = std::filesystem;

// The bufferViews compressed with meshopt, as the JSON declares them (checked, not decoded).
std::vector<GltfMeshoptView> meshopt_views(const fs::path& path, const std::string& json)
{
    std::vector<GltfMeshoptView> views;
    if (json.find("_meshopt_compression") == std::string::npos)
    {
        return views;
    }
    const auto doc = parse_asset_json(path, json);
    if (!doc.is_object() || !doc.contains("bufferViews") || !doc["bufferViews"].is_array())
    {
        return views;
    }
    for (std::size_t v = 0; v < doc["bufferViews"].size(); ++v)
    {
        const auto& view = doc["bufferViews"][v];
        std::string name;
        const GltfJson* ext = meshopt_extension(view, &name);
        if (ext == nullptr)
        {
            continue;
        }
        GltfMeshoptView record;
        record.view = static_cast<std::int32_t>(v);
        record.extension = name;
        const std::string where = name + " of bufferView " + std::to_string(v);
        for (const char* key : {"buffer", "byteLength", "byteStride", "count"})
        {
            if (!ext->contains(key) || !(*ext)[key].is_number_unsigned())
            {
                fail_io(path, "the " + where + " has no valid \"" + key + "\"");
            }
        }
        if ((ext->contains("byteOffset") && !(*ext)["byteOffset"].is_number_unsigned()) ||
            !ext->contains("mode") || !(*ext)["mode"].is_string() ||
            (ext->contains("filter") && !(*ext)["filter"].is_string()))
        {
            fail_io(path, "the " + where + " has an invalid byteOffset, mode or filter");
        }
        record.source_buffer = static_cast<std::int32_t>(
            std::min<std::uint64_t>((*ext)["buffer"].get<std::uint64_t>(), INT32_MAX));
        record.source_offset = ext->value("byteOffset", std::uint64_t{0});
        record.source_length = (*ext)["byteLength"].get<std::uint64_t>();
        record.stride = (*ext)["byteStride"].get<std::uint64_t>();
        record.count = (*ext)["count"].get<std::uint64_t>();
        if (record.stride > 256 || record.count > kMaxVertices)
        {
            fail_io(path, "the " + where + " has byteStride " + std::to_string(record.stride) +
                              " and count " + std::to_string(record.count) +
                              ", more than supported");
        }
        const auto mode = (*ext)["mode"].get<std::string>();
        const auto filter = ext->value("filter", std::string("NONE"));
        if (mode == "ATTRIBUTES")
        {
            record.mode = MeshoptMode::Attributes;
        }
        else if (mode == "TRIANGLES")
        {
            record.mode = MeshoptMode::Triangles;
        }
        else if (mode == "INDICES")
        {
            record.mode = MeshoptMode::Indices;
        }
        else
        {
            record.unsupported =
                "the " + where + " has mode \"" + mode + "\", which meshmark does not know";
        }
        if (filter == "NONE")
        {
            record.filter = MeshoptFilter::None;
        }
        else if (filter == "OCTAHEDRAL")
        {
            record.filter = MeshoptFilter::Octahedral;
        }
        else if (filter == "QUATERNION")
        {
            record.filter = MeshoptFilter::Quaternion;
        }
        else if (filter == "EXPONENTIAL")
        {
            record.filter = MeshoptFilter::Exponential;
        }
        else if (record.unsupported.empty())
        {
            record.unsupported =
                "the " + where + " has filter \"" + filter + "\", which meshmark does not support";
        }
        views.push_back(std::move(record));
    }
    return views;
}

// Decode every meshopt view the build supports into its range of its (fallback) buffer, so
// that everything downstream reads the decoded bytes like any other buffer data.
void decode_meshopt_views(const fs::path& path, const tinygltf::Model& model, GltfAsset& asset)
{
    for (auto& record : asset.meshopt)
    {
        const std::string where =
            "the " + record.extension + " of bufferView " + std::to_string(record.view);
        const auto& view = model.bufferViews[static_cast<std::size_t>(record.view)];
        if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= asset.buffers.size())
        {
            fail_io(path, where + " belongs to a missing buffer");
        }
        record.buffer = view.buffer;
        record.offset = view.byteOffset;
        auto& target = asset.buffers[static_cast<std::size_t>(view.buffer)];
        if (record.count * record.stride > view.byteLength ||
            view.byteOffset > target.bytes.size() ||
            view.byteLength > target.bytes.size() - view.byteOffset)
        {
            fail_io(path, where + " decodes to " + std::to_string(record.count) + " elements of " +
                              std::to_string(record.stride) +
                              " bytes, more than the bufferView or its buffer holds");
        }
        if (static_cast<std::size_t>(record.source_buffer) >= asset.buffers.size() ||
            asset.buffers[static_cast<std::size_t>(record.source_buffer)].source ==
                GltfBufferSource::MeshoptFallback)
        {
            fail_io(path, where + " refers to buffer " + std::to_string(record.source_buffer) +
                              ", which holds no compressed data");
        }
        const auto& source = asset.buffers[static_cast<std::size_t>(record.source_buffer)];
        const std::string& data = source.has_stored ? source.stored : source.bytes;
        if (record.source_length == 0 || record.source_offset > data.size() ||
            record.source_length > data.size() - record.source_offset)
        {
            fail_io(path, where +
                              " has a compressed range that is empty or past the end of buffer " +
                              std::to_string(record.source_buffer));
        }
        const std::string stream = data.substr(record.source_offset, record.source_length);
        if (record.unsupported.empty())
        {
            record.unsupported =
                meshopt_unsupported(path, record, static_cast<unsigned char>(stream[0]));
        }
        if (!record.unsupported.empty())
        {
            continue;  // the fallback's bytes stay; Reader refuses geometry without them
        }
        const std::string decoded = decode_meshopt(path, record, stream, &record.exponent_bits);
        if (target.source != GltfBufferSource::MeshoptFallback && !target.has_stored)
        {
            target.stored = target.bytes;
            target.has_stored = true;
        }
        std::copy(decoded.begin(), decoded.end(),
                  target.bytes.begin() + static_cast<std::ptrdiff_t>(view.byteOffset));
    }
}

}  // namespace meshmark::detail
