// SPDX-License-Identifier: MIT
// STL reader and writers. STL stores a triangle soup; corners with bit-identical coordinates
// are welded into shared vertices for analysis, and the preserving writer moves every corner
// of a vertex together and recomputes the facet normals that moved. Hand-written: packaged
// readers neither keep the original bytes nor weld by exact bits.
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

constexpr std::size_t kHeaderSize = 80;
constexpr std::size_t kFacetOffset = 84;  // Header and the uint32 facet count.
constexpr std::size_t kFacetSize = 50;    // Normal, 3 corners (float32 each), uint16 attribute.
constexpr int kFloatDecimalDigits = 9;    // FLT_DECIMAL_DIG: see append_like_token.

// Welds corners whose coordinates have identical bits, numbering vertices in order of first use.
template <typename Scalar>
class Welder
{
public:
    using Key = std::array<Scalar, 3>;

    explicit Welder(std::size_t corners) { map_.reserve(corners / 4); }

    std::int32_t vertex(const Key& key)
    {
        const auto [it, is_new] =
            map_.try_emplace(bits(key), static_cast<std::int32_t>(xyz_.size() / 3));
        if (is_new)
        {
            for (const auto value : key)
            {
                xyz_.push_back(static_cast<double>(value));
            }
        }
        return it->second;
    }
    [[nodiscard]] const std::vector<double>& xyz() const noexcept { return xyz_; }

private:
    using Bits = std::conditional_t<sizeof(Scalar) == 4, std::uint32_t, std::uint64_t>;
    using BitKey = std::array<Bits, 3>;
    struct Hash
    {
        std::size_t operator()(const BitKey& k) const noexcept
        {
            // 64-bit mix of the three words (boost::hash_combine's constant).
            std::uint64_t h = 0;
            for (const auto word : k)
            {
                h ^= static_cast<std::uint64_t>(word) + 0x9e3779b97f4a7c15ULL + (h << 6U) +
                     (h >> 2U);
            }
            return static_cast<std::size_t>(h);
        }
    };
    static BitKey bits(const Key& key) noexcept
    {
        BitKey result{};
        std::memcpy(result.data(), key.data(), sizeof(key));
        return result;
    }
    std::unordered_map<BitKey, std::int32_t, Hash> map_;
    std::vector<double> xyz_;
};

void add_facet_triangle(TriangleBuffer& triangles, const std::int32_t* corners)
{
    // A facet whose corners weld together is degenerate: kept in the file, not in F.
    if (corners[0] != corners[1] && corners[1] != corners[2] && corners[0] != corners[2])
    {
        triangles.push(corners[0], corners[1], corners[2]);
    }
}

// ASCII unless the bytes after a leading "solid" contain something no text file holds: a
// binary STL's header may itself begin with "solid", but its count and float data rarely stay
// within printable characters, and never also spell "facet" or "endsolid" while the facet
// count matches the file size.
bool is_ascii_stl(std::string_view bytes)
{
    std::size_t start = 0;
    while (start < bytes.size() && (is_blank(bytes[start]) || bytes[start] == '\n'))
    {
        ++start;
    }
    if (bytes.substr(start, 5) != "solid")
    {
        return false;
    }
    constexpr std::size_t kProbe = 4096;
    const auto probe = bytes.substr(0, kProbe);
    for (const char ch : probe)
    {
        const auto c = static_cast<unsigned char>(ch);
        if ((c < 0x20 && !is_blank(ch) && ch != '\n') || c == 0x7f)
        {
            return false;
        }
    }
    // Text all the way: ASCII when a facet or the end of the solid shows up early, or when the
    // size cannot be that of a binary STL.
    const bool has_keyword = probe.find("facet") != std::string_view::npos ||
                             probe.find("endsolid") != std::string_view::npos;
    const bool has_binary_size = bytes.size() >= kFacetOffset &&
                                 (bytes.size() - kFacetOffset) % kFacetSize == 0 &&
                                 static_cast<std::uint64_t>(load_integer(
                                     bytes.data() + kHeaderSize, ScalarType::UInt32, false)) ==
                                     (bytes.size() - kFacetOffset) / kFacetSize;
    return has_keyword || !has_binary_size;
}

TriangleMesh read_binary_stl(const std::filesystem::path& path, std::string_view bytes,
                             StlFacets& facets)
{
    if (bytes.size() < kFacetOffset)
    {
        fail_io(path,
                "truncated binary data: a binary STL needs an 84-byte header, but the file "
                "has " +
                    std::to_string(bytes.size()) + " bytes");
    }
    const auto count = static_cast<std::uint64_t>(
        load_integer(bytes.data() + kHeaderSize, ScalarType::UInt32, false));
    const auto remaining = bytes.size() - kFacetOffset;
    if (count > remaining / kFacetSize)
    {
        fail_io(path, "truncated binary data: the header declares " + std::to_string(count) +
                          " facets (" + std::to_string(kFacetOffset + count * kFacetSize) +
                          " bytes), but the file ends at byte " + std::to_string(bytes.size()));
    }
    const auto n = static_cast<std::size_t>(count);
    facets.is_binary = true;
    facets.corner_vertices.resize(3 * n);
    Welder<float> welder(3 * n);
    TriangleBuffer triangles;
    triangles.reserve(n);
    for (std::size_t f = 0; f < n; ++f)
    {
        const char* facet = bytes.data() + kFacetOffset + f * kFacetSize;
        for (std::size_t c = 0; c < 3; ++c)
        {
            std::array<float, 3> corner{};
            for (std::size_t d = 0; d < 3; ++d)
            {
                corner[d] = static_cast<float>(
                    load_scalar(facet + 12 + 12 * c + 4 * d, ScalarType::Float32, false));
                if (!std::isfinite(corner[d]))
                {
                    fail_mesh(path, "facet " + std::to_string(f) +
                                        " has a non-finite coordinate (NaN or infinity)");
                }
            }
            facets.corner_vertices[3 * f + c] = welder.vertex(corner);
        }
        add_facet_triangle(triangles, &facets.corner_vertices[3 * f]);
    }
    return make_mesh(welder.xyz(), triangles);
}

bool iequals(std::string_view a, std::string_view b) noexcept
{
    if (a.size() != b.size())
    {
        return false;
    }
    for (std::size_t i = 0; i < a.size(); ++i)
    {
        const auto lower = [](char c)
        { return c >= 'A' && c <= 'Z' ? static_cast<char>(c + 32) : c; };
        if (lower(a[i]) != lower(b[i]))
        {
            return false;
        }
    }
    return true;
}

class AsciiStlReader
{
public:
    AsciiStlReader(const std::filesystem::path& path, std::string_view bytes)
        : path_(path), bytes_(bytes), lines_(bytes)
    {
    }

    // Next line's tokens; false at the end of the file (blank lines skipped).
    bool next_line()
    {
        std::string_view line;
        while (lines_.next(line))
        {
            tokens_ = TokenCursor(line);
            TokenCursor probe = tokens_;
            std::string_view token;
            if (probe.next(token))
            {
                return true;
            }
        }
        return false;
    }

    void expect_line(std::string_view first, std::string_view second = {})
    {
        if (!next_line())
        {
            fail_io(path_, "unexpected end of file after line " +
                               std::to_string(lines_.line_number()) + ", expected '" +
                               std::string(first) + "'");
        }
        expect(first);
        if (!second.empty())
        {
            expect(second);
        }
    }

    void expect(std::string_view keyword)
    {
        std::string_view token;
        if (!tokens_.next(token) || !iequals(token, keyword))
        {
            fail_io(path_, "line " + std::to_string(lines_.line_number()) + ": expected '" +
                               std::string(keyword) + "', found " + quoted(token));
        }
    }

    bool keyword_is(std::string_view keyword)
    {
        TokenCursor probe = tokens_;
        std::string_view token;
        return probe.next(token) && iequals(token, keyword);
    }

    // Three numbers on the current line: their values and spans.
    void numbers(std::array<double, 3>& values, TextSpan* spans, bool& is_single)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            std::string_view token;
            if (!tokens_.next(token) || !parse_double(token, values[d]))
            {
                fail_io(path_, "line " + std::to_string(lines_.line_number()) + ": bad number " +
                                   quoted(token));
            }
            spans[d] = {static_cast<std::uint64_t>(token.data() - bytes_.data()),
                        static_cast<std::uint32_t>(token.size())};
            is_single = is_single && significant_digits(token) <= kFloatDecimalDigits;
        }
    }

    [[nodiscard]] std::size_t line_number() const noexcept { return lines_.line_number(); }

private:
    const std::filesystem::path& path_;
    std::string_view bytes_;
    LineCursor lines_;
    TokenCursor tokens_{std::string_view()};
};

TriangleMesh read_ascii_stl(const std::filesystem::path& path, std::string_view bytes,
                            StlFacets& facets, bool& is_single_precision)
{
    facets.is_binary = false;
    AsciiStlReader in(path, bytes);
    Welder<double> welder(bytes.size() / 64);
    TriangleBuffer triangles;
    is_single_precision = true;
    bool is_normal_single = true;  // Normals do not decide the precision of positions.
    // solid -> (facet normal / outer loop / 3 x vertex / endloop / endfacet)* -> endsolid,
    // possibly several solids in one file.
    while (in.next_line())
    {
        in.expect("solid");
        while (true)
        {
            if (!in.next_line())
            {
                fail_io(path, "unexpected end of file after line " +
                                  std::to_string(in.line_number()) + ", expected 'endsolid'");
            }
            if (in.keyword_is("endsolid"))
            {
                break;
            }
            const auto f = facets.corner_vertices.size() / 3;
            facets.tokens.resize(12 * (f + 1));
            std::array<double, 3> values{};
            in.expect("facet");
            in.expect("normal");
            in.numbers(values, &facets.tokens[12 * f], is_normal_single);
            in.expect_line("outer", "loop");
            for (std::size_t c = 0; c < 3; ++c)
            {
                in.expect_line("vertex");
                in.numbers(values, &facets.tokens[12 * f + 3 + 3 * c], is_single_precision);
                for (const double v : values)
                {
                    if (!std::isfinite(v))
                    {
                        fail_mesh(path, "facet " + std::to_string(f) + " (line " +
                                            std::to_string(in.line_number()) +
                                            ") has a non-finite coordinate (NaN or infinity)");
                    }
                }
                facets.corner_vertices.push_back(welder.vertex(values));
            }
            in.expect_line("endloop");
            in.expect_line("endfacet");
            add_facet_triangle(triangles, &facets.corner_vertices[3 * f]);
        }
    }
    if (welder.xyz().size() / 3 > kMaxVertices)
    {
        fail_io(path, "more than 2147483647 distinct vertices");
    }
    return make_mesh(welder.xyz(), triangles);
}

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
            char* facet = out.data() + kFacetOffset + f * kFacetSize;
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

TriangleMesh read_stl(const std::filesystem::path& path, FileLayout& layout,
                      bool& is_single_precision)
{
    const std::string_view bytes = layout.bytes;
    StlFacets facets;
    TriangleMesh mesh;
    if (is_ascii_stl(bytes))
    {
        mesh = read_ascii_stl(path, bytes, facets, is_single_precision);
    }
    else
    {
        mesh = read_binary_stl(path, bytes, facets);
        is_single_precision = true;
    }
    layout.positions = std::move(facets);
    return mesh;
}

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
        std::string out(kFacetOffset + nf * kFacetSize, '\0');
        const std::string_view title = "binary STL written by meshmark";
        std::memset(out.data(), ' ', kHeaderSize);
        std::memcpy(out.data(), title.data(), title.size());
        static_cast<void>(store_scalar(out.data() + kHeaderSize, ScalarType::UInt32, false,
                                       static_cast<double>(nf)));
        for (std::size_t f = 0; f < nf; ++f)
        {
            char* facet = out.data() + kFacetOffset + f * kFacetSize;
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
