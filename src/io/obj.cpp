// SPDX-License-Identifier: MIT
// Wavefront OBJ reader and generic writer. Only `v` and `f` statements matter for the
// geometry; every other one (vt, vn, vp, g, o, s, mg, mtllib, usemtl, l, p, the free-form
// curve and surface statements, comments, ...) is kept as bytes by the preserving writer. A
// statement continues on the next line when its line ends in a backslash (the specification's
// continuation). An `f` of one or two vertices, as older exporters write wires and loose edges,
// is an edge or a point, like `l` and `p`: read, kept, no triangle. Hand-written: the packaged
// OBJ loaders do not report where each coordinate token sits, which the byte-exact rewrite needs.
#include <charconv>
#include <filesystem>
#include <string>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/support.h"
#include "meshmark/io/obj_materials.h"

namespace meshmark::detail
{
namespace
{

constexpr int kFloatDecimalDigits = 9;  // FLT_DECIMAL_DIG: see append_like_token.

// The tokens of one statement: its line and the lines a trailing backslash continues it on.
// The parts are views into the file, so token offsets stay file offsets.
class StatementTokens
{
public:
    void reset(std::string_view line)
    {
        parts_.clear();
        parts_.push_back(line);
        part_ = 0;
        cursor_ = TokenCursor(line);
    }
    void continue_with(std::string_view line) { parts_.push_back(line); }
    // Next token across the parts; false at the end of the statement.
    bool next(std::string_view& token) noexcept
    {
        while (!cursor_.next(token))
        {
            if (++part_ >= parts_.size())
            {
                return false;
            }
            cursor_ = TokenCursor(parts_[part_]);
        }
        return true;
    }

private:
    std::vector<std::string_view> parts_;
    std::size_t part_ = 0;
    TokenCursor cursor_{std::string_view()};
};

// \p line without a final backslash (and the spaces before it), and whether it had one.
bool strip_continuation(std::string_view& line) noexcept
{
    std::size_t end = line.size();
    while (end > 0 && (line[end - 1] == ' ' || line[end - 1] == '\t' || line[end - 1] == '\r'))
    {
        --end;
    }
    if (end == 0 || line[end - 1] != '\\')
    {
        return false;
    }
    line = line.substr(0, end - 1);
    return true;
}

struct ObjState
{
    std::vector<double> xyz;
    TriangleBuffer triangles;
    std::vector<std::int32_t> polygon;  // Reused across faces.
    TextPositions slots;
    bool is_single_precision = true;
    std::uint64_t face_count = 0;
    // The largest forward index seen, checked once the vertex count is final.
    std::int64_t max_index = -1;
    std::uint64_t max_face = 0;
    std::size_t max_line = 0;
};

void read_vertex(const std::filesystem::path& path, std::string_view bytes, StatementTokens& tokens,
                 std::size_t line, ObjState& state)
{
    if (state.xyz.size() / 3 >= kMaxVertices)
    {
        fail_io(path, "line " + std::to_string(line) + ": more than 2147483647 vertices");
    }
    for (int d = 0; d < 3; ++d)
    {
        std::string_view token;
        double value = 0.0;
        if (!tokens.next(token))
        {
            fail_io(path,
                    "line " + std::to_string(line) + ": vertex with fewer than 3 coordinates");
        }
        if (!parse_double(token, value))
        {
            fail_io(path, "line " + std::to_string(line) + ": bad coordinate " + quoted(token));
        }
        state.xyz.push_back(value);
        state.slots.tokens.push_back({static_cast<std::uint64_t>(token.data() - bytes.data()),
                                      static_cast<std::uint32_t>(token.size())});
        state.is_single_precision =
            state.is_single_precision && significant_digits(token) <= kFloatDecimalDigits;
    }
}

// One `f` corner: "v", "v/vt", "v//vn" or "v/vt/vn", each index possibly negative.
bool parse_corner(std::string_view token, std::int64_t& vertex)
{
    const char* p = token.data();
    const char* end = p + token.size();
    const auto integer = [&p, end]
    {
        std::int64_t ignored = 0;
        const auto result = std::from_chars(p, end, ignored);
        p = result.ptr;
        return result.ec == std::errc();
    };
    auto result = std::from_chars(p, end, vertex);
    p = result.ptr;
    if (result.ec != std::errc() || p == end)
    {
        return result.ec == std::errc();
    }
    // "/vt" (empty only when "/vn" follows), then optionally "/vn".
    if (*p++ != '/' || p == end || (*p != '/' && !integer()))
    {
        return false;
    }
    if (p == end)
    {
        return true;
    }
    return *p++ == '/' && integer() && p == end;
}

void read_face(const std::filesystem::path& path, StatementTokens& tokens, std::size_t line,
               ObjState& state)
{
    const auto face = state.face_count++;
    const auto defined = static_cast<std::int64_t>(state.xyz.size() / 3);
    state.polygon.clear();
    std::string_view token;
    while (tokens.next(token) && token[0] != '#')
    {
        std::int64_t index = 0;
        if (!parse_corner(token, index))
        {
            fail_io(path, "line " + std::to_string(line) + ": bad face corner " + quoted(token));
        }
        const auto where = [face, line]
        { return "face " + std::to_string(face) + " (line " + std::to_string(line) + ")"; };
        if (index == 0)
        {
            fail_mesh(path, where() + " uses vertex index 0; OBJ indices start at 1");
        }
        // Negative indices count back from the last vertex defined so far.
        const auto resolved = index > 0 ? index - 1 : defined + index;
        if (resolved < 0)
        {
            fail_mesh(path, where() + " uses relative vertex index " + std::to_string(index) +
                                ", but only " + std::to_string(defined) + " vertices precede it");
        }
        if (resolved >= static_cast<std::int64_t>(kMaxVertices))
        {
            fail_mesh(path, where() + " uses vertex index " + std::to_string(index) +
                                ", beyond what 32-bit indices address");
        }
        if (resolved > state.max_index)
        {
            state.max_index = resolved;
            state.max_face = face;
            state.max_line = line;
        }
        state.polygon.push_back(static_cast<std::int32_t>(resolved));
    }
    if (state.polygon.empty())
    {
        fail_io(path, "line " + std::to_string(line) + ": face with no vertices");
    }
    if (state.polygon.size() < 3)
    {
        return;  // an edge or a point (a wire of an older exporter): kept as written, no triangle
    }
    state.triangles.push_polygon(state.polygon.data(), state.polygon.size());
}

}  // namespace

TriangleMesh read_obj(const std::filesystem::path& path, FileLayout& layout,
                      bool& is_single_precision)
{
    const std::string_view bytes = layout.bytes;
    ObjState state;
    state.xyz.reserve(bytes.size() / 16);
    state.slots.tokens.reserve(bytes.size() / 16);
    LineCursor lines(bytes);
    std::string_view line;
    StatementTokens tokens;
    // Statements -> v / f records; everything else stays in the bytes untouched.
    while (lines.next(line))
    {
        const std::size_t first_line = lines.line_number();
        const bool is_comment = line.find_first_not_of(" \t") != std::string_view::npos &&
                                line[line.find_first_not_of(" \t")] == '#';
        bool continued = !is_comment && strip_continuation(line);
        tokens.reset(line);
        while (continued && lines.next(line))
        {
            continued = strip_continuation(line);
            tokens.continue_with(line);
        }
        std::string_view keyword;
        if (!tokens.next(keyword))
        {
            continue;
        }
        if (keyword == "v")
        {
            read_vertex(path, bytes, tokens, first_line, state);
        }
        else if (keyword == "f")
        {
            read_face(path, tokens, first_line, state);
        }
    }
    const auto vertex_count = static_cast<std::int64_t>(state.xyz.size() / 3);
    if (state.max_index >= vertex_count)
    {
        fail_mesh(path, "face " + std::to_string(state.max_face) + " (line " +
                            std::to_string(state.max_line) + ") uses vertex index " +
                            std::to_string(state.max_index + 1) + ", outside 1.." +
                            std::to_string(vertex_count));
    }
    auto mesh = make_mesh(state.xyz, state.triangles);
    check_finite(path, mesh.V);
    is_single_precision = state.is_single_precision;
    layout.positions = std::move(state.slots);
    return mesh;
}

// `mtllib` names its libraries relative to the OBJ's folder (material_libraries), and a library
// names its textures relative to itself: relinking the library (rather than copying it) keeps
// both resolvable without parsing the MTL's texture options.
std::vector<TextEdit> material_library_edits(std::string_view bytes,
                                             const std::filesystem::path& source_folder,
                                             const std::filesystem::path& output_folder,
                                             const std::filesystem::path& link_folder)
{
    std::vector<TextEdit> edits;
    std::error_code error;
    if (bytes.find("mtllib") == std::string_view::npos ||
        std::filesystem::equivalent(
            source_folder.empty() ? "." : source_folder,
            !link_folder.empty() ? link_folder : (output_folder.empty() ? "." : output_folder),
            error))
    {
        return edits;  // (the usual cases: no scan of the lines)
    }
    for (MaterialLibraryStatement& statement : material_libraries(bytes, source_folder))
    {
        std::string replaced;
        bool is_changed = false;
        for (const std::string& name : statement.names)
        {
            const auto reach = relinked(source_folder, output_folder, name, link_folder);
            const bool moves = reach && !reach->empty();
            if (!replaced.empty())
            {
                replaced += ' ';
            }
            replaced += moves ? reach->generic_string() : name;
            is_changed = is_changed || moves;
        }
        if (is_changed)
        {
            edits.push_back({statement.offset, statement.length, std::move(replaced)});
        }
    }
    return edits;
}

std::string obj_bytes(const TriangleMesh& mesh, const WriteOptions& options)
{
    std::string out = "# written by meshmark\n";
    out.reserve(static_cast<std::size_t>(mesh.V.rows()) * 40 +
                static_cast<std::size_t>(mesh.F.rows()) * 24);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        out += 'v';
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            out += ' ';
            if (options.use_single_precision)
            {
                append_shortest(out, static_cast<float>(mesh.V(i, d)));
            }
            else
            {
                append_shortest(out, mesh.V(i, d));
            }
        }
        out += '\n';
    }
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        out += 'f';
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            out += ' ';
            out += std::to_string(static_cast<std::int64_t>(mesh.F(f, c)) + 1);
        }
        out += '\n';
    }
    return out;
}

}  // namespace meshmark::detail
