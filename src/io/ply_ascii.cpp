// SPDX-License-Identifier: MIT
// ASCII PLY bodies: a token stream over the whole buffer, std::from_chars for numbers, and
// the span of every coordinate token for the preserving writer.
#include <string>
#include <vector>

#include "io/detail/ply.h"

namespace meshmark::detail
{
namespace
{

class AsciiReader
{
public:
    AsciiReader(const std::filesystem::path& path, std::string_view bytes, std::size_t pos,
                std::size_t line)
        : path_(path), bytes_(bytes), tokens_(bytes, pos, line)
    {
    }

    std::string_view token(const PlyElement& element, std::uint64_t record)
    {
        const auto token = tokens_.next();
        if (token.empty())
        {
            fail_io(path_, "unexpected end of file at line " + std::to_string(tokens_.line()) +
                               " in record " + std::to_string(record) + " of element '" +
                               element.name + "'");
        }
        return token;
    }

    // Hostile counts: every record of an element with properties takes at least 2 bytes
    // (a token and a separator), so the count must fit in what remains.
    void check_count(const PlyElement& element) const
    {
        if (!element.properties.empty() && element.count > tokens_.remaining() / 2)
        {
            fail_io(path_, "element '" + element.name + "' declares " +
                               std::to_string(element.count) + " records, but only " +
                               std::to_string(tokens_.remaining()) + " bytes follow the header");
        }
    }

    std::int64_t integer(std::string_view token, const char* what)
    {
        std::int64_t value = 0;
        if (!parse_integer(token, value))
        {
            fail_io(path_, "line " + std::to_string(tokens_.line()) + ": bad " + what + " " +
                               quoted(token) + ", expected an integer");
        }
        return value;
    }

    std::uint64_t list_length(const PlyElement& element, std::uint64_t record)
    {
        const auto n = integer(token(element, record), "list length");
        if (n < 0 || static_cast<std::uint64_t>(n) > tokens_.remaining())
        {
            fail_io(path_, "line " + std::to_string(tokens_.line()) + ": bad list length " +
                               std::to_string(n) + " in record " + std::to_string(record) +
                               " of element '" + element.name + "'");
        }
        return static_cast<std::uint64_t>(n);
    }

    double coordinate(std::string_view token, ScalarType type, std::uint64_t vertex)
    {
        bool ok = false;
        double value = 0.0;
        if (type == ScalarType::Float32)
        {
            float f = 0.0F;
            ok = parse_float(token, f);
            value = static_cast<double>(f);
        }
        else if (type == ScalarType::Float64)
        {
            ok = parse_double(token, value);
        }
        else
        {
            std::int64_t i = 0;
            ok = parse_integer(token, i);
            value = static_cast<double>(i);
        }
        if (!ok)
        {
            fail_io(path_, "line " + std::to_string(tokens_.line()) + ": bad coordinate " +
                               quoted(token) + " of vertex " + std::to_string(vertex));
        }
        return value;
    }

    [[nodiscard]] std::uint64_t offset_of(std::string_view token) const noexcept
    {
        return static_cast<std::uint64_t>(token.data() - bytes_.data());
    }

private:
    const std::filesystem::path& path_;
    std::string_view bytes_;
    TokenStream tokens_;
};

void read_ascii_vertices(AsciiReader& in, const PlyElement& element, Positions& V,
                         TextPositions& slots)
{
    in.check_count(element);
    V.resize(static_cast<Eigen::Index>(element.count), 3);
    slots.tokens.resize(3 * static_cast<std::size_t>(element.count));
    for (std::size_t d = 0; d < 3; ++d)
    {
        slots.declared_types[d] = element.properties[element.axes[d]].type;
    }
    // Which axis each property is (3 = not a coordinate).
    std::vector<std::size_t> axis_of(element.properties.size(), 3);
    for (std::size_t d = 0; d < 3; ++d)
    {
        axis_of[element.axes[d]] = d;
    }
    for (std::uint64_t i = 0; i < element.count; ++i)
    {
        for (std::size_t p = 0; p < element.properties.size(); ++p)
        {
            const auto& property = element.properties[p];
            if (property.is_list)
            {
                const auto n = in.list_length(element, i);
                for (std::uint64_t k = 0; k < n; ++k)
                {
                    static_cast<void>(in.token(element, i));
                }
                continue;
            }
            const auto token = in.token(element, i);
            const auto d = axis_of[p];
            if (d < 3)
            {
                V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) =
                    in.coordinate(token, property.type, i);
                slots.tokens[3 * i + d] = {in.offset_of(token),
                                           static_cast<std::uint32_t>(token.size())};
            }
        }
    }
}

void read_ascii_lists(AsciiReader& in, const PlyElement& element, std::uint64_t vertex_count,
                      TriangleBuffer& triangles, const std::filesystem::path& path)
{
    in.check_count(element);
    if (element.role == Role::Faces)
    {
        triangles.reserve(triangles.size() + static_cast<std::size_t>(element.count));
    }
    ListSink sink(path, element, vertex_count, triangles);
    for (std::uint64_t r = 0; r < element.count; ++r)
    {
        for (std::size_t p = 0; p < element.properties.size(); ++p)
        {
            const auto& property = element.properties[p];
            if (!property.is_list)
            {
                static_cast<void>(in.token(element, r));
                continue;
            }
            const auto n = in.list_length(element, r);
            if (p != element.list)
            {
                for (std::uint64_t k = 0; k < n; ++k)
                {
                    static_cast<void>(in.token(element, r));
                }
                continue;
            }
            sink.begin(r, n);
            for (std::uint64_t k = 0; k < n; ++k)
            {
                sink.add(in.integer(in.token(element, r), "vertex index"));
            }
            sink.end();
        }
    }
}

void skip_ascii_element(AsciiReader& in, const PlyElement& element)
{
    in.check_count(element);
    for (std::uint64_t r = 0; r < element.count; ++r)
    {
        for (const auto& property : element.properties)
        {
            const auto n = property.is_list ? in.list_length(element, r) : 1;
            for (std::uint64_t k = 0; k < n; ++k)
            {
                static_cast<void>(in.token(element, r));
            }
        }
    }
}

}  // namespace

void read_ply_ascii_body(const std::filesystem::path& path, const PlyHeader& header,
                         std::string_view bytes, Positions& V, TriangleBuffer& triangles,
                         TextPositions& slots)
{
    AsciiReader in(path, bytes, header.body_offset, header.body_line);
    const std::uint64_t vertex_count = header.vertex_count();
    for (const auto& element : header.elements)
    {
        switch (element.role)
        {
            case Role::Vertex:
                read_ascii_vertices(in, element, V, slots);
                break;
            case Role::Faces:
            case Role::Strips:
                read_ascii_lists(in, element, vertex_count, triangles, path);
                break;
            case Role::Skip:
                skip_ascii_element(in, element);
                break;
        }
    }
}

}  // namespace meshmark::detail
