// SPDX-License-Identifier: MIT
// Binary PLY bodies (either byte order). Every read is bounds-checked; element counts are
// checked against the remaining bytes before anything is allocated from them.
#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <string>

#include "io/detail/ply.h"

namespace meshmark::detail
{
namespace
{

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
    [[nodiscard]] std::size_t remaining() const noexcept { return bytes_.size() - pos_; }
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

constexpr std::uint32_t byteswap32(std::uint32_t x) noexcept
{
    return (x >> 24U) | ((x >> 8U) & 0xff00U) | ((x << 8U) & 0xff0000U) | (x << 24U);
}

// Fast path for the common face layout, a single `list uchar int|uint` property: triangles
// are copied with memcpy at a 13-byte stride; polygons and bad indices go through the sink.
bool read_binary_triangles_fast(BinaryReader& in, const PlyElement& element,
                                std::uint64_t vertex_count, ListSink& sink,
                                TriangleBuffer& triangles)
{
    const auto& property = element.properties[element.list];
    if (element.role != Role::Faces || element.properties.size() != 1 ||
        scalar_size(property.count_type) != 1 || scalar_size(property.type) != 4)
    {
        return false;
    }
    constexpr std::size_t kTriangleRecord = 13;
    const bool is_native = in.is_big_endian() == (std::endian::native == std::endian::big);
    // vertex_count <= 2^31 - 1; read as unsigned, a negative int32 index is >= 2^31.
    const auto limit = static_cast<std::uint32_t>(vertex_count);
    for (std::uint64_t f = 0; f < element.count; ++f)
    {
        if (in.remaining() >= kTriangleRecord && *in.data() == 3)
        {
            std::array<std::uint32_t, 3> v{};
            std::memcpy(v.data(), in.data() + 1, sizeof(v));
            if (!is_native)
            {
                for (auto& index : v)
                {
                    index = byteswap32(index);
                }
            }
            if (v[0] < limit && v[1] < limit && v[2] < limit)
            {
                triangles.push(static_cast<std::int32_t>(v[0]), static_cast<std::int32_t>(v[1]),
                               static_cast<std::int32_t>(v[2]));
                in.skip(kTriangleRecord);
                continue;
            }
        }
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
                       TriangleBuffer& triangles, const std::filesystem::path& path)
{
    bool is_fixed = false;
    in.check_count(element, min_record_size(element, is_fixed));
    if (element.role == Role::Faces)
    {
        triangles.reserve(triangles.size() + static_cast<std::size_t>(element.count));
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

}  // namespace

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

void read_ply_binary_body(const std::filesystem::path& path, const PlyHeader& header,
                          std::string_view bytes, Positions& V, TriangleBuffer& triangles,
                          BinaryPositions& slots)
{
    slots.is_big_endian = header.encoding == PlyEncoding::BinaryBigEndian;
    BinaryReader in(path, bytes, header.body_offset, slots.is_big_endian);
    const std::uint64_t vertex_count = header.vertex_count();
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

}  // namespace meshmark::detail
