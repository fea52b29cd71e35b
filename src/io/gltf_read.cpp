// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB reader: the GLB container is split (gltf_container.cpp), tinygltf parses
// and validates the JSON and loads the buffers (this file patches what tinygltf 2.7 cannot
// load), and each buffer is recorded with where it came from. meshopt-compressed bufferViews
// are then decoded into their (fallback) buffers (gltf_meshopt_views.cpp), so that the scene
// walk (gltf_scene.cpp) reads them like uncompressed data.
#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <map>
#include <memory>
#include <string_view>
#include <vector>

#include <tiny_gltf.h>

#include "io/detail/gltf_json.h"
#include "io/detail/gltf_reader.h"
#include "io/detail/support.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// A meshopt fallback buffer without data is allocated (zeros, then the decoded views): the
// same 4 GiB bound as the file.
constexpr std::uint64_t kMaxFallbackBytes = std::uint64_t{1} << 32U;

// Image data is never decoded: images are carried through as they are.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*)
{
    return true;
}

std::string first_line(const std::string& text)
{
    const auto end = text.find('\n');
    std::string line = text.substr(0, end);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' '))
    {
        line.pop_back();
    }
    return line.empty() ? std::string("no reason given") : line;
}

// Required extensions that meshmark decodes (the others are named when reading fails).
constexpr std::array<const char*, 4> kDecodedExtensions = {
    kDracoExtension, "EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_mesh_quantization"};
// The uri given (in tinygltf's copy of the JSON only) to a meshopt fallback buffer that has
// none, with the buffer index appended; load_model's file callbacks serve it as zeros.
constexpr std::string_view kFallbackUri = "meshmark-meshopt-fallback:";

// " (the asset requires extension X, which meshmark does not support)" for every required
// extension meshmark does not decode, or empty: appended to an error reading the asset, since
// such an extension (an unknown compression, say) is the likely cause.
std::string required_note(const fs::path& path, const std::string& json)
{
    try
    {
        const auto doc = parse_asset_json(path, json);
        if (!doc.is_object() || !doc.contains("extensionsRequired") ||
            !doc["extensionsRequired"].is_array())
        {
            return "";
        }
        std::vector<std::string> unknown;
        for (const auto& name : doc["extensionsRequired"])
        {
            if (name.is_string() && std::find(kDecodedExtensions.begin(), kDecodedExtensions.end(),
                                              name.get<std::string>()) == kDecodedExtensions.end())
            {
                unknown.push_back(name.get<std::string>());
            }
        }
        if (unknown.empty())
        {
            return "";
        }
        std::string note = unknown.size() == 1 ? " (the asset requires extension "
                                               : " (the asset requires extensions ";
        for (std::size_t i = 0; i < unknown.size(); ++i)
        {
            note += (i == 0 ? "" : ", ") + unknown[i];
        }
        return note + ", which meshmark does not support)";
    }
    catch (const std::exception&)
    {
        return "";  // tinygltf's message names the problem
    }
}

// What tinygltf is given instead of the file, when the file needs patching.
struct Prepared
{
    std::string bytes;                               // the patched file (empty: none needed)
    std::map<std::string, std::uint64_t> fallbacks;  // placeholder uri -> byteLength
};

// tinygltf 2.7 (built without Draco and meshopt) cannot load two things valid assets contain,
// so the copy it validates is patched:
// - it rejects an indices accessor without bufferView, which is how every Draco primitive
//   declares its indices: those are left out (the triangles come from the Draco data anyway);
// - a meshopt fallback buffer without uri has no data, which tinygltf refuses ("uri is
//   missing", or in a GLB it even takes the BIN chunk for it): it gets a placeholder uri that
//   load_model's file callbacks serve as zeros of its byteLength. This keeps every index and
//   every other check of tinygltf intact (dropping the buffer or the compressed views would
//   renumber or unvalidate them), and read_gltf then overwrites the zeros with the decoded
//   views.
Prepared prepare(const fs::path& path, const std::string& file_bytes, const std::string& json,
                 bool is_glb)
{
    Prepared prepared;
    const bool has_draco = json.find(kDracoExtension) != std::string::npos;
    const bool has_meshopt = json.find("_meshopt_compression") != std::string::npos;
    if (!has_draco && !has_meshopt)
    {
        return prepared;
    }
    GltfJson doc = parse_asset_json(path, json);
    if (!doc.is_object())
    {
        return prepared;  // tinygltf names the problem
    }
    bool is_patched = false;
    if (has_draco && doc.contains("meshes") && doc["meshes"].is_array())
    {
        for (auto& mesh : doc["meshes"])
        {
            if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
            {
                continue;
            }
            for (auto& prim : mesh["primitives"])
            {
                if (prim.is_object() && prim.contains("extensions") &&
                    prim["extensions"].is_object() && prim["extensions"].contains(kDracoExtension))
                {
                    is_patched = prim.erase("indices") > 0 || is_patched;
                }
            }
        }
    }
    if (has_meshopt && doc.contains("buffers") && doc["buffers"].is_array())
    {
        auto& buffers = doc["buffers"];
        std::vector<char> is_target(buffers.size(), 0);
        if (doc.contains("bufferViews") && doc["bufferViews"].is_array())
        {
            for (const auto& view : doc["bufferViews"])
            {
                if (meshopt_extension(view) != nullptr && view.contains("buffer") &&
                    view["buffer"].is_number_unsigned() &&
                    view["buffer"].get<std::uint64_t>() < buffers.size())
                {
                    is_target[view["buffer"].get<std::size_t>()] = 1;
                }
            }
        }
        for (std::size_t b = 0; b < buffers.size(); ++b)
        {
            auto& buffer = buffers[b];
            const GltfJson* ext = meshopt_extension(buffer);
            const bool is_fallback = ext != nullptr && ext->value("fallback", false);
            // Buffer 0 of a GLB without uri is the BIN chunk, which has data.
            if (!buffer.is_object() || buffer.contains("uri") || (is_glb && b == 0) ||
                (!is_fallback && is_target[b] == 0) || !buffer.contains("byteLength") ||
                !buffer["byteLength"].is_number_unsigned())
            {
                continue;
            }
            const std::string uri = std::string(kFallbackUri) + std::to_string(b);
            buffer["uri"] = uri;
            prepared.fallbacks[uri] = buffer["byteLength"].get<std::uint64_t>();
            is_patched = true;
        }
    }
    if (!is_patched)
    {
        return prepared;
    }
    prepared.bytes = doc.dump();
    if (is_glb)
    {
        const auto chunks = split_glb(path, file_bytes);
        prepared.bytes =
            assemble_glb(path, prepared.bytes, chunks.has_bin ? &chunks.bin : nullptr, chunks.tail);
    }
    return prepared;
}

// tinygltf file callbacks that serve the placeholder uris of prepare() and leave every other
// file to tinygltf's own functions.
struct PlaceholderFiles
{
    const std::map<std::string, std::uint64_t>* fallbacks = nullptr;

    // tinygltf joins the uri to the base directory before asking.
    [[nodiscard]] const std::uint64_t* find(const std::string& file) const
    {
        const auto at = file.rfind(kFallbackUri);
        if (at == std::string::npos || (at > 0 && file[at - 1] != '/'))
        {
            return nullptr;
        }
        const auto it = fallbacks->find(file.substr(at));
        return it == fallbacks->end() ? nullptr : &it->second;
    }
    static bool exists(const std::string& file, void* self)
    {
        return static_cast<PlaceholderFiles*>(self)->find(file) != nullptr ||
               tinygltf::FileExists(file, nullptr);
    }
    static std::string expand(const std::string& file, void* self)
    {
        return static_cast<PlaceholderFiles*>(self)->find(file) != nullptr
                   ? file
                   : tinygltf::ExpandFilePath(file, nullptr);
    }
    static bool read(std::vector<unsigned char>* out, std::string* err, const std::string& file,
                     void* self)
    {
        if (const auto* size = static_cast<PlaceholderFiles*>(self)->find(file))
        {
            out->assign(static_cast<std::size_t>(*size), 0);
            return true;
        }
        return tinygltf::ReadWholeFile(out, err, file, nullptr);
    }
};

// The advice for an asset written to the glTF 1.0 specification (2015-2016: its collections
// are objects keyed by name, which tinygltf either refuses or reads as an empty scene).
constexpr const char* kUpgradeAdvice =
    "; meshmark reads glTF 2.0 (gltf-pipeline -i IN -o OUT.gltf upgrades a 1.0 asset)";

// The version an asset declares ("asset": {"version": ...}, a string in 2.0, a number in some
// 1.0 writers), or "1.0" for an asset without one whose meshes are an object (the 1.0 layout);
// empty when neither says anything.
std::string declared_version(const fs::path& path, const std::string& json)
{
    try
    {
        const auto doc = parse_asset_json(path, json);
        if (!doc.is_object())
        {
            return "";
        }
        if (doc.contains("asset") && doc["asset"].is_object() && doc["asset"].contains("version"))
        {
            const auto& version = doc["asset"]["version"];
            if (version.is_string())
            {
                return version.get<std::string>();
            }
            if (version.is_number())
            {
                return version.dump();
            }
        }
        if (doc.contains("meshes") && doc["meshes"].is_object())
        {
            return "1.0";
        }
    }
    catch (const std::exception&)
    {
        // not JSON: tinygltf names the problem
    }
    return "";
}

[[noreturn]] void fail_version(const fs::path& path, const std::string& version)
{
    fail_io(path, "glTF " + version + " is not supported" + kUpgradeAdvice);
}

bool is_version_2(const std::string& version)
{
    return version.rfind("2.", 0) == 0 || version == "2";
}

tinygltf::Model load_model(const fs::path& path, const std::string& file_bytes,
                           const std::string& json, bool is_glb)
{
    const Prepared prepared = prepare(path, file_bytes, json, is_glb);
    const std::string& bytes = prepared.bytes.empty() ? file_bytes : prepared.bytes;
    if (bytes.size() > UINT_MAX)
    {
        fail_io(path, "the file is larger than 4 GiB, which glTF loaders do not support");
    }
    for (const auto& [uri, size] : prepared.fallbacks)
    {
        if (size > kMaxFallbackBytes)
        {
            fail_io(path, "the meshopt fallback buffer " + uri.substr(kFallbackUri.size()) +
                              " declares " + std::to_string(size) + " bytes, more than supported");
        }
    }
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(skip_image, nullptr);
    PlaceholderFiles files{&prepared.fallbacks};
    if (!prepared.fallbacks.empty())
    {
        loader.SetFsCallbacks({&PlaceholderFiles::exists, &PlaceholderFiles::expand,
                               &PlaceholderFiles::read, &tinygltf::WriteWholeFile, &files});
    }
    tinygltf::Model model;
    std::string err;
    std::string warn;
    const std::string base_dir = path.parent_path().string();
    bool ok = false;
    try
    {
        ok = is_glb ? loader.LoadBinaryFromMemory(
                          &model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                          static_cast<unsigned int>(bytes.size()), base_dir)
                    : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                                 static_cast<unsigned int>(bytes.size()), base_dir);
    }
    catch (const std::exception& e)
    {
        fail_io(path,
                std::string("not a valid glTF 2.0 asset: ") + e.what() + required_note(path, json));
    }
    if (!ok)
    {
        if (const std::string version = declared_version(path, json);
            !version.empty() && !is_version_2(version))
        {
            fail_version(path, version);
        }
        fail_io(path, "not a valid glTF 2.0 asset: " + first_line(err) + required_note(path, json));
    }
    if (!is_version_2(model.asset.version))  // (tinygltf refuses an asset without a version)
    {
        fail_version(path, model.asset.version);
    }
    return model;
}

}  // namespace

std::string percent_decoded(const std::string& uri)
{
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i)
    {
        if (uri[i] == '%' && i + 2 < uri.size() &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 1])) != 0 &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 2])) != 0)
        {
            out += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
            i += 2;
        }
        else
        {
            out += uri[i];
        }
    }
    return out;
}

namespace
{

// The container (GLB chunks), tinygltf's parse and buffer loading, meshopt views decoded: what
// read_gltf walks the scene of (and keeps, for visit_gltf_poses to walk it again).
tinygltf::Model load_asset(const fs::path& path, const std::string& bytes, bool is_glb,
                           GltfAsset& asset)
{
    asset.is_glb = is_glb;
    asset.folder = path.parent_path();
    // The container first (GLB chunks), then tinygltf's parse and buffer loading.
    if (is_glb)
    {
        auto chunks = split_glb(path, bytes);
        asset.json = std::move(chunks.json);
        asset.glb_tail = std::move(chunks.tail);
        asset.glb_has_bin = chunks.has_bin;
        asset.glb_bin_padding = std::move(chunks.bin);  // trimmed to the padding below
    }
    else
    {
        asset.json = bytes;
    }
    const tinygltf::Model model = load_model(path, bytes, asset.json, is_glb);
    asset.buffers.resize(model.buffers.size());
    for (std::size_t b = 0; b < model.buffers.size(); ++b)
    {
        const auto& source = model.buffers[b];
        auto& buffer = asset.buffers[b];
        buffer.bytes.assign(source.data.begin(), source.data.end());
        if (source.uri.rfind(kFallbackUri, 0) == 0)
        {
            buffer.source = GltfBufferSource::MeshoptFallback;  // zeros until decoded below
        }
        else if (source.uri.empty())
        {
            if (!is_glb || b != 0)
            {
                fail_io(path, "buffer " + std::to_string(b) + " has no uri" +
                                  required_note(path, asset.json));
            }
            buffer.source = GltfBufferSource::GlbBinChunk;
            if (asset.glb_bin_padding.size() < buffer.bytes.size())
            {
                fail_io(path, "the GLB BIN chunk is shorter than buffer 0");
            }
            asset.glb_bin_padding.erase(0, buffer.bytes.size());
        }
        else if (source.uri.rfind("data:", 0) == 0)
        {
            buffer.source = GltfBufferSource::DataUri;
            buffer.uri_prefix = source.uri.substr(0, source.uri.find(',') + 1);
        }
        else
        {
            buffer.source = GltfBufferSource::External;
            buffer.file = path.parent_path() / percent_decoded(source.uri);
        }
    }
    asset.meshopt = meshopt_views(path, asset.json);
    decode_meshopt_views(path, model, asset);
    return model;
}

}  // namespace

TriangleMesh read_gltf(const fs::path& path, const std::string& bytes, bool is_glb,
                       GltfAsset& asset)
{
    auto model = std::make_shared<tinygltf::Model>(load_asset(path, bytes, is_glb, asset));
    TriangleMesh mesh = read_scene(path, *model, asset);
    // Kept to pose the scene later (visit_gltf_poses). Without animations and without a stored
    // blend of morph targets (no AnimationSpan), no time of any animation poses the mesh.
    if (!model->animations.empty() || !asset.animations.empty())
    {
        for (tinygltf::Buffer& buffer : model->buffers)
        {
            std::vector<unsigned char>().swap(buffer.data);  // (asset.buffers holds the bytes)
        }
        asset.model = std::move(model);
    }
    return mesh;
}

void visit_gltf_poses(const fs::path& path, const GltfAsset& read, std::span<const double> times,
                      const std::function<void(ShownPose&&)>& visit, std::size_t animation)
{
    // What the scene walk reads of a loaded asset (load_asset's result); what it fills starts
    // empty, as does the welding it caches from the first time for the others.
    GltfAsset loaded;
    loaded.is_glb = read.is_glb;
    loaded.folder = read.folder;
    loaded.buffers = read.buffers;
    loaded.meshopt = read.meshopt;
    for (const double t : times)
    {
        // The scene walk fills the asset's lists of accessors, Draco primitives and instances:
        // each time gets them afresh over the same loaded buffers.
        loaded.accessors.clear();
        loaded.draco.clear();
        loaded.instances = TriangleMesh{};
        loaded.pose = ShownPose{};
        (void)read_scene(path, *read.model, loaded, t, animation);
        visit(std::move(loaded.pose));
    }
}

}  // namespace meshmark::detail
