// SPDX-License-Identifier: MIT
// PLY reader and generic writer. The reader keeps the whole file and records where every
// coordinate sits (binary: byte offsets; ASCII: token spans) so that the preserving writer
// can replace positions alone. Hand-written because no packaged PLY library (e.g. rply,
// tinyply, happly) both decodes `tristrips` and reports coordinate locations for a
// byte-exact rewrite.
#include "io/detail/ply.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include "io/detail/formats.h"

namespace meshmark::detail
{
namespace
{

void append_header(std::string& out, const TriangleMesh& mesh, const WriteOptions& options)
{
    out += "ply\nformat ";
    out += options.is_binary ? "binary_little_endian" : "ascii";
    out += " 1.0\ncomment written by meshmark\nelement vertex ";
    out += std::to_string(mesh.V.rows());
    const char* type = options.use_single_precision ? "float" : "double";
    for (const char* axis : {"x", "y", "z"})
    {
        out += "\nproperty ";
        out += type;
        out += ' ';
        out += axis;
    }
    if (options.vertex_colors != nullptr)
    {
        out += "\nproperty uchar red\nproperty uchar green\nproperty uchar blue";
    }
    out += "\nelement face ";
    out += std::to_string(mesh.F.rows());
    out += "\nproperty list uchar int vertex_indices\nend_header\n";
}

void append_binary_body(std::string& out, const TriangleMesh& mesh, const WriteOptions& options)
{
    const std::size_t coordinate_size = options.use_single_precision ? 4 : 8;
    const std::size_t color_size = options.vertex_colors != nullptr ? 3 : 0;
    const auto nv = static_cast<std::size_t>(mesh.V.rows());
    const auto nf = static_cast<std::size_t>(mesh.F.rows());
    const auto start = out.size();
    out.resize(start + nv * (3 * coordinate_size + color_size) + nf * 13);
    char* p = out.data() + start;
    const auto type = options.use_single_precision ? ScalarType::Float32 : ScalarType::Float64;
    for (std::size_t i = 0; i < nv; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            static_cast<void>(store_scalar(p, type, false, mesh.V.data()[3 * i + d]));
            p += coordinate_size;
        }
        if (color_size != 0)
        {
            std::memcpy(p, (*options.vertex_colors)[i].data(), 3);
            p += 3;
        }
    }
    for (std::size_t f = 0; f < nf; ++f)
    {
        *p++ = 3;
        for (std::size_t c = 0; c < 3; ++c)
        {
            static_cast<void>(store_scalar(p, ScalarType::Int32, false, mesh.F.data()[3 * f + c]));
            p += 4;
        }
    }
}

void append_ascii_body(std::string& out, const TriangleMesh& mesh, const WriteOptions& options)
{
    const auto nv = static_cast<std::size_t>(mesh.V.rows());
    for (std::size_t i = 0; i < nv; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double value = mesh.V.data()[3 * i + d];
            if (options.use_single_precision)
            {
                append_shortest(out, static_cast<float>(value));
            }
            else
            {
                append_shortest(out, value);
            }
            out += d < 2 ? ' ' : '\n';
        }
        if (options.vertex_colors != nullptr)
        {
            out.pop_back();
            for (const auto channel : (*options.vertex_colors)[i])
            {
                out += ' ';
                out += std::to_string(channel);
            }
            out += '\n';
        }
    }
    const auto nf = static_cast<std::size_t>(mesh.F.rows());
    for (std::size_t f = 0; f < nf; ++f)
    {
        out += '3';
        for (std::size_t c = 0; c < 3; ++c)
        {
            out += ' ';
            out += std::to_string(mesh.F.data()[3 * f + c]);
        }
        out += '\n';
    }
}

}  // namespace

TriangleMesh read_ply(const std::filesystem::path& path, FileLayout& layout,
                      bool& is_single_precision)
{
    const std::string_view bytes = layout.bytes;
    // Header -> element roles -> body (binary or ASCII) -> checks.
    const auto header = parse_ply_header(path, bytes);
    TriangleMesh mesh;
    TriangleBuffer triangles;
    std::array<ScalarType, 3> types{};
    if (header.encoding == PlyEncoding::Ascii)
    {
        TextPositions slots;
        read_ply_ascii_body(path, header, bytes, mesh.V, triangles, slots);
        for (std::size_t d = 0; d < 3; ++d)
        {
            types[d] = *slots.declared_types[d];
        }
        layout.positions = std::move(slots);
    }
    else
    {
        BinaryPositions slots;
        read_ply_binary_body(path, header, bytes, mesh.V, triangles, slots);
        types = slots.types;
        layout.positions = std::move(slots);
    }
    check_finite(path, mesh.V);
    fill_polygons(mesh.V.data(), triangles);
    mesh.fans = triangles.take_fans();
    mesh.polygons = triangles.take_polygons();
    mesh.F = triangles.take();
    is_single_precision = std::all_of(types.begin(), types.end(),
                                      [](ScalarType t) { return t == ScalarType::Float32; });
    return mesh;
}

std::string ply_bytes(const TriangleMesh& mesh, const WriteOptions& options)
{
    std::string out;
    append_header(out, mesh, options);
    if (options.is_binary)
    {
        append_binary_body(out, mesh, options);
    }
    else
    {
        append_ascii_body(out, mesh, options);
    }
    return out;
}

}  // namespace meshmark::detail
