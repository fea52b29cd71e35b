// SPDX-License-Identifier: MIT
// Uses the io module's internal layout (src/io/detail): the writer must patch coordinates at
// the byte offsets the reader recorded, which the public io interface does not expose.
#include "streamed_write.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <variant>
#include <vector>

#include "io/detail/file_layout.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {
namespace {

constexpr std::size_t kSliceBytes = std::size_t{1} << 20U;

bool is_changed(double a, double b) noexcept { return std::memcmp(&a, &b, sizeof(double)) != 0; }

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

}  // namespace

bool write_binary_ply_streamed(const std::filesystem::path& path, const MeshFile& source,
                               const Positions& positions)
{
    if (source.layout == nullptr || format_from_extension(path) != source.format)
    {
        return false;
    }
    const auto* slots = std::get_if<BinaryPositions>(&source.layout->positions);
    if (slots == nullptr)
    {
        return false;
    }
    if (positions.rows() != source.mesh.V.rows())
    {
        throw InvalidOption("write_binary_ply_streamed: positions have " + std::to_string(positions.rows()) +
                            " rows, but " + source.path.string() + " has " +
                            std::to_string(source.mesh.V.rows()) + " vertices.");
    }
    check_finite(path, positions);
    const std::string& bytes = source.layout->bytes;
    const auto n = static_cast<std::size_t>(positions.rows());
    const double* old_values = source.mesh.V.data();
    const double* new_values = positions.data();
    write_file_atomically(path, [&](std::ostream& out) {
        std::vector<char> slice;
        std::size_t cursor = 0;  // bytes before it are written
        std::size_t vertex = 0;
        while (vertex < n)
        {
            // Whole vertices, at least one, up to about kSliceBytes past the cursor.
            std::size_t last = vertex;
            while (last + 1 < n && coordinates_end(*slots, last + 1) - cursor <= kSliceBytes)
            {
                ++last;
            }
            const auto end = static_cast<std::size_t>(coordinates_end(*slots, last));
            slice.assign(bytes.begin() + static_cast<std::ptrdiff_t>(cursor),
                         bytes.begin() + static_cast<std::ptrdiff_t>(end));
            for (std::size_t i = vertex; i <= last; ++i)
            {
                for (std::size_t d = 0; d < 3; ++d)
                {
                    const double value = new_values[3 * i + d];
                    if (!is_changed(old_values[3 * i + d], value))
                    {
                        continue;
                    }
                    char* target = slice.data() + (slots->offset(i, d) - cursor);
                    if (!store_scalar(target, slots->types[d], slots->is_big_endian, value))
                    {
                        std::string text;
                        append_shortest(text, value);
                        fail_io(path, "cannot store coordinate " + text + " of vertex " +
                                          std::to_string(i) + " in the file's position property type");
                    }
                }
            }
            out.write(slice.data(), static_cast<std::streamsize>(slice.size()));
            cursor = end;
            vertex = last + 1;
        }
        out.write(bytes.data() + cursor, static_cast<std::streamsize>(bytes.size() - cursor));
    });
    return true;
}

}  // namespace meshmark::detail
