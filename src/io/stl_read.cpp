// SPDX-License-Identifier: MIT
// STL reader. STL stores a triangle soup; corners with bit-identical coordinates are welded
// into shared vertices for analysis (the writers are in stl_write.cpp). Hand-written: packaged
// readers neither keep the original bytes nor weld by exact bits.
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/stl.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

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
    const bool has_binary_size = bytes.size() >= kStlFacetOffset &&
                                 (bytes.size() - kStlFacetOffset) % kStlFacetSize == 0 &&
                                 static_cast<std::uint64_t>(load_integer(
                                     bytes.data() + kStlHeaderSize, ScalarType::UInt32, false)) ==
                                     (bytes.size() - kStlFacetOffset) / kStlFacetSize;
    return has_keyword || !has_binary_size;
}

TriangleMesh read_binary_stl(const std::filesystem::path& path, std::string_view bytes,
                             StlFacets& facets)
{
    if (bytes.size() < kStlFacetOffset)
    {
        fail_io(path,
                "truncated binary data: a binary STL needs an 84-byte header, but the file "
                "has " +
                    std::to_string(bytes.size()) + " bytes");
    }
    const auto count = static_cast<std::uint64_t>(
        load_integer(bytes.data() + kStlHeaderSize, ScalarType::UInt32, false));
    const auto remaining = bytes.size() - kStlFacetOffset;
    if (count > remaining / kStlFacetSize)
    {
        fail_io(path, "truncated binary data: the header declares " + std::to_string(count) +
                          " facets (" + std::to_string(kStlFacetOffset + count * kStlFacetSize) +
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
        const char* facet = bytes.data() + kStlFacetOffset + f * kStlFacetSize;
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
            is_single = is_single && significant_digits(token) <= kStlFloatDecimalDigits;
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

}  // namespace meshmark::detail
