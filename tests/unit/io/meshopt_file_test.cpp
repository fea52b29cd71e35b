// SPDX-License-Identifier: MIT
// meshopt files as a whole: KHR_meshopt_compression, fallback buffers with data, truncated or
// corrupt streams, codec versions and required extensions.
#include <cmath>

#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "meshopt_test_support.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::decode_view;
using test::expect_same_mesh;
using test::GltfBuilder;
using test::Json;
using test::kPoints;
using test::Layout;
using test::meshopt_asset;
using test::moved_positions;
using test::Options;
using test::vertex_at;
using test::world_of;

class MeshoptFileTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("meshopt_file_test");
};

// The error message of reading \p path, or "" when it reads.
std::string read_error(const fs::path& path)
{
    try
    {
        static_cast<void>(read_mesh_file(path));
    }
    catch (const IoError& e)
    {
        return e.what();
    }
    return "";
}

TEST_F(MeshoptFileTest, khr_meshopt_compression_reads_and_writes_like_ext)
{
    Options options;
    options.extension = "KHR_meshopt_compression";
    const auto asset = meshopt_asset(options);
    test::put_bytes(dir / "k.glb", asset.builder.glb());
    options.is_compressed = false;
    test::put_bytes(dir / "plain.glb", meshopt_asset(options).builder.glb());
    const MeshFile file = read_mesh_file(dir / "k.glb");
    expect_same_mesh(file.mesh, read_mesh_file(dir / "plain.glb").mesh);
    const Positions moved = moved_positions(file.mesh.V);
    write_mesh_file(dir / "out.glb", file, moved);
    std::string bin;
    const Json after = test::glb_json(test::file_bytes(dir / "out.glb"), &bin);
    const std::string decoded =
        decode_view(after, bin, asset.position_view, "KHR_meshopt_compression");
    const std::string& old_decoded = asset.fallback;  // the decoded data of the input
    for (std::size_t k = 0; k < kPoints; ++k)
    {
        const Eigen::Index w = vertex_at(file.mesh.V, world_of(Layout::Float12, old_decoded, k));
        ASSERT_GE(w, 0);
        EXPECT_NEAR(world_of(Layout::Float12, decoded, k)[2], moved(w, 2), 1e-6);
    }
    EXPECT_LE((read_mesh_file(dir / "out.glb").mesh.V - moved).cwiseAbs().maxCoeff(), 1e-7);
}

TEST_F(MeshoptFileTest, a_fallback_with_data_gets_the_new_positions_and_keeps_the_rest)
{
    // The fallback is an external file (gltfpack -cf): meshmark prefers the decoded data, and
    // writes the re-encoded view's new decoded bytes into the new fallback file.
    Options options;
    options.fallback_uri = "fallback.bin";
    const auto asset = meshopt_asset(options);
    test::put_bytes(dir / "f.glb", asset.builder.glb());
    std::string stale = asset.fallback;
    stale[0] = '\x7f';  // a fallback that differs from the decoded data is not what is read
    test::put_bytes(dir / "fallback.bin", stale);
    const MeshFile file = read_mesh_file(dir / "f.glb");
    options.is_compressed = false;
    options.fallback_uri.clear();
    test::put_bytes(dir / "plain.glb", meshopt_asset(options).builder.glb());
    expect_same_mesh(file.mesh, read_mesh_file(dir / "plain.glb").mesh);

    write_mesh_file(dir / "same.glb", file, file.mesh.V);
    EXPECT_EQ(test::file_bytes(dir / "same.bin"), stale) << "unchanged: the stored bytes";

    const Positions moved = moved_positions(file.mesh.V);
    write_mesh_file(dir / "out.glb", file, moved);
    std::string bin;
    const Json after = test::glb_json(test::file_bytes(dir / "out.glb"), &bin);
    EXPECT_EQ(after["buffers"][1]["uri"], "out.bin");
    EXPECT_EQ(after["buffers"][1]["byteLength"], asset.fallback.size());
    const std::string fallback = test::file_bytes(dir / "out.bin");
    ASSERT_EQ(fallback.size(), asset.fallback.size());
    const auto& view = after["bufferViews"][static_cast<std::size_t>(asset.position_view)];
    const auto offset = view["byteOffset"].get<std::size_t>();
    const auto length = view["byteLength"].get<std::size_t>();
    EXPECT_EQ(fallback.substr(offset, length), decode_view(after, bin, asset.position_view));
    EXPECT_NE(fallback.substr(offset, length), stale.substr(offset, length));
    // Everything outside the re-encoded view is as stored (indices included).
    EXPECT_EQ(fallback.substr(offset + length), stale.substr(offset + length));
}

TEST_F(MeshoptFileTest, a_truncated_or_corrupt_stream_is_one_clear_error)
{
    auto asset = meshopt_asset({});
    auto& ext = asset.builder.doc["bufferViews"][static_cast<std::size_t>(asset.position_view)]
                                 ["extensions"]["EXT_meshopt_compression"];
    const auto length = ext["byteLength"].get<std::size_t>();
    ext["byteLength"] = length - 9;
    test::put_bytes(dir / "short.glb", asset.builder.glb());
    const std::string truncated = read_error(dir / "short.glb");
    EXPECT_NE(truncated.find("EXT_meshopt_compression stream of bufferView 0 is corrupt or "
                             "truncated"),
              std::string::npos)
        << truncated;

    ext["byteLength"] = length;
    asset.builder.bin[ext["byteOffset"].get<std::size_t>()] = '\x55';
    test::put_bytes(dir / "bad.glb", asset.builder.glb());
    const std::string header = read_error(dir / "bad.glb");
    EXPECT_NE(header.find("is not a meshopt ATTRIBUTES stream (header byte 0x55)"),
              std::string::npos)
        << header;

    // An index stream past the end of its buffer.
    auto asset2 = meshopt_asset({});
    asset2.builder.doc["bufferViews"][static_cast<std::size_t>(asset2.index_view)]["extensions"]
                      ["EXT_meshopt_compression"]["byteOffset"] = asset2.builder.bin.size();
    test::put_bytes(dir / "past.glb", asset2.builder.glb());
    const std::string past = read_error(dir / "past.glb");
    EXPECT_NE(past.find("past the end of buffer 0"), std::string::npos) << past;
}

TEST_F(MeshoptFileTest, an_unsupported_codec_version_is_named)
{
    // Vertex codec version 1 (meshoptimizer >= 0.23) in a view without fallback data.
    auto asset = meshopt_asset({});
    const auto& ext =
        asset.builder.doc["bufferViews"][static_cast<std::size_t>(asset.position_view)]
                         ["extensions"]["EXT_meshopt_compression"];
    asset.builder.bin[ext["byteOffset"].get<std::size_t>()] = '\xa1';
    test::put_bytes(dir / "v1.glb", asset.builder.glb());
    const std::string message = read_error(dir / "v1.glb");
    if (MESHOPTIMIZER_VERSION < 230)
    {
        EXPECT_NE(message.find("cannot read POSITION accessor 0: the EXT_meshopt_compression "
                               "stream of bufferView 0 uses vertex codec version 1, which the "
                               "meshoptimizer library meshmark is built with"),
                  std::string::npos)
            << message;
    }

    // An unknown filter on a view that holds no geometry does not stop the read.
    auto colors = meshopt_asset({});
    colors.builder.doc["bufferViews"].push_back({{"buffer", 1},
                                                 {"byteOffset", colors.fallback.size()},
                                                 {"byteLength", 4 * kPoints},
                                                 {"byteStride", 4},
                                                 {"extensions",
                                                  {{"EXT_meshopt_compression",
                                                    {{"buffer", 0},
                                                     {"byteOffset", 0},
                                                     {"byteLength", 8},
                                                     {"byteStride", 4},
                                                     {"count", kPoints},
                                                     {"mode", "ATTRIBUTES"},
                                                     {"filter", "COLOR"}}}}}});
    colors.builder.more_buffers[0]["byteLength"] = colors.fallback.size() + 4 * kPoints;
    test::put_bytes(dir / "color.glb", colors.builder.glb());
    EXPECT_EQ(read_error(dir / "color.glb"), "");
}

TEST_F(MeshoptFileTest, required_extensions_are_named_only_when_reading_fails)
{
    // An image extension does not affect positions: the asset reads.
    auto asset = meshopt_asset({});
    asset.builder.doc["extensionsRequired"].push_back("KHR_texture_basisu");
    test::put_bytes(dir / "basisu.glb", asset.builder.glb());
    EXPECT_EQ(read_error(dir / "basisu.glb"), "");

    // An unknown compression whose buffer has no data: the error names it.
    GltfBuilder b;
    const int pos = b.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    b.doc["bufferViews"][0]["buffer"] = 1;
    b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", pos}}}}}))}});
    b.more_buffers.push_back({{"byteLength", 4096}});
    b.doc["extensionsUsed"] = {"EXT_other_compression", "KHR_texture_basisu"};
    b.doc["extensionsRequired"] = {"EXT_other_compression", "KHR_texture_basisu"};
    test::put_bytes(dir / "other.glb", b.glb());
    const std::string message = read_error(dir / "other.glb");
    EXPECT_NE(message.find("(the asset requires extensions EXT_other_compression, "
                           "KHR_texture_basisu, which meshmark does not support)"),
              std::string::npos)
        << message;
}

}  // namespace
}  // namespace meshmark
