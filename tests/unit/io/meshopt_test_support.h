// SPDX-License-Identifier: MIT
// The meshopt test assets (meshopt_*_test.cpp): EXT_meshopt_compression /
// KHR_meshopt_compression fixtures encoded with libmeshoptimizer (float and int16 positions,
// byteStride 12 and 8, the EXPONENTIAL filter, TRIANGLES indices, a fallback buffer without uri),
// their uncompressed twins, and meshoptimizer's own decoding of what meshmark writes.
#pragma once
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
namespace meshmark::test
{
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

inline std::array<double, 3> grid_point(std::size_t k)
{
    const double x = static_cast<double>(k % kGrid) / (kGrid - 1);
    const double y = static_cast<double>(k / kGrid) / (kGrid - 1);
    return {x, y, 0.15 * std::sin(5.0 * x) * std::cos(3.0 * y)};
}

inline std::vector<std::uint16_t> grid_triangles()
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

inline std::size_t stride_of(Layout layout)
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

inline VertexData vertex_data(Layout layout)
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

inline std::string encode_vertices(const std::string& bytes, std::size_t count, std::size_t stride)
{
    std::string out(meshopt_encodeVertexBufferBound(count, stride), '\0');
    out.resize(meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(),
                                          bytes.data(), count, stride));
    return out;
}

inline std::string encode_triangles(const std::vector<std::uint16_t>& indices)
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

inline Asset meshopt_asset(const Options& options)
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
inline std::string decode_view(const Json& doc, const std::string& bin, int view_index,
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
inline Positions moved_positions(const Positions& V)
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
inline std::array<double, 3> world_of(Layout layout, const std::string& decoded, std::size_t k)
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
inline Eigen::Index vertex_at(const Positions& V, const std::array<double, 3>& p)
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
inline double tolerance_of(Layout layout)
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

inline void expect_same_mesh(const TriangleMesh& a, const TriangleMesh& b)
{
    ASSERT_EQ(a.V.rows(), b.V.rows());
    ASSERT_EQ(a.F.rows(), b.F.rows());
    EXPECT_TRUE(a.V == b.V);
    EXPECT_TRUE(a.F == b.F);
}

}  // namespace meshmark::test
