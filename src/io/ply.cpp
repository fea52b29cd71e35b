// SPDX-License-Identifier: MIT
// PLY reader and generic writer. The reader keeps the whole file and records where every
// coordinate sits (binary: byte offsets; ASCII: token spans) so that the preserving writer
// can replace positions alone. Hand-written because no packaged PLY library (e.g. rply,
// tinyply, happly) both decodes `tristrips` and reports coordinate locations for a
// byte-exact rewrite.
#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/support.h"

namespace meshmark::detail {
namespace {

enum class PlyEncoding
{
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
};

struct PlyProperty
{
    std::string name;
    ScalarType type = ScalarType::Float32;  ///< Value type; for a list, the index type.
    bool is_list = false;
    ScalarType count_type = ScalarType::UInt8;
};

enum class Role
{
    Skip,
    Vertex,
    Faces,
    Strips,
};

struct PlyElement
{
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
    std::size_t line = 0;  ///< Header line that declares it.
    Role role = Role::Skip;
    std::array<std::size_t, 3> axes{};  ///< Vertex: property index of x, y, z.
    std::size_t list = 0;               ///< Faces/strips: property index of the index list.
};

struct PlyHeader
{
    PlyEncoding encoding = PlyEncoding::Ascii;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;
    std::size_t body_line = 0;  ///< Line number of the first body line (ASCII).
};

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

PlyHeader parse_header(const std::filesystem::path& path, std::string_view bytes)
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

// Decodes triangle strips: -1 restarts a strip, odd triangles are flipped to keep the
// winding, and triangles with a repeated index are skipped (they only serve to join runs).
class StripDecoder
{
public:
    explicit StripDecoder(std::vector<std::int32_t>& triangles) : triangles_(triangles) {}
    void restart() noexcept { run_ = 0; }
    void push(std::int32_t index)
    {
        if (run_ >= 2)
        {
            const bool is_odd = ((run_ - 2) & 1U) != 0;
            if (a_ != b_ && b_ != index && a_ != index)
            {
                triangles_.push_back(is_odd ? b_ : a_);
                triangles_.push_back(is_odd ? a_ : b_);
                triangles_.push_back(index);
            }
        }
        a_ = b_;
        b_ = index;
        ++run_;
    }

private:
    std::vector<std::int32_t>& triangles_;
    std::int32_t a_ = 0;
    std::int32_t b_ = 0;
    std::size_t run_ = 0;
};

// Checks and narrows the indices of one face or strip record, then triangulates it.
class ListSink
{
public:
    ListSink(const std::filesystem::path& path, const PlyElement& element,
             std::uint64_t vertex_count, std::vector<std::int32_t>& triangles)
        : path_(path),
          element_(element),
          vertex_count_(vertex_count),
          triangles_(triangles),
          strips_(triangles)
    {
    }

    // Start of record `record` with `n` indices.
    void begin(std::uint64_t record, std::uint64_t n)
    {
        record_ = record;
        position_ = 0;
        polygon_.clear();
        strips_.restart();
        if (element_.role == Role::Faces)
        {
            polygon_.reserve(static_cast<std::size_t>(n));
        }
    }

    void add(std::int64_t index)
    {
        const bool is_restart = element_.role == Role::Strips && index == -1;
        if (!is_restart && (index < 0 || static_cast<std::uint64_t>(index) >= vertex_count_))
        {
            const std::string which = element_.role == Role::Faces
                                          ? "face " + std::to_string(record_)
                                          : "tristrips record " + std::to_string(record_) +
                                                " (entry " + std::to_string(position_) + ")";
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

    void end() { append_fan(triangles_, polygon_.data(), polygon_.size()); }

private:
    const std::filesystem::path& path_;
    const PlyElement& element_;
    std::uint64_t vertex_count_;
    std::vector<std::int32_t>& triangles_;
    std::vector<std::int32_t> polygon_;  // Reused across records: no per-face allocation.
    StripDecoder strips_;
    std::uint64_t record_ = 0;
    std::uint64_t position_ = 0;
};

// ---------------------------------------------------------------------------------------
// Binary bodies

class BinaryReader
{
public:
    BinaryReader(const std::filesystem::path& path, std::string_view bytes, std::size_t pos,
                 bool is_big_endian)
        : path_(path), bytes_(bytes), pos_(pos), is_big_endian_(is_big_endian)
    {
    }

    void need(std::uint64_t n, const PlyElement& element, std::uint64_t record) const
    {
        if (n > bytes_.size() - pos_)
        {
            fail_io(path_, "truncated binary data: record " + std::to_string(record) +
                               " of element '" + element.name + "' needs " + std::to_string(n) +
                               " bytes at byte offset " + std::to_string(pos_) +
                               ", but the file ends at byte " + std::to_string(bytes_.size()));
        }
    }

    // Hostile counts: every record takes at least `min_size` bytes, so the count must fit
    // in what remains before anything is allocated from it.
    void check_count(const PlyElement& element, std::uint64_t min_size) const
    {
        const auto remaining = bytes_.size() - pos_;
        if (min_size > 0 && element.count > remaining / min_size)
        {
            fail_io(path_, "truncated binary data: element '" + element.name + "' declares " +
                               std::to_string(element.count) + " records of at least " +
                               std::to_string(min_size) + " bytes, but only " +
                               std::to_string(remaining) + " bytes follow byte offset " +
                               std::to_string(pos_));
        }
    }

    [[nodiscard]] std::int64_t integer(ScalarType type) const noexcept
    {
        return load_integer(bytes_.data() + pos_, type, is_big_endian_);
    }
    [[nodiscard]] const char* data() const noexcept { return bytes_.data() + pos_; }
    [[nodiscard]] std::size_t pos() const noexcept { return pos_; }
    void skip(std::uint64_t n) noexcept { pos_ += static_cast<std::size_t>(n); }
    [[nodiscard]] bool is_big_endian() const noexcept { return is_big_endian_; }

    // Length of a list at the current position (count already bounds-checked).
    std::uint64_t list_length(const PlyElement& element, const PlyProperty& property,
                              std::uint64_t record)
    {
        need(scalar_size(property.count_type), element, record);
        const auto n = integer(property.count_type);
        if (n < 0)
        {
            fail_io(path_, "negative list length " + std::to_string(n) + " at byte offset " +
                               std::to_string(pos_) + " (record " + std::to_string(record) +
                               " of element '" + element.name + "')");
        }
        skip(scalar_size(property.count_type));
        need(static_cast<std::uint64_t>(n) * scalar_size(property.type), element, record);
        return static_cast<std::uint64_t>(n);
    }

private:
    const std::filesystem::path& path_;
    std::string_view bytes_;
    std::size_t pos_;
    bool is_big_endian_;
};

std::uint64_t min_record_size(const PlyElement& element, bool& is_fixed)
{
    std::uint64_t size = 0;
    is_fixed = true;
    for (const auto& property : element.properties)
    {
        size += scalar_size(property.is_list ? property.count_type : property.type);
        is_fixed = is_fixed && !property.is_list;
    }
    return size;
}

template <typename T>
void load_fixed_positions(const char* base, std::size_t stride,
                          const std::array<std::uint64_t, 3>& offsets, bool is_big_endian,
                          ScalarType type, Positions& V)
{
    const auto n = static_cast<std::size_t>(V.rows());
    double* out = V.data();
    const bool is_native = is_big_endian == (std::endian::native == std::endian::big);
    for (std::size_t i = 0; i < n; ++i)
    {
        const char* record = base + i * stride;
        for (std::size_t d = 0; d < 3; ++d)
        {
            if (is_native)
            {
                T value;
                std::memcpy(&value, record + offsets[d], sizeof(T));
                out[3 * i + d] = static_cast<double>(value);
            }
            else
            {
                out[3 * i + d] = load_scalar(record + offsets[d], type, is_big_endian);
            }
        }
    }
}

void read_binary_vertices(BinaryReader& in, const PlyElement& element, Positions& V,
                          BinaryPositions& slots)
{
    bool is_fixed = false;
    const auto min_size = min_record_size(element, is_fixed);
    in.check_count(element, min_size);
    V.resize(static_cast<Eigen::Index>(element.count), 3);
    for (std::size_t d = 0; d < 3; ++d)
    {
        slots.types[d] = element.properties[element.axes[d]].type;
    }
    slots.first_record = in.pos();
    if (is_fixed)
    {
        // Fast path: fixed-stride records, positions copied with memcpy.
        slots.record_stride = min_size;
        for (std::size_t d = 0; d < 3; ++d)
        {
            for (std::size_t p = 0; p < element.axes[d]; ++p)
            {
                slots.field_offsets[d] += scalar_size(element.properties[p].type);
            }
        }
        const auto type = slots.types[0];
        const bool is_uniform = slots.types[1] == type && slots.types[2] == type;
        const auto stride = static_cast<std::size_t>(min_size);
        if (is_uniform && type == ScalarType::Float32)
        {
            load_fixed_positions<float>(in.data(), stride, slots.field_offsets, in.is_big_endian(),
                                        type, V);
        }
        else if (is_uniform && type == ScalarType::Float64)
        {
            load_fixed_positions<double>(in.data(), stride, slots.field_offsets, in.is_big_endian(),
                                         type, V);
        }
        else
        {
            for (std::size_t i = 0; i < element.count; ++i)
            {
                for (std::size_t d = 0; d < 3; ++d)
                {
                    V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) =
                        load_scalar(in.data() + i * stride + slots.field_offsets[d], slots.types[d],
                                    in.is_big_endian());
                }
            }
        }
        in.skip(element.count * min_size);
        return;
    }
    // Records with lists vary in size: walk them and remember each coordinate's offset.
    slots.coordinate_offsets.resize(3 * static_cast<std::size_t>(element.count));
    for (std::uint64_t i = 0; i < element.count; ++i)
    {
        for (std::size_t p = 0; p < element.properties.size(); ++p)
        {
            const auto& property = element.properties[p];
            if (property.is_list)
            {
                in.skip(in.list_length(element, property, i) * scalar_size(property.type));
                continue;
            }
            in.need(scalar_size(property.type), element, i);
            for (std::size_t d = 0; d < 3; ++d)
            {
                if (element.axes[d] == p)
                {
                    slots.coordinate_offsets[3 * i + d] = in.pos();
                    V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) =
                        load_scalar(in.data(), property.type, in.is_big_endian());
                }
            }
            in.skip(scalar_size(property.type));
        }
    }
}

// Fast path for the common face layout: a single `list uchar int|uint` property.
bool read_binary_triangles_fast(BinaryReader& in, const PlyElement& element,
                                std::uint64_t vertex_count, ListSink& sink,
                                std::vector<std::int32_t>& triangles)
{
    const auto& property = element.properties[element.list];
    if (element.role != Role::Faces || element.properties.size() != 1 ||
        scalar_size(property.count_type) != 1 || scalar_size(property.type) != 4)
    {
        return false;
    }
    for (std::uint64_t f = 0; f < element.count; ++f)
    {
        in.need(1, element, f);
        const auto count = in.integer(property.count_type);
        if (count == 3)
        {
            in.need(13, element, f);
            std::array<std::int64_t, 3> v{};
            for (std::size_t k = 0; k < 3; ++k)
            {
                v[k] = load_integer(in.data() + 1 + 4 * k, property.type, in.is_big_endian());
            }
            if (v[0] >= 0 && v[1] >= 0 && v[2] >= 0 &&
                static_cast<std::uint64_t>(std::max({v[0], v[1], v[2]})) < vertex_count)
            {
                triangles.push_back(static_cast<std::int32_t>(v[0]));
                triangles.push_back(static_cast<std::int32_t>(v[1]));
                triangles.push_back(static_cast<std::int32_t>(v[2]));
                in.skip(13);
                continue;
            }
        }
        // Polygons and bad indices take the general path (which names the face).
        const auto n = in.list_length(element, property, f);
        sink.begin(f, n);
        for (std::uint64_t k = 0; k < n; ++k)
        {
            sink.add(in.integer(property.type));
            in.skip(4);
        }
        sink.end();
    }
    return true;
}

void read_binary_lists(BinaryReader& in, const PlyElement& element, std::uint64_t vertex_count,
                       std::vector<std::int32_t>& triangles, const std::filesystem::path& path)
{
    bool is_fixed = false;
    in.check_count(element, min_record_size(element, is_fixed));
    if (element.role == Role::Faces)
    {
        triangles.reserve(triangles.size() + 3 * static_cast<std::size_t>(element.count));
    }
    ListSink sink(path, element, vertex_count, triangles);
    if (read_binary_triangles_fast(in, element, vertex_count, sink, triangles))
    {
        return;
    }
    for (std::uint64_t r = 0; r < element.count; ++r)
    {
        for (std::size_t p = 0; p < element.properties.size(); ++p)
        {
            const auto& property = element.properties[p];
            const auto size = scalar_size(property.type);
            if (!property.is_list)
            {
                in.need(size, element, r);
                in.skip(size);
                continue;
            }
            const auto n = in.list_length(element, property, r);
            if (p != element.list)
            {
                in.skip(n * size);
                continue;
            }
            sink.begin(r, n);
            for (std::uint64_t k = 0; k < n; ++k)
            {
                sink.add(in.integer(property.type));
                in.skip(size);
            }
            sink.end();
        }
    }
}

void skip_binary_element(BinaryReader& in, const PlyElement& element)
{
    bool is_fixed = false;
    const auto min_size = min_record_size(element, is_fixed);
    in.check_count(element, min_size);
    if (is_fixed)
    {
        in.skip(element.count * min_size);
        return;
    }
    for (std::uint64_t r = 0; r < element.count; ++r)
    {
        for (const auto& property : element.properties)
        {
            if (property.is_list)
            {
                in.skip(in.list_length(element, property, r) * scalar_size(property.type));
            }
            else
            {
                in.need(scalar_size(property.type), element, r);
                in.skip(scalar_size(property.type));
            }
        }
    }
}

void read_binary_body(const std::filesystem::path& path, const PlyHeader& header,
                      std::string_view bytes, Positions& V, std::vector<std::int32_t>& triangles,
                      BinaryPositions& slots)
{
    slots.is_big_endian = header.encoding == PlyEncoding::BinaryBigEndian;
    BinaryReader in(path, bytes, header.body_offset, slots.is_big_endian);
    std::uint64_t vertex_count = 0;
    for (const auto& element : header.elements)
    {
        if (element.role == Role::Vertex)
        {
            vertex_count = element.count;
        }
    }
    for (const auto& element : header.elements)
    {
        switch (element.role)
        {
            case Role::Vertex:
                read_binary_vertices(in, element, V, slots);
                break;
            case Role::Faces:
            case Role::Strips:
                read_binary_lists(in, element, vertex_count, triangles, path);
                break;
            case Role::Skip:
                skip_binary_element(in, element);
                break;
        }
    }
}

// ---------------------------------------------------------------------------------------
// ASCII bodies

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
                      std::vector<std::int32_t>& triangles, const std::filesystem::path& path)
{
    in.check_count(element);
    if (element.role == Role::Faces)
    {
        triangles.reserve(triangles.size() + 3 * static_cast<std::size_t>(element.count));
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

void read_ascii_body(const std::filesystem::path& path, const PlyHeader& header,
                     std::string_view bytes, Positions& V, std::vector<std::int32_t>& triangles,
                     TextPositions& slots)
{
    AsciiReader in(path, bytes, header.body_offset, header.body_line);
    std::uint64_t vertex_count = 0;
    for (const auto& element : header.elements)
    {
        if (element.role == Role::Vertex)
        {
            vertex_count = element.count;
        }
    }
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

// ---------------------------------------------------------------------------------------
// Generic writer

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
    auto header = parse_header(path, bytes);
    plan_elements(path, header);
    TriangleMesh mesh;
    std::vector<std::int32_t> triangles;
    std::array<ScalarType, 3> types{};
    if (header.encoding == PlyEncoding::Ascii)
    {
        TextPositions slots;
        read_ascii_body(path, header, bytes, mesh.V, triangles, slots);
        for (std::size_t d = 0; d < 3; ++d)
        {
            types[d] = *slots.declared_types[d];
        }
        layout.positions = std::move(slots);
    }
    else
    {
        BinaryPositions slots;
        read_binary_body(path, header, bytes, mesh.V, triangles, slots);
        types = slots.types;
        layout.positions = std::move(slots);
    }
    check_finite(path, mesh.V);
    mesh.F = make_faces(triangles);
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
