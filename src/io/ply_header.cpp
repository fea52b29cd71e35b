// SPDX-License-Identifier: MIT
// PLY header parsing, element roles, and the face/strip index sink.
#include <array>
#include <string>

#include "io/detail/ply.h"

namespace meshmark::detail
{
namespace
{

std::string header_line(std::size_t line)
{
    return "line " + std::to_string(line) + " of the header";
}

std::uint64_t parse_count(const std::filesystem::path& path, std::string_view token,
                          std::size_t line)
{
    std::int64_t value = 0;
    if (!parse_integer(token, value) || value < 0)
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has element count " +
                          quoted(token) + ", expected a non-negative integer");
    }
    return static_cast<std::uint64_t>(value);
}

ScalarType parse_type(const std::filesystem::path& path, std::string_view token, std::size_t line)
{
    const auto type = scalar_type_from_name(token);
    if (!type)
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has unknown type " +
                          quoted(token));
    }
    return *type;
}

void parse_format(const std::filesystem::path& path, TokenCursor& tokens, std::size_t line,
                  PlyHeader& header)
{
    std::string_view name;
    if (!tokens.next(name))
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has no format name");
    }
    if (name == "ascii")
    {
        header.encoding = PlyEncoding::Ascii;
    }
    else if (name == "binary_little_endian")
    {
        header.encoding = PlyEncoding::BinaryLittleEndian;
    }
    else if (name == "binary_big_endian")
    {
        header.encoding = PlyEncoding::BinaryBigEndian;
    }
    else
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has unknown format " +
                          quoted(name));
    }
}

void parse_property(const std::filesystem::path& path, TokenCursor& tokens, std::size_t line,
                    PlyHeader& header)
{
    if (header.elements.empty())
    {
        fail_io(path, "malformed PLY header: " + header_line(line) +
                          " declares a property before any element");
    }
    PlyProperty property;
    std::string_view token;
    if (!tokens.next(token))
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has no property type");
    }
    if (token == "list")
    {
        property.is_list = true;
        std::string_view count_type;
        if (!tokens.next(count_type) || !tokens.next(token))
        {
            fail_io(path, "malformed PLY header: " + header_line(line) +
                              " has an incomplete list property");
        }
        property.count_type = parse_type(path, count_type, line);
        if (!is_integer(property.count_type))
        {
            fail_io(path, "malformed PLY header: " + header_line(line) +
                              " has a list count of non-integer type " + quoted(count_type));
        }
    }
    property.type = parse_type(path, token, line);
    std::string_view name;
    if (!tokens.next(name))
    {
        fail_io(path, "malformed PLY header: " + header_line(line) + " has no property name");
    }
    property.name = std::string(name);
    header.elements.back().properties.push_back(std::move(property));
}

PlyHeader parse_header_lines(const std::filesystem::path& path, std::string_view bytes)
{
    LineCursor lines(bytes);
    std::string_view line;
    std::string_view magic;
    if (!lines.next(line) || !TokenCursor(line).next(magic) || magic != "ply")
    {
        fail_io(path, "not a PLY file: the first line is not 'ply'");
    }
    PlyHeader header;
    bool has_format = false;
    while (lines.next(line))
    {
        const auto n = lines.line_number();
        TokenCursor tokens(line);
        std::string_view keyword;
        if (!tokens.next(keyword) || keyword == "comment" || keyword == "obj_info")
        {
            continue;
        }
        if (keyword == "end_header")
        {
            if (!has_format)
            {
                fail_io(path, "malformed PLY header: no 'format' line before 'end_header'");
            }
            header.body_offset = lines.next_offset();
            header.body_line = n + 1;
            return header;
        }
        if (keyword == "format")
        {
            parse_format(path, tokens, n, header);
            has_format = true;
        }
        else if (keyword == "element")
        {
            PlyElement element;
            std::string_view name;
            std::string_view count;
            if (!tokens.next(name) || !tokens.next(count))
            {
                fail_io(path, "malformed PLY header: " + header_line(n) +
                                  " needs 'element <name> <count>'");
            }
            element.name = std::string(name);
            element.count = parse_count(path, count, n);
            element.line = n;
            header.elements.push_back(std::move(element));
        }
        else if (keyword == "property")
        {
            parse_property(path, tokens, n, header);
        }
        else
        {
            fail_io(path, "malformed PLY header: " + header_line(n) + " has unknown keyword " +
                              quoted(keyword));
        }
    }
    fail_io(path, "malformed PLY header: no 'end_header' line");
}

std::size_t find_property(const PlyElement& element, std::string_view name)
{
    for (std::size_t i = 0; i < element.properties.size(); ++i)
    {
        if (element.properties[i].name == name)
        {
            return i;
        }
    }
    return element.properties.size();
}

// Decide which elements meshmark reads and how; everything else is skipped by type.
void plan_elements(const std::filesystem::path& path, PlyHeader& header)
{
    bool has_vertex = false;
    for (auto& element : header.elements)
    {
        if (element.name == "vertex")
        {
            if (has_vertex)
            {
                fail_io(path, "unsupported PLY layout: two 'vertex' elements");
            }
            has_vertex = true;
            element.role = Role::Vertex;
            constexpr std::array<std::string_view, 3> kAxes{"x", "y", "z"};
            for (std::size_t d = 0; d < 3; ++d)
            {
                element.axes[d] = find_property(element, kAxes[d]);
                if (element.axes[d] == element.properties.size() ||
                    element.properties[element.axes[d]].is_list)
                {
                    fail_io(path, "unsupported PLY layout: the vertex element (" +
                                      header_line(element.line) + ") has no scalar '" +
                                      std::string(kAxes[d]) + "' property");
                }
            }
            if (element.count > kMaxVertices)
            {
                fail_io(path, "the header declares " + std::to_string(element.count) +
                                  " vertices, more than the 2147483647 that 32-bit indices "
                                  "address");
            }
        }
        else if (element.name == "face" || element.name == "tristrips")
        {
            element.list = find_property(element, "vertex_indices");
            if (element.list == element.properties.size())
            {
                element.list = find_property(element, "vertex_index");
            }
            if (element.list == element.properties.size() ||
                !element.properties[element.list].is_list ||
                !is_integer(element.properties[element.list].type))
            {
                fail_io(path, "unsupported PLY layout: the '" + element.name + "' element (" +
                                  header_line(element.line) +
                                  ") has no integer list property 'vertex_indices'");
            }
            element.role = element.name == "face" ? Role::Faces : Role::Strips;
        }
    }
    if (!has_vertex)
    {
        fail_io(path, "unsupported PLY layout: the file has no 'vertex' element");
    }
}

}  // namespace

PlyHeader parse_ply_header(const std::filesystem::path& path, std::string_view bytes)
{
    auto header = parse_header_lines(path, bytes);
    plan_elements(path, header);
    return header;
}

void ListSink::add(std::int64_t index)
{
    const bool is_restart = element_.role == Role::Strips && index == -1;
    if (!is_restart && (index < 0 || static_cast<std::uint64_t>(index) >= vertex_count_))
    {
        const std::string which = element_.role == Role::Faces
                                      ? "face " + std::to_string(record_)
                                      : "tristrips record " + std::to_string(record_) + " (entry " +
                                            std::to_string(position_) + ")";
        fail_mesh(path_, which + " uses vertex index " + std::to_string(index) + ", " +
                             index_range(vertex_count_));
    }
    ++position_;
    if (element_.role == Role::Faces)
    {
        polygon_.push_back(static_cast<std::int32_t>(index));
    }
    else if (is_restart)
    {
        strips_.restart();
    }
    else
    {
        strips_.push(static_cast<std::int32_t>(index));
    }
}

}  // namespace meshmark::detail
