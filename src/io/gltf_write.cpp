// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB writers. The preserving writer patches position bytes in copies of the
// original buffers and edits only what positions determine in the JSON (POSITION min/max;
// for re-encoded Draco data, its bufferView, the views after it and the buffer length; for a
// re-encoded meshopt stream, its extension's byteLength, the streams and views after it and
// the buffer length): nlohmann::ordered_json keeps every other member, unknown ones included,
// in its order. This file runs its steps in order and writes the files (external buffers
// beside the asset, all atomically), or returns the asset as one file's bytes (no external
// buffers; image URIs as written); the generic writer builds a minimal asset.
#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <fstream>
#include <limits>
#include <string_view>
#include <utility>

#include "io/detail/gltf_writer.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

std::string percent_encoded(const std::string& name)
{
    std::string out;
    for (const char ch : name)
    {
        const auto c = static_cast<unsigned char>(ch);
        if (std::isalnum(c) != 0 || c == '-' || c == '.' || c == '_' || c == '~')
        {
            out += ch;
        }
        else
        {
            constexpr std::string_view kHex = "0123456789ABCDEF";
            out += '%';
            out += kHex[c >> 4U];
            out += kHex[c & 0xfU];
        }
    }
    return out;
}

// Runs \p body; the reader validated the asset, so an unexpected JSON shape met while
// rewriting it is still one clear error naming \p path.
template <typename Body>
void guarded_json(const fs::path& path, const Body& body)
{
    try
    {
        body();
    }
    catch (const GltfJson::exception& e)
    {
        fail_io(path, std::string("cannot update the glTF JSON: ") + e.what());
    }
}

}  // namespace

GltfWriter::GltfWriter(const fs::path& path, const GltfAsset& asset, const Positions& original,
                       const Positions& positions, fs::path link_folder)
    : path_(path),
      asset_(asset),
      original_(original),
      positions_(positions),
      link_folder_(std::move(link_folder))
{
    for (const auto& b : asset.buffers)
    {
        buffers_.push_back(b.bytes);
    }
}

void GltfWriter::fail(const std::string& what) const
{
    fail_io(path_, what);
}

GltfJson& GltfWriter::doc()
{
    if (!doc_)
    {
        try
        {
            doc_ = parse_unpadded_json(asset_.json);
        }
        catch (const GltfJson::exception& e)
        {
            fail(std::string("cannot re-parse the glTF JSON: ") + e.what());
        }
    }
    return *doc_;
}

std::vector<std::pair<fs::path, std::string>> GltfWriter::external_files()
{
    std::vector<std::size_t> external;
    for (std::size_t b = 0; b < asset_.buffers.size(); ++b)
    {
        if (asset_.buffers[b].source == GltfBufferSource::External)
        {
            external.push_back(b);
        }
    }
    std::vector<std::pair<fs::path, std::string>> files;
    if (external.empty())
    {
        return files;
    }
    // Names derived from the output; never one of the files the source asset reads.
    std::string stem = path_.stem().string();
    const auto name_of = [&](std::size_t k)
    { return external.size() == 1 ? stem + ".bin" : stem + "_" + std::to_string(k) + ".bin"; };
    const auto collides = [&]()
    {
        for (std::size_t k = 0; k < external.size(); ++k)
        {
            const fs::path candidate = path_.parent_path() / name_of(k);
            for (const auto& b : asset_.buffers)
            {
                if (b.source == GltfBufferSource::External && is_same_file(candidate, b.file))
                {
                    return true;
                }
            }
        }
        return false;
    };
    while (collides())
    {
        stem += "_wm";
    }
    for (std::size_t k = 0; k < external.size(); ++k)
    {
        const std::string name = name_of(k);
        doc()["buffers"][external[k]]["uri"] = percent_encoded(name);
        files.emplace_back(path_.parent_path() / name, buffers_[external[k]]);
    }
    is_json_changed_ = true;
    return files;
}

// Images with relative URIs resolve against the asset's folder. Written to another folder,
// the marked asset would show no textures, so each image the source has is copied beside the
// output under the same relative path (the folders made as needed), unless a file with the same
// bytes is already there (copies for several recipients in one folder share them). An image
// whose path would leave the output's folder ("../x.png") or whose place holds another file
// keeps the source's image instead: its URI is rewritten to reach it from the output. A
// missing image is left as it was (the source shows none either). Returns (from, to) pairs.
std::vector<std::pair<fs::path, fs::path>> GltfWriter::image_copies()
{
    std::vector<std::pair<fs::path, fs::path>> copies;
    const fs::path from_folder = asset_.folder.empty() ? fs::path(".") : asset_.folder;
    const fs::path to_folder = path_.parent_path().empty() ? fs::path(".") : path_.parent_path();
    if (is_same_file(from_folder, link_folder_.empty() ? to_folder : link_folder_) ||
        !doc().contains("images") || !doc()["images"].is_array())
    {
        return copies;
    }
    for (auto& image : doc()["images"])
    {
        if (!image.is_object() || !image.contains("uri") || !image["uri"].is_string())
        {
            continue;
        }
        const std::string uri = image["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0 || uri.find(':') != std::string::npos)
        {
            continue;  // embedded, or an absolute URI (a scheme): resolves anywhere
        }
        const fs::path relative = fs::path(percent_decoded(uri)).lexically_normal();
        const fs::path from = from_folder / relative;
        const fs::path to = to_folder / relative;
        const bool stays_inside =
            relative.is_relative() && !relative.empty() && *relative.begin() != "..";
        std::error_code error;
        if (stays_inside && fs::is_regular_file(from, error) && !fs::exists(to, error))
        {
            copies.emplace_back(from, to);
            continue;
        }
        const auto reach = relinked(from_folder, to_folder, relative, link_folder_);
        if (reach && !reach->empty())
        {
            std::string encoded;
            for (const auto& part : *reach)
            {
                if (!encoded.empty())
                {
                    encoded += '/';
                }
                encoded += percent_encoded(part.string());
            }
            image["uri"] = encoded;
            is_json_changed_ = true;
        }
    }
    return copies;
}

std::string GltfWriter::json_text()
{
    for (std::size_t b = 0; b < asset_.buffers.size(); ++b)
    {
        if (asset_.buffers[b].source == GltfBufferSource::DataUri &&
            buffers_[b] != asset_.buffers[b].bytes)
        {
            doc()["buffers"][b]["uri"] = asset_.buffers[b].uri_prefix + base64_encode(buffers_[b]);
            is_json_changed_ = true;
        }
    }
    if (!is_json_changed_)
    {
        return asset_.json;
    }
    // Indented like the source: pretty-printed sources get 2-space indentation back.
    const bool is_pretty = asset_.json.find('\n') != std::string::npos;
    try
    {
        return is_pretty ? doc().dump(2) : doc().dump();
    }
    catch (const GltfJson::exception& e)
    {
        fail(std::string("cannot serialize the glTF JSON: ") + e.what());
    }
}

void GltfWriter::rewrite()
{
    // New stored values of every POSITION record; a record that a moved vertex pushes past
    // what its integer type holds gets a wider grid (or float32) before anything is written.
    std::vector<Plan> plans;
    for (std::size_t slot = 0; slot < asset_.accessors.size(); ++slot)
    {
        plans.push_back(plan_accessor(slot));
    }
    for (std::size_t slot = 0; slot < asset_.draco.size(); ++slot)
    {
        plans.push_back(plan_draco(slot));
    }
    for (std::size_t p = 0; p < plans.size(); ++p)
    {
        if (overflows(plans[p]))
        {
            fit_range(plans, p);
        }
    }
    keep_vertices_apart(plans);
    // Plain accessors first: their byte offsets are those of the original buffers, which
    // meshopt and Draco re-encoding may shift and float32 views appended to a buffer extend.
    // Positions in meshopt views are written into the decoded data, which write_meshopt then
    // compresses.
    for (const auto& plan : plans)
    {
        if (!plan.is_draco && !plan.as_float)
        {
            write_accessor(plan);
        }
    }
    write_meshopt();
    for (const auto& plan : plans)
    {
        if (plan.is_draco)
        {
            write_draco(plan);
        }
    }
    for (const auto& plan : plans)
    {
        if (plan.as_float && !plan.is_draco)
        {
            write_float_accessor(plan);
        }
    }
}

std::string GltfWriter::main_file(bool is_glb)
{
    if (!is_glb)
    {
        return json_text();
    }
    // The BIN chunk is buffer 0 (moved out: this is the writer's last step) and the chunk's
    // original padding, kept when the buffer kept its length.
    const std::string json = json_text();
    std::string bin;
    const bool has_bin_buffer =
        !asset_.buffers.empty() && asset_.buffers[0].source == GltfBufferSource::GlbBinChunk;
    if (has_bin_buffer)
    {
        const bool is_same_length = buffers_[0].size() == asset_.buffers[0].bytes.size();
        bin = std::move(buffers_[0]);
        if (is_same_length)
        {
            bin += asset_.glb_bin_padding;
        }
    }
    else
    {
        bin = asset_.glb_bin_padding;
    }
    return assemble_glb(path_, json, asset_.glb_has_bin ? &bin : nullptr, asset_.glb_tail);
}

std::string GltfWriter::one_file(bool is_glb)
{
    // External buffers are files of their own: refused before any work.
    const auto is_external = [](const GltfBuffer& b)
    { return b.source == GltfBufferSource::External; };
    if (std::any_of(asset_.buffers.begin(), asset_.buffers.end(), is_external))
    {
        fail(std::string("the asset has external buffers (.bin files) and cannot be returned as "
                         "one ") +
             (is_glb ? ".glb" : ".gltf") +
             " file; ask for another format (which carries the positions and triangles only)");
    }
    rewrite();
    return main_file(is_glb);
}

void GltfWriter::run(bool is_glb)
{
    rewrite();
    // External buffers and images beside the output: their names and URIs are set in the
    // JSON before it is serialized.
    const auto files = external_files();
    const auto images = image_copies();
    const std::string main = main_file(is_glb);

    // Buffers and images beside the output first, then the asset; on failure nothing new is
    // left (the files written and the folders made for images).
    std::vector<fs::path> written;
    std::vector<fs::path> made;
    try
    {
        for (const auto& [from, to] : images)
        {
            for (fs::path folder = to.parent_path(); !folder.empty() && !fs::exists(folder);
                 folder = folder.parent_path())
            {
                made.push_back(folder);
            }
            fs::create_directories(to.parent_path());
            write_file_atomically(to, [&from = from](std::ostream& out)
                                  { out << std::ifstream(from, std::ios::binary).rdbuf(); });
            written.push_back(to);
        }
        for (const auto& [file, bytes] : files)
        {
            write_file_atomically(
                file, [&bytes = bytes](std::ostream& out)
                { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
            written.push_back(file);
        }
        write_file_atomically(
            path_, [&main](std::ostream& out)
            { out.write(main.data(), static_cast<std::streamsize>(main.size())); });
    }
    catch (...)
    {
        std::error_code ignored;
        for (const auto& file : written)
        {
            fs::remove(file, ignored);
        }
        std::sort(made.begin(), made.end(),
                  [](const fs::path& a, const fs::path& b)
                  { return a.native().size() > b.native().size(); });
        for (const auto& folder : made)  // deepest first; each only if empty
        {
            fs::remove(folder, ignored);
        }
        throw;
    }
}

void write_gltf_preserving(const fs::path& path, bool is_glb, const GltfAsset& asset,
                           const Positions& original, const Positions& positions,
                           const fs::path& link_folder)
{
    GltfWriter writer(path, asset, original, positions, link_folder);
    guarded_json(path, [&] { writer.run(is_glb); });
}

std::string preserved_gltf_bytes(const fs::path& path, bool is_glb, const GltfAsset& asset,
                                 const Positions& original, const Positions& positions)
{
    GltfWriter writer(path, asset, original, positions);
    std::string bytes;
    guarded_json(path, [&] { bytes = writer.one_file(is_glb); });
    return bytes;
}

std::string gltf_bytes(const TriangleMesh& mesh, bool is_glb)
{
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    const auto f = static_cast<std::size_t>(mesh.F.rows());
    GltfJson doc;
    doc["asset"] = {{"version", "2.0"}, {"generator", "meshmark"}};
    doc["scene"] = 0;
    if (n == 0)
    {
        doc["scenes"] = GltfJson::array({GltfJson::object({{"nodes", GltfJson::array()}})});
        const std::string text = doc.dump();
        return is_glb ? assemble_glb("(generated)", text, nullptr, "") : text;
    }
    doc["scenes"] = GltfJson::array({{{"nodes", {0}}}});
    doc["nodes"] = GltfJson::array({{{"mesh", 0}}});

    // One buffer: float32 positions, then uint32 indices (both 4-byte aligned).
    std::string bin(12 * n + 12 * f, '\0');
    std::array<double, 3> lo{};
    std::array<double, 3> hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            const float v = static_cast<float>(
                mesh.V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)));
            store_float(bin.data() + 12 * i + 4 * d, v, false);
            lo[d] = std::min(lo[d], static_cast<double>(v));
            hi[d] = std::max(hi[d], static_cast<double>(v));
        }
    }
    static_assert(sizeof(std::int32_t) == 4);
    std::memcpy(bin.data() + 12 * n, mesh.F.data(), 12 * f);  // little-endian host assumed

    GltfJson min = GltfJson::array();
    GltfJson max = GltfJson::array();
    for (std::size_t d = 0; d < 3; ++d)
    {
        min.push_back(float_number(lo[d]));
        max.push_back(float_number(hi[d]));
    }
    GltfJson primitive = {{"attributes", {{"POSITION", 0}}}, {"mode", f > 0 ? 4 : 0}};
    doc["bufferViews"] = GltfJson::array(
        {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 12 * n}, {"target", kArrayBuffer}}});
    doc["accessors"] = GltfJson::array({{{"bufferView", 0},
                                         {"componentType", kFloat},
                                         {"count", n},
                                         {"type", "VEC3"},
                                         {"min", min},
                                         {"max", max}}});
    if (f > 0)
    {
        primitive["indices"] = 1;
        doc["bufferViews"].push_back({{"buffer", 0},
                                      {"byteOffset", 12 * n},
                                      {"byteLength", 12 * f},
                                      {"target", kElementArrayBuffer}});
        doc["accessors"].push_back({{"bufferView", 1},
                                    {"componentType", kUnsignedInt},
                                    {"count", 3 * f},
                                    {"type", "SCALAR"}});
    }
    doc["meshes"] = GltfJson::array({{{"primitives", GltfJson::array({primitive})}}});
    GltfJson buffer = {{"byteLength", bin.size()}};
    if (!is_glb)
    {
        buffer["uri"] = "data:application/octet-stream;base64," + base64_encode(bin);
    }
    doc["buffers"] = GltfJson::array({buffer});
    const std::string text = doc.dump();
    return is_glb ? assemble_glb("(generated)", text, &bin, "") : text;
}

}  // namespace meshmark::detail
