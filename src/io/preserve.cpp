// SPDX-License-Identifier: MIT
// Preserving writers for text and binary position layouts: the original bytes with only the
// changed coordinates replaced (STL facets are handled in stl_write.cpp). A binary PLY file goes
// out in slices of at most 1 MiB with the changed coordinates patched in, so the output never
// occupies memory twice; its bytes in memory (preserved_bytes) are one copy, patched in place.
#include <algorithm>
#include <string>
#include <variant>
#include <vector>

#include "io/detail/formats.h"
#include "io/detail/ply_stream.h"
#include "io/detail/support.h"
#include "meshmark/core/atomic_file.h"

namespace meshmark::detail
{

namespace
{

const char* type_name(ScalarType type) noexcept
{
    switch (type)
    {
        case ScalarType::Int8:
            return "char";
        case ScalarType::UInt8:
            return "uchar";
        case ScalarType::Int16:
            return "short";
        case ScalarType::UInt16:
            return "ushort";
        case ScalarType::Int32:
            return "int";
        case ScalarType::UInt32:
            return "uint";
        case ScalarType::Float32:
            return "float";
        case ScalarType::Float64:
            return "double";
    }
    return "?";
}

std::string preserved_text(const std::filesystem::path& path, const std::string& bytes,
                           const TextPositions& slots, const Positions& original,
                           const Positions& positions)
{
    const auto n = static_cast<std::size_t>(positions.size());
    const double* old_values = original.data();
    const double* new_values = positions.data();
    std::string out;
    out.reserve(bytes.size() + bytes.size() / 4);
    std::size_t cursor = 0;
    for (std::size_t k = 0; k < n; ++k)
    {
        if (!is_changed(old_values[k], new_values[k]))
        {
            continue;
        }
        const auto& span = slots.tokens[k];
        const auto offset = static_cast<std::size_t>(span.offset);
        out.append(bytes, cursor, offset - cursor);
        const auto& type = slots.declared_types[k % 3];
        if (type)
        {
            if (!append_typed(out, *type, new_values[k]))
            {
                fail_coordinate_range(path, k / 3, *type, new_values[k]);
            }
        }
        else
        {
            append_like_token(out, std::string_view(bytes).substr(offset, span.length),
                              new_values[k]);
        }
        cursor = offset + span.length;
    }
    out.append(bytes, cursor);
    return out;
}

constexpr std::size_t kSliceBytes = std::size_t{1} << 20U;

// One past the last byte of vertex i's coordinates.
std::uint64_t coordinates_end(const BinaryPositions& slots, std::size_t i)
{
    std::uint64_t end = 0;
    for (std::size_t d = 0; d < 3; ++d)
    {
        end = std::max<std::uint64_t>(end, slots.offset(i, d) + scalar_size(slots.types[d]));
    }
    return end;
}

// Patches the changed coordinates of vertices [first, last] into \p data, which holds the
// file's bytes from offset \p base on (the whole file, or a slice of it).
void patch_vertices(char* data, std::size_t base, const BinaryPositions& slots, std::size_t first,
                    std::size_t last, const Positions& original, const Positions& positions,
                    const std::filesystem::path& path)
{
    const double* old_values = original.data();
    const double* new_values = positions.data();
    for (std::size_t i = first; i <= last; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            patch_coordinate(data + (slots.offset(i, d) - base), slots.types[d],
                             slots.is_big_endian, old_values[3 * i + d], new_values[3 * i + d],
                             path, i);
        }
    }
}

// The whole file in one string: one copy of the original, patched in place.
std::string preserved_binary(const std::filesystem::path& path, const std::string& bytes,
                             const BinaryPositions& slots, const Positions& original,
                             const Positions& positions)
{
    std::string out = bytes;
    const auto n = static_cast<std::size_t>(positions.rows());
    if (n > 0)
    {
        patch_vertices(out.data(), 0, slots, 0, n - 1, original, positions, path);
    }
    return out;
}

void write_preserved_binary(const std::filesystem::path& path, const std::string& bytes,
                            const BinaryPositions& slots, const Positions& original,
                            const Positions& positions)
{
    const auto n = static_cast<std::size_t>(positions.rows());
    write_file_atomically(
        path,
        [&](std::ostream& out)
        {
            std::vector<char> slice;
            std::size_t cursor = 0;  // bytes before it are written
            std::size_t vertex = 0;
            while (vertex < n)
            {
                // Whole vertices, at least one, up to about kSliceBytes past the cursor.
                std::size_t last = vertex;
                while (last + 1 < n && coordinates_end(slots, last + 1) - cursor <= kSliceBytes)
                {
                    ++last;
                }
                const auto end = static_cast<std::size_t>(coordinates_end(slots, last));
                slice.assign(bytes.begin() + static_cast<std::ptrdiff_t>(cursor),
                             bytes.begin() + static_cast<std::ptrdiff_t>(end));
                patch_vertices(slice.data(), cursor, slots, vertex, last, original, positions,
                               path);
                out.write(slice.data(), static_cast<std::streamsize>(slice.size()));
                cursor = end;
                vertex = last + 1;
            }
            out.write(bytes.data() + cursor, static_cast<std::streamsize>(bytes.size() - cursor));
        });
}

}  // namespace

void fail_coordinate_range(const std::filesystem::path& path, std::uint64_t vertex, ScalarType type,
                           double value)
{
    std::string text;
    append_shortest(text, value);
    fail_io(path, "cannot store coordinate " + text + " of vertex " + std::to_string(vertex) +
                      " in the file's '" + type_name(type) + "' position property");
}

std::string preserved_bytes(const std::filesystem::path& path, const FileLayout& layout,
                            const Positions& original, const Positions& positions)
{
    if (const auto* text = std::get_if<TextPositions>(&layout.positions))
    {
        return preserved_text(path, layout.bytes, *text, original, positions);
    }
    if (const auto* binary = std::get_if<BinaryPositions>(&layout.positions))
    {
        return preserved_binary(path, layout.bytes, *binary, original, positions);
    }
    return preserved_stl_bytes(path, layout, std::get<StlFacets>(layout.positions), original,
                               positions);
}

void write_preserved(const std::filesystem::path& path, const FileLayout& layout,
                     const Positions& original, const Positions& positions,
                     const std::filesystem::path& source_folder,
                     const std::filesystem::path& link_folder)
{
    if (const auto* binary = std::get_if<BinaryPositions>(&layout.positions))
    {
        write_preserved_binary(path, layout.bytes, *binary, original, positions);
        return;
    }
    const std::string bytes = preserved_bytes(path, layout, original, positions);
    // An OBJ's material libraries, relinked when the output is in another folder; streamed
    // around the edits: no second copy of the text.
    const auto edits =
        layout.format == MeshFormat::Obj
            ? material_library_edits(bytes, source_folder, path.parent_path(), link_folder)
            : std::vector<TextEdit>{};
    write_file_atomically(path,
                          [&](std::ostream& out)
                          {
                              std::size_t cursor = 0;
                              for (const TextEdit& edit : edits)
                              {
                                  out.write(bytes.data() + cursor,
                                            static_cast<std::streamsize>(edit.offset - cursor));
                                  out << edit.text;
                                  cursor = edit.offset + edit.length;
                              }
                              out.write(bytes.data() + cursor,
                                        static_cast<std::streamsize>(bytes.size() - cursor));
                          });
}

}  // namespace meshmark::detail
