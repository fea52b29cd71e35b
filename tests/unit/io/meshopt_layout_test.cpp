// SPDX-License-Identifier: MIT
// EXT_meshopt_compression in each vertex layout (float and int16 positions, byteStride 12 and 8,
// the EXPONENTIAL filter): read like the uncompressed equivalent; moved positions are re-encoded,
// and what meshoptimizer's own decoder makes of the written streams is checked against the
// positions written.
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
using test::Asset;
using test::decode_view;
using test::expect_same_mesh;
using test::GltfBuilder;
using test::Json;
using test::kGrid;
using test::kPoints;
using test::kShortScale;
using test::Layout;
using test::meshopt_asset;
using test::moved_positions;
using test::Options;
using test::stride_of;
using test::tolerance_of;
using test::vertex_at;
using test::world_of;

class MeshoptTest : public ::testing::TestWithParam<Layout>
{
protected:
    /// The asset of this test's layout, saved as dir / "c.glb".
    Asset saved_asset() const
    {
        Options options;
        options.layout = GetParam();
        Asset asset = meshopt_asset(options);
        test::put_bytes(dir / "c.glb", asset.builder.glb());
        return asset;
    }

    fs::path dir = test::temp_dir("meshopt_test");
};

TEST_P(MeshoptTest, reads_like_the_uncompressed_asset)
{
    Options options;
    options.layout = GetParam();
    test::put_bytes(dir / "c.glb", meshopt_asset(options).builder.glb());
    options.is_compressed = false;
    test::put_bytes(dir / "plain.glb", meshopt_asset(options).builder.glb());
    const MeshFile compressed = read_mesh_file(dir / "c.glb");
    const MeshFile plain = read_mesh_file(dir / "plain.glb");
    EXPECT_EQ(compressed.mesh.V.rows(), static_cast<Eigen::Index>(kPoints + 3));
    EXPECT_EQ(compressed.mesh.F.rows(), 2 * (kGrid - 1) * (kGrid - 1) + 1);
    expect_same_mesh(compressed.mesh, plain.mesh);
}

TEST_P(MeshoptTest, unchanged_positions_keep_the_file)
{
    const std::string glb = saved_asset().builder.glb();
    EXPECT_EQ(test::rewritten_unchanged(dir / "c.glb", dir / "same.glb"), glb);
}

TEST_P(MeshoptTest, moved_positions_are_reencoded_and_decode_to_what_was_written)
{
    const Layout layout = GetParam();
    const auto asset = saved_asset();
    const MeshFile file = read_mesh_file(dir / "c.glb");
    const Positions moved = moved_positions(file.mesh.V);
    write_mesh_file(dir / "out.glb", file, moved);

    std::string bin_before;
    std::string bin_after;
    const Json before = test::glb_json(test::file_bytes(dir / "c.glb"), &bin_before);
    const Json after = test::glb_json(test::file_bytes(dir / "out.glb"), &bin_after);
    // The fallback buffer is untouched; buffer 0 holds the new streams.
    EXPECT_EQ(after["buffers"][1], before["buffers"][1]);
    EXPECT_EQ(after["buffers"][0]["byteLength"].get<std::size_t>(), bin_after.size());
    for (const int v : {asset.position_view, asset.index_view})
    {
        EXPECT_EQ(after["bufferViews"][static_cast<std::size_t>(v)]["byteOffset"],
                  before["bufferViews"][static_cast<std::size_t>(v)]["byteOffset"]);
        EXPECT_EQ(after["bufferViews"][static_cast<std::size_t>(v)]["byteLength"],
                  before["bufferViews"][static_cast<std::size_t>(v)]["byteLength"]);
    }
    const auto& ext = after["bufferViews"][static_cast<std::size_t>(asset.position_view)]
                           ["extensions"]["EXT_meshopt_compression"];
    EXPECT_EQ(static_cast<unsigned char>(bin_after[ext["byteOffset"].get<std::size_t>()]), 0xa0)
        << "vertex codec version 0";
    EXPECT_NE(ext["byteLength"],
              before["bufferViews"][static_cast<std::size_t>(asset.position_view)]["extensions"]
                    ["EXT_meshopt_compression"]["byteLength"])
        << "new data compresses to another size, which exercises the shifts";

    // The indices decode as before (the stream may have moved, 4-byte aligned).
    EXPECT_EQ(decode_view(after, bin_after, asset.index_view),
              decode_view(before, bin_before, asset.index_view));
    EXPECT_EQ(after["bufferViews"][static_cast<std::size_t>(asset.index_view)]["extensions"]
                   ["EXT_meshopt_compression"]["byteOffset"]
                       .get<std::size_t>() %
                  4,
              0U);

    // The positions decode to the moved ones, to the precision of the stored type.
    const std::string decoded = decode_view(after, bin_after, asset.position_view);
    const double tolerance = tolerance_of(layout);
    bool is_any_moved = false;
    std::array<double, 3> lo{1e30, 1e30, 1e30};
    std::array<double, 3> hi{-1e30, -1e30, -1e30};
    const std::string old_decoded = decode_view(before, bin_before, asset.position_view);
    for (std::size_t k = 0; k < kPoints; ++k)
    {
        const auto p = world_of(layout, decoded, k);
        const auto original = world_of(layout, old_decoded, k);
        const Eigen::Index w = vertex_at(file.mesh.V, original);
        ASSERT_GE(w, 0);
        for (std::size_t d = 0; d < 3; ++d)
        {
            EXPECT_NEAR(p[d], moved(w, static_cast<Eigen::Index>(d)), tolerance)
                << "element " << k << " axis " << d;
            is_any_moved = is_any_moved || p[d] != original[d];
            const double local = p[d] - (d == 2 ? 2.0 : 0.0);
            const double stored = layout == Layout::Short8 ? local * kShortScale : local;
            lo[d] = std::min(lo[d], stored);
            hi[d] = std::max(hi[d], stored);
        }
    }
    EXPECT_TRUE(is_any_moved);
    // min/max are those of the decoded data.
    const auto& acc = after["accessors"][0];
    for (std::size_t d = 0; d < 3; ++d)
    {
        EXPECT_NEAR(acc["min"][d].get<double>(), lo[d], layout == Layout::Short8 ? 1e-9 : 1e-6);
        EXPECT_NEAR(acc["max"][d].get<double>(), hi[d], layout == Layout::Short8 ? 1e-9 : 1e-6);
    }

    // meshmark reads back what it wrote, the plain triangle after the shifted streams too.
    const MeshFile back = read_mesh_file(dir / "out.glb");
    ASSERT_EQ(back.mesh.V.rows(), moved.rows());
    EXPECT_LE((back.mesh.V - moved).cwiseAbs().maxCoeff(), tolerance);
    EXPECT_TRUE(back.mesh.F == file.mesh.F);
    EXPECT_EQ(back.mesh.V.col(2).maxCoeff(), 5.0);
}

TEST_P(MeshoptTest, one_moved_vertex_leaves_the_others_decoding_to_their_old_bytes)
{
    // With the exponential filter this holds only when the re-encoding uses the input's
    // mantissa bits (recovered from the stream): fewer would round the other elements.
    const Layout layout = GetParam();
    const auto asset = saved_asset();
    const MeshFile file = read_mesh_file(dir / "c.glb");
    Positions moved = file.mesh.V;
    const Eigen::Index w = vertex_at(moved, world_of(layout, asset.fallback, 40));
    ASSERT_GE(w, 0);
    moved(w, 2) += 0.01;
    write_mesh_file(dir / "out.glb", file, moved);
    std::string bin;
    const Json after = test::glb_json(test::file_bytes(dir / "out.glb"), &bin);
    const std::string decoded = decode_view(after, bin, asset.position_view);
    const std::size_t stride = stride_of(layout);
    ASSERT_EQ(decoded.size(), kPoints * stride);
    for (std::size_t k = 0; k < kPoints; ++k)
    {
        const bool is_same =
            decoded.compare(k * stride, stride, asset.fallback, k * stride, stride) == 0;
        EXPECT_EQ(is_same, k != 40) << "element " << k;
    }
}

INSTANTIATE_TEST_SUITE_P(Layouts, MeshoptTest,
                         ::testing::Values(Layout::Float12, Layout::Float12Exp, Layout::Short8),
                         [](const ::testing::TestParamInfo<Layout>& info)
                         {
                             switch (info.param)
                             {
                                 case Layout::Float12:
                                     return std::string("float_stride12");
                                 case Layout::Float12Exp:
                                     return std::string("float_exponential");
                                 default:
                                     return std::string("int16_stride8");
                             }
                         });

}  // namespace
}  // namespace meshmark
