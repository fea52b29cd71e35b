// SPDX-License-Identifier: MIT
// OFF reader and generic writer (Geomview's Object File Format, 3D variants). Hand-written:
// no packaged reader reports token locations for the byte-exact rewrite.
#include <string>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

constexpr int kFloatDecimalDigits = 9;  // FLT_DECIMAL_DIG: see append_like_token.

// Lines without comments; blank and comment-only lines are skipped.
class OffLines
{
public:
    explicit OffLines(std::string_view bytes) : cursor_(bytes) {}
    bool next(std::string_view& line)
    {
        while (cursor_.next(line))
        {
            line = line.substr(0, line.find('#'));
            std::string_view token;
            if (TokenCursor(line).next(token))
            {
                return true;
            }
        }
        return false;
    }
    [[nodiscard]] std::size_t line_number() const noexcept { return cursor_.line_number(); }
    [[nodiscard]] std::size_t remaining(std::size_t size) const noexcept
    {
        return size - cursor_.next_offset();
    }

private:
    LineCursor cursor_;
};

// The header keyword: [ST][C][N]OFF; 4OFF and nOFF change the dimension and are refused.
bool is_off_keyword(std::string_view keyword)
{
    if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF")
    {
        return false;
    }
    keyword.remove_suffix(3);
    if (keyword.substr(0, 2) == "ST")
    {
        keyword.remove_prefix(2);
    }
    if (!keyword.empty() && keyword[0] == 'C')
    {
        keyword.remove_prefix(1);
    }
    if (!keyword.empty() && keyword[0] == 'N')
    {
        keyword.remove_prefix(1);
    }
    return keyword.empty();
}

std::uint64_t read_count(const std::filesystem::path& path, TokenCursor& tokens, std::size_t line,
                         const char* what)
{
    std::string_view token;
    std::int64_t value = 0;
    if (!tokens.next(token) || !parse_integer(token, value) || value < 0)
    {
        fail_io(path, "malformed OFF header: line " + std::to_string(line) + " has no valid " +
                          what + " count");
    }
    return static_cast<std::uint64_t>(value);
}

// Hostile counts: every record takes at least 2 bytes, so a count must fit in what remains.
void check_count(const std::filesystem::path& path, std::uint64_t count, std::size_t remaining,
                 const char* what)
{
    if (count > remaining / 2)
    {
        fail_io(path, "malformed OFF header: it declares " + std::to_string(count) + " " + what +
                          ", but only " + std::to_string(remaining) + " bytes follow");
    }
}

struct OffCounts
{
    std::uint64_t vertices = 0;
    std::uint64_t faces = 0;
};

// The keyword line, then the counts (on the same line or the next), checked against the size.
OffCounts read_off_header(const std::filesystem::path& path, OffLines& lines, std::size_t size)
{
    std::string_view line;
    std::string_view keyword;
    if (!lines.next(line) || !TokenCursor(line).next(keyword) || !is_off_keyword(keyword))
    {
        fail_io(path, "not an OFF file: the first line is not 'OFF' (or COFF, NOFF, CNOFF)");
    }
    TokenCursor header(line);
    static_cast<void>(header.next(keyword));
    std::string_view probe;
    if (TokenCursor rest = header; !rest.next(probe))
    {
        if (!lines.next(line))
        {
            fail_io(path, "malformed OFF header: no counts line");
        }
        header = TokenCursor(line);
    }
    OffCounts counts;
    counts.vertices = read_count(path, header, lines.line_number(), "vertex");
    counts.faces = read_count(path, header, lines.line_number(), "face");
    if (counts.vertices > kMaxVertices)
    {
        fail_io(path, "the header declares " + std::to_string(counts.vertices) +
                          " vertices, more than the 2147483647 that 32-bit indices address");
    }
    check_count(path, counts.vertices, lines.remaining(size), "vertices");
    check_count(path, counts.faces, lines.remaining(size), "faces");
    return counts;
}

// One line per vertex: its first three numbers are the position, the rest is kept as text.
void read_off_vertices(const std::filesystem::path& path, std::string_view bytes, OffLines& lines,
                       Positions& V, TextPositions& slots, bool& is_single_precision)
{
    const auto count = static_cast<std::size_t>(V.rows());
    slots.tokens.resize(3 * count);
    is_single_precision = true;
    std::string_view line;
    for (std::size_t i = 0; i < count; ++i)
    {
        if (!lines.next(line))
        {
            fail_io(path, "unexpected end of file: the header declares " + std::to_string(count) +
                              " vertices, found " + std::to_string(i));
        }
        TokenCursor tokens(line);
        for (std::size_t d = 0; d < 3; ++d)
        {
            std::string_view token;
            double value = 0.0;
            if (!tokens.next(token) || !parse_double(token, value))
            {
                fail_io(path, "line " + std::to_string(lines.line_number()) + ": bad coordinate " +
                                  quoted(token) + " of vertex " + std::to_string(i));
            }
            V.data()[3 * i + d] = value;
            slots.tokens[3 * i + d] = {static_cast<std::uint64_t>(token.data() - bytes.data()),
                                       static_cast<std::uint32_t>(token.size())};
            is_single_precision =
                is_single_precision && significant_digits(token) <= kFloatDecimalDigits;
        }
    }
}

// One line per face: `n i0 ... i(n-1)`, then optional color values; the triangles into
// mesh.F (and mesh.fans), over mesh.V.
void read_off_faces(const std::filesystem::path& path, OffLines& lines, const OffCounts& counts,
                    TriangleMesh& mesh)
{
    const Positions& V = mesh.V;
    TriangleBuffer triangles;
    triangles.reserve(static_cast<std::size_t>(counts.faces));
    std::vector<std::int32_t> polygon;  // Reused across faces.
    std::string_view line;
    for (std::uint64_t f = 0; f < counts.faces; ++f)
    {
        if (!lines.next(line))
        {
            fail_io(path, "unexpected end of file: the header declares " +
                              std::to_string(counts.faces) + " faces, found " + std::to_string(f));
        }
        const auto where = [&lines] { return "line " + std::to_string(lines.line_number()); };
        TokenCursor tokens(line);
        std::string_view token;
        std::int64_t n = 0;
        if (!tokens.next(token) || !parse_integer(token, n) || n < 0 ||
            static_cast<std::size_t>(n) > line.size())
        {
            fail_io(path, where() + ": bad vertex count " + quoted(token) + " of face " +
                              std::to_string(f));
        }
        polygon.clear();
        for (std::int64_t k = 0; k < n; ++k)
        {
            std::int64_t index = 0;
            if (!tokens.next(token) || !parse_integer(token, index))
            {
                fail_io(path, where() + ": bad vertex index " + quoted(token) + " of face " +
                                  std::to_string(f));
            }
            if (index < 0 || static_cast<std::uint64_t>(index) >= counts.vertices)
            {
                fail_mesh(path, "face " + std::to_string(f) + " (" + where() +
                                    ") uses vertex index " + std::to_string(index) + ", " +
                                    index_range(counts.vertices));
            }
            polygon.push_back(static_cast<std::int32_t>(index));
        }
        triangles.push_polygon(polygon.data(), polygon.size());
    }
    fill_polygons(V.data(), triangles);
    mesh.fans = triangles.take_fans();
    mesh.polygons = triangles.take_polygons();
    mesh.F = triangles.take();
}

}  // namespace

TriangleMesh read_off(const std::filesystem::path& path, FileLayout& layout,
                      bool& is_single_precision)
{
    const std::string_view bytes = layout.bytes;
    OffLines lines(bytes);
    // Header (keyword, counts) -> vertex lines -> face lines.
    const auto counts = read_off_header(path, lines, bytes.size());
    TriangleMesh mesh;
    mesh.V.resize(static_cast<Eigen::Index>(counts.vertices), 3);
    TextPositions slots;
    read_off_vertices(path, bytes, lines, mesh.V, slots, is_single_precision);
    check_finite(path, mesh.V);
    read_off_faces(path, lines, counts, mesh);
    layout.positions = std::move(slots);
    return mesh;
}

std::string off_bytes(const TriangleMesh& mesh, const WriteOptions& options)
{
    std::string out =
        "OFF\n" + std::to_string(mesh.V.rows()) + " " + std::to_string(mesh.F.rows()) + " 0\n";
    out.reserve(static_cast<std::size_t>(mesh.V.rows()) * 40 +
                static_cast<std::size_t>(mesh.F.rows()) * 24);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            if (options.use_single_precision)
            {
                append_shortest(out, static_cast<float>(mesh.V(i, d)));
            }
            else
            {
                append_shortest(out, mesh.V(i, d));
            }
            out += d < 2 ? ' ' : '\n';
        }
    }
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        out += '3';
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            out += ' ';
            out += std::to_string(mesh.F(f, c));
        }
        out += '\n';
    }
    return out;
}

}  // namespace meshmark::detail
