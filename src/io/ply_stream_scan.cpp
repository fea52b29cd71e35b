// SPDX-License-Identifier: MIT
// PlyStream::scan_faces: the elements after the vertices in one sequential pass, faces and
// strips triangulated by the reader's own ListSink to mark the referenced vertices.
#include <array>
#include <bit>
#include <cstring>

#include "io/detail/ply_stream.h"
#include "meshmark/io/ply_stream.h"

namespace meshmark
{
namespace detail
{
namespace
{

[[noreturn]] void fail_truncated(const InputFile& file, const PlyElement& element,
                                 std::uint64_t record, std::uint64_t offset)
{
    fail_io(file.path(),
            "truncated binary data: record " + std::to_string(record) + " of element '" +
                element.name + "' runs past the end of the file (byte offset " +
                std::to_string(offset) + ", file size " + std::to_string(file.size()) + ")");
}

// Pass over the elements after the vertices: faces and strips triangulated by the reader's own
// ListSink, everything else skipped (it is copied through unread).
ReferencedVertices scan(const PlyStream::Impl& layout, std::size_t window)
{
    const InputFile& file = layout.file;
    ReferencedVertices result;
    const auto n = layout.vertex_count;
    std::vector<std::uint8_t> flags(static_cast<std::size_t>(n), 0);
    SequentialReader in(file, layout.vertex_end, window);
    TriangleBuffer triangles;
    const auto drain = [&]()
    {
        const Faces F = triangles.take();
        const std::int32_t* p = F.data();
        for (Eigen::Index i = 0; i < F.size(); ++i)
        {
            flags[static_cast<std::size_t>(p[i])] = 1;
        }
        result.triangles += static_cast<std::uint64_t>(F.rows());
    };
    for (std::size_t e = layout.vertex_element + 1; e < layout.header.elements.size(); ++e)
    {
        const auto& element = layout.header.elements[e];
        const bool is_list_element = element.role == Role::Faces || element.role == Role::Strips;
        ListSink sink(file.path(), element, n, triangles);
        // The usual face record, a 1-byte count 3 and three 4-byte integer indices, is checked
        // and marked here directly (the generic loop below costs ~20 ns a face: 0.84 s for 40M).
        // Anything else, including an index out of range, takes the generic loop, which reads
        // the record again and reports it as before.
        const bool is_plain_triangles =
            element.role == Role::Faces && element.properties.size() == 1 &&
            element.properties[0].is_list && scalar_size(element.properties[0].count_type) == 1 &&
            (element.properties[0].type == ScalarType::Int32 ||
             element.properties[0].type == ScalarType::UInt32);
        const bool is_signed =
            is_plain_triangles && element.properties[0].type == ScalarType::Int32;
        constexpr std::size_t kPlainTriangle = 13;
        for (std::uint64_t r = 0; r < element.count; ++r)
        {
            if (is_plain_triangles && in.ensure(kPlainTriangle) && in.data()[0] == 3)
            {
                std::array<std::uint32_t, 3> index{};
                std::memcpy(index.data(), in.data() + 1, sizeof(index));
                bool in_range = true;
                for (std::uint32_t& v : index)
                {
                    if (layout.is_big_endian != (std::endian::native == std::endian::big))
                    {
                        v = __builtin_bswap32(v);
                    }
                    // A negative Int32 is a huge uint32: out of range as well.
                    in_range = in_range && v < n && (!is_signed || v <= 0x7fffffffU);
                }
                if (in_range)
                {
                    for (const std::uint32_t v : index)
                    {
                        flags[v] = 1;
                    }
                    ++result.triangles;
                    in.skip(kPlainTriangle);
                    continue;
                }
            }
            for (std::size_t p = 0; p < element.properties.size(); ++p)
            {
                const auto& property = element.properties[p];
                const auto size = scalar_size(property.type);
                if (!property.is_list)
                {
                    if (!in.ensure(size))
                    {
                        fail_truncated(file, element, r, in.offset());
                    }
                    in.skip(size);
                    continue;
                }
                const auto count_size = scalar_size(property.count_type);
                if (!in.ensure(count_size))
                {
                    fail_truncated(file, element, r, in.offset());
                }
                const auto length =
                    load_integer(in.data(), property.count_type, layout.is_big_endian);
                if (length < 0)
                {
                    fail_io(file.path(), "negative list length " + std::to_string(length) +
                                             " at byte offset " + std::to_string(in.offset()) +
                                             " (record " + std::to_string(r) + " of element '" +
                                             element.name + "')");
                }
                in.skip(count_size);
                const auto bytes = static_cast<std::uint64_t>(length) * size;
                if (bytes > file.size() || !in.ensure(static_cast<std::size_t>(bytes)))
                {
                    fail_truncated(file, element, r, in.offset());
                }
                if (is_list_element && p == element.list)
                {
                    sink.begin(r, static_cast<std::uint64_t>(length));
                    for (std::int64_t k = 0; k < length; ++k)
                    {
                        sink.add(load_integer(in.data() + static_cast<std::size_t>(k) * size,
                                              property.type, layout.is_big_endian));
                    }
                    sink.end();
                }
                in.skip(static_cast<std::size_t>(bytes));
            }
            if (triangles.size() >= (std::size_t{1} << 16U))
            {
                drain();
            }
        }
        drain();
    }
    if (result.triangles > 0)
    {
        result.flags = std::move(flags);
        result.active_before.reserve(
            static_cast<std::size_t>(n / ReferencedVertices::kSelectBlock + 1));
        std::uint64_t count = 0;
        for (std::uint64_t v = 0; v < n; ++v)
        {
            if (v % ReferencedVertices::kSelectBlock == 0)
            {
                result.active_before.push_back(count);
            }
            count += result.flags[static_cast<std::size_t>(v)];
        }
        result.active = count;
    }
    else
    {
        result.active = n;
    }
    return result;
}

}  // namespace
}  // namespace detail

ReferencedVertices PlyStream::scan_faces(std::size_t window_bytes) const
{
    return detail::scan(*impl_, window_bytes);
}

}  // namespace meshmark
