// SPDX-License-Identifier: MIT
// STL writers: the preserving writer moves every corner of a vertex together and recomputes
// the facet normals that moved; the plain writer writes binary or ASCII STL. Hand-written:
// packaged writers do not keep a file's other bytes.
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/stl.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

// Unit normal of triangle (a, b, c) by the right-hand rule; zero when degenerate.
std::array<double, 3> facet_normal(const std::array<std::array<double, 3>, 3>& p)
{
    std::array<double, 3> u{};
    std::array<double, 3> v{};
    for (std::size_t d = 0; d < 3; ++d)
    {
        u[d] = p[1][d] - p[0][d];
        v[d] = p[2][d] - p[0][d];
    }
    std::array<double, 3> n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                            u[0] * v[1] - u[1] * v[0]};
    const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(length > 0.0) || !std::isfinite(length))
    {
        return {0.0, 0.0, 0.0};
    }
    for (auto& value : n)
    {
        value /= length;
    }
    return n;
}

std::vector<char> moved_vertices(const Positions& original, const Positions& positions)
{
    std::vector<char> moved(static_cast<std::size_t>(original.rows()), 0);
    for (std::size_t i = 0; i < moved.size(); ++i)
    {
        moved[i] =
            std::memcmp(original.data() + 3 * i, positions.data() + 3 * i, 3 * sizeof(double)) != 0
                ? 1
                : 0;
    }
    return moved;
}

// Calls f(facet, its three corner vertices) for each facet with a corner at a moved vertex,
// in file order.
template <typename F>
void for_each_moved_facet(const StlFacets& facets, const std::vector<char>& moved, F&& f)
{
    const auto n = facets.corner_vertices.size() / 3;
    for (std::size_t facet = 0; facet < n; ++facet)
    {
        const std::int32_t* corners = &facets.corner_vertices[3 * facet];
        if (moved[static_cast<std::size_t>(corners[0])] != 0 ||
            moved[static_cast<std::size_t>(corners[1])] != 0 ||
            moved[static_cast<std::size_t>(corners[2])] != 0)
        {
            f(facet, corners);
        }
    }
}

void patch_binary_facets(std::string& out, const StlFacets& facets, const std::vector<char>& moved,
                         const Positions& positions)
{
    for_each_moved_facet(
        facets, moved,
        [&](std::size_t f, const std::int32_t* corners)
        {
            char* facet = out.data() + kStlFacetOffset + f * kStlFacetSize;
            // The normal is recomputed from the float32 corners as stored.
            std::array<std::array<double, 3>, 3> stored{};
            for (std::size_t c = 0; c < 3; ++c)
            {
                for (std::size_t d = 0; d < 3; ++d)
                {
                    const auto value =
                        static_cast<float>(positions(corners[c], static_cast<Eigen::Index>(d)));
                    store_float(facet + 12 + 12 * c + 4 * d, value, false);
                    stored[c][d] = static_cast<double>(value);
                }
            }
            bool is_zero_normal = true;
            for (std::size_t d = 0; d < 3; ++d)
            {
                is_zero_normal =
                    is_zero_normal && load_scalar(facet + 4 * d, ScalarType::Float32, false) == 0.0;
            }
            if (!is_zero_normal)
            {
                const auto normal = facet_normal(stored);
                for (std::size_t d = 0; d < 3; ++d)
                {
                    store_float(facet + 4 * d, static_cast<float>(normal[d]), false);
                }
            }
        });
}

std::string patched_ascii_facets(const std::string& bytes, const StlFacets& facets,
                                 const std::vector<char>& moved, const Positions& original,
                                 const Positions& positions)
{
    std::string out;
    out.reserve(bytes.size() + bytes.size() / 4);
    std::size_t cursor = 0;
    const auto replace = [&](const TextSpan& span, double value)
    {
        const auto offset = static_cast<std::size_t>(span.offset);
        out.append(bytes, cursor, offset - cursor);
        append_like_token(out, std::string_view(bytes).substr(offset, span.length), value);
        cursor = offset + span.length;
    };
    for_each_moved_facet(
        facets, moved,
        [&](std::size_t f, const std::int32_t* corners)
        {
            const TextSpan* spans = &facets.tokens[12 * f];
            std::array<std::array<double, 3>, 3> corner_positions{};
            for (std::size_t c = 0; c < 3; ++c)
            {
                for (std::size_t d = 0; d < 3; ++d)
                {
                    corner_positions[c][d] = positions(corners[c], static_cast<Eigen::Index>(d));
                }
            }
            bool is_zero_normal = true;
            for (std::size_t d = 0; d < 3; ++d)
            {
                double value = 1.0;
                const auto token = std::string_view(bytes).substr(spans[d].offset, spans[d].length);
                is_zero_normal = is_zero_normal && parse_double(token, value) && value == 0.0;
            }
            if (!is_zero_normal)
            {
                const auto normal = facet_normal(corner_positions);
                for (std::size_t d = 0; d < 3; ++d)
                {
                    replace(spans[d], normal[d]);
                }
            }
            for (std::size_t c = 0; c < 3; ++c)
            {
                for (std::size_t d = 0; d < 3; ++d)
                {
                    const auto e = static_cast<Eigen::Index>(d);
                    const double before = original(corners[c], e);
                    const double after = positions(corners[c], e);
                    if (std::memcmp(&before, &after, sizeof(double)) != 0)
                    {
                        replace(spans[3 + 3 * c + d], after);
                    }
                }
            }
        });
    out.append(bytes, cursor);
    return out;
}

void append_number(std::string& out, double value, bool is_single)
{
    if (is_single)
    {
        append_shortest(out, static_cast<float>(value));
    }
    else
    {
        append_shortest(out, value);
    }
}

std::array<std::array<double, 3>, 3> triangle(const TriangleMesh& mesh, Eigen::Index f,
                                              bool is_single)
{
    std::array<std::array<double, 3>, 3> p{};
    for (Eigen::Index c = 0; c < 3; ++c)
    {
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            const double value = mesh.V(mesh.F(f, c), d);
            p[static_cast<std::size_t>(c)][static_cast<std::size_t>(d)] =
                is_single ? static_cast<double>(static_cast<float>(value)) : value;
        }
    }
    return p;
}

}  // namespace

std::string preserved_stl_bytes(const std::filesystem::path& /*path*/, const FileLayout& layout,
                                const StlFacets& facets, const Positions& original,
                                const Positions& positions)
{
    const auto moved = moved_vertices(original, positions);
    if (facets.is_binary)
    {
        std::string out = layout.bytes;
        patch_binary_facets(out, facets, moved, positions);
        return out;
    }
    return patched_ascii_facets(layout.bytes, facets, moved, original, positions);
}

std::string stl_bytes(const TriangleMesh& mesh, const WriteOptions& options)
{
    const auto nf = static_cast<std::size_t>(mesh.F.rows());
    if (options.is_binary)
    {
        // The header must not begin with "solid", which would suggest ASCII to other readers.
        std::string out(kStlFacetOffset + nf * kStlFacetSize, '\0');
        const std::string_view title = "binary STL written by meshmark";
        std::memset(out.data(), ' ', kStlHeaderSize);
        std::memcpy(out.data(), title.data(), title.size());
        static_cast<void>(store_scalar(out.data() + kStlHeaderSize, ScalarType::UInt32, false,
                                       static_cast<double>(nf)));
        for (std::size_t f = 0; f < nf; ++f)
        {
            char* facet = out.data() + kStlFacetOffset + f * kStlFacetSize;
            const auto p = triangle(mesh, static_cast<Eigen::Index>(f), true);
            const auto normal = facet_normal(p);
            for (std::size_t d = 0; d < 3; ++d)
            {
                store_float(facet + 4 * d, static_cast<float>(normal[d]), false);
                for (std::size_t c = 0; c < 3; ++c)
                {
                    store_float(facet + 12 + 12 * c + 4 * d, static_cast<float>(p[c][d]), false);
                }
            }
        }
        return out;
    }
    std::string out = "solid meshmark\n";
    for (std::size_t f = 0; f < nf; ++f)
    {
        const auto p = triangle(mesh, static_cast<Eigen::Index>(f), options.use_single_precision);
        const auto normal = facet_normal(p);
        out += "facet normal";
        for (const double value : normal)
        {
            out += ' ';
            append_number(out, value, options.use_single_precision);
        }
        out += "\n  outer loop\n";
        for (const auto& corner : p)
        {
            out += "    vertex";
            for (const double value : corner)
            {
                out += ' ';
                append_number(out, value, options.use_single_precision);
            }
            out += '\n';
        }
        out += "  endloop\nendfacet\n";
    }
    out += "endsolid meshmark\n";
    return out;
}

}  // namespace meshmark::detail
