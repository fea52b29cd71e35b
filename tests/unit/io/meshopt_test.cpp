// SPDX-License-Identifier: MIT
// EXT_meshopt_compression / KHR_meshopt_compression: fixtures encoded here with
// libmeshoptimizer (float and int16 positions, byteStride 12 and 8, the EXPONENTIAL filter,
// TRIANGLES indices, a fallback buffer without uri) read like their uncompressed equivalents;
// moved positions are re-encoded, and what meshoptimizer's own decoder makes of the written
// streams is checked against the positions written.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::Json;

constexpr int kGrid = 9;
constexpr std::size_t kPoints = kGrid * kGrid;
constexpr double kShortScale = 1000.0;  // int16 positions store 1000 x local
constexpr int kExpBits = 14;

enum class Layout
{
    Float12,     // float VEC3, byteStride 12, filter NONE
    Float12Exp,  // float VEC3, byteStride 12, filter EXPONENTIAL (14-bit mantissas)
    Short8,      // SHORT VEC3 + 2 padding bytes, byteStride 8, under a scaling node
};

std::array<double, 3> grid_point(std::size_t k)
{
    const double x = static_cast<double>(k % kGrid) / (kGrid - 1);
    const double y = static_cast<double>(k / kGrid) / (kGrid - 1);
    return {x, y, 0.15 * std::sin(5.0 * x) * std::cos(3.0 * y)};
}

std::vector<std::uint16_t> grid_triangles()
{
    std::vector<std::uint16_t> t;
    for (int j = 0; j + 1 < kGrid; ++j)
    {
        for (int i = 0; i + 1 < kGrid; ++i)
        {
            const auto a = static_cast<std::uint16_t>(j * kGrid + i);
            const auto b = static_cast<std::uint16_t>(a + 1);
            const auto c = static_cast<std::uint16_t>(a + kGrid + 1);
            const auto d = static_cast<std::uint16_t>(a + kGrid);
            t.insert(t.end(), {a, b, c, a, c, d});
        }
    }
    return t;
}

std::size_t stride_of(Layout layout)
{
    return layout == Layout::Short8 ? 8 : 12;
}

// The vertex bytes as stored in the (decoded) bufferView, and their filtered encoding for
// the exponential layout (whose decoded values are what the uncompressed twin holds).
struct VertexData
{
    std::string decoded;
    std::string filtered;  // input of the vertex codec
};

VertexData vertex_data(Layout layout)
{
    VertexData data;
    const std::size_t stride = stride_of(layout);
    data.decoded.assign(kPoints * stride, '\0');
    for (std::size_t k = 0; k < kPoints; ++k)
    {
        const auto p = grid_point(k);
        for (std::size_t d = 0; d < 3; ++d)
        {
            if (layout == Layout::Short8)
            {
                const auto v = static_cast<std::int16_t>(std::lround(p[d] * kShortScale));
                std::memcpy(data.decoded.data() + k * stride + 2 * d, &v, 2);
            }
            else
            {
                const auto v = static_cast<float>(p[d]);
                std::memcpy(data.decoded.data() + k * stride + 4 * d, &v, 4);
            }
        }
    }
    data.filtered = data.decoded;
    if (layout == Layout::Float12Exp)
    {
        std::vector<float> values(kPoints * 3);
        std::memcpy(values.data(), data.decoded.data(), data.decoded.size());
        meshopt_encodeFilterExp(data.filtered.data(), kPoints, stride, kExpBits, values.data());
        data.decoded = data.filtered;
        meshopt_decodeFilterExp(data.decoded.data(), kPoints, stride);
    }
    return data;
}

std::string encode_vertices(const std::string& bytes, std::size_t count, std::size_t stride)
{
    std::string out(meshopt_encodeVertexBufferBound(count, stride), '\0');
    out.resize(meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(),
                                          bytes.data(), count, stride));
    return out;
}

std::string encode_triangles(const std::vector<std::uint16_t>& indices)
{
    std::string out(meshopt_encodeIndexBufferBound(indices.size(), kPoints), '\0');
    out.resize(meshopt_encodeIndexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(),
                                         indices.data(), indices.size()));
    return out;
}

struct Options
{
    Layout layout = Layout::Float12;
    bool is_compressed = true;
    const char* extension = "EXT_meshopt_compression";
    std::string fallback_uri;  // empty: a fallback buffer without data
};

// The grid (compressed positions and TRIANGLES indices in buffer 0, decoding into fallback
// buffer 1), followed in buffer 0 by a plain triangle whose bytes come after the compressed
// streams. Uncompressed: the same decoded bytes as plain views in buffer 0.
struct Asset
{
    GltfBuilder builder;
    std::string fallback;  // the decoded bytes of buffer 1 (what a fallback file holds)
    int position_view = 0;
    int index_view = 0;
    int triangle_view = 0;
};

Asset meshopt_asset(const Options& options)
{
    Asset asset;
    auto& b = asset.builder;
    const auto vertices = vertex_data(options.layout);
    const auto triangles = grid_triangles();
    const std::string index_stream = encode_triangles(triangles);
    // The codec may rotate a triangle's corners: the decoded order is what both twins hold.
    std::string index_bytes(2 * triangles.size(), '\0');
    EXPECT_EQ(meshopt_decodeIndexBuffer(index_bytes.data(), triangles.size(), 2,
                                        reinterpret_cast<const unsigned char*>(index_stream.data()),
                                        index_stream.size()),
              0);
    const std::size_t stride = stride_of(options.layout);
    const auto add = [&](const std::string& decoded, const std::string& encoded, std::size_t count,
                         std::size_t element, const char* mode, int target)
    {
        if (!options.is_compressed)
        {
            const int v =
                b.view(decoded, std::string(mode) == "ATTRIBUTES" ? static_cast<int>(element) : 0);
            b.doc["bufferViews"][static_cast<std::size_t>(v)]["target"] = target;
            return v;
        }
        b.align();
        Json ext = {{"buffer", 0},
                    {"byteOffset", b.bin.size()},
                    {"byteLength", encoded.size()},
                    {"byteStride", element},
                    {"mode", mode},
                    {"count", count}};
        if (options.layout == Layout::Float12Exp && std::string(mode) == "ATTRIBUTES")
        {
            ext["filter"] = "EXPONENTIAL";
        }
        b.bin += encoded;
        while (asset.fallback.size() % 4 != 0)
        {
            asset.fallback.push_back('\0');
        }
        Json view = {
            {"buffer", 1}, {"byteOffset", asset.fallback.size()}, {"byteLength", decoded.size()}};
        if (std::string(mode) == "ATTRIBUTES")
        {
            view["byteStride"] = element;
        }
        view["target"] = target;
        view["extensions"] = {{options.extension, ext}};
        asset.fallback += decoded;
        b.doc["bufferViews"].push_back(view);
        return static_cast<int>(b.doc["bufferViews"].size() - 1);
    };
    asset.position_view = add(vertices.decoded, encode_vertices(vertices.filtered, kPoints, stride),
                              kPoints, stride, "ATTRIBUTES", 34962);
    asset.index_view = add(index_bytes, index_stream, triangles.size(), 2, "TRIANGLES", 34963);
    const bool is_short = options.layout == Layout::Short8;
    const int pos = b.accessor(asset.position_view, 0, is_short ? 5122 : 5126, kPoints, "VEC3");
    // Bounds of the stored (decoded) values, as the spec asks.
    std::array<double, 3> lo{1e30, 1e30, 1e30};
    std::array<double, 3> hi{-1e30, -1e30, -1e30};
    for (std::size_t k = 0; k < kPoints; ++k)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            double v = 0.0;
            if (is_short)
            {
                std::int16_t s = 0;
                std::memcpy(&s, vertices.decoded.data() + k * stride + 2 * d, 2);
                v = s;
            }
            else
            {
                v = test::float_at(vertices.decoded, k * stride + 4 * d);
            }
            lo[d] = std::min(lo[d], v);
            hi[d] = std::max(hi[d], v);
        }
    }
    b.doc["accessors"][static_cast<std::size_t>(pos)]["min"] = lo;
    b.doc["accessors"][static_cast<std::size_t>(pos)]["max"] = hi;
    const int idx = b.accessor(asset.index_view, 0, 5123, triangles.size(), "SCALAR");
    const int mesh = b.mesh(
        Json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", idx}, {"material", 0}}}));
    if (is_short)
    {
        b.node({{"mesh", mesh},
                {"scale", {1.0 / kShortScale, 1.0 / kShortScale, 1.0 / kShortScale}},
                {"translation", {0.0, 0.0, 2.0}}});
    }
    else
    {
        b.node({{"mesh", mesh}, {"translation", {0.0, 0.0, 2.0}}});
    }
    // A plain triangle after the compressed data (its view shifts when they change size).
    const int tri = b.positions({0, 0, 5, 1, 0, 5, 0, 1, 5});
    asset.triangle_view = b.doc["accessors"][static_cast<std::size_t>(tri)]["bufferView"];
    b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", tri}}}}}))}});
    if (options.is_compressed)
    {
        Json fallback = {{"byteLength", asset.fallback.size()},
                         {"extensions", {{options.extension, {{"fallback", true}}}}}};
        if (!options.fallback_uri.empty())
        {
            fallback["uri"] = options.fallback_uri;
        }
        b.more_buffers.push_back(fallback);
        b.doc["extensionsUsed"] = {options.extension};
        if (options.fallback_uri.empty())
        {
            b.doc["extensionsRequired"] = {options.extension};
        }
    }
    return asset;
}

// The decoded bytes of a compressed view, by meshoptimizer alone (no meshmark code).
std::string decode_view(const Json& doc, const std::string& bin, int view_index,
                        const char* extension = "EXT_meshopt_compression")
{
    const auto& ext =
        doc["bufferViews"][static_cast<std::size_t>(view_index)]["extensions"][extension];
    const auto count = ext["count"].get<std::size_t>();
    const auto stride = ext["byteStride"].get<std::size_t>();
    const auto offset = ext.value("byteOffset", std::size_t{0});
    const auto length = ext["byteLength"].get<std::size_t>();
    std::string out(count * stride, '\0');
    const auto* data = reinterpret_cast<const unsigned char*>(bin.data() + offset);
    const int result = ext["mode"] == "ATTRIBUTES"
                           ? meshopt_decodeVertexBuffer(out.data(), count, stride, data, length)
                           : meshopt_decodeIndexBuffer(out.data(), count, stride, data, length);
    EXPECT_EQ(result, 0);
    if (ext.value("filter", std::string("NONE")) == "EXPONENTIAL")
    {
        meshopt_decodeFilterExp(out.data(), count, stride);
    }
    return out;
}

// Moves the grid's vertices (not the plain triangle's) by a smooth field.
Positions moved_positions(const Positions& V)
{
    Positions moved = V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        if (moved(i, 2) > 4.0)
        {
            continue;
        }
        moved(i, 2) += 0.01 * std::sin(4.0 * moved(i, 0) + 2.0 * moved(i, 1));
        moved(i, 0) += 0.004 * std::cos(3.0 * moved(i, 1));
    }
    return moved;
}

// The world position of element k of the decoded position view.
std::array<double, 3> world_of(Layout layout, const std::string& decoded, std::size_t k)
{
    std::array<double, 3> p{};
    for (std::size_t d = 0; d < 3; ++d)
    {
        if (layout == Layout::Short8)
        {
            std::int16_t s = 0;
            std::memcpy(&s, decoded.data() + k * 8 + 2 * d, 2);
            p[d] = s / kShortScale;
        }
        else
        {
            p[d] = test::float_at(decoded, k * 12 + 4 * d);
        }
    }
    p[2] += 2.0;
    return p;
}

// The vertex of \p V at \p p (the grid welds nothing), or -1.
Eigen::Index vertex_at(const Positions& V, const std::array<double, 3>& p)
{
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        if (std::abs(V(i, 0) - p[0]) < 1e-9 && std::abs(V(i, 1) - p[1]) < 1e-9 &&
            std::abs(V(i, 2) - p[2]) < 1e-9)
        {
            return i;
        }
    }
    return -1;
}

// How far a decoded coordinate may be from the position written: the stored type's rounding.
double tolerance_of(Layout layout)
{
    switch (layout)
    {
        case Layout::Short8:
            return 0.5 / kShortScale + 1e-12;
        case Layout::Float12Exp:
            // |v| < 2: 14-bit mantissas of a shared exponent E <= 1 step by 2^-12.
            return std::ldexp(1.0, -12);
        default:
            return 1e-6;  // float32 rounding of values below 2.2 (world z = local + 2)
    }
}

void expect_same_mesh(const TriangleMesh& a, const TriangleMesh& b)
{
    ASSERT_EQ(a.V.rows(), b.V.rows());
    ASSERT_EQ(a.F.rows(), b.F.rows());
    EXPECT_TRUE(a.V == b.V);
    EXPECT_TRUE(a.F == b.F);
}

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
