// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB reader: tinygltf parses and validates the container and loads the buffers;
// this file walks the scene graph, locates every POSITION element's bytes (strides, sparse
// substitution, KHR_mesh_quantization types), decodes Draco primitives, and welds coincident
// world-space vertices into one mesh. meshopt-compressed bufferViews are decoded into their
// (fallback) buffers before the walk, so it reads them like uncompressed data.
#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "io/detail/gltf.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "io/detail/weld.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {
namespace {

namespace fs = std::filesystem;

constexpr int kModePoints = 0;
constexpr int kModeTriangles = 4;
constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";

// Node visits allowed while walking the scene graph (a DAG of shared children can otherwise
// explode exponentially in a hostile file).
constexpr std::size_t kMaxNodeVisits = 1U << 20U;
// Elements of an accessor without any stored data (all implicit zeros).
constexpr std::uint64_t kMaxImplicitElements = 1U << 24U;
// A meshopt fallback buffer without data is allocated (zeros, then the decoded views): the
// same 4 GiB bound as the file.
constexpr std::uint64_t kMaxFallbackBytes = std::uint64_t{1} << 32U;

// Image data is never decoded: images are carried through as they are.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*)
{
    return true;
}

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

constexpr std::array<const char*, 2> kMeshoptExtensions = {"EXT_meshopt_compression",
                                                           "KHR_meshopt_compression"};
// Required extensions that meshmark decodes (the others are named when reading fails).
constexpr std::array<const char*, 4> kDecodedExtensions = {
    kDracoExtension, "EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_mesh_quantization"};
// The uri given (in tinygltf's copy of the JSON only) to a meshopt fallback buffer that has
// none, with the buffer index appended; load_model's file callbacks serve it as zeros.
constexpr std::string_view kFallbackUri = "meshmark-meshopt-fallback:";

using Json = nlohmann::ordered_json;

// The JSON as nlohmann parses it: GLB JSON chunks are padded with spaces (some writers use
// NULs), which are left out.
Json parse_json(const fs::path& path, const std::string& json)
{
    try
    {
        const auto end = json.find_last_not_of(std::string(" \t\r\n\0", 5));
        return Json::parse(json.substr(0, end == std::string::npos ? 0 : end + 1));
    }
    catch (const Json::exception& e)
    {
        fail_io(path, std::string("not a valid glTF 2.0 asset: ") + e.what());
    }
}

// " (the asset requires extension X, which meshmark does not support)" for every required
// extension meshmark does not decode, or empty: appended to an error reading the asset, since
// such an extension (an unknown compression, say) is the likely cause.
std::string required_note(const fs::path& path, const std::string& json)
{
    try
    {
        const auto doc = parse_json(path, json);
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

// The meshopt extension object of a bufferView or buffer, or null.
const Json* meshopt_extension(const Json& object, std::string* name = nullptr)
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
    Json doc = parse_json(path, json);
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
            const Json* ext = meshopt_extension(buffer);
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
        fail_io(path, "not a valid glTF 2.0 asset: " + first_line(err) + required_note(path, json));
    }
    return model;
}

// The bufferViews compressed with meshopt, as the JSON declares them (checked, not decoded).
std::vector<GltfMeshoptView> meshopt_views(const fs::path& path, const std::string& json)
{
    std::vector<GltfMeshoptView> views;
    if (json.find("_meshopt_compression") == std::string::npos)
    {
        return views;
    }
    const auto doc = parse_json(path, json);
    if (!doc.is_object() || !doc.contains("bufferViews") || !doc["bufferViews"].is_array())
    {
        return views;
    }
    for (std::size_t v = 0; v < doc["bufferViews"].size(); ++v)
    {
        const auto& view = doc["bufferViews"][v];
        std::string name;
        const Json* ext = meshopt_extension(view, &name);
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

std::optional<GltfComponent> component_of(int type)
{
    switch (type)
    {
        case 5120:
        case 5121:
        case 5122:
        case 5123:
        case 5125:
        case 5126:
            return static_cast<GltfComponent>(type);
        default:
            return std::nullopt;
    }
}

std::size_t component_size(GltfComponent c)
{
    switch (c)
    {
        case GltfComponent::Int8:
        case GltfComponent::UInt8:
            return 1;
        case GltfComponent::Int16:
        case GltfComponent::UInt16:
            return 2;
        default:
            return 4;
    }
}

// One vertex of one instance before welding.
struct RawVertices
{
    std::vector<double> world;        // 3 per element
    std::vector<std::int32_t> group;  // transform group per element
};

class Reader
{
public:
    Reader(const fs::path& path, const tinygltf::Model& model, GltfAsset& asset)
        : path_(path), model_(model), asset_(asset)
    {
        for (const auto& record : asset.meshopt)
        {
            if (!record.unsupported.empty() &&
                asset.buffers[static_cast<std::size_t>(record.buffer)].source ==
                    GltfBufferSource::MeshoptFallback)
            {
                undecoded_[record.view] = record.unsupported;
            }
        }
    }

    TriangleMesh run();

private:
    void walk(int node, const Eigen::Matrix4d& parent, std::vector<char>& on_stack);
    void add_primitive(int mesh, int index, const Eigen::Matrix4d& to_world);
    void add_plain(const tinygltf::Primitive& prim, int mesh, int index,
                   const Eigen::Matrix4d& to_world);
    void add_draco(const tinygltf::Primitive& prim, int mesh, int index,
                   const Eigen::Matrix4d& to_world);
    std::vector<GltfElement> locate(int accessor, int components, const std::string& what) const;
    void add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                       std::size_t count);
    void add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                       std::size_t count, std::vector<std::size_t>& corners);
    std::size_t add_instance(std::size_t first, std::size_t count, const Eigen::Matrix4d& from,
                             const Eigen::Matrix4d& to);
    std::int32_t group_of(const Eigen::Matrix4d& to_world);
    void append_world(const std::vector<double>& local, const Eigen::Matrix4d& to_world,
                      std::int32_t group);
    TriangleMesh weld();
    [[noreturn]] void fail(const std::string& what) const { fail_io(path_, what); }
    // The view's byte range lies inside its (loaded) buffer; no overflow on hostile sizes.
    [[nodiscard]] bool is_view_in_buffer(const tinygltf::BufferView& view) const
    {
        if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= asset_.buffers.size())
        {
            return false;
        }
        const std::uint64_t size =
            asset_.buffers[static_cast<std::size_t>(view.buffer)].bytes.size();
        return view.byteOffset <= size && view.byteLength <= size - view.byteOffset;
    }
    // n elements of element_size bytes, stride apart from offset, end within length.
    [[nodiscard]] static bool fits(std::uint64_t offset, std::uint64_t stride, std::uint64_t n,
                                   std::uint64_t element_size, std::uint64_t length)
    {
        if (n == 0)
        {
            return offset <= length;
        }
        return offset <= length && element_size <= length - offset &&
               n - 1 <= (length - offset - element_size) / stride;
    }

    const fs::path& path_;
    const tinygltf::Model& model_;
    GltfAsset& asset_;
    std::size_t visits_ = 0;
    std::map<int, std::size_t> accessor_slot_;  // POSITION accessor -> asset_.accessors
    std::map<int, std::size_t> draco_slot_;     // Draco bufferView -> asset_.draco
    std::vector<std::size_t> slot_base_;        // first raw element of each accessor slot
    std::vector<std::size_t> draco_base_;       // first raw element of each Draco slot
    std::vector<std::pair<std::size_t, std::size_t>> draco_corners_;  // its range of corners_
    std::vector<double> instance_xyz_;             // other instances, world frame, 3 per point
    std::vector<std::size_t> instance_corners_;  // their triangles, into instance_xyz_
    std::vector<Eigen::Matrix4d> groups_;       // distinct world transforms
    RawVertices raw_;
    std::vector<std::size_t> corners_;  // raw element ids, 3 per triangle
    // meshopt views this build cannot decode and with no fallback data: why.
    std::map<int, std::string> undecoded_;
};

Eigen::Matrix4d local_matrix(const tinygltf::Node& node)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    if (node.matrix.size() == 16)
    {
        for (int k = 0; k < 16; ++k)
        {
            m(k % 4, k / 4) = node.matrix[static_cast<std::size_t>(k)];  // column-major
        }
        return m;
    }
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    if (node.translation.size() == 3)
    {
        t.translate(Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]));
    }
    if (node.rotation.size() == 4)
    {
        // glTF stores (x, y, z, w); Eigen's constructor takes (w, x, y, z).
        Eigen::Quaterniond q(node.rotation[3], node.rotation[0], node.rotation[1],
                             node.rotation[2]);
        if (q.norm() > 0.0)
        {
            q.normalize();
        }
        t.rotate(q);
    }
    if (node.scale.size() == 3)
    {
        t.scale(Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]));
    }
    return t.matrix();
}

bool same_matrix(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    return std::memcmp(a.data(), b.data(), sizeof(double) * 16) == 0;
}

TriangleMesh Reader::run()
{
    // Roots: the default scene, else every scene, else every node that is no one's child.
    std::vector<int> roots;
    const auto scene_count = static_cast<int>(model_.scenes.size());
    if (model_.defaultScene >= 0 && model_.defaultScene < scene_count)
    {
        roots = model_.scenes[static_cast<std::size_t>(model_.defaultScene)].nodes;
    }
    else if (scene_count > 0)
    {
        for (const auto& scene : model_.scenes)
        {
            roots.insert(roots.end(), scene.nodes.begin(), scene.nodes.end());
        }
    }
    else
    {
        std::vector<char> is_child(model_.nodes.size(), 0);
        for (const auto& node : model_.nodes)
        {
            for (const int c : node.children)
            {
                if (c >= 0 && static_cast<std::size_t>(c) < is_child.size())
                {
                    is_child[static_cast<std::size_t>(c)] = 1;
                }
            }
        }
        for (std::size_t n = 0; n < is_child.size(); ++n)
        {
            if (is_child[n] == 0)
            {
                roots.push_back(static_cast<int>(n));
            }
        }
    }
    std::vector<char> on_stack(model_.nodes.size(), 0);
    for (const int root : roots)
    {
        walk(root, Eigen::Matrix4d::Identity(), on_stack);
    }
    return weld();
}

void Reader::walk(int node_index, const Eigen::Matrix4d& parent, std::vector<char>& on_stack)
{
    if (node_index < 0 || static_cast<std::size_t>(node_index) >= model_.nodes.size())
    {
        fail("node index " + std::to_string(node_index) + " is out of range");
    }
    const auto n = static_cast<std::size_t>(node_index);
    if (on_stack[n] != 0)
    {
        fail("node " + std::to_string(node_index) +
             " is its own ancestor (a cycle in the node tree)");
    }
    if (++visits_ > kMaxNodeVisits)
    {
        fail("the node graph expands to more than " + std::to_string(kMaxNodeVisits) + " nodes");
    }
    const auto& node = model_.nodes[n];
    const Eigen::Matrix4d to_world = parent * local_matrix(node);
    if (!to_world.allFinite())
    {
        fail("node " + std::to_string(node_index) + " has a non-finite transform");
    }
    if (node.mesh >= 0)
    {
        if (static_cast<std::size_t>(node.mesh) >= model_.meshes.size())
        {
            fail("node " + std::to_string(node_index) + " refers to missing mesh " +
                 std::to_string(node.mesh));
        }
        // A singular transform (zero scale) hides the mesh: it has no world geometry to mark.
        if (std::abs(to_world.topLeftCorner<3, 3>().determinant()) > 0.0)
        {
            const auto& mesh = model_.meshes[static_cast<std::size_t>(node.mesh)];
            for (std::size_t p = 0; p < mesh.primitives.size(); ++p)
            {
                add_primitive(node.mesh, static_cast<int>(p), to_world);
            }
        }
    }
    on_stack[n] = 1;
    for (const int child : node.children)
    {
        walk(child, to_world, on_stack);
    }
    on_stack[n] = 0;
}

void Reader::add_primitive(int mesh, int index, const Eigen::Matrix4d& to_world)
{
    const auto& prim =
        model_.meshes[static_cast<std::size_t>(mesh)].primitives[static_cast<std::size_t>(index)];
    if (prim.mode != kModeTriangles && prim.mode != kModePoints)
    {
        return;  // lines, strips and fans are carried through untouched
    }
    if (prim.extensions.count(kDracoExtension) != 0)
    {
        add_draco(prim, mesh, index, to_world);
    }
    else
    {
        add_plain(prim, mesh, index, to_world);
    }
}

std::vector<GltfElement> Reader::locate(int accessor_index, int components,
                                        const std::string& what) const
{
    const auto& acc = model_.accessors[static_cast<std::size_t>(accessor_index)];
    const auto component = component_of(acc.componentType);
    if (!component)
    {
        fail(what + " accessor " + std::to_string(accessor_index) + " has component type " +
             std::to_string(acc.componentType));
    }
    const std::size_t element_size =
        component_size(*component) * static_cast<std::size_t>(components);
    const std::uint64_t count = acc.count;
    if (count > kMaxVertices || (acc.bufferView < 0 && count > kMaxImplicitElements))
    {
        fail(what + " accessor " + std::to_string(accessor_index) + " has " +
             std::to_string(count) + " elements, more than supported");
    }
    std::vector<GltfElement> elements(static_cast<std::size_t>(count));
    // Byte range [offset, offset + size) of a bufferView, checked against its buffer.
    const auto view_range = [&](int view_index, std::uint64_t offset, std::uint64_t stride,
                                std::uint64_t n) -> std::pair<std::int32_t, std::uint64_t>
    {
        if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size())
        {
            fail(what + " accessor " + std::to_string(accessor_index) +
                 " refers to missing bufferView " + std::to_string(view_index));
        }
        if (const auto it = undecoded_.find(view_index); it != undecoded_.end())
        {
            fail("cannot read " + what + " accessor " + std::to_string(accessor_index) + ": " +
                 it->second);
        }
        const auto& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
        if (!is_view_in_buffer(view) || !fits(offset, stride, n, element_size, view.byteLength))
        {
            fail(what + " accessor " + std::to_string(accessor_index) +
                 " reaches past the end of bufferView " + std::to_string(view_index) +
                 " or its buffer");
        }
        return {view.buffer, view.byteOffset + offset};
    };
    if (acc.bufferView >= 0)
    {
        std::uint64_t stride = element_size;
        if (static_cast<std::size_t>(acc.bufferView) < model_.bufferViews.size())
        {
            const auto declared =
                model_.bufferViews[static_cast<std::size_t>(acc.bufferView)].byteStride;
            if (declared != 0)
            {
                if (declared < element_size)
                {
                    fail(what + " accessor " + std::to_string(accessor_index) +
                         " has a byteStride smaller than its element");
                }
                stride = declared;
            }
        }
        const auto [buffer, first] = view_range(acc.bufferView, acc.byteOffset, stride, count);
        for (std::uint64_t e = 0; e < count; ++e)
        {
            elements[e] = {buffer, first + e * stride};
        }
    }
    if (acc.sparse.isSparse)
    {
        const auto& sparse = acc.sparse;
        const auto n = static_cast<std::uint64_t>(std::max(sparse.count, 0));
        const auto index_type = component_of(sparse.indices.componentType);
        if (n > count || !index_type ||
            (*index_type != GltfComponent::UInt8 && *index_type != GltfComponent::UInt16 &&
             *index_type != GltfComponent::UInt32) ||
            sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0)
        {
            fail(what + " accessor " + std::to_string(accessor_index) + " has invalid sparse data");
        }
        const std::size_t index_size = component_size(*index_type);
        if (sparse.indices.bufferView < 0 ||
            static_cast<std::size_t>(sparse.indices.bufferView) >= model_.bufferViews.size())
        {
            fail(what + " accessor " + std::to_string(accessor_index) +
                 " has invalid sparse indices");
        }
        if (const auto it = undecoded_.find(sparse.indices.bufferView); it != undecoded_.end())
        {
            fail("cannot read " + what + " accessor " + std::to_string(accessor_index) + ": " +
                 it->second);
        }
        const auto& index_view =
            model_.bufferViews[static_cast<std::size_t>(sparse.indices.bufferView)];
        const auto index_offset = static_cast<std::uint64_t>(sparse.indices.byteOffset);
        if (!is_view_in_buffer(index_view) ||
            !fits(index_offset, index_size, n, index_size, index_view.byteLength))
        {
            fail(what + " accessor " + std::to_string(accessor_index) +
                 " has sparse indices past the end of their bufferView");
        }
        const char* index_bytes =
            asset_.buffers[static_cast<std::size_t>(index_view.buffer)].bytes.data() +
            index_view.byteOffset + index_offset;
        const auto [buffer, first] =
            view_range(sparse.values.bufferView,
                       static_cast<std::uint64_t>(sparse.values.byteOffset), element_size, n);
        for (std::uint64_t j = 0; j < n; ++j)
        {
            const auto target = static_cast<std::uint64_t>(
                load_integer(index_bytes + j * index_size, scalar_of(*index_type), false));
            if (target >= count)
            {
                fail(what + " accessor " + std::to_string(accessor_index) + " has sparse index " +
                     std::to_string(target) + " " + index_range(count));
            }
            elements[target] = {buffer, first + j * element_size};
        }
    }
    return elements;
}

std::int32_t Reader::group_of(const Eigen::Matrix4d& to_world)
{
    for (std::size_t g = 0; g < groups_.size(); ++g)
    {
        if (same_matrix(groups_[g], to_world))
        {
            return static_cast<std::int32_t>(g);
        }
    }
    groups_.push_back(to_world);
    return static_cast<std::int32_t>(groups_.size() - 1);
}

void Reader::append_world(const std::vector<double>& local, const Eigen::Matrix4d& to_world,
                          std::int32_t group)
{
    const std::size_t n = local.size() / 3;
    for (std::size_t i = 0; i < n; ++i)
    {
        const Eigen::Vector4d p(local[3 * i], local[3 * i + 1], local[3 * i + 2], 1.0);
        const Eigen::Vector4d w = to_world * p;
        raw_.world.insert(raw_.world.end(), {w.x(), w.y(), w.z()});
        raw_.group.push_back(group);
    }
}

void Reader::add_plain(const tinygltf::Primitive& prim, int mesh, int index,
                       const Eigen::Matrix4d& to_world)
{
    const auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end())
    {
        return;
    }
    const int a = it->second;
    if (a < 0 || static_cast<std::size_t>(a) >= model_.accessors.size())
    {
        fail("mesh " + std::to_string(mesh) + " primitive " + std::to_string(index) +
             " has a missing POSITION accessor");
    }
    std::size_t slot = 0;
    if (const auto found = accessor_slot_.find(a); found != accessor_slot_.end())
    {
        slot = found->second;
        // Another instance of the same positions under a different transform: its vertices
        // cannot take a second displacement, so only the first instance is watermarked; its
        // geometry is kept aside for registration (MeshFile::instances).
        if (!same_matrix(asset_.accessors[slot].to_world, to_world))
        {
            const std::size_t base = add_instance(slot_base_[slot],
                                                  asset_.accessors[slot].elements.size(),
                                                  asset_.accessors[slot].to_world, to_world);
            if (prim.mode == kModeTriangles)
            {
                add_triangles(prim, mesh, index, base, asset_.accessors[slot].elements.size(),
                              instance_corners_);
            }
            return;
        }
    }
    else
    {
        const auto& acc = model_.accessors[static_cast<std::size_t>(a)];
        const auto component = component_of(acc.componentType);
        if (acc.type != TINYGLTF_TYPE_VEC3 || !component || *component == GltfComponent::UInt32)
        {
            fail("POSITION accessor " + std::to_string(a) +
                 " is not a VEC3 of float or 8/16-bit integers");
        }
        GltfPositionAccessor record;
        record.accessor = a;
        record.component = *component;
        record.is_normalized = acc.normalized;
        record.to_world = to_world;
        record.elements = locate(a, 3, "POSITION");
        // Local positions, decoded and de-normalized as a renderer would.
        std::vector<double> local(3 * record.elements.size(), 0.0);
        const auto type = scalar_of(record.component);
        const std::size_t size = component_size(record.component);
        for (std::size_t e = 0; e < record.elements.size(); ++e)
        {
            const auto& el = record.elements[e];
            for (std::size_t d = 0; d < 3 && el.buffer >= 0; ++d)
            {
                const char* p = asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() +
                                el.offset + d * size;
                local[3 * e + d] =
                    dequantize(load_scalar(p, type, false), record.component, record.is_normalized);
            }
        }
        for (std::size_t k = 0; k < local.size(); ++k)
        {
            if (!std::isfinite(local[k]))
            {
                fail_mesh(path_, "POSITION accessor " + std::to_string(a) + " element " +
                                     std::to_string(k / 3) + " has a non-finite coordinate");
            }
        }
        slot = asset_.accessors.size();
        accessor_slot_[a] = slot;
        slot_base_.push_back(raw_.group.size());
        append_world(local, to_world, group_of(to_world));
        asset_.accessors.push_back(std::move(record));
    }
    if (prim.mode == kModeTriangles)
    {
        add_triangles(prim, mesh, index, slot_base_[slot], asset_.accessors[slot].elements.size());
    }
}

void Reader::add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                           std::size_t count)
{
    add_triangles(prim, mesh, index, base, count, corners_);
}

// The points of another instance of raw elements [first, first + count), first read under
// \p from, now under \p to; returns the index of its first point in instance_xyz_.
std::size_t Reader::add_instance(std::size_t first, std::size_t count, const Eigen::Matrix4d& from,
                                 const Eigen::Matrix4d& to)
{
    const Eigen::Matrix4d map = to * from.inverse();
    const std::size_t base = instance_xyz_.size() / 3;
    for (std::size_t e = first; e < first + count; ++e)
    {
        const Eigen::Vector4d p(raw_.world[3 * e], raw_.world[3 * e + 1], raw_.world[3 * e + 2],
                                1.0);
        const Eigen::Vector4d q = map * p;
        instance_xyz_.insert(instance_xyz_.end(), {q.x(), q.y(), q.z()});
    }
    return base;
}

void Reader::add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                           std::size_t count, std::vector<std::size_t>& corners)
{
    const std::string where =
        "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index);
    if (prim.indices < 0)
    {
        if (count % 3 != 0)
        {
            fail_mesh(path_, where + " has " + std::to_string(count) +
                                 " non-indexed vertices, not a multiple of 3");
        }
        for (std::size_t e = 0; e < count; ++e)
        {
            corners.push_back(base + e);
        }
        return;
    }
    if (static_cast<std::size_t>(prim.indices) >= model_.accessors.size())
    {
        fail(where + " has a missing indices accessor");
    }
    const auto& acc = model_.accessors[static_cast<std::size_t>(prim.indices)];
    const auto component = component_of(acc.componentType);
    if (acc.type != TINYGLTF_TYPE_SCALAR || !component ||
        (*component != GltfComponent::UInt8 && *component != GltfComponent::UInt16 &&
         *component != GltfComponent::UInt32))
    {
        fail(where + " has indices that are not unsigned integer scalars");
    }
    const auto elements = locate(prim.indices, 1, "indices");
    if (elements.size() % 3 != 0)
    {
        fail_mesh(path_, where + " has " + std::to_string(elements.size()) +
                             " indices, not a multiple of 3");
    }
    const auto type = scalar_of(*component);
    for (const auto& el : elements)
    {
        const std::uint64_t i =
            el.buffer < 0
                ? 0
                : static_cast<std::uint64_t>(load_integer(
                      asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() + el.offset,
                      type, false));
        if (i >= count)
        {
            fail_mesh(path_, where + " has index " + std::to_string(i) + " " + index_range(count));
        }
        corners.push_back(base + i);
    }
}

void Reader::add_draco(const tinygltf::Primitive& prim, int mesh, int index,
                       const Eigen::Matrix4d& to_world)
{
    const std::string where =
        "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index);
    const auto& ext = prim.extensions.at(kDracoExtension);
    // tinygltf::Value::Get asserts an object: check the shape before each lookup.
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
    {
        fail(where + " has a malformed " + std::string(kDracoExtension) + " extension");
    }
    const auto& view_value = ext.Get("bufferView");
    const auto& position_value = ext.Get("attributes").Get("POSITION");
    const auto position = prim.attributes.find("POSITION");
    if (!view_value.IsInt() || !position_value.IsInt() || position == prim.attributes.end() ||
        position->second < 0 ||
        static_cast<std::size_t>(position->second) >= model_.accessors.size())
    {
        fail(where + " has a " + std::string(kDracoExtension) +
             " extension without bufferView or POSITION attribute");
    }
    const int view_index = view_value.Get<int>();
    if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size())
    {
        fail(where + " refers to missing Draco bufferView " + std::to_string(view_index));
    }
    std::size_t slot = 0;
    if (const auto found = draco_slot_.find(view_index); found != draco_slot_.end())
    {
        slot = found->second;
        if (!same_matrix(asset_.draco[slot].to_world, to_world))
        {
            // A second instance, see add_plain.
            const std::size_t base = add_instance(draco_base_[slot], asset_.draco[slot].welded.size(),
                                                  asset_.draco[slot].to_world, to_world);
            const auto [first, last] = draco_corners_[slot];
            for (std::size_t k = first; k < last; ++k)
            {
                instance_corners_.push_back(base + corners_[k] - draco_base_[slot]);
            }
            return;
        }
    }
    else
    {
        const auto& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
        if (!is_view_in_buffer(view))
        {
            fail(where + " has a Draco bufferView past the end of its buffer");
        }
        GltfDracoPrimitive record;
        record.mesh = mesh;
        record.primitive = index;
        record.buffer_view = view_index;
        record.position_accessor = position->second;
        record.position_attribute_id = position_value.Get<int>();
        record.to_world = to_world;
        const auto& draco_attributes = ext.Get("attributes").Keys();
        record.has_foreign_attributes = !prim.targets.empty();
        for (const auto& [name, accessor] : prim.attributes)
        {
            static_cast<void>(accessor);
            if (std::find(draco_attributes.begin(), draco_attributes.end(), name) ==
                draco_attributes.end())
            {
                record.has_foreign_attributes = true;
            }
        }
        const auto& buffer = asset_.buffers[static_cast<std::size_t>(view.buffer)].bytes;
        const auto geometry = decode_draco(path_, buffer.substr(view.byteOffset, view.byteLength),
                                           record.position_attribute_id);
        // The decoded values are stored values: with KHR_mesh_quantization, integers that the
        // accessor's `normalized` maps to [-1, 1] or [0, 1], as for uncompressed data.
        const auto& accessor = model_.accessors[static_cast<std::size_t>(position->second)];
        record.component = geometry.component;
        record.is_normalized = accessor.normalized && geometry.component != GltfComponent::Float32;
        std::vector<double> local(geometry.positions.size());
        for (std::size_t k = 0; k < local.size(); ++k)
        {
            local[k] = dequantize(geometry.positions[k], record.component, record.is_normalized);
        }
        slot = asset_.draco.size();
        draco_slot_[view_index] = slot;
        draco_base_.push_back(raw_.group.size());
        append_world(local, to_world, group_of(to_world));
        record.welded.resize(geometry.point_count);
        asset_.draco.push_back(std::move(record));
        const std::size_t first_corner = corners_.size();
        if (prim.mode == kModeTriangles)
        {
            for (const auto c : geometry.triangles)
            {
                corners_.push_back(draco_base_[slot] + c);
            }
        }
        draco_corners_.emplace_back(first_corner, corners_.size());
        return;
    }
    // A repeated use under the same transform adds the same triangles again; the Draco data
    // has one connectivity, so they are already there.
}

TriangleMesh Reader::weld()
{
    if (raw_.group.size() > kMaxVertices)
    {
        fail("the asset has more than " + std::to_string(kMaxVertices) + " vertices");
    }
    std::vector<double> xyz;
    const auto welded =
        weld_world_positions(raw_.world, raw_.group, groups_.size(), kCrossTransformWeldRel, xyz);

    // Hand the welded ids to the layout, then build the mesh.
    for (std::size_t s = 0; s < asset_.accessors.size(); ++s)
    {
        auto& record = asset_.accessors[s];
        record.welded.assign(
            welded.begin() + static_cast<std::ptrdiff_t>(slot_base_[s]),
            welded.begin() + static_cast<std::ptrdiff_t>(slot_base_[s] + record.elements.size()));
    }
    for (std::size_t s = 0; s < asset_.draco.size(); ++s)
    {
        auto& record = asset_.draco[s];
        const auto first = welded.begin() + static_cast<std::ptrdiff_t>(draco_base_[s]);
        std::copy(first, first + static_cast<std::ptrdiff_t>(record.welded.size()),
                  record.welded.begin());
    }
    if (!instance_xyz_.empty())
    {
        asset_.instances = make_mesh(instance_xyz_, instance_corners_);
    }
    TriangleBuffer triangles;
    triangles.reserve(corners_.size() / 3);
    for (std::size_t t = 0; t + 2 < corners_.size(); t += 3)
    {
        triangles.push(welded[corners_[t]], welded[corners_[t + 1]], welded[corners_[t + 2]]);
    }
    return make_mesh(xyz, triangles);
}

}  // namespace

double dequantize(double stored, GltfComponent component, bool is_normalized)
{
    if (!is_normalized)
    {
        return stored;
    }
    switch (component)
    {
        case GltfComponent::Int8:
            return std::max(stored / 127.0, -1.0);
        case GltfComponent::UInt8:
            return stored / 255.0;
        case GltfComponent::Int16:
            return std::max(stored / 32767.0, -1.0);
        case GltfComponent::UInt16:
            return stored / 65535.0;
        default:
            return stored;
    }
}

double quantize(double value, GltfComponent component, bool is_normalized)
{
    if (!is_normalized)
    {
        return value;
    }
    switch (component)
    {
        case GltfComponent::Int8:
            return value * 127.0;
        case GltfComponent::UInt8:
            return value * 255.0;
        case GltfComponent::Int16:
            return value * 32767.0;
        case GltfComponent::UInt16:
            return value * 65535.0;
        default:
            return value;
    }
}

std::pair<double, double> stored_range(GltfComponent component, bool is_normalized)
{
    switch (component)
    {
        case GltfComponent::Int8:
            return {is_normalized ? -127.0 : -128.0, 127.0};
        case GltfComponent::UInt8:
            return {0.0, 255.0};
        case GltfComponent::Int16:
            return {is_normalized ? -32767.0 : -32768.0, 32767.0};
        case GltfComponent::UInt16:
            return {0.0, 65535.0};
        default:
            return {-std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
    }
}

TriangleMesh read_gltf(const fs::path& path, const std::string& bytes, bool is_glb,
                       GltfAsset& asset)
{
    asset.is_glb = is_glb;
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
    Reader reader(path, model, asset);
    return reader.run();
}

}  // namespace meshmark::detail
